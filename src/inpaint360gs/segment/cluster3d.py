"""Objects as clusters of Gaussians standing on the support plane (the 3D half of the ``geometric``
segmenter; see :mod:`.geometric` for the design and its limits).

Steps, every length a fraction of the orbit radius R (:class:`.frame.SceneFrame`):

1. **seeds**: Gaussians that are opaque, above the plane by more than τ, near the orbit's axis and
   not huge (large background splats); DBSCAN over their centres; clusters holding more than
   ``min_cluster_frac`` of the seeds are kept.
2. **support peeling**: a cluster whose densest thin height layer (a plate, a tray, a board) is big,
   stands out of the cluster's height histogram, lies low in the cluster and carries at least two
   separate groups side by side above it becomes one support object plus one object per group;
   otherwise it stays whole (a cone keeps its base). Groups stacked over each other (a group whose
   horizontal centre lies inside a larger group's footprint seen from above) are one object whose
   middle was reconstructed sparsely — a cone's dark band — not two objects on a plate. What stands
   above the layer but is too sparse for any group (a fruit's underside next to the plate) joins
   the nearest group, not the support.
3. **growing**: less opaque or lower Gaussians near the axis join the cluster of their nearest labelled
   Gaussian when it is close.

A sparse model (fewer Gaussians per object, e.g. one trained on 128×96 images) widens all three
neighbourhoods together so DBSCAN's eps stays above twice the seeds' typical neighbour distance
(:func:`density_scale`).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace

import numpy as np
from scipy.spatial import cKDTree

from inpaint360gs.core.errors import InputError
from inpaint360gs.segment.frame import SceneFrame


@dataclass(frozen=True)
class ClusterConfig:
    """Parameters of the 3D clustering; lengths are fractions of the orbit radius R.

    Defaults from a probe on the synthetic benchmark: results were stable for ``tau`` in
    0.005–0.012 and ``eps`` in 0.02–0.045.
    """

    # frame (ground plane by RANSAC)
    plane_min_opacity: float = 0.3  # Gaussians voting for the plane
    plane_tol: float = 0.005  # inlier distance, × the median camera distance (not R)
    plane_tries: int = 400
    plane_max_tilt_deg: float = 30.0  # the plane's normal within this angle of the cameras' up
    # seeds
    seed_min_opacity: float = 0.2
    tau: float = 0.008  # seeds stand higher than this above the plane
    max_radius: float = 0.6  # horizontal distance from the look-at point
    max_scale: float = 0.05  # largest axis of a seed Gaussian
    eps: float = 0.03  # DBSCAN neighbourhood
    min_samples: int = 4  # DBSCAN core points
    min_cluster_frac: float = 0.02  # clusters holding less of the seeds are dropped
    density_eps: float = 2.0  # sparse models: every neighbourhood (eps, upper_eps, grow_radius) grows so that eps is at
    # least this × the seeds' median distance to their min_samples-th neighbour (0 = off; the 256×192 models never trigger it)
    # support peeling
    layer_bin: float = 0.005  # height bin of the layer search
    layer_min_frac: float = 0.15  # the densest bin ±1 must hold this much of the cluster
    layer_low_frac: float = 1.0 / 3.0  # ... and lie in this lowest part of its height range
    layer_peak: float = 3.0  # ... and its densest bin hold this many times the median non-empty bin (a layer, not a slice of a round object)
    upper_eps: float = 0.015  # DBSCAN neighbourhood of what stands on the layer
    upper_min_frac: float = 0.05  # a group above the layer needs this much of the cluster
    # growing
    grow_min_opacity: float = 0.05
    grow_min_height: float = 0.3  # × tau
    grow_radius: float = 0.03  # join the nearest labelled Gaussian within this distance
    grow_rounds: int = 2  # repeat so chains of faint Gaussians join too

    def validate(self) -> None:
        """Raise :class:`InputError` (naming the field) for a setting out of range."""
        for name, v in asdict(self).items():
            if not np.isfinite(v) or v < 0:
                raise InputError(f"geometric segmenter setting {name} must be a finite number >= 0, got {v}", setting=f"ClusterConfig.{name}")
        for name in ("eps", "upper_eps", "layer_bin", "max_radius", "max_scale", "plane_tol"):
            if getattr(self, name) <= 0:
                raise InputError(f"geometric segmenter setting {name} must be > 0", setting=f"ClusterConfig.{name}")
        if self.min_samples < 1 or self.plane_tries < 1:
            raise InputError("min_samples and plane_tries must be >= 1")


@dataclass
class Clusters:
    """Per-Gaussian object labels: 0 = none, 1..K = object; ``support`` marks peeled support layers."""

    labels: np.ndarray  # (N,) int32
    support: list[int]  # labels that came from support peeling (plates, trays)
    num_seeds: int
    num_grown: int
    density_scale: float = 1.0  # factor applied to every neighbourhood (>= 1; > 1 for sparse models)

    @property
    def count(self) -> int:
        """Number of clusters (labels are 1..count, 0 = none)."""
        return int(self.labels.max()) if self.labels.size else 0

    def sizes(self) -> list[int]:
        """Number of members of each cluster 1..count."""
        return np.bincount(self.labels, minlength=self.count + 1)[1:].tolist()


def _dbscan(x: np.ndarray, eps: float, min_samples: int) -> np.ndarray:
    from sklearn.cluster import DBSCAN

    if len(x) == 0:
        return np.zeros(0, np.int64)
    return DBSCAN(eps=eps, min_samples=min_samples).fit(x).labels_


def density_scale(seeds: np.ndarray, cfg: ClusterConfig, R: float) -> float:
    """How much to widen every neighbourhood for a sparse model: eps must be at least
    ``density_eps`` × the median distance of a seed to its ``min_samples``-th neighbour (DBSCAN's
    k-distance), else DBSCAN breaks objects into crumbs. 1 for the dense models of the benchmark's
    256×192 budget (k-distance ≈ 0.01 R); about 1.5 for the sparser 128×96 CI-size models."""
    if cfg.density_eps <= 0 or len(seeds) <= cfg.min_samples:
        return 1.0
    d, _ = cKDTree(seeds).query(seeds, k=cfg.min_samples + 1)
    return max(1.0, cfg.density_eps * float(np.median(d[:, -1])) / (cfg.eps * R))


def _merge_stacked(groups: list[np.ndarray], x: np.ndarray, up: np.ndarray) -> list[np.ndarray]:
    """Merge each group (index arrays into ``x``, largest first) into the first larger group whose
    footprint seen from above (the convex hull of its centres projected on the plane) holds the
    group's horizontal centre."""
    from scipy.spatial import Delaunay, QhullError

    a = np.cross(up, [1.0, 0.0, 0.0] if abs(up[0]) < 0.9 else [0.0, 1.0, 0.0])
    a /= np.linalg.norm(a)
    flat = np.stack([x @ a, x @ np.cross(up, a)], axis=1)  # plane coordinates
    kept: list[np.ndarray] = []
    hulls: list[Delaunay | None] = []
    for g in sorted(groups, key=lambda g: -len(g)):
        centre = flat[g].mean(axis=0)
        host = next((i for i, t in enumerate(hulls) if t is not None and t.find_simplex(centre) >= 0), None)
        if host is not None:
            kept[host] = np.concatenate([kept[host], g])
            continue
        kept.append(g)
        try:
            hulls.append(Delaunay(flat[g]))
        except QhullError:  # degenerate footprint (collinear centres): holds nothing
            hulls.append(None)
    return kept


