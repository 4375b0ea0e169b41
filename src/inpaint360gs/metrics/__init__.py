"""Evaluation metrics (paper Sec. 4 "Metrics", Tab. 1; AMCR: supp. Eq. 1).

Three mask conventions are named apart (see :mod:`.masked`): full image (``psnr``, ``ssim``,
``lpips`` = VGG as in the paper's evaluation code, ``lpips_alex``), ``masked_*`` (the paper's
code: both images multiplied by the unseen mask) and ``roi_*`` (mask pixels only). FID (Inception
features, :mod:`.inception`) and its VGG16 substitutes share the distances of :mod:`.distribution`.
The evaluation stage that applies them to a folder of renders is :mod:`inpaint360gs.evaluate`.
"""

from inpaint360gs.metrics.distribution import (
    feature_statistics,
    frechet_distance,
    frechet_distance_features,
    kernel_inception_distance,
)
from inpaint360gs.metrics.image import psnr, ssim, ssim_index_map
from inpaint360gs.metrics.inception import FIDInceptionV3, inception_features, load_fid_inception
from inpaint360gs.metrics.lpips import get_lpips_net, lpips, lpips_alex, lpips_map
from inpaint360gs.metrics.masked import (
    CONVENTIONS,
    amcr,
    apply_mask,
    masked_lpips,
    masked_lpips_alex,
    masked_psnr,
    masked_ssim,
    roi_lpips,
    roi_lpips_alex,
    roi_psnr,
    roi_ssim,
    roi_undefined_reason,
)

__all__ = [
    "CONVENTIONS",
    "FIDInceptionV3",
    "amcr",
    "apply_mask",
    "feature_statistics",
    "frechet_distance",
    "frechet_distance_features",
    "get_lpips_net",
    "inception_features",
    "kernel_inception_distance",
    "load_fid_inception",
    "lpips",
    "lpips_alex",
    "lpips_map",
    "masked_lpips",
    "masked_lpips_alex",
    "masked_psnr",
    "masked_ssim",
    "psnr",
    "roi_lpips",
    "roi_lpips_alex",
    "roi_psnr",
    "roi_ssim",
    "roi_undefined_reason",
    "ssim",
    "ssim_index_map",
]
