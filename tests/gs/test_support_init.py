"""Support points where the SfM points leave the photos uncovered (gs/support_init.py), on a
closed-form scene: a floor z = 0 whose outer ring has SfM points and whose plain middle has none, a
box standing in the middle with points on its faces, cameras circling it."""

from __future__ import annotations

import argparse
from types import SimpleNamespace

import numpy as np
import pytest
import torch

from inpaint360gs.core.camera import Camera
from inpaint360gs.gs.support_init import SupportInit, support_points

BOX = 0.15  # half side of the box standing at the centre, 0.3 high


def _scene(rng, ring_points: int = 20000):
    cams = []
    for k in range(12):
        a = 2 * np.pi * k / 12
        eye = (1.2 * np.cos(a), 1.2 * np.sin(a), 0.5 + 0.1 * (k % 2))
        cams.append(Camera.look_at(eye, (0.0, 0.0, 0.1), (0.0, 0.0, 1.0), 120.0, 120.0, 80.0, 60.0, 160, 120, name=f"v{k}"))
    r = np.sqrt(rng.uniform(0.6**2, 2.0**2, ring_points))
    a = rng.uniform(0, 2 * np.pi, ring_points)
    ring = np.c_[r * np.cos(a), r * np.sin(a), np.zeros(ring_points)]
    g = rng.uniform(-BOX, BOX, (6, 800, 2))
    h = rng.uniform(0.0, 0.3, (4, 800))
    faces = [np.c_[np.full(800, s * BOX), g[i, :, 0], h[i]] for i, s in enumerate((-1, 1))]
    faces += [np.c_[g[2 + i, :, 0], np.full(800, s * BOX), h[2 + i]] for i, s in enumerate((-1, 1))]
    faces += [np.c_[g[4, :, 0], g[4, :, 1], np.full(800, 0.3)]]
    return cams, np.concatenate([ring, *faces])


def test_points_fill_the_plain_support_and_nothing_else():
    rng = np.random.default_rng(0)
    cams, pts = _scene(rng)
    images = [np.full((120, 160, 3), 0.8) for _ in cams]
    xyz, rgb = support_points(cams, images, pts, SupportInit(cell_px=4))
    assert len(xyz) > 200
    np.testing.assert_allclose(xyz[:, 2], 0.0, atol=5e-4)  # on the floor (the cameras are float32)
    np.testing.assert_allclose(rgb, 0.8)  # coloured by the photos
    r = np.hypot(xyz[:, 0], xyz[:, 1])
    assert r.max() < 0.75  # the plain middle (r < 0.6), not the ring the SfM points cover (a cell's width of slack)
    under_box = (np.abs(xyz[:, 0]) < BOX - 0.02) & (np.abs(xyz[:, 1]) < BOX - 0.02)
    assert not under_box.any()  # the box's faces cover it: nothing is put under it
    # the plain middle around the box is covered: a point within a merge square's diagonal (8 cm squares here) of every place
    q = rng.uniform(-0.55, 0.55, (4000, 2))
    q = q[(np.hypot(q[:, 0], q[:, 1]) < 0.55) & ((np.abs(q[:, 0]) > BOX + 0.05) | (np.abs(q[:, 1]) > BOX + 0.05))]
    from scipy.spatial import cKDTree

    d, _ = cKDTree(xyz[:, :2]).query(q)
    assert np.quantile(d, 0.99) < 0.06


def test_nothing_is_added_where_the_points_cover_the_photos():
    rng = np.random.default_rng(1)
    cams, pts = _scene(rng)
    middle = np.sqrt(rng.uniform(0.0, 0.6**2, 4000)), rng.uniform(0, 2 * np.pi, 4000)
    disc = np.c_[middle[0] * np.cos(middle[1]), middle[0] * np.sin(middle[1]), np.zeros(4000)]
    disc = disc[(np.abs(disc[:, 0]) > BOX) | (np.abs(disc[:, 1]) > BOX)]
    images = [np.full((120, 160, 3), 0.5) for _ in cams]
    xyz, _ = support_points(cams, images, np.concatenate([pts, disc]), SupportInit(cell_px=4))
    assert len(xyz) < 10
    assert support_points(cams, images, pts[:2])[0].shape == (0, 3)  # too few points for a plane: nothing


def _fake_scene(cams, pts, grey):
    """What :func:`with_support_points` reads of a scene."""
    views = [SimpleNamespace(camera=c) for c in cams]
    return SimpleNamespace(
        train_views=views, load_image=lambda v: torch.full((120, 160, 3), grey), points=torch.from_numpy(pts).float(),
        point_colors=torch.full((len(pts), 3), grey),
    )  # fmt: skip


