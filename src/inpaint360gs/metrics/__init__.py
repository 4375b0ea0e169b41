"""Evaluation metrics (paper Sec. 4 "Metrics", Tab. 1): PSNR, SSIM and LPIPS (``lpips`` = VGG as in
the paper's evaluation code, ``lpips_alex``).
"""

from inpaint360gs.metrics.image import psnr, ssim
from inpaint360gs.metrics.lpips import (
    get_lpips_net,
    lpips,
    lpips_alex,
    lpips_map,
)

__all__ = [
    "get_lpips_net",
    "lpips",
    "lpips_alex",
    "lpips_map",
    "psnr",
    "ssim",
]
