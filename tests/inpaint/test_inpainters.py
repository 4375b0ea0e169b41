"""2D inpainters (paper Sec. 3.5): the contract (only masked pixels change, bit for bit), closed-form
fills, exact plane recovery for depth, the LaMa ONNX plumbing on tiny generated models, bad input."""

from __future__ import annotations

import importlib.util

import cv2
import numpy as np
import pytest

from inpaint360gs.core.errors import InputError
from inpaint360gs.inpaint.inpainters import (
    DEFAULT_DEPTH,
    DEFAULT_RGB,
    DEPTH_METHODS,
    INPAINTERS,
    RGB_METHODS,
    inpaint_depth,
    inpaint_rgb,
    make_inpainter,
    relative_noise,
)

LOCAL_RGB = [m for m in RGB_METHODS if m != "lama"]
LOCAL_DEPTH = [m for m in DEPTH_METHODS if m != "lama"]
H, W = 48, 64


def _box_mask(y0=18, y1=30, x0=24, x1=40, shape=(H, W)):
    m = np.zeros(shape, dtype=bool)
    m[y0:y1, x0:x1] = True
    return m


def _plane_depth(h=H, w=W, normal=(0.1, -0.3, -0.8), offset=-1.5, f=50.0):
    """z-depth of the plane n·X = c seen by a pinhole camera at the origin looking down +z."""
    v, u = np.mgrid[0:h, 0:w].astype(np.float64)
    rays = np.stack([(u + 0.5 - w / 2) / f, (v + 0.5 - h / 2) / f, np.ones_like(u)], axis=-1)
    z = offset / (rays @ np.asarray(normal))
    assert (z > 0).all()
    return z.astype(np.float32)


def test_registry_and_defaults():
    assert set(INPAINTERS) == {"telea", "ns", "harmonic", "plane", "patchmatch", "patchmatch_harmonic", "shiftmap", "lama"}
    assert DEFAULT_RGB in RGB_METHODS and DEFAULT_DEPTH in DEPTH_METHODS
    assert "plane" not in RGB_METHODS and "shiftmap" not in DEPTH_METHODS


@pytest.mark.parametrize("method", LOCAL_RGB)
def test_rgb_fills_only_the_mask(method):
    rng = np.random.default_rng(0)
    img = rng.random((H, W, 3), dtype=np.float32)
    mask = _box_mask()
    mask[2, 60] = True  # a second, one-pixel hole
    given = img.copy()
    given[mask] = np.nan  # masked pixels are never read
    out = inpaint_rgb(given, mask, method)
    assert out.shape == img.shape and out.dtype == np.float32
    assert np.array_equal(out[~mask], img[~mask])
    assert np.isfinite(out[mask]).all() and (out[mask] >= -1e-6).all() and (out[mask] <= 1 + 1e-6).all()
    assert np.isnan(given[mask]).all()  # the input is not modified


@pytest.mark.parametrize("method", LOCAL_DEPTH)
def test_depth_fills_only_the_mask(method):
    rng = np.random.default_rng(1)
    depth = (1.0 + 4.0 * rng.random((H, W))).astype(np.float32)
    mask = _box_mask()
    given = depth.copy()
    given[mask] = np.nan
    out = inpaint_depth(given, mask, method)
    assert out.shape == depth.shape and out.dtype == np.float32
    assert np.array_equal(out[~mask], depth[~mask])
    assert np.isfinite(out[mask]).all() and (out[mask] > 0).all()


@pytest.mark.parametrize("method", LOCAL_RGB)
def test_empty_mask_returns_a_copy(method):
    img = np.random.default_rng(2).random((H, W, 3)).astype(np.float32)
    out = inpaint_rgb(img, np.zeros((H, W), bool), method)
    assert np.array_equal(out, img) and out is not img
    d = img[..., 0] + 1.0
    assert np.array_equal(inpaint_depth(d, np.zeros((H, W), bool), "plane"), d)


def test_float64_in_float64_out():
    img = np.random.default_rng(3).random((H, W, 3))
    mask = _box_mask()
    out = inpaint_rgb(img, mask, "telea")
    assert out.dtype == np.float64 and np.array_equal(out[~mask], img[~mask])


