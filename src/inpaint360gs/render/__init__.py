"""Differentiable Gaussian rasterization with interchangeable backends (torch, numba CPU, gsplat CUDA)."""

from inpaint360gs.render.api import RenderOutput, available_backends, rasterize_to_pixels, render
from inpaint360gs.core.camera import Camera

__all__ = ["Camera", "RenderOutput", "available_backends", "rasterize_to_pixels", "render"]