def test_auto_adds_the_points_on_a_plain_support_only():
    """The share of the support's cells that no SfM point covers decides "auto": the plain middle of
    the closed-form floor is most of what the cameras see of it; with points on it, nothing is uncovered."""
    from inpaint360gs.gs.support_init import with_support_points

    rng = np.random.default_rng(2)
    cams, pts = _scene(rng)
    pts = pts[(np.hypot(pts[:, 0], pts[:, 1]) > 1.0) | (pts[:, 2] > 0)]  # plain within 1.0 of the 1.2 the cameras' reach covers
    stats = {}
    support_points(cams, [np.full((120, 160, 3), 0.8)] * len(cams), pts, SupportInit(cell_px=4), stats)
    assert 0 < stats["uncovered_support_cells"] < stats["support_cells"]
    plain = _fake_scene(cams, pts, 0.8)
    p, c, report = with_support_points(plain, SupportInit(cell_px=4), auto=True)
    assert report["support_uncovered"] >= SupportInit().plain_share  # plain: most of the floor's cells in view are uncovered
    assert report["support_points"] > 200 and report["support_points"] + report["backdrop_points"] == len(p) - len(pts)
    middle = np.sqrt(rng.uniform(0.0, 1.0, 12000)), rng.uniform(0, 2 * np.pi, 12000)
    disc = np.c_[middle[0] * np.cos(middle[1]), middle[0] * np.sin(middle[1]), np.zeros(12000)]
    disc = disc[(np.abs(disc[:, 0]) > BOX) | (np.abs(disc[:, 1]) > BOX)]
    textured = _fake_scene(cams, np.concatenate([pts, disc]), 0.5)
    p, _, report = with_support_points(textured, SupportInit(cell_px=4), auto=True)
    assert report["support_uncovered"] < 0.05 and report["support_points"] == report["backdrop_points"] == 0 and len(p) == len(pts) + len(disc)


def test_support_init_modes_and_the_settings_written_before_them():
    from inpaint360gs.cli import run as run_cli, train as train_cli
    from inpaint360gs.core.errors import InputError
    from inpaint360gs.gs.config import TrainConfig

    assert TrainConfig().support_init == "auto"
    assert TrainConfig.from_dict({"support_init": True}).support_init == "on"
    assert TrainConfig.from_dict({"support_init": False}).support_init == "off"
    with pytest.raises(InputError, match="support init"):
        TrainConfig(support_init="yes").validate()
    for cli in (train_cli, run_cli):
        parser = argparse.ArgumentParser()
        cli.add_arguments(parser)
        for argv, mode in (([], "auto"), (["--support-init"], "on"), (["--support-init", "off"], "off")):
            assert parser.parse_args([".", "out", *argv]).support_init == mode


def test_backdrop_cells_get_points_at_the_depth_their_neighbours_agree_on():
    """Beyond the support (a wall round the closed-form floor, 4 from its centre), a cell holding no
    SfM point gets one at the median depth of the points a few cells around it when they lie on one
    surface; where they do not (the floor's edge against the wall), or too few are near, none."""
    from inpaint360gs.gs.support_init import thin_backdrop

    rng = np.random.default_rng(3)
    cams, pts = _scene(rng)
    a, z = rng.uniform(0, 2 * np.pi, 6000), rng.uniform(0.0, 3.0, 6000)
    wall = np.c_[4.0 * np.cos(a), 4.0 * np.sin(a), z]  # sparse: about one point in three of its cells
    images = [np.full((120, 160, 3), 0.3) for _ in cams]
    lists = ([], [], [])
    support_points(cams, images, np.concatenate([pts, wall]), SupportInit(cell_px=4), None, lists)
    xyz, rgb = thin_backdrop(*lists)
    assert len(xyz) > 100
    r = np.hypot(xyz[:, 0], xyz[:, 1])
    assert (np.abs(r - 4.0) < 0.15 * 4.0).all()  # on the wall (the depths of the window's points agree within 15 %), none in mid-air
    np.testing.assert_allclose(rgb, 0.3)
    # without the agreement test, cells over the floor's edge (floor and wall points around them) get
    # the median of the two depths: points in mid-air between them
    lists = ([], [], [])
    support_points(cams, images, np.concatenate([pts, wall]), SupportInit(cell_px=4, backdrop_spread=10.0), None, lists)
    loose, _ = thin_backdrop(*lists)
    mid_air = (np.abs(np.hypot(loose[:, 0], loose[:, 1]) - 4.0) >= 0.6) & (np.abs(loose[:, 2]) >= 0.05)
    assert mid_air.sum() > 100
    lists = ([], [], [])
    support_points(cams, images, pts, SupportInit(cell_px=4, backdrop_window=0), None, lists)
    assert sum(len(x) for x in lists[0]) == 0  # switched off