def _peel(x: np.ndarray, h: np.ndarray, up: np.ndarray, cfg: ClusterConfig, R: float) -> list[np.ndarray] | None:
    """Split one cluster (centres ``x``, heights ``h``) into [support, object, object, ...] index
    arrays, or None to keep it whole (see the module docstring)."""
    n = len(h)
    lo, hi = float(h.min()), float(h.max())
    step = cfg.layer_bin * R
    if hi - lo < 3 * step:
        return None
    edges = np.arange(lo, hi + step, step)
    counts, edges = np.histogram(h, bins=edges)
    k = int(np.argmax(counts))
    a, b = max(k - 1, 0), min(k + 1, len(counts) - 1)
    top = edges[b + 1]
    if counts[a : b + 1].sum() <= cfg.layer_min_frac * n or counts[k] < cfg.layer_peak * np.median(counts[counts > 0]):
        return None
    if 0.5 * (edges[k] + edges[k + 1]) > lo + cfg.layer_low_frac * (hi - lo):
        return None
    above = np.flatnonzero(h > top)
    lab = _dbscan(x[above], cfg.upper_eps * R, cfg.min_samples)
    groups = [above[lab == j] for j in range(lab.max() + 1)] if len(lab) else []
    groups = [g for g in groups if len(g) >= cfg.upper_min_frac * n]
    if len(groups) >= 2:
        groups = _merge_stacked(groups, x, up)
    if len(groups) < 2:
        return None
    layer = np.flatnonzero(h <= top)
    groups = sorted(groups, key=lambda g: -len(g))
    # what stands above the layer but fell out of the groups (DBSCAN noise: the sparse underside of
    # a fruit next to the plate) belongs to the nearest group, not to the support below it
    grouped = np.zeros(n, bool)
    for g in groups:
        grouped[g] = True
    rest = above[~grouped[above]]
    if len(rest):
        member = np.concatenate(groups)
        owner = np.concatenate([np.full(len(g), k) for k, g in enumerate(groups)])
        d, j = cKDTree(x[member]).query(x[rest], distance_upper_bound=cfg.eps * R)
        ok = np.isfinite(d)
        groups = [np.concatenate([g, rest[ok & (owner[np.minimum(j, len(owner) - 1)] == k)]]) for k, g in enumerate(groups)]
    return [layer] + groups


