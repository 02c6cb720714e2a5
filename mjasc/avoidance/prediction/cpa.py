"""Closest approaches of many (vessel, track) pairs at once: the temporal correlation's minima.

docs/thesis.md §3, step 2 (thesis §3.2.2, eq. 3.16). For P pairs, r_p(t) = P_o(t) − P_v(t) is the
track's position relative to the vessel [m] (world ENU) and d_p(t) = ‖r_p(t)‖. Given r on each
pair's time grid (t_0 … t_{n−1}, step h), :func:`closest_approaches` returns, for every pair, the
chosen local minimum (t_c, d(t_c)) of d — all pairs in two compiled passes around the zoom
(:mod:`~mjasc.avoidance.prediction.cpa_kernels`), no scalar optimizer:

1. **Grid minima.** Index i is a local minimum when d_i ≤ d_{i−1} and d_i < d_{i+1} (a window end
   counts when d rises from / falls to it) — over all pairs at once.
2. **Candidates.** Only minima that can matter are refined: each pair's first minimum, and any
   minimum whose closed form on the grid samples (step 3 on the grid) is within
   R_col + ½ m + ‖Δr‖ of a collision (‖Δr‖ the longer of its two grid segments: the true relative
   path between two samples cannot stray farther from their chord unless it is more than twice
   as long plus 1 m, i.e. turns back within one step). Two team mates sailing side by side have a
   nearly constant d(t) whose rounding noise makes a local minimum of every other sample; none
   of them is refined.
3. **Sampled zoom** (:data:`ZOOM_LEVELS` levels of :data:`ZOOM_SAMPLES` samples). The bracket
   [t_{i−1}, t_{i+1}] (the interval the former bounded Brent search covered) is sampled at
   K = 17 points on the *true* motion (``rel_at``, one vectorized evaluation for every
   (pair, minimum)); the bracket shrinks to the two sample spacings around the sampled minimum
   and is sampled again: spacings h/8, h/64, h/512. A minimum whose last three samples still
   bend — the middle one more than :data:`ZOOM_TOL_M` = 5e-8 m off the chord of the other two: a
   kink (a path corner, a knot of a team mate's plan or of the speed profile) or a tight turn —
   zooms on, 8× per level, up to :data:`ZOOM_MAX_LEVELS` = 9 levels (s = h/8⁹).
4. **Closed form.** Between adjacent samples of spacing s the relative motion is taken linear,
   r(t_j + σ s) = r_j + σ (r_{j+1} − r_j), σ ∈ [0, 1], whose closest point to the vessel is
   σ* = clip(−r_j·Δ / ‖Δ‖², 0, 1), Δ = r_{j+1} − r_j; the minimum is the smaller CPA of the two
   segments around the last sampled minimum (without ``rel_at``: around the grid minimum).
5. **Choice.** t_c = the first minimum (in time) with d ≤ R_col (a collision), else the first
   minimum; with ``stop_at_first`` the first minimum only (the thesis's rule). As with the former
   Brent search, a refined value larger than the grid value falls back to the grid sample.

**Error bound.** For straight motion at constant speed of both (a line of the vessel's path at a
constant speed; a straight or static track) r(t) is linear and the result is exact (to rounding).
Otherwise, with d unimodal on [t_{i−1}, t_{i+1}] (as the Brent search assumed), every level's
bracket contains the true minimizer, and the reported d(t_c) is within the chord error of the
last samples (spacing s) of the true local minimum: A s²/8 for ‖r̈‖ ≤ A — at s = h/512 (1 ms for
h = 0.5 s) 9e-9 m for a track turning at 0.05 rad/s at 1.5 m/s (A = v ω), 5e-8 m for the vessel
on an arc of 10 m at 2 m/s (A = v²/ρ) —, and for a kink turning the relative velocity w by Δψ
between the samples at most ½ ‖w‖ s sin(Δψ/2). Both are bounded by twice the bend of the last
samples, which the zoom brings under :data:`ZOOM_TOL_M`: |Δd| ≤ 1e-7 m unless the 9 levels end
first (a kink at 2 m/s turning 90°: then ≤ 3e-9 m·(h/0.5 s)). t_c lies in the last bracket:
within 2 s of the true minimizer (much closer for a deep minimum), exact for linear motion. (The
former Brent search had xatol = 1e-7 s.) Cost: 51 true samples per refined minimum in 3 array
operations, 17 more per extra level for the few that need it (Brent: about 25 scalar evaluations
per minimum, each a Python call).

Inputs are arrays over pairs; pairs of different grid lengths are padded with NaN times at the end
(their samples are ignored), so the vessels of a fleet, each with its own window, are predicted in
one call. Times are absolute simulation times [s].
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from mjasc.avoidance.prediction.cpa_kernels import choose, grid_pass, segment_cpa_one
from mjasc.core.compiled import kernel

__all__ = ["ZOOM_LEVELS", "ZOOM_MAX_LEVELS", "ZOOM_SAMPLES", "ZOOM_TOL_M", "closest_approaches", "segment_cpa"]

#: Levels and samples per level of the sampled zoom (see the module docstring): spacings h/8,
#: h/64, h/512 of the grid step h; more levels (up to ZOOM_MAX_LEVELS) while the last samples
#: bend by more than ZOOM_TOL_M [m].
ZOOM_LEVELS = 3
ZOOM_SAMPLES = 17
ZOOM_MAX_LEVELS = 9
ZOOM_TOL_M = 5e-8
_ZOOM_FRACTIONS = np.linspace(0.0, 1.0, ZOOM_SAMPLES)  # the samples' places in a bracket (read-only)
_ZOOM_FRACTIONS.flags.writeable = False


def segment_cpa(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Closest point to the origin of the segments from a (..., 2) to b (..., 2): (s* ∈ [0, 1] (...),
    distance (...)). Exact for r linear in s; s* = 0 for a degenerate segment."""
    dx, dy = b[..., 0] - a[..., 0], b[..., 1] - a[..., 1]
    dd = dx * dx + dy * dy
    num = -(a[..., 0] * dx + a[..., 1] * dy)
    s = np.minimum(np.maximum(num / np.maximum(dd, 1e-300), 0.0), 1.0)
    return s, np.hypot(a[..., 0] + s * dx, a[..., 1] + s * dy)


