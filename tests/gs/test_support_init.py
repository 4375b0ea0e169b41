"""Support points where the SfM points leave the photos uncovered (gs/support_init.py), on a
closed-form scene: a floor z = 0 whose outer ring has SfM points and whose plain middle has none, a
box standing in the middle with points on its faces, cameras circling it."""

from __future__ import annotations

import numpy as np

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
