"""The inpainting stage's settings (paper Sec. 3.4-3.5; the switches are the ablations of Tab. 3),
apart from the stage's code so that the presets (:mod:`inpaint360gs.pipeline.presets`) and the
workflow read them without importing torch."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.settings import check_fields
from inpaint360gs.gs.config import DensifyConfig
from inpaint360gs.inpaint.inpainters import DEFAULT_DEPTH, DEFAULT_RGB, DEPTH_METHODS, RGB_METHODS
from inpaint360gs.views.config import UnseenConfig, VirtualViewsConfig


@dataclass
class RefineConfig:
    """3D inpainting (Eq. 6); defaults are the paper's (supp. B)."""

    variant: str = "paper"  # "paper" | "code": the authors' public code (0.8 / 0.0005 / 5000, L1 over the whole image)
    iterations: int | None = None  # None: the variant's (2000 paper, 5000 code)
    lambda_dssim: float | None = None  # λ1; None: the variant's (0.2 paper, 0.8 code)
    lambda_lpips: float | None = None  # λ2; None: the variant's (0.005 paper, 0.0005 code; 1 with supervision "lpips")
    supervision: str = "hybrid"  # "hybrid" (Eq. 6) | "mask": ablation e) | "lpips": Gaussian Grouping's (LPIPS in the mask, L1 outside)
    # LPIPS network of the loss. AlexNet: a step's forward + backward through it is far cheaper on CPU than
    # through VGG16 (results/README.md, "Metrics"); the evaluation uses VGG like the paper's code.
    lpips_net: str = "alex"  # "alex" | "vgg"
    lpips_margin: int = 8  # pixels around the mask's bounding box for the LPIPS crop
    crop_margin_px: int = 16  # each view is optimised on its mask's bounding box grown by max(this, crop_margin x its size)
    crop_margin: float = 0.25  # x the bounding box's size, >= 0
    # A step optimises a window of at most this many pixels a side of its view's crop, centred on a
    # random pixel of the mask (0: the whole crop): the cost of a step, dominated by LPIPS and SSIM,
    # stays bounded for a large hole (SPIn-NeRF also takes its perceptual loss on patches). Crops
    # smaller than this are used whole.
    patch_px: int = 96  # pixels, >= 0
    region_margin: float = 0.5  # Gaussians within this x the region's diagonal of it train (see refine)
    # 3DGS adaptive density control of the Gaussians that train (densify_config): every 100 steps
    # from the 100th until this share of the iterations, no opacity reset (a run this short has no
    # time to recover from one). Off for the method (paper Sec. 3.5); on for the strong baseline.
    densify: bool = False
    densify_until: float = 0.5  # share of the iterations, in [0, 1]
    densify_grad: float = 2e-4  # mean view-space gradient (NDC units of the view's crop) above which a Gaussian is cloned or split, > 0
    seed: int = 0  # seeds the optimisation loop (views, patch centres)
    backend: str = "auto"  # rasterizer backend: auto | torch | numba | gsplat

    def resolved(self) -> RefineConfig:
        """A copy with the variant's iterations and loss weights filled in; raises :class:`InputError`
        for an unknown variant or supervision."""
        if self.variant not in ("paper", "code"):
            raise InputError(f"unknown 3D inpainting variant {self.variant!r} (paper, code)", setting="RefineConfig.variant")
        if self.supervision not in ("hybrid", "mask", "lpips"):
            raise InputError(f"unknown supervision {self.supervision!r} (hybrid, mask, lpips)", setting="RefineConfig.supervision")
        if not 0.0 <= self.densify_until <= 1.0:
            raise InputError(f"densify_until must be in [0, 1], got {self.densify_until}", setting="RefineConfig.densify_until")
        if not self.densify_grad > 0:
            raise InputError(f"densify_grad must be > 0, got {self.densify_grad}", setting="RefineConfig.densify_grad")
        paper = self.variant == "paper"
        lpips_weight = 1.0 if self.supervision == "lpips" else 0.005 if paper else 0.0005
        return replace(
            self,
            iterations=(2000 if paper else 5000) if self.iterations is None else self.iterations,
            lambda_dssim=(0.2 if paper else 0.8) if self.lambda_dssim is None else self.lambda_dssim,
            lambda_lpips=lpips_weight if self.lambda_lpips is None else self.lambda_lpips,
        )

    def densify_config(self) -> DensifyConfig:
        """The density control of a run of ``iterations`` steps (see ``densify``): 3DGS's thresholds,
        clone or split every 100 steps after step 100 until ``densify_until`` of the run, prune the
        nearly transparent ones, never reset opacities (so neither prune the large ones)."""
        n = self.resolved().iterations
        return DensifyConfig(grad_threshold=self.densify_grad, densify_from=100, densify_until=round(self.densify_until * n), densify_every=100, opacity_reset_every=n + 1)


