"""Test-session settings that must precede the first import of torch."""

import os

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
