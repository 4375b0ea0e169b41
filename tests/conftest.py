"""Test-session settings that must precede the first import of torch, and fixtures for the shared scenes."""

import os

import pytest

# As ``import inpaint360gs`` does (see its __init__): idle OpenMP threads of torch and numba sleep
# instead of spinning, or they steal the 2 CPU cores from each other. A test module that imports
# torch before the package would otherwise come too late.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
# and MKL's Conditional Numerical Reproducibility, so that seeded runs repeat bit for bit (see there)
os.environ.setdefault("MKL_CBWR", "AUTO")


def pytest_collection_modifyitems(config, items):
    """Slow end-to-end tests first, the longest (SLURM, workflow) at the head: with one worker per
    core (``make test``, pytest-xdist) they then run beside the many short tests instead of last."""
    first = ("test_workflow_slurm.py", "test_workflow.py", "test_numba_cold_warm.py", "test_end_to_end.py")

    def rank(item):
        if item.get_closest_marker("slow") is None:
            return len(first) + 1
        name = item.path.name
        return first.index(name) if name in first else len(first)

    items.sort(key=rank)  # stable: the order inside each group is kept


# --- shared scenes (builders in scene_builder.py; imported inside the fixtures, after the settings above) ---


@pytest.fixture(scope="session")
def make_blobs_scene(tmp_path_factory):
    """Factory: ``make_blobs_scene(name, **kw)`` writes :func:`scene_builder.blobs_scene` (keywords as
    there) to ``blobs/`` in a fresh temporary folder named after ``name`` and returns (root, model,
    labels); the folder above ``root`` is the caller's, for what it writes beside the scene."""
    from scene_builder import blobs_scene

    def make(name: str, **kw):
        return blobs_scene(tmp_path_factory.mktemp(name) / "blobs", **kw)

    return make


@pytest.fixture(scope="module")
def tiny_scene(tmp_path_factory):
    """A 32x24 blobs scene (10 views, 2 test views) and its exact model (blob k = object k after
    association) as ``model.ply`` beside it; returns (scene root, model path)."""
    from scene_builder import blobs_model, blobs_scene

    from inpaint360gs.io.ply import write_ply

    base = tmp_path_factory.mktemp("tiny")
    root = blobs_scene(base / "scene", n_views=10, width=32, height=24, f=27.5)[0]
    write_ply(base / "model.ply", blobs_model()[0])
    return root, base / "model.ply"