@dataclass
class InpaintConfig:
    """The inpainting stage; each switch off is one ablation of paper Tab. 3."""

    views: str = "virtual"  # "virtual" | "training": ablation c)
    masks: str = "unseen"  # "unseen": geometric NBS masks; "footprint": the removed objects' whole footprint (baseline ii)
    condition: bool = True  # recursive conditioning; False: ablation d)
    init: str = "depth"  # "depth": depth-guided initialisation; "naive": ablation b); "none": no new Gaussians (baseline ii)
    rgb_inpainter: str = DEFAULT_RGB  # 2D colour inpainter by name (inpaint.inpainters registry)
    depth_inpainter: str = DEFAULT_DEPTH  # 2D depth inpainter by name (same registry)
    lama_onnx: str | None = None  # LaMa checkpoint (ONNX) when an inpainter is "lama"
    occluders: bool = True  # take occluders out for inpainting, put them back after
    occluder_min_pixels: int = 10  # an object occludes when it hides at least this many pixels of the removed ones in one view
    # Start the recursion from a view straight above each removed object's footprint (the removal
    # stage's support plane), filled with ``support_inpainter``: the support is seen rectified there
    # (views.virtual.support_camera), so textures and straight borders continue across the hole,
    # and every later view inherits that fill through the conditioning. False: the trajectory alone.
    support_view: bool = True
    support_inpainter: str = "shiftmap"  # 2D inpainter of the support view, by name
    # With the removal's footprints, the scene's Gaussians that the 3D inpainting may adjust are those
    # within this x the footprint's size around it (footprint_rows); without, those near the removed
    # Gaussians (refine.RefineConfig.region_margin).
    footprint_margin: float = 0.25  # x the footprint's size, >= 0
    # A surface the removal reveals off the support plane is part of the region to fill (at its
    # rendered depth), and new Gaussians are kept, within this x the footprint's size of the
    # footprint's column; new Gaussians standing over the support in the column are dropped
    # (fill_rows). 0: inside the column only; beyond it the rendered depth is the 3DGS's uncertain
    # one and fill Gaussians put there show as smears from other views (docs/architecture.md,
    # "What the removal emptied is filled on its support").
    reveal_margin: float = 0.0  # x the footprint's size, >= 0
    virtual: VirtualViewsConfig = field(default_factory=VirtualViewsConfig)  # step 1: the virtual cameras
    unseen: UnseenConfig = field(default_factory=UnseenConfig)  # the unseen (to be filled) masks
    refine: RefineConfig = field(default_factory=RefineConfig)  # the 3D inpainting (Eq. 6); its seed also seeds the 2D inpainters
    backend: str = "auto"  # rasterizer backend: auto | torch | numba | gsplat


def check_inpaint_config(cfg: InpaintConfig) -> None:
    """The settings' types, names and ranges, before any work (the CLI's choices check the names
    too); :class:`InputError` naming the setting."""
    check_fields(cfg)
    for value, allowed, name in ((cfg.views, ("virtual", "training"), "views"), (cfg.masks, ("unseen", "footprint"), "masks"), (cfg.init, ("depth", "naive", "none"), "init"),
                                 (cfg.rgb_inpainter, RGB_METHODS, "rgb_inpainter"), (cfg.depth_inpainter, DEPTH_METHODS, "depth_inpainter"),
                                 (cfg.support_inpainter, RGB_METHODS, "support_inpainter")):  # fmt: skip
        if value not in allowed:
            raise InputError(f"unknown setting {value!r} ({', '.join(allowed)})", setting=f"InpaintConfig.{name}")
    for name in ("footprint_margin", "reveal_margin"):
        if getattr(cfg, name) < 0:
            raise InputError(f"must be >= 0, got {getattr(cfg, name)}", setting=f"InpaintConfig.{name}")
    if cfg.occluder_min_pixels < 0:
        raise InputError(f"must be >= 0, got {cfg.occluder_min_pixels}", setting="InpaintConfig.occluder_min_pixels")
    if cfg.virtual.num_views < 1:
        raise InputError(f"at least one virtual view, got {cfg.virtual.num_views}", setting="VirtualViewsConfig.num_views")
    r = cfg.refine.resolved()
    if r.iterations < 1:
        raise InputError(f"must be >= 1, got {r.iterations}", setting="RefineConfig.iterations")
    for name in ("lambda_dssim", "lambda_lpips", "crop_margin", "region_margin"):
        if getattr(r, name) < 0:
            raise InputError(f"must be >= 0, got {getattr(r, name)}", setting=f"RefineConfig.{name}")
    if cfg.backend not in ("auto", "torch", "numba", "gsplat"):
        raise InputError(f"unknown backend {cfg.backend!r}", setting="InpaintConfig.backend")
