"""Planar geometry: the one place for polygons and circles in the plane (world frame ENU, metres).

Every layer (metrics, sensing, tracking, prediction, planning, figures) takes its polygon and
circle helpers from here. A polygon is a (k, 2) array of vertices, not repeated at the end
(closed implicitly: the last vertex joins the first). Functions of points and a polygon take the
points first: ``f(points_xy, polygon)``, with points (n, 2) (a single (2,) point is read as (1, 2))
and a result per point (n,).

* distances: :func:`distance_to_polygon` (to the boundary, unsigned), :func:`signed_distance_to_polygon`
  (negative inside); containment: :func:`point_in_polygon` (even-odd rule);
* orientation: :func:`polygon_signed_area` (the shoelace formula, > 0 counter-clockwise),
  :func:`counter_clockwise`;
* construction: :func:`circle_polygon` (an n-gon circumscribing a circle, or points on it),
  :func:`convex_hull`, :func:`disc_hull` (the hull of discs), :func:`hull_outline` (a vessel's
  outline for drawing), :func:`covariance_ellipse` (an n-σ position ellipse for drawing);
* clean-up: :func:`clean_polygon` (validated, counter-clockwise, no degenerate vertices),
  :func:`inflate_polygon` (outward offset by a margin, containing the Minkowski sum with the disc),
  :func:`segments_intersect`, :func:`self_intersections`.
"""

from __future__ import annotations

import numpy as np

from mjasc.core.polygon_kernels import (boundary_distance, canonical_hull, clean_vertices, edges_cross, hull_indices,
                                        inside_even_odd, offset_vertices, self_crossings)

__all__ = ["covariance_ellipse", "distance_to_polygon", "signed_distance_to_polygon", "point_in_polygon", "polygon_signed_area",
           "counter_clockwise", "circle_polygon", "convex_hull", "disc_hull", "hull_outline", "clean_polygon",
           "inflate_polygon", "segments_intersect", "self_intersections", "polygons_overlap"]


# ---------------------------------------------------------------------------------------------- distance
def _points(xy) -> np.ndarray:
    """(n, 2) C-contiguous float64 view or copy of points (the compiled kernels' one layout)."""
    return np.ascontiguousarray(np.asarray(xy, dtype=float).reshape(-1, 2))


