"""Distances from points to the path ahead in one compiled call: the spatial correlation's gap
(:func:`mjasc.avoidance.prediction.spatial._path_gap`, tens of points against a detour's hundred
segments, and 31 per step of its bisection).

``Path.closest_points`` evaluates every candidate of every segment of the stretch for every
point (:func:`~mjasc.guidance.segment_geometry.closest_candidates`: a line's clamped foot of the
perpendicular, an arc's clamped polar angle and both ends, with arctan2, sin and cos) and the
distance is ``sqrt(min d²)`` as ``pick_closest`` takes it. :func:`path_distances` evaluates the
same candidates with the same expressions in the same order (``math``'s atan2, sin and cos equal
numpy's on this machine class, docs/architecture.md; numpy's ``x**2`` is x·x; Python's float
``%`` is ``np.mod``; a NaN makes the minimum NaN, as numpy's ``min``), so the result is
``closest_points``' bit for bit (``tests/test_path_distance.py``). On a stretch of more than
:data:`_FEW_SEGMENTS` segments it skips the segments that cannot hold the closest point: a segment
starting at p₀ with length ℓ lies within ℓ of p₀ (arc length bounds the chord), so for a point q
its candidates are at least ‖q − p₀‖ − ℓ away and some point of it at most ‖q − p₀‖ + ℓ; a
segment whose lower bound exceeds the least upper bound (by 1e-6 relative plus 1 cm, far beyond
rounding) holds no candidate as close as the closest (the minimum is the same without it).
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.compiled import clip_float, kernel, maximum, minimum
from mjasc.guidance.paths import Path
from mjasc.guidance.segment_geometry import A0, C, COS0, CX, CY, K, LEN, SIN0, TH0, X0, Y0

__all__ = ["path_distances"]

_FEW_SEGMENTS = 8  # at most this many segments in the stretch: none skipped
_MARGIN_REL, _MARGIN_M = 1e-6, 0.01
_TWO_PI = 2.0 * math.pi


def path_distances(path: Path, points: np.ndarray, gamma_min: float) -> np.ndarray:
    """``path.closest_points(points, gamma_min, path.length)[1]``: the distance [m] (n,) of each
    of ``points`` (n, 2) [m] to the stretch [gamma_min, L] of ``path`` (module docstring)."""
    pts = np.asarray(points, dtype=float)
    length = path.length
    if pts.ndim != 2 or pts.shape[0] == 0 or pts.shape[1] != 2:
        return path.closest_points(pts, gamma_min, length)[1]
    if float(gamma_min) >= length:  # at the path's end (a vessel waiting there): no stretch, its end point
        return np.hypot(*(pts - path.point(length)).T)
    out = np.empty(pts.shape[0])
    if not _distances_into(path.table, clip_float(float(gamma_min), 0.0, length), length, pts, _FEW_SEGMENTS, out):
        return path.closest_points(pts, gamma_min, length)[1]  # (no segment in the stretch: its error)
    return out


@kernel
def _distances_into(table, g_lo, length, pts, few, out):
    """:func:`path_distances` into ``out`` (n,): each point's least d² over the candidates of the
    segments whose window [max(0, g_lo − C), min(LEN, length − C)] is not empty (more than ``few``
    of them: those that can hold the closest point), its square root. False (``out`` unset) when
    no segment's window is open."""
    lo, hi, ok, n_ok, gap = open_segments(table, g_lo, length)
    if n_ok == 0:
        return False
    for i in range(pts.shape[0]):
        out[i] = point_distance(table, lo, hi, ok, n_ok, few, gap, pts[i, 0], pts[i, 1])
    return True


@kernel
def open_segments(table, g_lo, length):
    """(lo, hi, ok, n_ok, gap): each segment's window [max(0, g_lo − C), min(LEN, length − C)] in
    ``lo``, ``hi`` (n_seg,), the n_ok segments whose window is not empty in ``ok[:n_ok]``, and
    :func:`point_distance`'s scratch ``gap`` (n_ok,) (for kernels)."""
    n_seg = table.shape[1]
    lo = np.empty(n_seg)
    hi = np.empty(n_seg)
    ok = np.empty(n_seg, dtype=np.intp)
    n_ok = 0
    for j in range(table.shape[1]):
        lo[j] = maximum(0.0, g_lo - table[C, j])
        hi[j] = minimum(table[LEN, j], length - table[C, j])
        if lo[j] <= hi[j]:
            ok[n_ok] = j
            n_ok += 1
    return lo, hi, ok, n_ok, np.empty(n_ok)


@kernel
def point_distance(table, lo, hi, ok, n_ok, few, gap, qx, qy):
    """The distance [m] of the point (qx, qy) to the open segments ``ok[:n_ok]`` (windows ``lo``,
    ``hi``; :func:`open_segments`): the least d² over their candidates, its square root;
    ``gap`` (n_ok,) is scratch (for kernels)."""
    limit = math.inf
    if n_ok > few:  # the least upper bound ‖q − p₀‖ + ℓ, NaN propagating as numpy's min
        upper = math.inf
        for e in range(n_ok):
            j = ok[e]
            gap[e] = math.hypot(qx - table[X0, j], qy - table[Y0, j])
            upper = minimum(upper, gap[e] + table[LEN, j])
        limit = upper * (1.0 + _MARGIN_REL) + _MARGIN_M
    best = math.inf
    for e in range(n_ok):
        j = ok[e]
        if n_ok > few and gap[e] - table[LEN, j] > limit:
            continue  # (a NaN bound keeps the segment)
        a, b = lo[j], hi[j]
        k = table[K, j]
        if k == 0.0:  # a line: the clamped foot of the perpendicular
            dx, dy = qx - table[X0, j], qy - table[Y0, j]
            c0, s0 = table[COS0, j], table[SIN0, j]
            s = minimum(maximum(dx * c0 + dy * s0, a), b)
            ex, ey = dx - s * c0, dy - s * s0
            best = minimum(best, ex * ex + ey * ey)
            continue
        phi = math.atan2(qy - table[CY, j], qx - table[CX, j])  # an arc: the polar angle and both ends
        sgn = 1.0 if k > 0.0 else -1.0
        s_star = minimum(maximum((sgn * (phi - table[A0, j])) % _TWO_PI / abs(k), a), b)
        for q in range(3):
            s = s_star if q == 0 else (a if q == 1 else b)
            th = table[TH0, j] + k * s
            ex = table[X0, j] + (math.sin(th) - table[SIN0, j]) / k - qx
            ey = table[Y0, j] + (table[COS0, j] - math.cos(th)) / k - qy
            best = minimum(best, ex * ex + ey * ey)
    return math.sqrt(best)
