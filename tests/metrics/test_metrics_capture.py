"""Scores for captures without ground truth (inpaint360gs.metrics.capture): closed-form cases."""

import numpy as np
import pytest

from inpaint360gs.core.support import fit_plane, object_footprint
from inpaint360gs.metrics.capture import grow, object_beside, object_in_fill, psnr_outside, standing_share, texture_ratios


def test_psnr_outside_ignores_the_grown_footprint():
    rng = np.random.default_rng(0)
    a = 0.8 * rng.random((60, 80, 3))  # images in [0, 1], also after the changes below
    fp = np.zeros((60, 80), bool)
    fp[20:30, 30:40] = True
    b = a.copy()
    b[grow(fp, 5)] += 0.5  # changed only within 5 px of the footprint
    assert psnr_outside(b, a, fp, grow_px=5) == float("inf")
    assert np.isfinite(psnr_outside(b, a, fp, grow_px=2))
    c = a + 0.1  # everywhere: 20 dB
    assert psnr_outside(c, a, fp, grow_px=5) == pytest.approx(20.0, abs=1e-9)


def test_grow_is_a_disc():
    m = np.zeros((21, 21), bool)
    m[10, 10] = True
    g = grow(m, 3)
    assert g[10, 13] and g[13, 10] and not g[13, 13] and g.sum() == 29


def test_texture_ratios_flat_and_textured_fill():
    rng = np.random.default_rng(1)
    img = rng.random((80, 80, 3)) * 0.5 + 0.25
    hole = np.zeros((80, 80), bool)
    hole[30:50, 30:50] = True
    same = texture_ratios(img, hole, 10)
    assert same.laplacian == pytest.approx(1.0, abs=0.1) and same.luminance == pytest.approx(1.0, abs=0.05)
    flat = img.copy()
    flat[hole] = img[~hole].mean(axis=0)
    r = texture_ratios(flat, hole, 10)
    assert r.laplacian < 0.2  # only the border pixels see the ring's texture
    dark = img.copy()
    dark[hole] *= 0.5
    assert texture_ratios(dark, hole, 10).luminance == pytest.approx(0.5, abs=0.03)
    assert texture_ratios(img, np.zeros((80, 80), bool)) is None


