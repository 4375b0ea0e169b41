"""The splats ``inpaint360gs view`` sends before torch is imported (src/inpaint360gs/viewer/splats.py):
numpy alone gives what the page draws from the loaded Gaussians (the same splats, the same most
opaque ones), and the page keeps a node sent so instead of sending it again."""

from __future__ import annotations

import numpy as np
import pytest

from inpaint360gs.core.gaussians import SH_C0
from inpaint360gs.io.ply import read_ply, write_ply
from inpaint360gs.viewer.session import splat_arrays
from inpaint360gs.viewer.splats import SH_C0 as SPLATS_SH_C0
from inpaint360gs.viewer.splats import most_opaque, read_splats


def test_the_ply_read_with_numpy_gives_the_loaded_gaussians_splats(make_blobs_scene, tmp_path):
    _, model, _ = make_blobs_scene("splats-np", n_views=4)
    write_ply(tmp_path / "m.ply", model)
    assert SPLATS_SH_C0 == SH_C0
    quick, full = read_splats(tmp_path / "m.ply"), splat_arrays(read_ply(tmp_path / "m.ply"))
    for k in full:
        assert quick[k].dtype == np.float32 and np.allclose(quick[k], full[k], rtol=1e-5, atol=1e-7), k
    a, keep = most_opaque(quick, 100)
    b, keep_full = most_opaque(full, 100)
    assert len(keep) == 100 and np.array_equal(keep, keep_full) and a["centers"].shape == (100, 3)
    assert most_opaque(quick, 0)[1] is None and most_opaque(quick, len(model))[1] is None


def test_the_page_keeps_the_splats_the_command_sent(make_blobs_scene, tmp_path):
    pytest.importorskip("viser", reason="the viewer extra is not installed (pip install -e .[viewer])")
    from object_fields import labelled_field, write_field

    from inpaint360gs.io.scene import load_scene
    from inpaint360gs.pipeline.presets import get_preset
    from inpaint360gs.viewer.app import ViewerApp
    from inpaint360gs.viewer.server import start_server
    from inpaint360gs.viewer.session import ViewerSession
    from inpaint360gs.viewer.splats import send_splats

    root, model, labels = make_blobs_scene("splats-sent", n_views=4)
    scene = load_scene(root)
    write_ply(tmp_path / "model.ply", model)
    write_field(tmp_path / "run" / "distill", labelled_field(model, labels, [0, 3, 7]), scene)
    server = start_server("127.0.0.1", 0)
    try:
        sent = send_splats(server, tmp_path / "model.ply", 50)
        assert len(sent[2]) == 50
        app = ViewerApp(ViewerSession(scene, tmp_path / "run", get_preset("cpu"), model=tmp_path / "model.ply"), server=server, max_splats=50, sent=sent)
        assert app.splats["before"] is sent  # not sent again
        app.wait_loaded()
        other = send_splats(server, tmp_path / "model.ply", 60)  # another count: the page sends its own
        app2 = ViewerApp(app.session, server=server, max_splats=50, sent=other)
        assert app2.splats["before"] is not other and len(app2.splats["before"][2]) == 50
        app2.wait_loaded()
    finally:
        server.stop()
