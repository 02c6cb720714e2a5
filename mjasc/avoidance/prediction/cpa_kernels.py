"""The closest approaches' array glue in two compiled passes (:func:`mjasc.avoidance.prediction.cpa.closest_approaches`,
steps 1, 2, 4 and 5 around the zoom): about a hundred numpy calls on arrays of a few hundred numbers per
prediction, in two calls.

:func:`grid_pass` is steps 1–2 and the closed form on the grid samples: the distances d = ‖rel‖ [m]
(``math.hypot``, numpy's ``hypot``), the grid minima (``grid_minima``' comparisons, row-major: per
pair in time order), each minimum's two segments' closest approach (:func:`segment_cpa_one`,
``segment_cpa``'s operations) and which minima are candidates of the zoom (the pair's first, or
within R_col + ½ m + the longer grid segment of a collision; the sums left to right as numpy's).
:func:`choose` is step 5 after the zoom: the fallback to the grid sample when the refined value is
not smaller or equal, then per pair the first minimum that is a collision (not skipped), else the
first minimum. The same expressions in the same order as the numpy form, so the results are its bits
(``tests/test_cpa_kernels.py`` keeps it as the reference).
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.compiled import kernel, maximum, minimum

__all__ = ["choose", "grid_pass", "segment_cpa_one"]


@kernel
def segment_cpa_one(ax, ay, bx, by):
    """:func:`~mjasc.avoidance.prediction.cpa.segment_cpa` of one segment from (ax, ay) to (bx, by)
    [m], the same operations: (s* ∈ [0, 1], distance [m])."""
    dx, dy = bx - ax, by - ay
    dd = dx * dx + dy * dy
    num = -(ax * dx + ay * dy)
    s = minimum(maximum(num / maximum(dd, 1e-300), 0.0), 1.0)
    return s, math.hypot(ax + s * dx, ay + s * dy)


@kernel
def grid_pass(times, rel, r_col):
    """Steps 1–2 on the grid of P pairs: times (P, n) [s] (NaN padding at the end of shorter grids),
    rel (P, n, 2) [m], r_col (P,) [m]. Returns (pi, t_lo, t_hi, tt, dd, t_grid, d_grid,
    cand): per grid minimum (M,) its pair, its bracket's end times [s], the closed form
    on the grid samples (t* [s], d* [m]), the grid sample's time and distance, and the minima that
    are candidates of the zoom (as a mask)."""
    P, n = times.shape
    d = np.empty((P, n))
    last = np.empty(P, dtype=np.intp)
    padded = False
    for p in range(P):
        n_pad = 0
        for i in range(n):
            if times[p, i] != times[p, i]:
                d[p, i] = np.nan
                n_pad += 1
            else:
                d[p, i] = math.hypot(rel[p, i, 0], rel[p, i, 1])
        last[p] = n - 1 - n_pad
        padded = padded or n_pad > 0
    # grid_minima: not higher than the left neighbour, strictly lower than the right one; with
    # padding NaN counts as +inf and only finite samples are minima.
    mask = np.empty((P, n), dtype=np.bool_)
    m = 0
    for p in range(P):
        for i in range(n):
            x = d[p, i]
            if padded and x != x:
                x = np.inf
            ok = True
            if i > 0:
                left = d[p, i - 1]
                if padded and left != left:
                    left = np.inf
                ok = x <= left
            if ok and i < n - 1:
                right = d[p, i + 1]
                if padded and right != right:
                    right = np.inf
                ok = x < right
            if ok and padded:
                ok = x - x == 0.0  # finite
            mask[p, i] = ok
            if ok:
                m += 1
    pi = np.empty(m, dtype=np.intp)
    t_lo, t_hi, tt, dd = np.empty(m), np.empty(m), np.empty(m), np.empty(m)
    t_grid, d_grid = np.empty(m), np.empty(m)
    cand = np.empty(m, dtype=np.bool_)
    e = 0
    for p in range(P):
        for i in range(n):
            if not mask[p, i]:
                continue
            lo = i - 1 if i - 1 > 0 else 0
            hi = i + 1 if i + 1 < last[p] else last[p]
            pi[e] = p
            ta, tb, tc = times[p, lo], times[p, i], times[p, hi]
            t_lo[e], t_hi[e] = ta, tc
            rax, ray, rbx, rby, rcx, rcy = rel[p, lo, 0], rel[p, lo, 1], rel[p, i, 0], rel[p, i, 1], \
                rel[p, hi, 0], rel[p, hi, 1]
            s1, d1 = segment_cpa_one(rax, ray, rbx, rby)
            s2, d2 = segment_cpa_one(rbx, rby, rcx, rcy)
            if d2 < d1:
                tt[e], dd[e] = tb + s2 * (tc - tb), d2
            else:
                tt[e], dd[e] = ta + s1 * (tb - ta), d1
            t_grid[e], d_grid[e] = tb, d[p, i]
            chord = maximum(math.hypot(rbx - rax, rby - ray), math.hypot(rcx - rbx, rcy - rby))
            cand[e] = e == 0 or pi[e - 1] != p or dd[e] <= r_col[p] + 0.5 + chord
            e += 1
    return pi, t_lo, t_hi, tt, dd, t_grid, d_grid, cand


@kernel
def choose(P, pi, tt, dd, t_grid, d_grid, r_col, skip, stop_at_first):
    """Step 5: (t_c (P,) [s], d_c (P,) [m]) from the minima (M,) of :func:`grid_pass` after the
    zoom: each minimum's refined value, or its grid sample when the refined distance is not ≤ the
    grid's; per pair the first minimum that is a collision (d ≤ r_col, not ``skip``) unless
    ``stop_at_first`` (P,), else its first minimum; NaN for a pair without one."""
    t_c = np.full(P, np.nan)
    d_c = np.full(P, np.nan)
    m = pi.shape[0]
    e = 0
    for p in range(P):
        first = -1
        col = -1
        while e < m and pi[e] == p:
            if not (dd[e] <= d_grid[e]):
                tt[e], dd[e] = t_grid[e], d_grid[e]
            if first < 0:
                first = e
            if col < 0 and dd[e] <= r_col[p] and not skip[e]:
                col = e
            e += 1
        if first < 0:
            continue
        pick = col if col >= 0 and not stop_at_first[p] else first
        t_c[p], d_c[p] = tt[pick], dd[pick]
    return t_c, d_c
