"""The default segmenter, ``geometric``: objects as clusters of the trained Gaussians standing on the
support plane, rendered into each training view. Needs no learned weights.

The paper gets raw per-view masks from HQ-SAM's automatic mask generator (Sec. 3.2); this product
must run offline on a CPU without downloaded weights, and 2D-only substitutes failed on the synthetic
benchmark (CHANGELOG.md, "History"), while the trained 3DGS already separates what stands on the
floor from the floor. So:

1. **frame** (:mod:`.frame`): up from the cameras, look-at point, orbit radius R, ground plane by
   RANSAC on opaque Gaussian centres, heights above it;
2. **3D clusters** (:mod:`.cluster3d`): DBSCAN on opaque Gaussians above the plane near the orbit's
   axis, support peeling (a plate with fruits → plate + each fruit), growing to faint Gaussians;
3. **per view**: the cluster labels rendered as one-hot features (paper Eq. 2 compositing); a pixel
   takes the object with the largest weight when that weight is at least ``min_weight`` × the
   pixel's alpha, else no segment;
4. **like a 2D segmenter**: each rendered object's connected components become segments (small
   crumbs stay with their object's largest piece), numbered per view by decreasing area, so ids do
   not agree between views and the association stage has real work to do.

Every length is a fraction of R (:class:`GeometricConfig`), so the defaults carry across scene sizes;
a sparse model (few Gaussians per object, e.g. trained on 128×96 images) widens the DBSCAN and
growing neighbourhoods to twice the typical neighbour distance (:func:`.cluster3d.density_scale`).

Limits (what it cannot do that SAM can):
* Only objects standing on one support plane inside the orbit: a scene whose support is not a plane
  (a slope, stairs), objects hanging on walls, or a forward-facing capture are out of reach.
* Objects touching each other with no support layer between them form one segment; an object alone
  on a plate merges with the plate (peeling needs two groups above a layer).
* Thin, low-contrast parts that 3DGS reconstructs with low opacity get lost; thin supports get holes.
* Nothing below τ above the plane (a rug) and nothing of the background gets a segment (0).
"""

from __future__ import annotations

import warnings
from dataclasses import asdict, dataclass, field, replace

import numpy as np
import torch

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.render.api import render
from inpaint360gs.segment.base import Segmenter
from inpaint360gs.segment.cluster3d import ClusterConfig, Clusters, cluster_gaussians
from inpaint360gs.segment.frame import SceneFrame, scene_frame
from inpaint360gs.segment.masks import split_components


@dataclass(frozen=True)
class GeometricConfig:
    """Settings of the geometric segmenter (3D lengths are fractions of the orbit radius R)."""

    cluster: ClusterConfig = field(default_factory=ClusterConfig)
    min_weight: float = 0.5  # a pixel's object weight must reach this fraction of its alpha
    min_segment_px: int = 0  # components smaller than this vanish; 0 = 1e-4 of the image (>= 4 px)
    min_piece_fraction: float = 0.1  # a piece below this fraction of its object's largest piece stays with it
    seed: int = 0  # RANSAC of the ground plane
    backend: str = "auto"  # rasterizer of the label renders

    def validate(self) -> None:
        """Raise :class:`InputError` (naming the field) for a setting out of range."""
        self.cluster.validate()
        if not 0.0 < self.min_weight <= 1.0:
            raise InputError(f"min_weight must be in (0, 1], got {self.min_weight}", "min_weight")
        if not 0.0 <= self.min_piece_fraction <= 1.0:
            raise InputError(f"min_piece_fraction must be in [0, 1], got {self.min_piece_fraction}", "min_piece_fraction")
        if self.min_segment_px < 0:
            raise InputError(f"min_segment_px must be >= 0, got {self.min_segment_px}", "min_segment_px")

    def to_dict(self) -> dict:
        """Every field, JSON-ready."""
        return asdict(self)