def distance_to_polygon(points_xy: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """Distance [m] (n,) from each point (n, 2) to a closed polygon's boundary; 0 inside is NOT implied:
    use :func:`point_in_polygon` to tell inside from outside, or :func:`signed_distance_to_polygon`.
    The closest point a + t·(b − a) of each edge is formed first (zero-length edges are measured to
    their vertex); compiled (:func:`mjasc.core.polygon_kernels.boundary_distance`)."""
    return boundary_distance(_points(points_xy), _points(polygon))


def signed_distance_to_polygon(points_xy: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """Signed distance [m] (n,) from points (n, 2) to a closed polygon's boundary: negative inside
    (:func:`point_in_polygon`), positive outside.

    The same distance as :func:`distance_to_polygon`, written in the edge's own frame:
    ‖(p − a) − t·(b − a)‖. The two forms round differently in the last bit; each caller keeps the
    form it always used (the potential field this one, the run metrics the other), so that results
    stay bit-identical.
    """
    p = np.atleast_2d(np.asarray(points_xy, dtype=float))
    a = np.asarray(polygon, dtype=float)
    e = np.roll(a, -1, axis=0) - a
    d = p[:, None, :] - a[None, :, :]
    s = np.clip(np.einsum("nkj,kj->nk", d, e) / np.maximum(np.einsum("kj,kj->k", e, e), 1e-18), 0.0, 1.0)
    dist = np.linalg.norm(d - s[..., None] * e[None], axis=2).min(axis=1)
    return np.where(point_in_polygon(p, a), -dist, dist)


def point_in_polygon(points_xy: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """Even-odd rule (crossing number), compiled (:func:`mjasc.core.polygon_kernels.inside_even_odd`): bool (n,) for points (n, 2) strictly inside the
    polygon (k, 2) (points on the boundary may fall either way)."""
    return inside_even_odd(_points(points_xy), _points(polygon))


# ---------------------------------------------------------------------------------------------- orientation
def points_near_polygon(points_xy: np.ndarray, polygon: np.ndarray, margin_m: float) -> bool:
    """Whether any point (n, 2) is inside the polygon (k, 2) or closer than ``margin_m`` [m] to its
    boundary (:func:`point_in_polygon`, then :func:`distance_to_polygon`): a leg, a lane or a disc
    that meets an obstacle grown by the margin."""
    p = _points(points_xy)
    return bool(np.any(point_in_polygon(p, polygon)) or float(np.min(distance_to_polygon(p, polygon))) < margin_m)


def polygon_signed_area(polygon: np.ndarray) -> float:
    """Signed area [m²] of a closed polygon (k, 2) (shoelace formula); positive when counter-clockwise."""
    v = np.asarray(polygon, dtype=float)
    x, y = v[:, 0], v[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def counter_clockwise(polygon: np.ndarray) -> np.ndarray:
    """The polygon (k, 2) itself when its signed area is > 0, else its vertices reversed (a copy)."""
    return polygon if polygon_signed_area(polygon) > 0 else polygon[::-1].copy()


# ---------------------------------------------------------------------------------------------- construction
def circle_polygon(centre, radius_m: float, n: int, *, circumscribed: bool = True, closed: bool = False) -> np.ndarray:
    """Regular n-gon (n, 2) around the circle (centre (2,), radius_m), counter-clockwise from the
    vertex at angle 0 (east).

    circumscribed: True → vertices at radius_m / cos(π/n), so the polygon contains the whole disc
        (for obstacles); False → vertices on the circle (inscribed; for drawing).
    closed: True → n + 1 points, the last one repeating the first (at angle 2π), for drawing a
        closed line strip.
    """
    if closed:
        ang = np.linspace(0.0, 2.0 * np.pi, n + 1)
    else:
        ang = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    r = radius_m / np.cos(np.pi / n) if circumscribed else float(radius_m)
    return np.asarray(centre, dtype=float) + r * np.stack([np.cos(ang), np.sin(ang)], axis=-1)


def convex_hull(points_xy: np.ndarray, *, canonical: bool = True) -> np.ndarray:
    """Vertices (k, 2) of the convex hull of points (n, 2), counter-clockwise; collinear boundary
    points are dropped.

    canonical: True → points rounded to 1 µm and de-duplicated first, the hull starts at the
        lexicographically smallest point, and a degenerate set (≤ 2 distinct points, or all on a
        line) gives its extreme points; the hull is Andrew's monotone chain in exact arithmetic
        (:func:`mjasc.core.polygon_kernels.hull_indices`, 30× cheaper than Qhull on the few dozen
        points of a track's outline). False → Qhull's vertices of the points as given (exact
        coordinates, Qhull's start vertex; a degenerate set raises scipy's QhullError).
    """
    if not canonical:
        from scipy.spatial import ConvexHull

        pts = np.asarray(points_xy, dtype=float)
        return pts[ConvexHull(pts).vertices]
    p = np.ascontiguousarray(points_xy, dtype=float).reshape(-1, 2)
    if p.shape[0] > 256 or not np.isfinite(p).all():  # (the kernel sorts by insertion: for a few dozen points)
        p = np.round(p, 6)
        p = p[np.lexsort((p[:, 1], p[:, 0]))]  # sorted by x, then y (np.unique(axis=0)'s order)
        if p.shape[0] > 1:
            p = p[np.concatenate([[True], (p[1:] != p[:-1]).any(axis=1)])]
        if p.shape[0] <= 2:
            return p
        return p[hull_indices(p)]
    return canonical_hull(p)  # the same steps, compiled (mjasc.core.polygon_kernels)


def disc_hull(centres_xy: np.ndarray, radius_m: float, sides: int = 16) -> np.ndarray:
    """Convex polygon (k, 2), counter-clockwise, containing every disc of ``radius_m`` centred on
    ``centres_xy`` (m, 2): the hull (``canonical=False``) of the circumscribed ``sides``-gons."""
    pts = np.concatenate([circle_polygon(c, radius_m, sides) for c in centres_xy])
    return convex_hull(pts, canonical=False)


def hull_outline(length_m: float, beam_m: float, position_m, heading_rad: float) -> np.ndarray:
    """Closed pentagon (6, 2) drawing a hull seen from above: square stern, pointed bow."""
    l, b = 0.5 * length_m, 0.5 * beam_m
    body = np.array([[-l, -b], [0.6 * l, -b], [l, 0.0], [0.6 * l, b], [-l, b], [-l, -b]])
    c, s = np.cos(heading_rad), np.sin(heading_rad)
    return body @ np.array([[c, s], [-s, c]]) + np.asarray(position_m, dtype=float)


# ---------------------------------------------------------------------------------------------- clean-up
def segments_intersect(p1, p2, q1, q2, tol: float) -> np.ndarray:
    """Vectorized closed-segment intersection test (touching counts, within ``tol`` [m]) of
    segments p1–p2 and q1–q2, given as broadcastable arrays of endpoints (..., 2)."""

    def orient(a, b, c):
        return (b[..., 0] - a[..., 0]) * (c[..., 1] - a[..., 1]) - (b[..., 1] - a[..., 1]) * (
            c[..., 0] - a[..., 0]
        )

    def on_segment(a, b, c):  # c collinear with a-b: inside the bounding box?
        return (
            (np.minimum(a[..., 0], b[..., 0]) - tol <= c[..., 0])
            & (c[..., 0] <= np.maximum(a[..., 0], b[..., 0]) + tol)
            & (np.minimum(a[..., 1], b[..., 1]) - tol <= c[..., 1])
            & (c[..., 1] <= np.maximum(a[..., 1], b[..., 1]) + tol)
        )

    d1, d2 = orient(q1, q2, p1), orient(q1, q2, p2)
    d3, d4 = orient(p1, p2, q1), orient(p1, p2, q2)
    tol2 = tol * tol
    proper = (((d1 > tol2) & (d2 < -tol2)) | ((d1 < -tol2) & (d2 > tol2))) & (
        ((d3 > tol2) & (d4 < -tol2)) | ((d3 < -tol2) & (d4 > tol2))
    )
    touch = (
        ((np.abs(d1) <= tol2) & on_segment(q1, q2, p1))
        | ((np.abs(d2) <= tol2) & on_segment(q1, q2, p2))
        | ((np.abs(d3) <= tol2) & on_segment(p1, p2, q1))
        | ((np.abs(d4) <= tol2) & on_segment(p1, p2, q2))
    )
    return proper | touch


def self_intersections(polygon: np.ndarray, tol: float) -> list[tuple[int, int]]:
    """Pairs (i, j), i < j, of non-adjacent edges of the closed polygon (edge i: vertex i → i+1)
    that intersect or touch."""
    v = _points(polygon)
    k = v.shape[0]
    out = np.empty((max(k * (k - 1) // 2, 1), 2), dtype=np.int64)
    n = self_crossings(v, float(tol), out)  # (compiled: segments_intersect's tests per pair)
    return [(i, j) for i, j in out[:n].tolist()]


def polygons_overlap(a, b, tol: float = 0.0) -> bool:
    """Do the closed polygons a (k, 2) and b (m, 2) [m] overlap: an edge of one meets an edge of the
    other within ``tol`` [m] (:func:`segments_intersect` of every edge pair, compiled:
    ``polygon_kernels.edges_cross``), or one lies inside the other (its first vertex does)?"""
    a, b = _points(a), _points(b)
    return bool(edges_cross(a, b, float(tol)) or point_in_polygon(b[:1], a)[0] or point_in_polygon(a[:1], b)[0])


def clean_polygon(polygon, name: str = "obstacle") -> np.ndarray:
    """Validate one polygon and return it counter-clockwise, without degenerate vertices.

    - repeated vertices / zero-length edges (including a closing vertex equal to the first one)
      are dropped;
    - collinear vertices (edge continues straight on) are merged;
    - clockwise polygons are reversed (e.g. the potential field's panels are numbered
      counter-clockwise);
    - fewer than 3 distinct vertices, zero area, an edge folding back on itself, or
      self-intersection raise ValueError naming ``name``.
    """
    v = np.asarray(polygon, dtype=float)
    if v.ndim != 2 or v.shape[1] != 2:
        raise ValueError(f"{name}: vertices must have shape (k, 2), got {v.shape}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{name}: vertices must be finite")
    scale = float(np.max(np.ptp(v, axis=0))) if len(v) else 0.0
    tol = 1e-9 * max(scale, 1.0)
    # Zero-length edges (cyclic, e.g. an explicitly closed ring [v0, ..., v0]) dropped, collinear
    # vertices merged when straight on (refused when the boundary folds back), self-crossings
    # refused: the kept vertices in one compiled pass (polygon_kernels.clean_vertices)
    keep, pair = np.empty(len(v), dtype=np.int64), np.empty(2, dtype=np.int64)
    n, code = clean_vertices(_points(v), tol, keep, pair)
    if code == 1:
        raise ValueError(f"{name}: needs at least 3 distinct vertices, got {max(n, 1)}")
    if code == 2:
        raise ValueError(f"{name}: boundary folds back on itself at vertex {v[n].tolist()} "
                         "(degenerate, self-overlapping polygon)")
    if code == 3:
        raise ValueError(f"{name}: fewer than 3 non-collinear vertices (polygon has no area)")
    if code == 4:
        raise ValueError(f"{name}: polygon is self-intersecting (edges {pair[0]} and {pair[1]} cross); "
                         "give a simple polygon")
    v = v[keep[:n]]
    area = polygon_signed_area(v)
    if abs(area) <= 1e-12 * max(scale, 1.0) ** 2:
        raise ValueError(f"{name}: polygon has zero area")
    if area < 0:
        v = v[::-1].copy()
    return v


def inflate_polygon(polygon: np.ndarray, margin: float, name: str = "obstacle") -> np.ndarray:
    """Offset a clean counter-clockwise polygon outward by ``margin`` metres (≥ 0).

    Miter offset at every vertex; at convex corners turning by more than 90° the miter is
    replaced by a bevel tangent to the circle of radius ``margin`` around the vertex (two
    vertices), so the result contains the Minkowski sum of the polygon and that disc.
    Concave corners use the miter (the offset edges' intersection); a margin so large that it
    swallows an edge next to a concave corner raises ValueError.
    """
    v = np.asarray(polygon, dtype=float)
    if margin < 0 or not np.isfinite(margin):
        raise ValueError(f"inflation must be a finite margin ≥ 0 m, got {margin}")
    if margin == 0:
        return v.copy()
    out = np.empty((2 * len(v), 2))
    n = offset_vertices(_points(v), float(margin), out)  # each vertex's miter or bevel, compiled
    w = out[:n] if n else np.array([])
    try:
        cleaned = clean_polygon(w, name=f"{name} inflated by {margin} m")
    except ValueError as err:
        raise ValueError(
            f"{name}: inflation {margin} m is too large for its concave parts ({err})"
        ) from None
    # Every original vertex and edge midpoint must end up ≥ margin inside the offset boundary
    # (fails when the margin swallows an edge next to a concave corner).
    probe = np.concatenate([v, 0.5 * (v + np.roll(v, -1, axis=0))])
    if np.any(signed_distance_to_polygon(probe, cleaned) > -margin * (1.0 - 1e-6)):
        raise ValueError(f"{name}: inflation {margin} m is too large for its concave parts")
    return cleaned


def covariance_ellipse(centre, cov, n_sigma: float = 2.0, points: int = 33) -> np.ndarray:
    """Closed contour (points, 2) of the n-σ ellipse of a 2×2 covariance, world frame: centre +
    n·L·[cos t, sin t] with L the Cholesky-like factor V·√Λ (so it is rotated correctly)."""
    lam, vec = np.linalg.eigh(np.asarray(cov, dtype=float))
    lam = np.maximum(lam, 0.0)
    t = np.linspace(0.0, 2.0 * np.pi, points)
    circle = np.stack([np.cos(t), np.sin(t)], axis=0)
    return np.asarray(centre) + (n_sigma * (vec * np.sqrt(lam)) @ circle).T
