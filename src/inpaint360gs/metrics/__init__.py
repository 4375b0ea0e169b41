"""Image-quality metrics for evaluation (PSNR, SSIM; paper Sec. 4 "Metrics")."""

from inpaint360gs.metrics.image import psnr, ssim

__all__ = ["psnr", "ssim"]
