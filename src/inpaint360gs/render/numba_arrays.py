"""What the numba modules share on the Python side: the thread count and float32 array views."""

from __future__ import annotations

import threading
from contextlib import contextmanager

import numpy as np
import torch

_cap = threading.local()  # .n: the most threads the kernels launched from this thread use (numba_threads_at_most)


def set_numba_threads() -> None:
    """Run numba kernels on ``min(torch.get_num_threads(), NUMBA_NUM_THREADS)`` threads (torch and
    numba never oversubscribe the CPU), fewer within :func:`numba_threads_at_most` on this thread."""
    import numba

    n = min(torch.get_num_threads(), numba.config.NUMBA_NUM_THREADS, getattr(_cap, "n", 1 << 30))
    numba.set_num_threads(max(1, n))  # numba's count is the calling thread's own


@contextmanager
def numba_threads_at_most(n: int):
    """Within this block, the numba kernels launched from the calling thread use at most ``n``
    threads (other threads keep theirs): background work that leaves the other cores to what the
    user waits for (the viewer's selection check beside the browser drawing the selection). The
    kernels' results do not depend on the thread count."""
    old = getattr(_cap, "n", None)
    _cap.n = max(1, int(n))
    try:
        yield
    finally:
        if old is None:
            del _cap.n
        else:
            _cap.n = old


def to_f32(x: torch.Tensor) -> np.ndarray:
    """``x`` as a contiguous float32 numpy array on the CPU (a view when it already is one)."""
    return np.ascontiguousarray(x.detach().cpu().numpy(), dtype=np.float32)
