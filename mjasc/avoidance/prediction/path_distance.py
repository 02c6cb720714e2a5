"""Distances from points to the path ahead, evaluated only on the segments that can hold the
closest point: the spatial correlation's gap (:func:`mjasc.avoidance.prediction.spatial._path_gap`,
tens of points against a detour's hundred segments) without the full points × segments block.

``Path.closest_points`` evaluates every candidate of every segment of the stretch for every
point (:func:`~mjasc.guidance.segment_geometry.closest_candidates`, arcs with arctan2, sin and
cos) and takes the least d². A segment starting at p₀ with length ℓ lies within ℓ of p₀ (arc
length bounds the chord), so for a point q its candidates are at least ‖q − p₀‖ − ℓ away and
some point of it at most ‖q − p₀‖ + ℓ; a segment whose lower bound exceeds the least upper
bound (by 1e-6 relative plus 1 cm, far beyond rounding) holds no candidate as close as the
closest, and is left out. The rest are gathered per point and evaluated by the same
``closest_candidates`` (elementwise: the same numbers), and the distance is ``sqrt(min d²)`` as
``pick_closest`` takes it, so the result is ``closest_points``' bit for bit
(``tests/test_path_distance.py``).
"""

from __future__ import annotations

import numpy as np

from mjasc.guidance.paths import Path
from mjasc.guidance.segment_geometry import LEN, X0, Y0, C, closest_candidates

__all__ = ["path_distances"]

_FEW_SEGMENTS = 8  # at most this many segments in the stretch: Path.closest_points itself
_MARGIN_REL, _MARGIN_M = 1e-6, 0.01


def path_distances(path: Path, points: np.ndarray, gamma_min: float) -> np.ndarray:
    """``path.closest_points(points, gamma_min, path.length)[1]``: the distance [m] (n,) of each
    of ``points`` (n, 2) [m] to the stretch [gamma_min, L] of ``path`` (module docstring)."""
    pts = np.asarray(points, dtype=float)
    length = path.length
    g_lo = float(np.clip(gamma_min, 0.0, length))
    table = path.table
    lo = np.maximum(0.0, g_lo - table[C])
    hi = np.minimum(table[LEN], length - table[C])
    ok = np.flatnonzero(lo <= hi)
    m = pts.shape[0] if pts.ndim == 2 else 0
    if ok.size <= _FEW_SEGMENTS or m == 0 or pts.shape[1] != 2:
        return path.closest_points(pts, gamma_min, length)[1]
    seg, lo, hi = table[:, ok], lo[ok], hi[ok]
    qx, qy = pts[:, 0:1], pts[:, 1:2]
    gap = np.hypot(qx - seg[X0], qy - seg[Y0])  # (m, k)
    upper = (gap + seg[LEN]).min(axis=1, keepdims=True)
    keep = ~(gap - seg[LEN] > upper * (1.0 + _MARGIN_REL) + _MARGIN_M)  # (NaN: kept)
    counts = keep.sum(axis=1)
    width = int(counts.max())
    cols = np.argsort(~keep, axis=1, kind="stable")[:, :width]  # each point's kept segments first
    cols = np.where(np.arange(width) < counts[:, None], cols, cols[:, :1])  # padded with its first one
    d2, _ = closest_candidates(qx, qy, seg[:, cols], lo[cols], hi[cols])
    return np.sqrt(d2.reshape(m, -1).min(axis=1))
