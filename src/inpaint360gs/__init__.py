"""Inpaint360GS: object-aware 3D inpainting with Gaussian Splatting in 360° scenes (WACV 2026)."""

import os as _os

# torch and the numba rasterizer each bring an OpenMP runtime; with libgomp's default spin-waiting
# their idle threads steal the 2 cores from each other (torch ops measured 20-60x slower right after
# a numba kernel). Threads that sleep when idle avoid it. Effective when this package is imported
# before torch (the CLI does); an explicit user setting wins.
_os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
# MKL (torch's CPU BLAS) picks its code path and splits work between threads at run time; on CPUs
# with AVX-512 that made two identical backward passes of the LPIPS term of the inpainting loss
# (Eq. 6; a 1x1 feature map's convolution goes through MKL) differ in the last bits, so a seeded
# run did not repeat. Conditional Numerical Reproducibility ("AUTO": the best path for this CPU,
# chosen once) makes them repeat bit for bit, at no measured cost. MKL reads the variable at its
# first call: effective when this package is imported before torch computes anything.
_os.environ.setdefault("MKL_CBWR", "AUTO")

__version__ = "0.1.0"