@pytest.mark.parametrize("method", LOCAL_RGB)
def test_constant_image_is_reproduced(method):
    img = np.empty((H, W, 3), np.float32)
    img[...] = (0.2, 0.55, 0.9)
    mask = _box_mask()
    out = inpaint_rgb(img, mask, method)
    # patchmatch returns 8 bit; shift-map copies known pixels
    tol = {"patchmatch": 0.5 / 255, "patchmatch_harmonic": 0.5 / 255}.get(method, 1e-5 - 1e-6) + 1e-6
    assert np.abs(out - img).max() <= tol


def test_linear_ramp_stays_a_ramp():
    """Harmonic fill is exact for images linear in the pixel coordinates; OpenCV's Telea and
    Navier-Stokes stay within a few pixels' worth of slope in a small hole."""
    v, u = np.mgrid[0:H, 0:W].astype(np.float64)
    slope = 0.01
    ramp = np.stack([0.1 + slope * u, 0.2 + slope * 0.5 * v, 0.9 - slope * 0.3 * (u + v)], axis=-1)
    mask = _box_mask(20, 28, 28, 36)  # 8x8
    assert np.abs(inpaint_rgb(ramp, mask, "harmonic") - ramp).max() < 1e-9
    for method in ("telea", "ns"):
        err = np.abs(inpaint_rgb(ramp, mask, method) - ramp)[mask].max()
        assert err < 2.5 * slope, (method, err)


def test_telea_is_not_off_by_opencv_units():
    """cv2.inpaint's fast marching is off by ~1.5 sample units; the stretched range makes it negligible."""
    img = np.full((H, W, 3), 0.3, np.float32)
    img[:, W // 2 :] = 0.31
    out = inpaint_rgb(img, _box_mask(), "telea")
    assert out.min() >= 0.3 - 1e-4 and out.max() <= 0.31 + 1e-4


@pytest.mark.parametrize("method", ["plane", "harmonic"])
def test_depth_plane_is_recovered_exactly(method):
    depth = _plane_depth()
    mask = _box_mask()
    out = inpaint_depth(depth, mask, method)
    rel = np.abs(out - depth)[mask] / depth[mask]
    assert rel.max() < 1e-5, rel.max()


def test_plane_extrapolates_at_the_border_within_the_ring_range():
    import cv2

    depth = _plane_depth(normal=(0.1, -0.6, -0.5))
    mask = np.zeros((H, W), bool)
    mask[:10, 20:44] = True  # touches the top border
    out = inpaint_depth(depth, mask, "plane")
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (13, 13))  # the default ring of 6 pixels
    ring = cv2.dilate(mask.astype(np.uint8), kernel).astype(bool) & ~mask
    lo, hi = (1.0 / depth[ring]).min(), (1.0 / depth[ring]).max()
    inv = 1.0 / out[mask]
    assert inv.min() >= lo - 1e-6 and inv.max() <= hi + 1e-6
    # where the true plane stays within the ring's range the fill is exact; beyond it, clamped
    inside = mask & (1.0 / depth >= lo) & (1.0 / depth <= hi)
    assert inside.sum() > 0.5 * mask.sum()
    assert (np.abs(out - depth)[inside] / depth[inside]).max() < 1e-5