def cluster_gaussians(means: np.ndarray, opacities: np.ndarray, max_scales: np.ndarray, frame: SceneFrame, cfg: ClusterConfig) -> Clusters:
    """Object labels of every Gaussian (see the module docstring)."""
    R = frame.radius
    h = frame.heights(means)
    r = frame.horizontal_distance(means)
    near = r < cfg.max_radius * R
    seed_mask = (opacities > cfg.seed_min_opacity) & (h > cfg.tau * R) & near & (max_scales < cfg.max_scale * R)
    seeds = np.flatnonzero(seed_mask)
    labels = np.zeros(len(means), np.int32)
    support: list[int] = []
    scale = density_scale(means[seeds], cfg, R)
    if scale != 1.0:
        cfg = replace(cfg, eps=cfg.eps * scale, upper_eps=cfg.upper_eps * scale, grow_radius=cfg.grow_radius * scale)
    lab = _dbscan(means[seeds], cfg.eps * R, cfg.min_samples)
    clusters = [seeds[lab == j] for j in range(lab.max() + 1)] if len(lab) else []
    clusters = sorted((c for c in clusters if len(c) > cfg.min_cluster_frac * len(seeds)), key=lambda c: -len(c))
    next_id = 1
    for c in clusters:
        parts = _peel(means[c], h[c], frame.up, cfg, R)
        if parts is None:
            labels[c] = next_id
            next_id += 1
            continue
        support.append(next_id)
        for p in parts:
            labels[c[p]] = next_id
            next_id += 1
    # growing: faint or low Gaussians near the axis join their nearest labelled neighbour
    candidates = (labels == 0) & (opacities > cfg.grow_min_opacity) & (h > cfg.grow_min_height * cfg.tau * R) & near
    grown = 0
    for _ in range(cfg.grow_rounds):
        have = np.flatnonzero(labels > 0)
        todo = np.flatnonzero(candidates & (labels == 0))
        if not len(have) or not len(todo):
            break
        d, j = cKDTree(means[have]).query(means[todo], distance_upper_bound=cfg.grow_radius * R)
        ok = np.isfinite(d)
        if not ok.any():
            break
        labels[todo[ok]] = labels[have[j[ok]]]
        grown += int(ok.sum())
    return Clusters(labels=labels, support=support, num_seeds=len(seeds), num_grown=grown, density_scale=scale)
