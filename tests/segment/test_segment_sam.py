"""The sam segmenter's plumbing with tiny ONNX models built here (``onnx.helper``), with the input and
output names and shapes of SAM's image encoder and of the segment-anything prompt-decoder export.

The tiny encoder average-pools the normalised, padded S × S image into an s × s "embedding" (the
mean colour of each cell). The tiny decoder reads the embedding at the prompt point and returns, for
its four mask tokens, logits ``δ − γ ||e(pixel) − e(prompt)||²`` — the cell region of the prompt's
colour — upsampled to S × S, cropped to the resized image and resized to ``orig_im_size`` like
``SamOnnxModel.mask_postprocessing``. So automatic generation on an image of flat rectangles must
return exactly the rectangles and the background, which checks the resizing, normalisation,
padding, prompt coordinates, token selection, IoU and stability filters, NMS and flattening."""

from __future__ import annotations

import numpy as np
import pytest
import torch

onnx = pytest.importorskip("onnx")
pytest.importorskip("onnxruntime")
from onnx import TensorProto, helper  # noqa: E402

from inpaint360gs.cli import main  # noqa: E402
from inpaint360gs.core.errors import InputError  # noqa: E402
from inpaint360gs.segment.sam import SamConfig, SamSegmenter, box_nms, point_grid  # noqa: E402

S, CELL = 64, 8  # encoder input side, pooling cell (embedding 8 x 8)
IOU = [0.5, 0.97, 0.96, 0.3]  # token 0 is not multimask output; 1 and 2 duplicate; 3 fails the IoU filter


def _const(name: str, value, dtype=np.float32):
    return helper.make_node("Constant", [], [name], value=onnx.numpy_helper.from_array(np.asarray(value, dtype=dtype), name))


