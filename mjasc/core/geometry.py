"""Planar geometry shared by metrics, sensing and planning (world frame, metres)."""

from __future__ import annotations

import numpy as np

__all__ = ["distance_to_polygon", "point_in_polygon", "hull_outline", "convex_hull"]


def distance_to_polygon(points_xy: np.ndarray, vertices: np.ndarray) -> np.ndarray:
    """Distance [m] from each point (n, 2) to a closed polygon's boundary; 0 inside is NOT implied:
    use :func:`point_in_polygon` to tell inside from outside. Vectorized over points × edges."""
    p = np.asarray(points_xy, dtype=float).reshape(-1, 1, 2)
    a = np.asarray(vertices, dtype=float)
    b = np.roll(a, -1, axis=0)
    ab = b - a
    t = np.clip(np.einsum("nkj,kj->nk", p - a, ab) / np.maximum(np.einsum("kj,kj->k", ab, ab), 1e-18), 0.0, 1.0)
    closest = a + t[..., None] * ab
    return np.min(np.linalg.norm(p - closest, axis=-1), axis=1)


def point_in_polygon(points_xy: np.ndarray, vertices: np.ndarray) -> np.ndarray:
    """Even-odd rule, vectorized: bool (n,) for points (n, 2) inside the polygon (k, 2)."""
    p = np.asarray(points_xy, dtype=float).reshape(-1, 1, 2)
    a = np.asarray(vertices, dtype=float)
    b = np.roll(a, -1, axis=0)
    crosses = (a[:, 1] > p[..., 1]) != (b[:, 1] > p[..., 1])
    with np.errstate(divide="ignore", invalid="ignore"):
        x_int = a[:, 0] + (p[..., 1] - a[:, 1]) * (b[:, 0] - a[:, 0]) / (b[:, 1] - a[:, 1])
    return np.count_nonzero(crosses & (p[..., 0] < x_int), axis=1) % 2 == 1


def hull_outline(length_m: float, beam_m: float, position_m, heading_rad: float) -> np.ndarray:
    """Closed pentagon (6, 2) drawing a hull seen from above: square stern, pointed bow."""
    l, b = 0.5 * length_m, 0.5 * beam_m
    body = np.array([[-l, -b], [0.6 * l, -b], [l, 0.0], [0.6 * l, b], [-l, b], [-l, -b]])
    c, s = np.cos(heading_rad), np.sin(heading_rad)
    return body @ np.array([[c, s], [-s, c]]) + np.asarray(position_m, dtype=float)


def convex_hull(points_xy: np.ndarray) -> np.ndarray:
    """Vertices (k, 2) of the convex hull of points (n, 2), counter-clockwise, starting at the
    lexicographically smallest point; collinear boundary points are dropped (scipy's Qhull).
    Points are rounded to 1 µm and de-duplicated first; a degenerate set (≤ 2 distinct points, or all
    on a line) gives its extreme points."""
    from scipy.spatial import ConvexHull, QhullError

    p = np.unique(np.round(np.asarray(points_xy, dtype=float).reshape(-1, 2), 6), axis=0)  # sorted by x, y
    if p.shape[0] <= 2:
        return p
    try:
        hull = p[ConvexHull(p).vertices]
    except QhullError:  # all points on one line
        return p[[0, -1]]
    k = int(np.lexsort((hull[:, 1], hull[:, 0]))[0])
    return np.roll(hull, -k, axis=0)
