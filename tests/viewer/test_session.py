"""The viewer's state (src/inpaint360gs/viewer/session.py) on the blobs scene with a labelled field,
where every Gaussian's object is known: a click selects what ``plan_removal`` (the selection of
``inpaint360gs run --click``) selects for that click, a click on a selected object drops it, the
frustum's ray gives back the pixel it went through, a ray through the splats selects what the photo
click at the pixel it projects to selects, and the clicks saved to scene.json read back."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch
from object_fields import click_on, labelled_field, write_field

from inpaint360gs.core.errors import InputError
from inpaint360gs.io.scene import load_scene
from inpaint360gs.pipeline.presets import get_preset
from inpaint360gs.pipeline.run import scene_clicks
from inpaint360gs.remove.check import OBJECT
from inpaint360gs.remove.select import Click, clicks_from_json
from inpaint360gs.remove.stage import plan_removal
from inpaint360gs.viewer.session import ViewerSession, camera_pose, click_at_point, ray_hit, frustum_depth, frustum_shape, pixel_from_ray, ray_through_pixel, splat_arrays

IDS = [0, 3, 7]
BLOB_1 = (0.45, 0.0, 0.25)  # scene_builder.blobs_model's first blob (label 1)
BLOB_2 = (-0.45, 0.0, 0.25)


@pytest.fixture(scope="module")
def blobs(make_blobs_scene):
    root, model, labels = make_blobs_scene("viewer", n_views=10)
    scene = load_scene(root)
    field = labelled_field(model, labels, IDS)
    return scene, model, labels.numpy(), field


@pytest.fixture
def session(blobs, tmp_path):
    scene, _, _, field = blobs
    write_field(tmp_path / "run" / "distill", field, scene)
    return ViewerSession(scene, tmp_path / "run", get_preset("cpu"))


def test_a_click_selects_what_run_click_selects_and_a_second_click_drops_it(blobs, session):
    scene, _, labels, field = blobs
    v = scene.train_views[0]
    c1 = click_on(v, BLOB_1)
    session.click(c1)
    ref = plan_removal(field, scene, clicks=[c1], cfg=session.cfg.removal, backend=session.cfg.backend)
    assert np.array_equal(session.selected(), ref.removal.removed_mask.numpy())
    assert session.plan.targets == ref.targets == [3]  # blob 1 is object 3 of the field
    assert session.plan.check.verdict == OBJECT and session.verdict().startswith("passed (object): ")
    assert (session.selected() == (labels == 1)).mean() > 0.95
    # a second object, from another view: both are removed, as run with both clicks removes them
    c2 = click_on(scene.train_views[3], BLOB_2)
    session.click(c2)
    both = plan_removal(field, scene, clicks=[c1, c2], cfg=session.cfg.removal, backend=session.cfg.backend)
    assert session.clicks == [c1, c2] and np.array_equal(session.selected(), both.removal.removed_mask.numpy())
    # a click on blob 1 elsewhere drops it, and only it
    session.click(click_on(scene.train_views[5], BLOB_1))
    assert session.clicks == [c2] and session.plan.targets == [7]
    assert np.array_equal(session.selected(), plan_removal(field, scene, clicks=[c2], cfg=session.cfg.removal).removal.removed_mask.numpy())


def test_a_click_on_nothing_keeps_the_selection_and_says_why(blobs, session):
    scene = blobs[0]
    v = scene.train_views[0]
    session.click(click_on(v, BLOB_1))
    before = session.selected().copy()
    line = session.click(Click(v.name, 0, 0))  # the corner shows the sky: nothing rendered there
    assert line.startswith("not selected:") and "empty space" in line
    assert np.array_equal(session.selected(), before)


def test_the_photo_shows_the_selection_and_the_render_sits_beside_it(blobs, session):
    scene = blobs[0]
    v = scene.train_views[0]
    plain = session.photo(v)
    session.click(click_on(v, BLOB_1))
    shown = session.photo(v)
    mask = session.plan.masks[v.name]
    assert mask.any() and not np.allclose(shown[mask], plain[mask]) and np.allclose(shown[~mask][:50], plain[~mask][:50])
    pair = session.side_by_side(v, "before")
    h, w = v.camera.height, v.camera.width
    assert pair.shape == (h, 2 * w, 3) and pair.dtype == np.uint8
    assert not pair[:, w:].any()  # no 3DGS in this run folder: the render half is black


def test_saved_clicks_are_what_scene_json_gives_run(blobs, session):
    scene = blobs[0]
    c = click_on(scene.train_views[0], BLOB_1)
    session.click(c)
    path = scene.root / "scene.json"
    assert not path.exists()
    assert session.save_clicks() == path and json.loads(path.read_text()) == {"clicks": [{"view": c.view, "x": c.x, "y": c.y}]}
    path.write_text(json.dumps({"objects": [{"id": 1}], "clicks": []}))  # the other keys are kept
    session.save_clicks()
    saved = json.loads(path.read_text())
    assert saved["objects"] == [{"id": 1}] and clicks_from_json(saved["clicks"], path) == [c]
    assert scene_clicks(load_scene(scene.root)) == [c]  # what inpaint360gs run takes without --click
    session.clear()
    with pytest.raises(InputError, match="nothing selected"):
        session.save_clicks()
    path.unlink()


def test_a_ray_through_a_pixel_of_the_frustum_photo_gives_that_pixel(blobs):
    scene = blobs[0]
    for v in scene.train_views[:3]:
        fov, aspect = frustum_shape(v.camera)
        depth = frustum_depth(fov, aspect, 0.1)
        w, h = v.full_size or (v.camera.width, v.camera.height)
        for origin in ([0.0, 0.0, 0.0], v.camera.center.double().numpy(), [3.0, -2.0, 1.0]):
            for x, y in ((0, 0), (w - 1, h - 1), (w // 3, h // 2)):
                d = ray_through_pixel(v, x, y, origin, depth)
                assert pixel_from_ray(v, origin, d, depth) == (x, y)
        centre = v.camera.center.double().numpy()
        assert pixel_from_ray(v, centre, -ray_through_pixel(v, 1, 1, centre, depth), depth) is None  # behind the camera


def test_camera_pose_and_splat_arrays(blobs):
    from scipy.spatial.transform import Rotation

    scene, model, _, _ = blobs
    cam = scene.train_views[0].camera
    wxyz, pos = camera_pose(cam)
    R_cw = Rotation.from_quat([*wxyz[1:], wxyz[0]]).as_matrix()
    assert np.allclose(R_cw, cam.R.double().numpy().T, atol=1e-6) and np.allclose(pos, cam.center.double().numpy())
    arr = splat_arrays(model)
    n = len(model)
    assert arr["centers"].shape == (n, 3) and arr["covariances"].shape == (n, 3, 3) and arr["opacities"].shape == (n, 1)
    # covariance eigenvalues are the squared scales
    ev = np.sort(np.linalg.eigvalsh(arr["covariances"][:5].astype(np.float64)), axis=1)
    assert np.allclose(ev, np.sort(model.scales[:5].double().numpy() ** 2, axis=1), rtol=1e-3)
    assert (arr["rgbs"] >= 0).all() and (arr["rgbs"] <= 1).all()


def test_a_ray_through_the_splats_selects_what_the_photo_click_at_its_pixel_selects(blobs, session):
    """A ray from a training camera's centre through blob 2's centre: it hits blob 2's front surface
    (between the camera and the centre, on the ray), the view looking along it is that camera, the
    pixel is where the blob's centre projects, and the selection is the photo click's there."""
    scene, model, labels, field = blobs
    v = scene.train_views[2]
    origin = v.camera.center.double().numpy()
    centre = np.asarray(BLOB_2)
    d = centre - origin
    hit = ray_hit(field.gaussians, origin, d)
    assert hit is not None
    s = float((hit - origin) @ d / (d @ d))
    assert 0.8 < s < 1.0 and np.linalg.norm(np.cross(hit - origin, d)) / np.linalg.norm(d) < 1e-9  # in front of the centre, on the ray
    ref_click = click_on(v, BLOB_2)
    c, line = session.click_ray(origin, d)
    assert c is not None and c.view == v.name and abs(c.x - ref_click.x) <= 1 and abs(c.y - ref_click.y) <= 1, (c, ref_click)
    ref = plan_removal(field, scene, clicks=[c], cfg=session.cfg.removal, backend=session.cfg.backend)
    assert session.clicks == [c] and session.plan.targets == ref.targets == [7], line
    assert np.array_equal(session.selected(), ref.removal.removed_mask.numpy())
    assert (session.selected() == (labels == 2)).mean() > 0.95
    # the same click at the photo drops it again: one code path
    session.click(c)
    assert session.clicks == [] and session.plan is None
    # a ray into the sky hits nothing and leaves the selection as it was
    up = -v.camera.R.double().numpy()[1]
    assert ray_hit(field.gaussians, origin, up) is None
    assert session.click_ray(origin, up)[0] is None and session.clicks == []
    # a point behind every camera is in no view
    assert click_at_point(scene, origin + 100.0 * (origin - centre), d) is None


def test_ray_hit_takes_the_front_surface_of_two_gaussians_in_a_row():
    """Two opaque unit Gaussians on the x axis at 2 and 5: a ray from the origin along +x hits the
    first at its closest approach (its centre); from 10 along -x, the second."""
    import torch

    from inpaint360gs.core.gaussians import Gaussians

    n = 2
    g = Gaussians(means=torch.tensor([[2.0, 0, 0], [5.0, 0, 0]]), log_scales=torch.full((n, 3), float(np.log(0.3))), quats=torch.tensor([[1.0, 0, 0, 0]] * n),
                  opacity_logits=torch.full((n,), float(np.log(0.95 / 0.05))), sh0=torch.zeros(n, 1, 3), shN=torch.zeros(n, 0, 3))  # fmt: skip
    assert np.allclose(ray_hit(g, [0, 0, 0], [1, 0, 0]), [2, 0, 0])
    assert np.allclose(ray_hit(g, [10, 0, 0], [-1, 0, 0]), [5, 0, 0])
    assert np.allclose(ray_hit(g, [0, 0.1, 0], [1, 0, 0]), [2, 0.1, 0])  # the closest approach lies on the ray
    assert ray_hit(g, [0, 2, 0], [1, 0, 0]) is None  # passes both by


def test_a_click_draws_its_selection_first_and_its_check_follows_the_same_as_run_click(blobs, session):
    """The page's click (``wait=False``): the selected Gaussians and the clicked photo's fill mask
    come first, the other views' masks and the check in the background; all of them are
    ``plan_removal``'s, and a newer click's selection replaces an older one still being checked."""
    import threading

    scene, _, _, field = blobs
    v = scene.train_views[2]
    session.warm(v)  # the shown photo's id map, the support plane and the views' projections, as the page does once it is drawn
    assert all(session.renders.holds(w.name) for w in scene.train_views) and list(session._id_maps) == [v.name]
    checked = threading.Event()
    session.on_checked = checked.set
    c1 = click_on(v, BLOB_1)
    ref = plan_removal(field, scene, clicks=[c1], cfg=session.cfg.removal, backend=session.cfg.backend)
    line = session.click(c1, wait=False)
    assert line.startswith("selected (id map)") and "checking" in line
    assert np.array_equal(session.selected(), ref.removal.removed_mask.numpy())
    assert np.array_equal(session.mask(v), ref.masks[v.name])
    assert checked.wait(60) and not session.checking()
    assert session.plan.check == ref.check and session.plan.targets == ref.targets
    assert all(np.array_equal(session.plan.masks[k], ref.masks[k]) for k in ref.masks)
    assert session.message.startswith("selected (id map); passed (object)")
    from inpaint360gs.remove.select import click_id_map

    assert list(session._id_maps) == [v.name] and torch.equal(session._id_maps[v.name], click_id_map(field, v))  # what select renders
    # the id map of a photo shown and clicked at once: rendered once, by whichever comes first
    import inpaint360gs.viewer.session as session_module

    renders = []
    real = session_module.click_id_map
    session_module.click_id_map = lambda f, w: renders.append(w.name) or real(f, w)
    try:
        w = scene.train_views[6]
        threads = [threading.Thread(target=session.id_map, args=(w,)) for _ in range(3)]
        [t.start() for t in threads]
        [t.join() for t in threads]
    finally:
        session_module.click_id_map = real
    assert renders == [w.name] and torch.equal(session.id_map(w), click_id_map(field, w))
    # two clicks in a row: what stays is the selection of both, checked as run with both checks it
    c2 = click_on(scene.train_views[4], BLOB_2)
    session.click(click_on(scene.train_views[5], BLOB_1), wait=False)  # drops blob 1
    session.click(c2, wait=False)
    both = plan_removal(field, scene, clicks=[c2], cfg=session.cfg.removal, backend=session.cfg.backend)
    assert session.clicks == [c2] and np.array_equal(session.selected(), both.removal.removed_mask.numpy())
    assert session.plan.check == both.check and session.plan.targets == [7]


def test_the_run_job_records_the_running_stage_s_own_progress(tiny_scene, tmp_path):
    """The Run button's job (:class:`RunJob`) on the tiny scene with its model (segment, associate,
    distill): the distill stage's bar counts up to its 20 steps and the segment stage's to its views,
    though the run shows no terminal bars; the job's :meth:`RunJob.within` is None once it is done."""
    from dataclasses import replace

    from inpaint360gs.core.progress import progress_listener
    from inpaint360gs.pipeline.run import Runner
    from inpaint360gs.viewer.session import RunJob

    root, model = tiny_scene
    scene = load_scene(root)
    cfg = get_preset("cpu")
    cfg = replace(cfg, distill=replace(cfg.distill, iterations=20))
    runner = Runner(scene, tmp_path / "run", cfg, model=model, ids=[1], progress=False, accept=True)
    seen = []
    with progress_listener(lambda *a: seen.append(a)):  # this thread's listener: the job's bars are not its
        job = RunJob(runner, until="distill")
        told, on_bar = [], job._on_bar

        def spy(desc, done, total):  # what the job's thread tells the job, and what the page then reads
            on_bar(desc, done, total)
            told.append(((desc, done, total), job.within()))

        job._on_bar = spy
        assert job.start().wait(600) and job.error is None, job.error
    assert seen == [] and told and all(got == read for got, read in told)
    for desc in {d for (d, _, _), _ in told}:
        counts = [n for (d, n, _), _ in told if d == desc]
        assert counts == sorted(counts), desc
    assert [job.stages[s].what for s in ("train", "segment", "associate", "distill")] == ["given", "ran", "ran", "ran"]
    distill = [d for d in job.bars if d.startswith("distill")]
    assert len(distill) == 1 and job.bars[distill[0]] == (20, 20)
    segment = [d for d in job.bars if d.startswith("segment")]
    assert len(segment) == 1 and job.bars[segment[0]] == (len(scene.train_views),) * 2
    assert job.within() is None
