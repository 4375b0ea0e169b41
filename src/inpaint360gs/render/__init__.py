"""Differentiable Gaussian rasterization with interchangeable backends (torch, numba CPU, gsplat CUDA)."""
