"""The surface an object stands on and the object's footprint on it, from Gaussian centres.

An object standing on a support (a table, a floor, a mat) leaves, when removed, a region of that
support to fill; what may stand there afterwards and how far the fill reaches are scored in this
frame: the support plane fitted to the scene around the object, heights above it, and the object's
outline projected onto it (the convex hull of its centres). Used by the removal (paper Sec. 3.4),
the inpainting's support view and the no-ground-truth scores (docs/architecture.md, "Real captures").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

STANDING = 0.1  # an object's Gaussians higher than this x its height above the support stand on it (they make its outline)
# standing centres closer than this x their median nearest-neighbour spacing are one body; the outline is
# the body's (docs/architecture.md, "The footprint column": stray Gaussians over the support, labelled
# as the object, a few spacings apart from each other and from it, do not widen it)
OUTLINE_LINK = 6.0


def linked_body(points: np.ndarray, link: float, min_part: float) -> np.ndarray:
    """(N,) bool: the ``points`` in the connected components of the graph that links centres closer
    than ``link`` x the median nearest-neighbour distance, kept when they hold at least ``min_part``
    of the largest component's points (scipy's k-d tree and connected components). Fewer than 3
    points: all of them."""
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    if len(points) < 3:
        return np.ones(len(points), dtype=bool)
    tree = cKDTree(points)
    d, _ = tree.query(points, k=2)
    graph = tree.sparse_distance_matrix(tree, link * float(np.median(d[:, 1])), output_type="coo_matrix")
    _, labels = connected_components(graph, directed=False)
    sizes = np.bincount(labels)
    return sizes[labels] >= min_part * sizes.max()


def fit_plane(points: np.ndarray, up: np.ndarray, *, trim: float = 0.8, rounds: int = 5) -> tuple[np.ndarray, float]:
    """Least-squares plane (unit normal oriented with ``up``, offset d with n.x = d) through
    ``points``, refitted ``rounds`` times on the ``trim`` share of points nearest the current plane
    (robust to what stands on the surface or lies under it)."""
    pts = np.asarray(points, dtype=np.float64)
    if len(pts) < 3:
        raise ValueError(f"a plane needs at least 3 points, got {len(pts)}")
    sel = pts
    for _ in range(rounds + 1):
        c = sel.mean(0)
        _, _, vt = np.linalg.svd(sel - c, full_matrices=False)
        n = vt[2] if vt[2] @ up >= 0 else -vt[2]
        d = float(n @ c)
        r = np.abs(pts @ n - d)
        sel = pts[r <= np.quantile(r, trim)]
        if len(sel) < 3:
            break
    return n, d


def plane_candidates(points: np.ndarray, up: np.ndarray, tries: int, max_tilt_deg: float, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """RANSAC's candidate planes: ``tries`` planes through three random ``points`` each; returns
    (unit normals oriented with ``up`` (tries, 3), offsets (tries,), which are usable: not degenerate
    and tilted at most ``max_tilt_deg`` from ``up``)."""
    idx = rng.integers(0, len(points), size=(tries, 3))
    a, b, c = points[idx[:, 0]], points[idx[:, 1]], points[idx[:, 2]]
    n = np.cross(b - a, c - a)
    norm = np.linalg.norm(n, axis=1)
    ok = norm > 1e-12
    n[ok] /= norm[ok, None]
    n[n @ up < 0] *= -1
    ok &= n @ up >= np.cos(np.radians(max_tilt_deg))
    return n, np.einsum("ij,ij->i", n, a), ok


def voxel_thin(points: np.ndarray, colors: np.ndarray, voxel: float) -> tuple[np.ndarray, np.ndarray]:
    """One point per occupied voxel: the mean position and colour of the points in it."""
    keys = np.floor(points / voxel).astype(np.int64)
    _, inv, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    inv = inv.reshape(-1)
    p = np.zeros((len(counts), 3))
    c = np.zeros((len(counts), 3))
    np.add.at(p, inv, points)
    np.add.at(c, inv, colors)
    return p / counts[:, None], c / counts[:, None]


def plane_basis(normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two orthonormal directions across ``normal`` (a fixed choice for a given normal)."""
    a = np.array([1.0, 0.0, 0.0]) if abs(normal[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(normal, a)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(normal, e1)


def plane_coordinates(points: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """(N, 2) coordinates of ``points`` in the directions of :func:`plane_basis`."""
    e1, e2 = plane_basis(normal)
    return np.stack([points @ e1, points @ e2], axis=1)


def inside_polygon_hull(hull_points: np.ndarray, queries: np.ndarray) -> np.ndarray:
    """Which 2D ``queries`` lie inside the convex hull of the 2D ``hull_points`` (scipy Delaunay)."""
    from scipy.spatial import Delaunay, QhullError

    if len(hull_points) < 3:
        return np.zeros(len(queries), dtype=bool)
    try:
        return Delaunay(hull_points).find_simplex(queries) >= 0
    except QhullError:
        return np.zeros(len(queries), dtype=bool)


@dataclass
class Footprint:
    """An object's footprint column: the support plane around it and its outline on that plane."""

    normal: np.ndarray  # (3,) the support plane's unit normal (up)
    offset: float  # plane: normal . x = offset
    outline: np.ndarray  # (K, 2) plane coordinates of the object's centres (their convex hull is the footprint)
    height: float  # the object's height above the plane

    def heights(self, points: np.ndarray) -> np.ndarray:
        """Signed heights of ``points`` (N, 3) above the support plane."""
        return points @ self.normal - self.offset

    def inside(self, points: np.ndarray) -> np.ndarray:
        """Which ``points`` (N, 3) lie in the column over the outline's convex hull."""
        return inside_polygon_hull(self.outline, plane_coordinates(points, self.normal))

    def widened(self, points: np.ndarray) -> "Footprint":
        """The same footprint with ``points`` (N, 3) added to its outline (their plane coordinates)."""
        if not len(points):
            return self
        return Footprint(self.normal, self.offset, np.concatenate([self.outline, plane_coordinates(points, self.normal)]), self.height)

    def to_json(self) -> dict:
        """JSON-ready dict (normal, offset, height, outline)."""
        return {"normal": self.normal.tolist(), "offset": self.offset, "height": self.height, "outline": self.outline.tolist()}

    @staticmethod
    def from_json(d: dict) -> "Footprint":
        """Inverse of :meth:`to_json`."""
        return Footprint(np.asarray(d["normal"], dtype=np.float64), float(d["offset"]), np.asarray(d["outline"], dtype=np.float64), float(d["height"]))

    def _hull(self):
        from scipy.spatial import ConvexHull

        if not hasattr(self, "_hull_cache"):
            self._hull_cache = ConvexHull(self.outline)
        return self._hull_cache

    @property
    def size(self) -> float:
        """Square root of the footprint's area (a length)."""
        return float(np.sqrt(self._hull().volume))  # in 2D, "volume" is the area

    def to_world(self, xy: np.ndarray) -> np.ndarray:
        """Points (N, 3) on the plane at plane coordinates ``xy`` (N, 2)."""
        e1, e2 = plane_basis(self.normal)
        return xy[:, :1] * e1 + xy[:, 1:2] * e2 + self.offset * self.normal

    @property
    def centre(self) -> np.ndarray:
        """The footprint's centroid on the plane (3,)."""
        hull = self._hull()
        return self.to_world(self.outline[hull.vertices].mean(axis=0, keepdims=True))[0]

    @property
    def diameter(self) -> float:
        """Largest distance between two outline points."""
        from scipy.spatial.distance import pdist

        v = self.outline[self._hull().vertices]
        return float(pdist(v).max()) if len(v) > 1 else 0.0

    def distance(self, points: np.ndarray) -> np.ndarray:
        """Signed distance of ``points`` (N, 3) from the outline across the plane: negative inside;
        outside, the distance to the farthest edge line (the outline grown by d has mitred corners)."""
        eq = self._hull().equations  # unit outward normals and offsets of the edges
        return (plane_coordinates(points, self.normal) @ eq[:, :2].T + eq[:, 2]).max(axis=1)


def object_footprint(object_means: np.ndarray, object_opacities: np.ndarray, scene_means: np.ndarray, scene_opacities: np.ndarray, up: np.ndarray,
                     *, min_opacity: float = 0.1, ring: float = 0.5, trim_share: float = 0.01, standing: float = STANDING) -> Footprint:  # fmt: skip
    """The footprint of an object (its Gaussians ``object_means``) standing on a surface of the
    scene (``scene_means``, the Gaussians left after removal), with ``up`` roughly the surface's
    normal (e.g. the training cameras' up). The support plane is fitted (:func:`fit_plane`) to the
    opaque scene Gaussians in a ring around the object, out to ``ring`` x its radius and below the
    object's middle; the object's height is its opaque centres' 99th percentile above the plane;
    the outline is those standing higher than ``standing`` x that height (a piece of the support
    taken for the object does not widen it), minus the ``trim_share`` farthest from their median
    and those apart from the standing body (:func:`linked_body` at :data:`OUTLINE_LINK`, parts of
    at least a tenth of the largest: stray Gaussians over the support). :class:`ValueError` when
    there are too few Gaussians for either."""
    up = np.asarray(up, dtype=np.float64) / np.linalg.norm(up)
    obj = object_means[object_opacities > min_opacity]
    if len(obj) < 4:
        raise ValueError(f"the object has {len(obj)} opaque Gaussians: too few for a footprint")
    flat = plane_coordinates(obj, up)
    med = np.median(flat, axis=0)
    r = np.linalg.norm(flat - med, axis=1)
    keep = r <= np.quantile(r, 1.0 - trim_share)
    radius = float(np.quantile(r, 0.95))
    z = obj @ up
    lo, hi = np.quantile(z, 0.02), np.quantile(z, 0.98)
    sc = scene_means[scene_opacities > min_opacity]
    sr = np.linalg.norm(plane_coordinates(sc, up) - med, axis=1)
    sz = sc @ up
    near = (sr > radius) & (sr < (1.0 + ring) * radius) & (sz < 0.5 * (lo + hi)) & (sz > lo - 0.5 * (hi - lo))
    if near.sum() < 10:
        raise ValueError(f"only {int(near.sum())} scene Gaussians around the object: cannot fit its support plane")
    normal, offset = fit_plane(sc[near], up)
    hts = obj @ normal - offset
    height = float(np.quantile(hts, 0.99))
    if not height > 0:
        raise ValueError("the object does not stand above the surface around it")
    pts = obj[keep & (hts > standing * height)]
    pts = pts[linked_body(pts, OUTLINE_LINK, 0.1)]
    if len(pts) < 3:
        raise ValueError("too few of the object's Gaussians stand above the surface around it for an outline")
    fp = Footprint(normal, offset, plane_coordinates(pts, normal), height)
    try:
        fp.size
    except Exception as e:  # scipy's QhullError: the outline is a line or a point seen from above
        raise ValueError(f"the object's outline on its support has no area ({type(e).__name__})") from None
    return fp