def closest_approaches(
    times: np.ndarray,
    rel: np.ndarray,
    r_col: np.ndarray,
    rel_at: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
    stop_at_first: np.ndarray | bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """The chosen local minimum of d = ‖rel‖ per pair (module docstring).

    times: (P, n) grid times [s] (NaN padding at the end of shorter grids); rel: (P, n, 2) track
    minus vessel position on the grid [m]; r_col: (P,) collision distances R_vh + R_ob + safety [m];
    rel_at(pairs (k,), t (k, K)) → (k, K, 2): the true relative positions at times t for the zoom
    (None: the closed form on the grid samples only); stop_at_first: (P,) or a bool, the thesis's
    rule per pair.

    Returns (t_c (P,), d_c (P,)); NaN for a pair without a valid sample.
    """
    times = np.asarray(times, dtype=float)
    P = times.shape[0]
    r_col = np.asarray(r_col, dtype=float)
    pi, t_lo, t_hi, tt, dd, t_grid, d_grid, cand = grid_pass(times, np.asarray(rel, dtype=float), r_col)
    if rel_at is not None and pi.size:
        refine = cand.nonzero()[0]
        tt[refine], dd[refine] = _zoom(rel_at, pi[refine], t_lo[refine], t_hi[refine])
        skip = ~cand  # the others are no collision: keep them out of the choice
    else:
        skip = np.zeros(pi.size, dtype=bool)
    stop = np.ascontiguousarray(np.broadcast_to(np.asarray(stop_at_first, dtype=bool), (P,)))
    return choose(P, pi, tt, dd, t_grid, d_grid, r_col, skip, stop)


def _zoom(rel_at, pairs, a, b):
    """The sampled zoom and closed form (module docstring, steps 3–4) of brackets [a, b] (k,) of
    ``pairs`` (k,): (t*, d*) per bracket. Items whose last three samples still bend by more than
    :data:`ZOOM_TOL_M` (a kink near the minimum) zoom on, up to :data:`ZOOM_MAX_LEVELS`. Each
    level is ``rel_at`` between two compiled passes (:func:`_zoom_samples`, :func:`_zoom_level`:
    the numbers of the numpy form, ``tests/test_zoom_kernels.py``), or with a ``rel_at`` that has
    a ``level`` (a :class:`~mjasc.avoidance.prediction.zoom_motion.ZoomMotion`) that level whole in
    compiled passes."""
    K, frac = ZOOM_SAMPLES, _ZOOM_FRACTIONS
    t_out, d_out = np.empty(a.size), np.empty(a.size)
    act = np.arange(a.size)  # the items still zooming
    a, b = a.copy(), b.copy()
    keep = np.empty(a.size, dtype=np.intp)
    compiled = getattr(rel_at, "level", None)  # (a ZoomMotion: the level in compiled passes, the same numbers)
    for level in range(ZOOM_MAX_LEVELS):
        final = level + 1 >= ZOOM_LEVELS
        if compiled is not None:
            n = compiled(pairs, a, b, act, frac, final, ZOOM_TOL_M, t_out, d_out, keep)
        else:
            ts = np.empty((act.size, K))
            _zoom_samples(a, b, act, frac, ts)
            r = rel_at(pairs[act], ts)
            n = _zoom_level(r, ts, act, a, b, final, ZOOM_TOL_M, t_out, d_out, keep)
        if not final:
            continue
        act = keep[:n].copy()
        if n == 0:
            break
    return t_out, d_out


@kernel
def _zoom_samples(a, b, act, frac, ts):
    """ts (k, K) ← the K sample times of each zooming item's bracket: a + (b − a)·frac."""
    for i in range(act.shape[0]):
        e = act[i]
        lo = a[e]
        span = b[e] - lo
        for q in range(frac.shape[0]):
            ts[i, q] = lo + span * frac[q]


@kernel
def _zoom_level(r, ts, act, a, b, final, tol, t_out, d_out, keep):
    """One zoom level after ``rel_at`` gave r (k, K, 2) at ts (k, K): each item's sampled minimum
    (``np.argmin`` of the distances: the first minimum, the first NaN if any), its new bracket into
    a, b; with ``final``, the closed form (step 4: the smaller CPA of the two segments) into t_out, d_out and the items
    still bending by more than ``tol`` [m] (not at a bracket end) into ``keep``, in order: their
    count is returned (0 without ``final``)."""
    K = ts.shape[1]
    n_keep = 0
    for i in range(act.shape[0]):
        j = 0
        best = math.hypot(r[i, 0, 0], r[i, 0, 1])
        if best == best:
            for q in range(1, K):
                v = math.hypot(r[i, q, 0], r[i, q, 1])
                if v != v:  # (argmin: the first NaN)
                    j = q
                    break
                if v < best:
                    best = v
                    j = q
        ja = j - 1 if j > 0 else 0
        jb = j + 1 if j + 1 < K else K - 1
        e = act[i]
        a[e], b[e] = ts[i, ja], ts[i, jb]
        if not final:
            continue
        rax, ray, rjx, rjy, rbx, rby = r[i, ja, 0], r[i, ja, 1], r[i, j, 0], r[i, j, 1], r[i, jb, 0], r[i, jb, 1]
        s1, d1 = segment_cpa_one(rax, ray, rjx, rjy)
        s2, d2 = segment_cpa_one(rjx, rjy, rbx, rby)
        t_a, t_b, t_c = ts[i, ja], ts[i, j], ts[i, jb]
        if d2 < d1:
            t_out[e], d_out[e] = t_b + s2 * (t_c - t_b), d2
        else:
            t_out[e], d_out[e] = t_a + s1 * (t_b - t_a), d1
        bend = math.hypot(rjx - 0.5 * (rax + rbx), rjy - 0.5 * (ray + rby))
        if bend > tol and j > 0 and j < K - 1:
            keep[n_keep] = e
            n_keep += 1
    return n_keep
