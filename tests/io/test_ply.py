"""Gaussian PLY I/O: exact round trip, the original 3DGS layout both ways, bad files."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from plyfile import PlyData, PlyElement

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.io.ply import ply_field_names, read_ply, write_ply


def random_gaussians(n: int = 57, degree: int = 3, features: int = 0, seed: int = 0) -> Gaussians:
    g = torch.Generator().manual_seed(seed)
    k = (degree + 1) ** 2
    return Gaussians(
        means=torch.randn(n, 3, generator=g),
        log_scales=torch.randn(n, 3, generator=g) - 3,
        quats=torch.randn(n, 4, generator=g),
        opacity_logits=torch.randn(n, generator=g),
        sh0=torch.randn(n, 1, 3, generator=g),
        shN=torch.randn(n, k - 1, 3, generator=g),
        features=torch.randn(n, features, generator=g) if features else None,
    )


def assert_same(a: Gaussians, b: Gaussians) -> None:
    ta, tb = a.tensors(), b.tensors()
    assert ta.keys() == tb.keys()
    for k in ta:
        assert ta[k].shape == tb[k].shape, k
        assert torch.equal(ta[k], tb[k]), k


@pytest.mark.parametrize("degree,features", [(3, 0), (3, 16), (1, 0), (0, 4)])
def test_round_trip_is_exact(tmp_path, degree, features):
    g = random_gaussians(degree=degree, features=features)
    p = tmp_path / "m.ply"
    write_ply(p, g)
    assert_same(read_ply(p), g)
    assert [x.name for x in tmp_path.iterdir()] == ["m.ply"]  # atomic write leaves no temporary file


def original_3dgs_save(path, g: Gaussians) -> None:
    """What 3DGS ``GaussianModel.save_ply`` writes (its attribute list and f_rest flattening)."""
    xyz = g.means.numpy()
    normals = np.zeros_like(xyz)
    f_dc = g.sh0.transpose(1, 2).flatten(start_dim=1).contiguous().numpy()
    f_rest = g.shN.transpose(1, 2).flatten(start_dim=1).contiguous().numpy()
    opacities = g.opacity_logits[:, None].numpy()
    scale = g.log_scales.numpy()
    rotation = g.quats.numpy()
    names = ["x", "y", "z", "nx", "ny", "nz"]
    names += [f"f_dc_{i}" for i in range(f_dc.shape[1])] + [f"f_rest_{i}" for i in range(f_rest.shape[1])]
    names += ["opacity"] + [f"scale_{i}" for i in range(3)] + [f"rot_{i}" for i in range(4)]
    elements = np.empty(xyz.shape[0], dtype=[(n, "f4") for n in names])
    attributes = np.concatenate((xyz, normals, f_dc, f_rest, opacities, scale, rotation), axis=1)
    elements[:] = list(map(tuple, attributes))
    PlyData([PlyElement.describe(elements, "vertex")]).write(str(path))


def original_3dgs_load(path, degree: int = 3) -> dict[str, np.ndarray]:
    """What 3DGS ``GaussianModel.load_ply`` reads back."""
    el = PlyData.read(str(path)).elements[0]
    xyz = np.stack([np.asarray(el["x"]), np.asarray(el["y"]), np.asarray(el["z"])], axis=1)
    fdc = np.stack([np.asarray(el[f"f_dc_{i}"]) for i in range(3)], axis=1)[:, :, None]
    rest = sorted([p.name for p in el.properties if p.name.startswith("f_rest_")], key=lambda x: int(x.split("_")[-1]))
    extra = np.stack([np.asarray(el[n]) for n in rest], axis=1).reshape(xyz.shape[0], 3, (degree + 1) ** 2 - 1)
    return {
        "means": xyz,
        "sh0": fdc.transpose(0, 2, 1),
        "shN": extra.transpose(0, 2, 1),
        "opacity_logits": np.asarray(el["opacity"]),
        "log_scales": np.stack([np.asarray(el[f"scale_{i}"]) for i in range(3)], axis=1),
        "quats": np.stack([np.asarray(el[f"rot_{i}"]) for i in range(4)], axis=1),
    }


def test_reads_original_3dgs_layout(tmp_path):
    g = random_gaussians()
    p = tmp_path / "orig.ply"
    original_3dgs_save(p, g)
    assert_same(read_ply(p), g)


def test_written_file_matches_original_layout(tmp_path):
    g = random_gaussians(n=5)
    # distinct values per (coefficient, channel) to pin the channel-major order of f_rest
    g.shN = torch.arange(5 * 15 * 3, dtype=torch.float32).reshape(5, 15, 3)
    p = tmp_path / "ours.ply"
    write_ply(p, g)
    el = PlyData.read(str(p))["vertex"]
    assert [q.name for q in el.properties] == ply_field_names(3)
    assert all(q.val_dtype in ("f4", "float32") for q in el.properties)
    # f_rest_{c*15 + j} holds shN[:, j, c]
    assert np.array_equal(np.asarray(el["f_rest_16"]), g.shN[:, 1, 1].numpy())
    assert np.array_equal(np.asarray(el["f_rest_44"]), g.shN[:, 14, 2].numpy())
    back = original_3dgs_load(p)
    for k, v in back.items():
        assert np.array_equal(v, getattr(g, k).numpy()), k


def test_reads_gaussian_grouping_object_fields(tmp_path):
    g = random_gaussians(n=6, features=3)
    p = tmp_path / "gg.ply"
    write_ply(p, g)
    v = PlyData.read(str(p))["vertex"].data
    renamed = v.dtype.descr
    renamed = [(n.replace("obj_", "obj_dc_"), t) for n, t in renamed]
    arr = np.empty(len(v), dtype=renamed)
    for (old, _), (new, _) in zip(v.dtype.descr, renamed):
        arr[new] = v[old]
    PlyData([PlyElement.describe(arr, "vertex")]).write(str(p))
    assert torch.equal(read_ply(p).features, g.features)


def test_bad_plys(tmp_path):
    with pytest.raises(InputError) as e:
        read_ply(tmp_path / "missing.ply")
    assert e.value.path == tmp_path / "missing.ply"
    junk = tmp_path / "junk.ply"
    junk.write_bytes(b"\x00\x01garbage")
    with pytest.raises(InputError) as e:
        read_ply(junk)
    assert e.value.path == junk
    pts = tmp_path / "points.ply"  # a plain point cloud, not Gaussians
    PlyData([PlyElement.describe(np.zeros(3, dtype=[("x", "f4"), ("y", "f4"), ("z", "f4")]), "vertex")]).write(str(pts))
    with pytest.raises(InputError, match="missing properties"):
        read_ply(pts)
    g = random_gaussians(n=4)
    p = tmp_path / "m.ply"
    write_ply(p, g)
    arr = PlyData.read(str(p))["vertex"].data
    keep = [n for n in arr.dtype.names if n != "f_rest_44"]
    smaller = np.empty(len(arr), dtype=[(n, "f4") for n in keep])
    for n in keep:
        smaller[n] = arr[n]
    PlyData([PlyElement.describe(smaller, "vertex")]).write(str(p))
    with pytest.raises(InputError, match="44 f_rest"):
        read_ply(p)
    g.means[1, 0] = float("nan")
    write_ply(p, g)
    with pytest.raises(InputError, match="NaN"):
        read_ply(p)
    data = p.read_bytes()
    p.write_bytes(data[: len(data) - 100])
    with pytest.raises(InputError) as e:
        read_ply(p)
    assert e.value.path == p
