"""Inpaint360GS: object-aware 3D inpainting with Gaussian Splatting in 360° scenes (WACV 2026)."""

__version__ = "0.1.0"
