"""Inpaint360GS: object-aware 3D inpainting with Gaussian Splatting in 360° scenes (WACV 2026)."""

import os as _os

# torch and the numba rasterizer each bring an OpenMP runtime; with libgomp's default spin-waiting
# their idle threads steal the 2 cores from each other (torch ops measured 20-60x slower right after
# a numba kernel). Threads that sleep when idle avoid it. Effective when this package is imported
# before torch (the CLI does); an explicit user setting wins.
_os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

__version__ = "0.1.0"
