"""What the numba modules share on the Python side: the thread count and float32 array views."""

from __future__ import annotations

import numpy as np
import torch


def set_numba_threads() -> None:
    """Run numba kernels on ``min(torch.get_num_threads(), NUMBA_NUM_THREADS)`` threads (torch and
    numba never oversubscribe the CPU)."""
    import numba

    numba.set_num_threads(max(1, min(torch.get_num_threads(), numba.config.NUMBA_NUM_THREADS)))


def to_f32(x: torch.Tensor) -> np.ndarray:
    """``x`` as a contiguous float32 numpy array on the CPU (a view when it already is one)."""
    return np.ascontiguousarray(x.detach().cpu().numpy(), dtype=np.float32)