def encoder_model(path, *, with_preprocess: bool = False):
    """(1, 3, S, S) normalised padded image -> pooled embedding; ``with_preprocess``: the input is the
    resized (H', W', 3) 0-255 image and the graph normalises and pads it (like exports that take raw pixels)."""
    y = helper.make_tensor_value_info("image_embeddings", TensorProto.FLOAT, [1, 3, S // CELL, S // CELL])
    pool = helper.make_node("AveragePool", ["image"], ["image_embeddings"], kernel_shape=[CELL, CELL], strides=[CELL, CELL])
    if not with_preprocess:
        x = helper.make_tensor_value_info("image", TensorProto.FLOAT, [1, 3, S, S])
        nodes = [pool]
    else:
        x = helper.make_tensor_value_info("input_image", TensorProto.FLOAT, ["h", "w", 3])
        nodes = [
            _const("mean", [123.675, 116.28, 103.53]), _const("std", [58.395, 57.12, 57.375]),
            _const("side", [S, S], np.int64), _const("zeros6", [0, 0, 0, 0, 0, 0], np.int64), _const("axis0", [0], np.int64),
            helper.make_node("Sub", ["input_image", "mean"], ["c"]), helper.make_node("Div", ["c", "std"], ["n"]),
            helper.make_node("Transpose", ["n"], ["chw"], perm=[2, 0, 1]), helper.make_node("Unsqueeze", ["chw", "axis0"], ["nchw"]),
            helper.make_node("Shape", ["input_image"], ["shape"], start=0, end=2), helper.make_node("Sub", ["side", "shape"], ["pad_hw"]),
            helper.make_node("Concat", ["zeros6", "pad_hw"], ["pads"], axis=0),
            helper.make_node("Pad", ["nchw", "pads"], ["image"]),
            pool,
        ]  # fmt: skip
    onnx.save(helper.make_model(helper.make_graph(nodes, "enc", [x], [y]), opset_imports=[helper.make_opsetid("", 17)]), path)


def decoder_model(path, *, drop_input: str | None = None):
    s = S // CELL
    f = TensorProto.FLOAT
    inputs = [
        helper.make_tensor_value_info("image_embeddings", f, [1, 3, s, s]),
        helper.make_tensor_value_info("point_coords", f, [1, "num_points", 2]),
        helper.make_tensor_value_info("point_labels", f, [1, "num_points"]),
        helper.make_tensor_value_info("mask_input", f, [1, 1, 4 * s, 4 * s]),
        helper.make_tensor_value_info("has_mask_input", f, [1]),
        helper.make_tensor_value_info("orig_im_size", f, [2]),
    ]
    if drop_input:
        inputs = [i for i in inputs if i.name != drop_input]
    outputs = [
        helper.make_tensor_value_info("masks", f, None),
        helper.make_tensor_value_info("iou_predictions", f, None),
        helper.make_tensor_value_info("low_res_masks", f, None),
    ]
    grid = np.arange(s, dtype=np.float32) + 0.5
    n = [
        _const("i0", [0], np.int64), _const("i1", [1], np.int64), _const("i2", [2], np.int64), _const("i3", [3], np.int64),
        _const("scale_cells", s / S), _const("half", 0.5), _const("gx", grid.reshape(1, 1, 1, s)), _const("gy", grid.reshape(1, 1, s, 1)),
        _const("inv_sigma2", 1.0 / 0.02), _const("gamma", 50.0), _const("delta", np.array([-5.0, 4.0, 4.0, 4.0]).reshape(1, 4, 1, 1)),
        _const("iou", np.array([IOU])), _const("side", float(S)), _const("up", np.array([1, 1, CELL, CELL])),
        _const("lead", np.array([1, 4]), np.int64),
        # prompt (first point) in embedding cells: (coord + 0.5) / S * s, as SamOnnxModel._embed_points normalises
        helper.make_node("Slice", ["point_coords", "i0", "i1", "i1"], ["p0"]),  # (1, 1, 2)
        helper.make_node("Add", ["p0", "half"], ["p1"]),
        helper.make_node("Mul", ["p1", "scale_cells"], ["pc"]),
        helper.make_node("Slice", ["pc", "i0", "i1", "i2"], ["px"]), helper.make_node("Slice", ["pc", "i1", "i2", "i2"], ["py"]),
        helper.make_node("Reshape", ["px", "lead_px"], ["ux"]), helper.make_node("Reshape", ["py", "lead_px"], ["uy"]),
        _const("lead_px", np.array([1, 1, 1, 1]), np.int64),
        # sharp kernel around the prompt cell -> the prompt's embedding vector e (1, 3, 1, 1)
        helper.make_node("Sub", ["gx", "ux"], ["dx"]), helper.make_node("Sub", ["gy", "uy"], ["dy"]),
        helper.make_node("Mul", ["dx", "dx"], ["dx2"]), helper.make_node("Mul", ["dy", "dy"], ["dy2"]),
        helper.make_node("Add", ["dx2", "dy2"], ["d2"]), helper.make_node("Mul", ["d2", "inv_sigma2"], ["d2s"]),
        helper.make_node("Neg", ["d2s"], ["nd2"]), helper.make_node("Exp", ["nd2"], ["k"]),
        helper.make_node("ReduceSum", ["k", "axes23"], ["ksum"], keepdims=1), _const("axes23", np.array([2, 3]), np.int64),
        helper.make_node("Div", ["k", "ksum"], ["kn"]),
        helper.make_node("Mul", ["image_embeddings", "kn"], ["ek"]),
        helper.make_node("ReduceSum", ["ek", "axes23"], ["e"], keepdims=1),
        # logits per token: delta - gamma * ||E - e||^2, (1, 4, s, s)
        helper.make_node("Sub", ["image_embeddings", "e"], ["diff"]), helper.make_node("Mul", ["diff", "diff"], ["sq"]),
        helper.make_node("ReduceSum", ["sq", "i1"], ["dist"], keepdims=1),
        helper.make_node("Mul", ["dist", "gamma"], ["gd"]), helper.make_node("Sub", ["delta", "gd"], ["low_res_masks"]),
        # postprocessing: to S x S, crop to the resized image, to the original size
        helper.make_node("Resize", ["low_res_masks", "", "up"], ["full"], mode="nearest"),
        helper.make_node("ReduceMax", ["orig_im_size"], ["longest"], keepdims=1),
        helper.make_node("Div", ["side", "longest"], ["rs"]), helper.make_node("Mul", ["orig_im_size", "rs"], ["sz"]),
        helper.make_node("Add", ["sz", "half"], ["sz5"]), helper.make_node("Floor", ["sz5"], ["szf"]),
        helper.make_node("Cast", ["szf"], ["ends"], to=TensorProto.INT64),
        _const("starts", np.array([0, 0]), np.int64), _const("axes_hw", np.array([2, 3]), np.int64),
        helper.make_node("Slice", ["full", "starts", "ends", "axes_hw"], ["crop"]),
        helper.make_node("Cast", ["orig_im_size"], ["hw"], to=TensorProto.INT64),
        helper.make_node("Concat", ["lead", "hw"], ["sizes"], axis=0),
        helper.make_node("Resize", ["crop", "", "", "sizes"], ["masks"], mode="nearest"),
        helper.make_node("Identity", ["iou"], ["iou_predictions"]),
    ]  # fmt: skip
    del n[0:0]
    graph = helper.make_graph(n, "dec", inputs, outputs)
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    onnx.save(model, path)


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    d = tmp_path_factory.mktemp("sam")
    encoder_model(d / "enc.onnx")
    decoder_model(d / "dec.onnx")
    return d / "enc.onnx", d / "dec.onnx"


def rectangles() -> tuple[np.ndarray, list[np.ndarray]]:
    """128 x 96 image (scale 0.5 to S = 64: a 16-px cell per embedding cell): green background, a red
    and a blue rectangle on cell boundaries; returns it and the expected masks."""
    img = np.zeros((96, 128, 3), np.uint8)
    img[:] = (20, 200, 20)
    img[16:48, 16:48] = (220, 30, 30)
    img[32:80, 80:112] = (30, 30, 220)
    red = np.all(img == (220, 30, 30), axis=2)
    blue = np.all(img == (30, 30, 220), axis=2)
    return img, [red, blue, ~(red | blue)]


class _View:
    name = "IMG_000.png"


def test_automatic_masks_are_the_rectangles_and_background(models):
    enc, dec = models
    seg = SamSegmenter(SamConfig(encoder=str(enc), decoder=str(dec), points_per_side=8))
    seg.prepare(None, None)
    img, expected = rectangles()
    masks = seg.generate(img)
    assert len(masks) == 3  # duplicates (tokens 1 and 2, many prompts per region) removed by NMS
    ids = seg.segment(_View, torch.from_numpy(img).float() / 255)
    assert ids.dtype == np.uint16 and ids.shape == (96, 128)
    for m in expected:
        vals = np.unique(ids[m])
        assert len(vals) == 1 and vals[0] > 0 and np.array_equal(ids == vals[0], m)
    assert ids[expected[2]][0] == 1  # the largest mask (background) is painted first, smaller on top
    assert seg.settings()["encoder_input_side"] == S


def test_encoder_with_its_preprocessing_inside(models, tmp_path):
    """An encoder taking the resized (H', W', 3) 0-255 image (S given by the settings: its input is dynamic)."""
    _, dec = models
    encoder_model(tmp_path / "enc_raw.onnx", with_preprocess=True)
    seg = SamSegmenter(SamConfig(encoder=str(tmp_path / "enc_raw.onnx"), decoder=str(dec), points_per_side=8, image_size=S))
    seg.prepare(None, None)
    img, expected = rectangles()
    ids = seg.segment(_View, torch.from_numpy(img).float() / 255)
    assert int(ids.max()) == 3 and all(np.array_equal(ids == ids[m][0], m) for m in expected)


def test_a_prompt_segments_what_lies_under_it(models):
    """Prompt coordinates go through the resize to S: each point's masks are the region it lies in."""
    enc, dec = models
    seg = SamSegmenter(SamConfig(encoder=str(enc), decoder=str(dec)))
    seg.prepare(None, None)
    img, (red, blue, background) = rectangles()
    feed = seg.decoder_feed(img)
    for (x, y), want in (((40, 20), red), ((100, 70), blue), ((60, 20), background), ((8, 90), background)):
        logits, iou = seg.point_logits(feed, x, y)
        assert logits.shape == (3, 96, 128) and np.allclose(iou, IOU[1:])  # tokens 1..3 of 4
        assert np.array_equal(logits[0] > 0, want), (x, y)


def test_small_regions_are_removed(models):
    from inpaint360gs.segment.masks import remove_small_regions

    m = np.zeros((20, 20), bool)
    m[2:12, 2:12] = True
    m[5, 5] = False  # a 1-px hole
    m[16:18, 16:18] = True  # a 4-px island
    out, changed = remove_small_regions(m, 5)
    assert changed and out[5, 5] and not out[16:18, 16:18].any() and out[2:12, 2:12].all()
    assert not remove_small_regions(out, 5)[1]
    enc, dec = models
    seg = SamSegmenter(SamConfig(encoder=str(enc), decoder=str(dec), points_per_side=8, min_mask_region_area=300))
    seg.prepare(None, None)
    img, (red, blue, background) = rectangles()
    img[64:80, 16:32] = (220, 30, 30)  # a red cell apart from the red rectangle: an island of red, a hole in green
    ids = seg.segment(_View, torch.from_numpy(img).float() / 255)
    assert int(ids.max()) == 3
    assert np.array_equal(ids == ids[20, 20], red)  # the island left the red mask ...
    assert (ids[64:80, 16:32] == ids[0, 0]).all()  # ... and the hole in the background was filled


def test_filters_drop_low_iou_and_unstable_masks(models):
    enc, dec = models
    strict = SamSegmenter(SamConfig(encoder=str(enc), decoder=str(dec), points_per_side=4, pred_iou_thresh=0.99))
    strict.prepare(None, None)
    img, _ = rectangles()
    assert strict.generate(img) == []  # every token's predicted IoU is below 0.99
    assert not strict.segment(_View, torch.from_numpy(img).float() / 255).any()
    wide = SamSegmenter(SamConfig(encoder=str(enc), decoder=str(dec), points_per_side=4, stability_score_offset=5.0))
    wide.prepare(None, None)
    assert wide.generate(img) == []  # logits of 4 inside: thresholding at +5 leaves nothing, stability 0


def test_box_nms_and_grid():
    boxes = np.array([[0, 0, 10, 10], [1, 1, 10, 10], [20, 20, 30, 30]], float)
    assert box_nms(boxes, np.array([1, 0, 2]), 0.7) == [1, 2]
    g = point_grid(2)
    assert np.allclose(g, [[0.25, 0.25], [0.75, 0.25], [0.25, 0.75], [0.75, 0.75]])


def test_missing_and_bad_model_files(models, tmp_path, monkeypatch):
    enc, dec = models
    monkeypatch.delenv("INPAINT360GS_SAM_ENCODER", raising=False)
    monkeypatch.delenv("INPAINT360GS_SAM_DECODER", raising=False)
    with pytest.raises(InputError, match="SamConfig.encoder") as e:
        SamSegmenter(SamConfig(decoder=str(dec))).prepare(None, None)
    assert e.value.setting == "SamConfig.encoder"
    with pytest.raises(InputError, match="ONNX file not found"):
        SamSegmenter(SamConfig(encoder=str(tmp_path / "nope.onnx"), decoder=str(dec))).prepare(None, None)
    junk = tmp_path / "junk.onnx"
    junk.write_bytes(b"not a protobuf")
    with pytest.raises(InputError, match="not a loadable ONNX model"):
        SamSegmenter(SamConfig(encoder=str(junk), decoder=str(dec))).prepare(None, None)
    with pytest.raises(InputError, match="not a SAM prompt decoder"):
        SamSegmenter(SamConfig(encoder=str(enc), decoder=str(enc))).prepare(None, None)
    partial = tmp_path / "partial.onnx"
    decoder_model(partial, drop_input="orig_im_size")
    with pytest.raises(InputError, match="orig_im_size"):
        SamSegmenter(SamConfig(encoder=str(enc), decoder=str(partial))).prepare(None, None)
    monkeypatch.setenv("INPAINT360GS_SAM_ENCODER", str(enc))
    monkeypatch.setenv("INPAINT360GS_SAM_DECODER", str(dec))
    SamSegmenter(SamConfig(points_per_side=2)).prepare(None, None)  # from the environment


def test_cli_with_sam(models, tmp_path, capsys):
    from segment_scenes import two_blobs, write_scene

    enc, dec = models
    root = write_scene(tmp_path / "blobs", two_blobs()[0], n_train=4)
    ply = tmp_path / "unused.ply"
    ply.write_bytes(b"recorded, not read")
    out = tmp_path / "seg"
    args = ["segment", str(root), str(ply), str(out), "--segmenter", "sam", "--sam-encoder", str(enc), "--sam-decoder", str(dec),
            "--sam-points-per-side", "4", "--no-progress"]  # fmt: skip
    assert main(args) == 0
    assert "sam segmented 3 training views" in capsys.readouterr().out
    assert main([*args[:-1], "--sam-decoder", str(tmp_path / "missing.onnx"), "--overwrite"]) == 2
    err = capsys.readouterr().err.strip()
    assert "missing.onnx" in err and len(err.splitlines()) == 1