class GeometricSegmenter(Segmenter):
    name = "geometric"
    uses_model = True

    def __init__(self, config: GeometricConfig | None = None, *, seed: int | None = None, backend: str | None = None):
        cfg = config or GeometricConfig()
        if seed is not None or backend is not None:
            cfg = replace(cfg, **{k: v for k, v in (("seed", seed), ("backend", backend)) if v is not None})
        cfg.validate()
        self.config = cfg
        self.frame: SceneFrame | None = None
        self.clusters: Clusters | None = None
        self._model: Gaussians | None = None

    def prepare(self, scene, model: Gaussians | None) -> None:
        """Cluster the model's Gaussians into objects in 3D; :class:`InputError` without a model."""
        if model is None:
            raise InputError("the geometric segmenter needs the trained 3DGS model", "MODEL")
        cfg, cc = self.config, self.config.cluster
        g = model.map(lambda t: t.detach().float().cpu())
        means = g.means.numpy().astype(np.float64)
        opac = g.opacities.numpy()
        max_scale = g.scales.max(dim=1).values.numpy()
        self.frame = scene_frame(
            [v.camera for v in scene.train_views], means, opac,
            min_opacity=cc.plane_min_opacity, tol_frac=cc.plane_tol, tries=cc.plane_tries, max_tilt_deg=cc.plane_max_tilt_deg, seed=cfg.seed,
        )  # fmt: skip
        self.clusters = cluster_gaussians(means, opac, max_scale, self.frame, cc)
        k = self.clusters.count
        if k == 0:
            warnings.warn(
                f"no object found standing on the ground plane ({self.clusters.num_seeds} Gaussians above it near the orbit's axis); "
                "every id image will be empty (try a smaller --tau or --eps larger than the gaps in the model)"
            )
        feats = torch.zeros(len(g), max(k, 1))
        lab = torch.from_numpy(self.clusters.labels.astype(np.int64))
        on = lab > 0
        feats[on.nonzero()[:, 0], lab[on] - 1] = 1.0
        g.features = feats
        self._model = g

    def object_weights(self, camera) -> tuple[np.ndarray, np.ndarray]:
        """((H, W, K) rendered one-hot object weights, (H, W) alpha) at ``camera``."""
        if self._model is None:
            raise RuntimeError("GeometricSegmenter.prepare() must run before segment()")
        with torch.no_grad():
            out = render(self._model, camera, with_features=True, sh_degree=0, backend=self.config.backend)  # colour unused
        return out.features.numpy(), out.alpha.numpy()

    def label_image(self, camera) -> np.ndarray:
        """(H, W) int32 rendered 3D cluster label (0 = none) at ``camera``, before per-view numbering."""
        w, alpha = self.object_weights(camera)
        if self.clusters is None or self.clusters.count == 0:
            return np.zeros(alpha.shape, np.int32)
        best = w.argmax(axis=2)
        top = np.take_along_axis(w, best[..., None], axis=2)[..., 0]
        return np.where((top >= self.config.min_weight * alpha) & (top > 1e-6), best + 1, 0).astype(np.int32)

    def segment(self, view, image: torch.Tensor) -> np.ndarray:
        """(H, W) id image of ``view``: the 3D clusters rendered, split into connected pieces."""
        cam = view.camera
        labels = self.label_image(cam)
        min_px = self.config.min_segment_px or max(4, round(1e-4 * cam.width * cam.height))
        return split_components(labels, min_px, self.config.min_piece_fraction)

    def settings(self) -> dict:
        """The configuration, as a dict."""
        return self.config.to_dict()

    def summary(self) -> dict:
        """The scene frame and the clusters found ({} before :meth:`prepare`)."""
        if self.frame is None or self.clusters is None:
            return {}
        c = self.clusters
        return {
            "frame": self.frame.to_json(),
            "objects_3d": c.count,
            "support_objects_3d": c.support,
            "gaussians_per_object": c.sizes(),
            "seed_gaussians": c.num_seeds,
            "grown_gaussians": c.num_grown,
            "neighbourhood_scale": round(c.density_scale, 4),
        }
