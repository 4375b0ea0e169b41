"""``set_threads`` (what every CLI command calls first) makes a process's first multi-threaded call of
torch's vector math (MKL VML: exp, sqrt, log, ...) round like every later call.

Regression test: without the single-threaded first call that ``set_threads`` now makes, in one process
in ten to one in four (measured on a 2-core AVX-512 machine; 7 of 24 in this test's setting) the pool
thread's half of the first large ``sqrt`` rounded differently (1492 of 2987 values). In training that call is the
initial Gaussian scales (``Gaussians.from_points``), so a seeded 3DGS run differed at rounding level
from run to run, and the workflow's interrupted-then-resumed run did not always equal the
uninterrupted one. The race is in a process's first call, so the check runs in fresh processes.
"""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

pytestmark = pytest.mark.slow  # ~30 s: 16 processes, each importing torch

PROCESSES = 16  # at the rate measured in this setting (7 failing processes in 24), 16 clean ones by chance: p = 0.004

# torch imported before this package, its OpenMP threads spin-waiting (OMP_WAIT_POLICY=ACTIVE, libgomp's
# default; the package sets PASSIVE when imported first): the setting in which the race showed most
# often in a short script (in training it showed with either)
SNIPPET = r"""
import numpy as np, torch
from inpaint360gs.cli.common import set_threads
set_threads(2)
t = torch.from_numpy(np.random.default_rng(0).uniform(1e-6, 1e-2, 2987)).float()
first = t.sqrt()  # the process's first vector-math call large enough to be split over the two threads
print(int((first != t.sqrt()).sum()))
"""


def test_first_multithreaded_vector_math_call_rounds_like_the_later_ones():
    env = dict(os.environ, OMP_WAIT_POLICY="ACTIVE")
    differing = []
    for _ in range(PROCESSES):
        p = subprocess.run([sys.executable, "-c", SNIPPET], capture_output=True, text=True, timeout=120, env=env)
        assert p.returncode == 0, p.stderr[-2000:]
        differing.append(int(p.stdout.split()[-1]))
    assert differing == [0] * PROCESSES, f"values of the first sqrt that differ from a later one, per process: {differing}"