def test_plane_handles_two_surfaces_and_an_outlier_object():
    """A hole across the fold of two planes (floor meeting a wall): one plane per side of the ring;
    a small object next to the hole does not pull the fit."""
    floor = _plane_depth(normal=(0.0, -1.0, -0.6), offset=-1.0)
    wall = _plane_depth(normal=(0.6, 0.0, -1.0), offset=-3.0)
    depth = np.where(np.arange(W)[None, :] < W // 2, floor, wall).astype(np.float32)
    mask = _box_mask(16, 32, 24, 40)
    depth[12:16, 22:26] = 0.7  # an object touching the hole's ring
    out = inpaint_depth(depth, mask, "plane")
    rel = np.abs(out - depth)[mask] / depth[mask]
    assert np.mean(rel < 1e-5) > 0.85, np.mean(rel < 1e-5)
    single = inpaint_depth(depth, mask, "plane", planes=1)
    assert np.mean(np.abs(single - depth)[mask] / depth[mask] < 1e-5) < np.mean(rel < 1e-5)


def test_plane_is_robust_to_noise():
    rng = np.random.default_rng(4)
    depth = _plane_depth()
    noisy = (depth * (1 + rng.normal(0, 0.01, depth.shape))).astype(np.float32)
    assert 0.005 < relative_noise(1.0 / noisy.astype(np.float64), np.zeros((H, W), bool)) < 0.02
    assert relative_noise(1.0 / depth.astype(np.float64), np.zeros((H, W), bool)) < 1e-6
    mask = _box_mask()
    out = inpaint_depth(noisy, mask, "plane")
    assert np.median(np.abs(out - depth)[mask] / depth[mask]) < 0.004


def test_patchmatch_harmonic_is_patchmatch_texture_on_membrane_low_frequencies():
    """A bright shading peak inside the hole with fine texture on top: PatchMatch alone can only
    copy the darker surroundings, the membrane fill is smooth; their combination keeps PatchMatch's
    texture and the membrane's brightness. The fill is exactly pm + G_sigma * (harmonic - pm)."""
    import cv2

    rng = np.random.default_rng(0)
    v, u = np.mgrid[0:H, 0:W].astype(np.float64)
    shade = 0.25 + 0.6 * np.exp(-((u - 32) ** 2 + (v - 24) ** 2) / (2 * 14**2))
    tex = cv2.GaussianBlur(rng.random((H, W)), (0, 0), 0.7)
    img = np.stack([shade, 0.8 * shade, 0.6 * shade], axis=-1) + ((tex - tex.mean()) / tex.std() * 0.04)[..., None]
    mask = _box_mask(16, 32, 22, 42)
    out = {m: inpaint_rgb(img, mask, m, seed=3) for m in ("patchmatch", "harmonic", "patchmatch_harmonic")}
    low = cv2.GaussianBlur(out["harmonic"] - out["patchmatch"], (0, 0), 3.0, borderType=cv2.BORDER_REFLECT)
    assert np.allclose(out["patchmatch_harmonic"][mask], np.clip(out["patchmatch"] + low, 0, 1)[mask], atol=1e-12)
    rmse = {m: float(np.sqrt(((o - img)[mask] ** 2).mean())) for m, o in out.items()}
    detail = {m: float(np.abs(o - cv2.GaussianBlur(o, (0, 0), 2.0))[mask].mean()) for m, o in out.items()}
    assert rmse["patchmatch_harmonic"] < 0.6 * rmse["patchmatch"], rmse
    assert detail["patchmatch_harmonic"] > 3 * detail["harmonic"] and detail["patchmatch_harmonic"] > 0.8 * detail["patchmatch"], detail


def test_patchmatch_is_seeded():
    rng = np.random.default_rng(5)
    img = rng.random((H, W, 3)).astype(np.float32)
    mask = _box_mask()
    a = inpaint_rgb(img, mask, "patchmatch", seed=7)
    assert np.array_equal(a, inpaint_rgb(img, mask, "patchmatch", seed=7))


# ---------------------------------------------------------------------------------------------
# bad input


@pytest.mark.parametrize(
    "image, mask, match",
    [
        (np.zeros((H, W, 3), np.float32), np.zeros((H, W + 1), bool), "shape"),
        (np.zeros((H, W), np.float32), np.zeros((H, W), bool), r"\(H, W, 3\)"),
        (np.zeros((H, W, 3), np.uint8), np.zeros((H, W), bool), "float"),
        (np.zeros((H, W, 3), np.float32), np.ones((H, W), bool), "every pixel"),
    ],
)
def test_bad_rgb_input(image, mask, match):
    with pytest.raises(InputError, match=match):
        inpaint_rgb(image, mask, "telea")


def test_nan_in_known_pixels_is_refused():
    img = np.zeros((H, W, 3), np.float32)
    img[0, 0, 1] = np.nan
    with pytest.raises(InputError, match="NaN"):
        inpaint_rgb(img, _box_mask(), "telea")
    d = np.ones((H, W), np.float32)
    d[1, 1] = np.inf
    with pytest.raises(InputError, match="NaN or infinite"):
        inpaint_depth(d, _box_mask(), "plane")


def test_bad_depth_input():
    d = np.ones((H, W), np.float32)
    with pytest.raises(InputError, match="every pixel"):
        inpaint_depth(d, np.ones((H, W), bool))
    with pytest.raises(InputError, match="shape"):
        inpaint_depth(d, np.zeros((H + 1, W), bool))
    d[0, 0] = 0.0
    with pytest.raises(InputError, match="> 0"):
        inpaint_depth(d, _box_mask())
    d[0, 0] = 1.0
    with pytest.raises(InputError, match=r"\(H, W\) depth"):
        inpaint_depth(np.ones((H, W, 1), np.float32), _box_mask())


def test_unknown_method_option_and_modality():
    img = np.zeros((H, W, 3), np.float32)
    with pytest.raises(InputError, match="unknown inpainter"):
        inpaint_rgb(img, _box_mask(), "lama2")
    with pytest.raises(InputError, match="unknown inpainter option"):
        inpaint_rgb(img, _box_mask(), "telea", radus=3)
    with pytest.raises(InputError, match="depth only"):
        inpaint_rgb(img, _box_mask(), "plane")
    assert make_inpainter("telea", ring=3, radius=5).radius == 5  # another method's option is ignored


# ---------------------------------------------------------------------------------------------
# LaMa through onnxruntime, on tiny generated models with the common export's inputs and output

needs_onnx = pytest.mark.skipif(
    importlib.util.find_spec("onnx") is None or importlib.util.find_spec("onnxruntime") is None,
    reason="onnx and onnxruntime (the test extra) are not installed",
)


def _lama_model(path, kind="mean", scale=1.0, size=None, names=("image", "mask")):
    """A minimal ONNX graph with LaMa's signature.

    ``mean``: output = image * (1 - mask) + mask * (mean colour of the known pixels), times ``scale``;
    ``blur``: output = 3x3 box average of the image (count_include_pad=0), times ``scale``.
    """
    import onnx
    from onnx import TensorProto, helper

    hh, ww = size if size else ("H", "W")
    inputs = [
        helper.make_tensor_value_info(names[0], TensorProto.FLOAT, [1, 3, hh, ww]),
        helper.make_tensor_value_info(names[1], TensorProto.FLOAT, [1, 1, hh, ww]),
    ]
    output = helper.make_tensor_value_info("output", TensorProto.FLOAT, [1, 3, hh, ww])
    inits = [
        helper.make_tensor("one", TensorProto.FLOAT, [], [1.0]),
        helper.make_tensor("scale", TensorProto.FLOAT, [], [scale]),
        helper.make_tensor("axes", TensorProto.INT64, [2], [2, 3]),
    ]
    img, msk = names
    if kind == "mean":
        nodes = [
            helper.make_node("Sub", ["one", msk], ["keep"]),
            helper.make_node("Mul", [img, "keep"], ["known"]),
            helper.make_node("ReduceSum", ["known", "axes"], ["total"], keepdims=1),
            helper.make_node("ReduceSum", ["keep", "axes"], ["count"], keepdims=1),
            helper.make_node("Div", ["total", "count"], ["mean"]),
            helper.make_node("Mul", [msk, "mean"], ["fill"]),
            helper.make_node("Add", ["known", "fill"], ["raw"]),
            helper.make_node("Mul", ["raw", "scale"], ["output"]),
        ]
    else:
        nodes = [
            helper.make_node("AveragePool", [img], ["pooled"], kernel_shape=[3, 3], pads=[1, 1, 1, 1], count_include_pad=0),
            helper.make_node("Mul", ["pooled", "scale"], ["output"]),
        ]
    graph = helper.make_graph(nodes, "tiny_lama", inputs, [output], initializer=inits)
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    onnx.checker.check_model(model)
    onnx.save(model, str(path))
    return path


@needs_onnx
@pytest.mark.parametrize("scale", [1.0, 255.0])
@pytest.mark.parametrize("shape", [(37, 45), (32, 40)])
@needs_onnx
def test_lama_fills_the_hole_with_the_model_output(tmp_path, scale, shape):
    model = _lama_model(tmp_path / "lama.onnx", "mean", scale)
    h, w = shape
    img = np.empty((h, w, 3), np.float32)
    img[...] = (0.25, 0.5, 0.75)
    rng = np.random.default_rng(6)
    img[: h // 3] = rng.random((h // 3, w, 3))  # texture away from the hole: unmasked pixels must survive it
    img[h // 3 :] = (0.25, 0.5, 0.75)
    mask = _box_mask(h // 2, h // 2 + 8, w // 3, w // 3 + 9, shape=(h, w))
    out = inpaint_rgb(img, mask, "lama", lama_onnx=model)
    assert np.array_equal(out[~mask], img[~mask])
    # mean of the known pixels (with reflect padding for 37x45) is a fixed colour; 255-scaled output detected
    fill = out[mask]
    assert np.abs(fill - fill[0]).max() < 1e-6 and (fill >= 0).all() and (fill <= 1).all()
    expected = img[~mask].mean(axis=0) if shape == (32, 40) else None
    if expected is not None:
        assert np.abs(fill[0] - expected).max() < 1e-5


@needs_onnx
def test_lama_output_range_can_be_forced(tmp_path):
    model = _lama_model(tmp_path / "lama.onnx", "mean", 255.0)
    img = np.full((32, 40, 3), 0.5, np.float32)
    mask = _box_mask(10, 20, 10, 20, shape=(32, 40))
    assert np.allclose(inpaint_rgb(img, mask, "lama", lama_onnx=model, output_range="byte")[mask], 0.5, atol=1e-6)
    # read as [0, 1], the 0..255 output saturates
    assert np.allclose(inpaint_rgb(img, mask, "lama", lama_onnx=model, output_range="unit")[mask], 1.0)


@needs_onnx
def test_lama_padding_and_cropping_keep_pixels_aligned(tmp_path):
    """A 3x3 box-blur 'model' on a 37x45 frame (padded to 40x48): inside the hole the fill must be
    the box average of the hole-zeroed image at the same pixel."""
    model = _lama_model(tmp_path / "blur.onnx", "blur")
    h, w = 37, 45
    img = np.random.default_rng(7).random((h, w, 3)).astype(np.float32)
    mask = _box_mask(14, 22, 17, 27, shape=(h, w))
    out = inpaint_rgb(img, mask, "lama", lama_onnx=model)
    z = np.where(mask[..., None], 0.0, img.astype(np.float64))
    box = sum(np.roll(np.roll(z, dy, 0), dx, 1) for dy in (-1, 0, 1) for dx in (-1, 0, 1)) / 9.0
    assert np.abs(out[mask] - box[mask]).max() < 1e-5
    assert np.array_equal(out[~mask], img[~mask])


@needs_onnx
def test_lama_static_size_model_is_resized(tmp_path):
    model = _lama_model(tmp_path / "lama64.onnx", "mean", 1.0, size=(64, 64))
    img = np.full((37, 45, 3), 0.3, np.float32)
    mask = _box_mask(10, 20, 10, 20, shape=(37, 45))
    out = inpaint_rgb(img, mask, "lama", lama_onnx=model)
    assert np.allclose(out, 0.3, atol=1e-6) and np.array_equal(out[~mask], img[~mask])


@needs_onnx
def test_lama_depth_is_normalised_inpainted_and_restored(tmp_path, monkeypatch):
    model = _lama_model(tmp_path / "lama.onnx", "mean")
    monkeypatch.setenv("INPAINT360GS_LAMA_ONNX", str(model))  # the path from the environment
    rng = np.random.default_rng(8)
    depth = (1.0 + 2.0 * rng.random((32, 40))).astype(np.float32)
    mask = _box_mask(10, 20, 10, 20, shape=(32, 40))
    out = inpaint_depth(depth, mask, "lama")
    assert np.array_equal(out[~mask], depth[~mask])
    # the model fills the mean of the normalised known depth: restored, the mean known depth
    assert np.abs(out[mask] - depth[~mask].astype(np.float64).mean()).max() < 1e-4


@needs_onnx
def test_lama_bad_checkpoints(tmp_path, monkeypatch):
    img = np.zeros((32, 40, 3), np.float32)
    mask = _box_mask(10, 20, 10, 20, shape=(32, 40))
    monkeypatch.delenv("INPAINT360GS_LAMA_ONNX", raising=False)
    with pytest.raises(InputError, match="INPAINT360GS_LAMA_ONNX"):
        make_inpainter("lama")
    missing = tmp_path / "nope.onnx"
    with pytest.raises(InputError, match="not found") as e:
        inpaint_rgb(img, mask, "lama", lama_onnx=missing)
    assert str(missing) in str(e.value)
    junk = tmp_path / "junk.onnx"
    junk.write_bytes(b"this is not a protobuf\x00\xff" * 10)
    with pytest.raises(InputError, match="not a loadable ONNX model") as e:
        make_inpainter("lama", lama_onnx=junk)
    assert str(junk) in str(e.value) and "\n" not in str(e.value)
    wrong = _lama_model(tmp_path / "wrong.onnx", "mean", names=("img", "msk"))
    with pytest.raises(InputError, match="not a LaMa model") as e:
        make_inpainter("lama", lama_onnx=wrong)
    assert str(wrong) in str(e.value) and "img" in str(e.value)


def test_patchmatch_with_almost_no_known_pixels_fills_from_them():
    """A hole leaving too few known pixels for one PatchMatch source patch is filled by diffusing
    the known pixels inward; a mask over the whole image is refused."""
    from inpaint360gs.core.errors import InputError
    from inpaint360gs.inpaint.inpainters import make_inpainter

    rng = np.random.default_rng(0)
    img = rng.random((24, 32, 3))
    mask = np.ones((24, 32), bool)
    mask[10:12, 10:12] = False
    out = make_inpainter("patchmatch").rgb(img, mask)
    assert np.array_equal(out[~mask], img[~mask])
    known = img[~mask]
    assert np.all(out[mask] >= known.min(axis=0) - 1e-6) and np.all(out[mask] <= known.max(axis=0) + 1e-6)
    with pytest.raises(InputError, match="covers every pixel"):
        make_inpainter("patchmatch").rgb(img, np.ones((24, 32), bool))


def test_shiftmap_continues_stripes():
    """Horizontal stripes of period 8 through a hole: the shift-map fill copies them in phase."""
    h, w = 64, 96
    yy = np.mgrid[0:h, 0:w][0]
    img = np.repeat(np.where((yy // 4) % 2 == 0, 0.8, 0.2)[..., None], 3, axis=2)
    hole = np.zeros((h, w), bool)
    hole[20:44, 30:66] = True
    out = make_inpainter("shiftmap").rgb(img, hole)
    assert np.abs(out[hole] - img[hole]).mean() < 0.05


def test_shiftmap_is_deterministic_across_calls_and_processes(tmp_path):
    """Same arrays, same bytes: twice in this process and once in a fresh interpreter."""
    import subprocess
    import sys

    rng = np.random.default_rng(7)
    yy, xx = np.mgrid[0:48, 0:64]
    img = np.stack([0.5 + 0.3 * np.sin(xx / 2.0), 0.4 + 0.2 * ((yy // 5) % 2), 0.3 + 0.0 * xx], axis=-1)
    img = np.clip(img + 0.05 * rng.random(img.shape), 0, 1)
    hole = np.zeros((48, 64), bool)
    hole[14:32, 20:44] = True
    a = make_inpainter("shiftmap").rgb(img, hole)
    b = make_inpainter("shiftmap").rgb(img, hole)
    assert np.array_equal(a, b)
    np.save(tmp_path / "img.npy", img)
    np.save(tmp_path / "hole.npy", hole)
    code = (
        "import numpy as np, sys; from inpaint360gs.inpaint.inpainters import make_inpainter; "
        f"d = {str(tmp_path)!r}; "
        "np.save(d + '/out.npy', make_inpainter('shiftmap').rgb(np.load(d + '/img.npy'), np.load(d + '/hole.npy')))"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
    assert np.array_equal(np.load(tmp_path / "out.npy"), a)


def test_shiftmap_continues_vertical_stripes():
    """Vertical stripes of period 8 through a square hole: the column means inside the hole follow
    the column pattern."""
    h, w = 64, 96
    xx = np.mgrid[0:h, 0:w][1]
    img = np.repeat(np.where((xx // 4) % 2 == 0, 0.85, 0.15)[..., None], 3, axis=2)
    hole = np.zeros((h, w), bool)
    hole[18:46, 32:60] = True
    out = make_inpainter("shiftmap").rgb(img, hole)
    filled = out[18:46, 32:60, 0].mean(axis=0)
    pattern = img[0, 32:60, 0]
    assert np.corrcoef(filled, pattern)[0, 1] > 0.9


def test_shiftmap_continues_a_straight_border():
    """A straight (slanted) border between two flat colours crossing the hole is continued."""
    h, w = 64, 96
    yy, xx = np.mgrid[0:h, 0:w]
    line = 0.25 * xx + 20.0  # border y = 20 + x / 4
    below = yy > line
    img = np.where(below[..., None], np.array([0.8, 0.4, 0.4]), np.array([0.4, 0.45, 0.5]))
    hole = np.zeros((h, w), bool)
    hole[16:48, 30:62] = True
    out = make_inpainter("shiftmap").rgb(img, hole)
    off = np.abs(yy - line) > 1.0  # pixels right at the border line may go either way
    sel = hole & off
    right = np.all(np.abs(out - img) < 1e-9, axis=-1)
    assert right[sel].mean() > 0.95


def test_shiftmap_keeps_each_side_of_a_border_through_a_slanted_hole():
    """A slightly slanted border between a noisy pink region and wavy wood grain, crossed by a slanted
    blob (a removed object's footprint): the border is found as the one straight boundary (the grain's
    own stripes are texture, not structure), and no fill pixel takes the other side's colour; without
    the structure line the offset statistics copy pink up into the grain."""
    from inpaint360gs.inpaint.inpainters import _crossing_lines

    h, w = 120, 160
    rng = np.random.default_rng(0)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
    border = 62.0 + 0.06 * (xx - w / 2)
    below = yy > border
    pink, wood = np.array([0.85, 0.5, 0.45]), np.array([0.55, 0.4, 0.25])
    grain = 0.08 * np.sin(xx / 3.0 + 2 * np.sin(yy / 7.0))[..., None]
    img = np.where(below[..., None], pink + 0.03 * rng.standard_normal((h, w, 1)), wood + grain)
    img = np.clip(img, 0, 1).astype(np.float32)
    hole = np.zeros((h, w), np.uint8)
    cv2.ellipse(hole, (80, 60), (38, 16), 35, 0, 360, 1, -1)
    hole = hole.astype(bool)

    rgb8 = np.clip(np.round(img * 255), 0, 255).astype(np.uint8)
    lines = _crossing_lines(cv2.cvtColor(rgb8, cv2.COLOR_RGB2Lab).astype(np.float64), hole)
    assert len(lines) == 1
    angle, rho = lines[0]
    at = lambda x: (rho - x * np.cos(angle)) / np.sin(angle)  # noqa: E731  (the line's y at column x)
    assert abs(at(40.0) - (62.0 + 0.06 * (40 - w / 2))) < 2.0 and abs(at(120.0) - (62.0 + 0.06 * (120 - w / 2))) < 2.0

    off = np.abs(yy - border) > 1.0  # pixels right at the border may go either way

    def wrong_side(out):
        took_pink = np.linalg.norm(out - pink, axis=-1) < np.linalg.norm(out - wood, axis=-1)
        return (took_pink != below)[hole & off].mean()

    assert wrong_side(make_inpainter("shiftmap").rgb(img, hole)) < 0.01
    assert wrong_side(make_inpainter("shiftmap", structure=False).rgb(img, hole)) > 0.05