def _disc_on_checker(h: int = 120, w: int = 160):
    """A yellow-and-black disc photographed on a grey-and-white checker: (support, disc, photo, yy, xx)."""
    yy, xx = np.mgrid[:h, :w]
    support = np.where(((yy // 8 + xx // 8) % 2)[..., None] == 1, [0.9, 0.9, 0.9], [0.45, 0.45, 0.5])
    disc = (yy - 60) ** 2 + (xx - 80) ** 2 <= 25**2
    photo = support.copy()
    photo[disc] = np.where(((xx // 6) % 2 == 0)[disc][:, None], [0.95, 0.8, 0.1], [0.05, 0.05, 0.05])
    return support, disc, photo, yy, xx


def test_object_beside_counts_the_objects_colours_left_next_to_its_footprint():
    """A yellow-and-black disc on a grey-and-white checker: a clean removal's band reads 0; a patch of
    the disc's colours left just outside the footprint reads its area over the footprint's; a patch of
    the checker's colours (support that looks like its surroundings) and a patch far from the
    footprint read 0."""
    support, disc, photo, yy, xx = _disc_on_checker()
    h, w = disc.shape
    clean = support.copy()  # the removed render: the support where the object stood
    assert object_beside(clean, photo, disc) == 0.0
    left = clean.copy()
    patch = np.zeros((h, w), bool)
    patch[55:65, 107:112] = True  # 2-7 px outside the disc's edge (x = 105): in the 10-px band
    assert not disc[patch].any() and grow(disc, 10)[patch].all()
    left[patch] = [0.95, 0.8, 0.1]  # a yellow part of the object left there
    assert object_beside(left, photo, disc) == pytest.approx(patch.sum() / disc.sum())
    grey = clean.copy()
    grey[patch] = [0.45, 0.45, 0.5]  # the support's own colour
    assert object_beside(grey, photo, disc) == 0.0
    far = clean.copy()
    far[5:15, 5:15] = [0.95, 0.8, 0.1]  # the object's colour, but far from its footprint
    assert object_beside(far, photo, disc) == 0.0
    assert object_beside(clean, photo, np.zeros((h, w), bool)) is None


def test_object_in_fill_counts_the_objects_colours_left_inside_the_footprint():
    """The same disc on the checker: a fill in the checker's colours reads 0, whatever its pattern
    (here shifted by half a square); yellow specks drawn into the fill read their area over the
    footprint's; the object's colours left beside the footprint are not counted here."""
    support, disc, photo, yy, xx = _disc_on_checker()
    h, w = disc.shape
    fill = support.copy()
    fill[disc] = np.where(((yy // 8 + (xx + 4) // 8) % 2)[..., None] == 1, [0.9, 0.9, 0.9], [0.45, 0.45, 0.5])[disc]
    assert object_in_fill(fill, photo, disc) == 0.0
    specks = np.zeros((h, w), bool)
    for y, x in ((50, 70), (62, 85), (70, 78)):
        specks[y : y + 3, x : x + 3] = True
    assert disc[specks].all()
    speckled = fill.copy()
    speckled[specks] = [0.95, 0.8, 0.1]
    assert object_in_fill(speckled, photo, disc) == pytest.approx(specks.sum() / disc.sum())
    beside = fill.copy()
    beside[55:65, 107:112] = [0.95, 0.8, 0.1]  # outside the footprint: object_beside's, not this score's
    assert object_in_fill(beside, photo, disc) == 0.0 and object_beside(beside, photo, disc) > 0
    assert object_in_fill(fill, photo, np.zeros((h, w), bool)) is None


def test_fit_plane_ignores_what_stands_on_it():
    rng = np.random.default_rng(2)
    n_true = np.array([0.1, -0.2, 1.0])
    n_true /= np.linalg.norm(n_true)
    e1 = np.cross(n_true, [1.0, 0, 0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n_true, e1)
    uv = rng.uniform(-1, 1, (400, 2))
    pts = uv[:, :1] * e1 + uv[:, 1:] * e2 + 0.3 * n_true
    junk = pts[:60] + rng.uniform(0.05, 0.5, (60, 1)) * n_true  # objects standing on it
    n, d = fit_plane(np.concatenate([pts, junk]), np.array([0, 0, 1.0]))
    assert n @ n_true > 0.9999 and d == pytest.approx(0.3, abs=1e-6)


def _floor_and_box(rng, standing: int):
    """A floor z=0 of 2000 Gaussians over [-1, 1]^2, an object (box 0.4 x 0.4 x 0.3 at the centre)."""
    floor = np.c_[rng.uniform(-1, 1, (2000, 2)), np.zeros(2000)]
    obj = np.c_[rng.uniform(-0.2, 0.2, (500, 2)), rng.uniform(0.0, 0.3, 500)]
    left = np.c_[rng.uniform(-0.15, 0.15, (standing, 2)), rng.uniform(0.1, 0.25, standing)]
    return floor, obj, left


def test_standing_share_counts_what_stands_in_the_column():
    rng = np.random.default_rng(3)
    floor, obj, left = _floor_and_box(rng, 10)
    fp = object_footprint(obj, np.ones(len(obj)), floor, np.ones(len(floor)), np.array([0.0, 0.0, 1.0]))
    assert fp.height == pytest.approx(0.3, abs=0.01) and abs(fp.offset) < 1e-9
    inside_floor = int(fp.inside(floor).sum())
    assert 55 < inside_floor <= 80  # the box covers 0.16 / 4 of the floor: 80 expected, less its hull's trimmed corners
    share, count = standing_share(floor, np.ones(len(floor)), fp)
    assert share == 0.0 and count == 0
    pts = np.concatenate([floor, left])
    op = np.r_[np.ones(len(floor)), np.full(len(left), 0.5)]
    share, count = standing_share(pts, op, fp)
    assert count == 10 and share == pytest.approx(5.0 / (inside_floor + 5.0))
    outside = left + np.array([0.6, 0.0, 0.0])  # beside the footprint: not counted
    assert standing_share(np.concatenate([floor, outside]), np.ones(len(floor) + 10), fp) == (0.0, 0)


def test_standing_share_of_the_object_is_not_inflated_by_an_emptied_column():
    from inpaint360gs.metrics.capture import standing_mass

    rng = np.random.default_rng(4)
    floor, obj, left = _floor_and_box(rng, 10)
    fp = object_footprint(obj, np.ones(len(obj)), floor, np.ones(len(floor)), np.array([0.0, 0.0, 1.0]))
    before = standing_mass(np.concatenate([floor, obj]), np.ones(len(floor) + len(obj)), fp)
    standing_obj = int((fp.inside(obj) & (fp.heights(obj) > 0.1 * fp.height)).sum())
    assert before == pytest.approx(standing_obj)  # the floor lies on the plane: only the object stands
    # the removal took the object and the floor under it; 10 faint Gaussians (opacity 0.5) stand on
    kept = np.concatenate([floor[~fp.inside(floor)], left])
    op = np.r_[np.ones(len(kept) - len(left)), np.full(len(left), 0.5)]
    assert standing_share(kept, op, fp)[0] == pytest.approx(1.0)  # of the column: all of it
    share, count = standing_share(kept, op, fp, reference=before)
    assert count == 10 and share == pytest.approx(5.0 / standing_obj)  # of the object: a few per cent
    assert standing_share(kept, op, fp, reference=0.0) == (0.0, 0)


def test_standing_share_leaves_out_faint_floaters_over_the_objects_top():
    from inpaint360gs.metrics.capture import OPAQUE_ABOVE_TOP, standing_mass

    rng = np.random.default_rng(5)
    floor, obj, _ = _floor_and_box(rng, 10)
    fp = object_footprint(obj, np.ones(len(obj)), floor, np.ones(len(floor)), np.array([0.0, 0.0, 1.0]))
    before = standing_mass(np.concatenate([floor, obj]), np.ones(len(floor) + len(obj)), fp)
    # over the object's top (up to twice its height): faint floaters do not stand there, an opaque part does
    over = np.c_[rng.uniform(-0.15, 0.15, (20, 2)), rng.uniform(0.35, 0.55, 20)]
    pts = np.concatenate([floor[~fp.inside(floor)], over])
    faint = np.r_[np.ones(len(pts) - 20), np.full(20, 0.5 * OPAQUE_ABOVE_TOP)]
    assert standing_share(pts, faint, fp, reference=before) == (0.0, 0)
    opaque = np.r_[np.ones(len(pts) - 20), np.full(20, 0.9)]
    share, count = standing_share(pts, opaque, fp, reference=before)
    assert count == 20 and share == pytest.approx(20 * 0.9 / before)
    # below the top a faint Gaussian still counts
    low = np.c_[over[:, :2], np.full(20, 0.2)]
    assert standing_share(np.concatenate([floor[~fp.inside(floor)], low]), faint, fp, reference=before)[1] == 20


def test_a_neighbour_reaching_into_the_column_does_not_stand_where_the_object_stood():
    """A big box beside the object reaches into the footprint column (the outline is convex); after
    a clean removal only the box's corner stands there. Left out as a neighbour (most of it lies
    outside the column), the share is 0; a piece of the object the field gave another label, lying
    wholly inside the column, is no neighbour and still counts."""
    from inpaint360gs.metrics.capture import neighbour_gaussians, standing_mass

    rng = np.random.default_rng(6)
    floor, obj, _ = _floor_and_box(rng, 0)
    fp = object_footprint(obj, np.ones(len(obj)), floor, np.ones(len(floor)), np.array([0.0, 0.0, 1.0]))
    big = np.c_[rng.uniform(0.15, 0.9, 2000), rng.uniform(-0.5, 0.5, 2000), rng.uniform(0.0, 0.4, 2000)]
    piece = np.c_[rng.uniform(-0.1, 0.0, (50, 2)), rng.uniform(0.1, 0.2, 50)]
    before_pts = np.concatenate([floor, obj, big, piece])
    op = np.ones(len(before_pts))
    members = np.zeros((len(before_pts), 2), dtype=bool)
    members[len(floor) + len(obj) : len(floor) + len(obj) + len(big), 0] = True
    members[-len(piece) :, 1] = True
    nb = neighbour_gaussians(before_pts, op, fp, members)
    assert nb[members[:, 0]].all() and not nb[~members[:, 0]].any()
    in_col = fp.inside(big) & (fp.heights(big) > 0.1 * fp.height)
    assert in_col.sum() > 20  # the box's corner stands in the column
    before = standing_mass(before_pts, op, fp, exclude=nb)
    after = np.concatenate([floor, big])  # the object removed cleanly
    keep = np.r_[np.zeros(len(floor), bool), np.ones(len(big), bool)]
    assert standing_share(after, np.ones(len(after)), fp, reference=before)[1] == int(in_col.sum())
    assert standing_share(after, np.ones(len(after)), fp, reference=before, exclude=keep) == (0.0, 0)
    left = np.concatenate([floor, big, piece])  # the piece the field labelled otherwise is left
    exclude = np.r_[np.zeros(len(floor), bool), np.ones(len(big), bool), np.zeros(len(piece), bool)]
    share, count = standing_share(left, np.ones(len(left)), fp, reference=before, exclude=exclude)
    assert count == 50 and share == pytest.approx(50 / before)
