"""The per-time loop of :meth:`mjasc.evaluation.tracking_metrics.TrackingScore.add_run`, compiled:
each time's assignment of tracks to truth objects, its GOSPA terms summed in time order, the
identity switches and first confirmations — the same floating-point operations in the same order as
:meth:`~mjasc.evaluation.tracking_metrics.TrackingScore.add` (``dr ** p`` and the p-th root are
libm's ``pow`` in both), so the same sums bit for bit (tests/test_run_evaluation_batch.py).

An assignment is found here when it is the unique optimum that the least costs give
(:func:`least_pairs`); a time where it is not (exact ties, shared least-cost tracks, non-finite
costs) stops the pass and goes to :func:`scipy.optimize.linear_sum_assignment`, whose pairs the
next pass starts with (:func:`score_ticks`).

Costs and distances are track-major: ``cost[r, m]`` is track row r's cost to truth object m.
"""

from __future__ import annotations

import numpy as np

from mjasc.core.compiled import kernel

__all__ = ["least_pairs", "score_ticks"]


@kernel
def least_pairs(cost, a, b, idx, rows_out, cols_out):
    """The pairs (truth position k in ``idx``, track j = row − a) of the optimal assignment of the
    truth objects ``idx`` to the track rows a … b − 1 when the least costs decide it, in scipy's
    order (truth positions ascending), written to ``rows_out``/``cols_out``; their number, or −1.

    With no more truths than tracks every truth is assigned, so the sum of each truth's least cost
    bounds every assignment from below: when each truth's least cost is unique and no two truths
    share their least-cost track, those pairs are the one optimal assignment (likewise with the
    roles swapped when there are more truths than tracks)."""
    n_x, n_y = idx.size, b - a
    if n_x <= n_y:  # each truth's costs to the tracks
        taken = np.zeros(n_y, dtype=np.bool_)
        for k in range(n_x):
            m = idx[k]
            best = cost[a, m]
            pick = 0
            for j in range(1, n_y):
                v = cost[a + j, m]
                if v < best:
                    best, pick = v, j
            for j in range(n_y):
                if j != pick and cost[a + j, m] == best:
                    return -1
            if taken[pick]:
                return -1
            taken[pick] = True
            rows_out[k], cols_out[k] = k, pick
        return n_x
    owner = np.full(n_x, -1, dtype=np.int64)  # each track's costs to the truths
    for j in range(n_y):
        r = a + j
        best = cost[r, idx[0]]
        pick = 0
        for k in range(1, n_x):
            v = cost[r, idx[k]]
            if v < best:
                best, pick = v, k
        for k in range(n_x):
            if k != pick and cost[r, idx[k]] == best:
                return -1
        if owner[pick] >= 0:
            return -1
        owner[pick] = j
    n = 0
    for k in range(n_x):
        if owner[k] >= 0:
            rows_out[n], cols_out[n] = k, owner[k]
            n += 1
    return n


@kernel
def score_ticks(k0, ends, in_range, d, cost, track_ids, static, times, c, p, half, fast, given_rows, given_cols,
                n_given, sums, sq, last_id, has_last, confirmed_at, confirm_order, counters):
    """Score the times k0, k0 + 1, … (their tracks are rows ends[k − 1] … ends[k] − 1, ends[−1]
    read as 0) until one needs scipy: returns its index (len(ends) when every time is scored).
    Time k0 takes ``given_rows``/``given_cols`` (``n_given`` pairs: scipy's) when ``n_given`` ≥ 0.

    ``in_range`` (T, M): the observable truths (every truth takes part in the assignment; one not
    observable is never missed); ``d``, ``cost`` (R, M); ``track_ids`` (R,); ``static`` (R,): the
    static tracks (never false; optional objects: :mod:`mjasc.evaluation.tracking_metrics`);
    ``fast``: least-cost assignments allowed (every cost finite). State, updated in place:
    ``sums`` [distance, localization, missed, false], ``sq`` [Σ squared distance of the assigned
    pairs, m²], per truth ``last_id`` / ``has_last`` (its last matched track), ``confirmed_at``
    (NaN: not yet) and ``confirm_order`` (the order of first confirmations), ``counters``
    [identity switches, confirmations so far, assigned pairs]."""
    n_t, n_m = ends.size, in_range.shape[1]
    idx = np.empty(n_m, dtype=np.int64)
    rows = np.empty(n_m, dtype=np.int64)
    cols = np.empty(n_m, dtype=np.int64)
    inv_p = 1.0 / p
    for k in range(k0, n_t):
        a = ends[k - 1] if k > 0 else 0
        b = ends[k]
        n_x = n_m
        n_seen = 0
        for m in range(n_m):
            idx[m] = m
            if in_range[k, m]:
                n_seen += 1
        n_y = b - a
        n_moving = 0
        for r in range(a, b):
            if not static[r]:
                n_moving += 1
        loc = 0.0
        n_assigned_seen = 0
        n_assigned_moving = 0
        if n_x and n_y:
            if k == k0 and n_given >= 0:
                n_pairs = n_given
                for q in range(n_pairs):
                    rows[q], cols[q] = given_rows[q], given_cols[q]
            else:
                n_pairs = least_pairs(cost, a, b, idx[:n_x], rows, cols) if fast else -1
                if n_pairs < 0:
                    return k
            t = times[k]
            for q in range(n_pairs):
                m = idx[rows[q]]
                r = a + cols[q]
                dr = d[r, m]
                n_opt = (1 if static[r] else 0) + (0 if in_range[k, m] else 1)
                if (dr < c) if n_opt == 0 else (dr ** p + half * n_opt < c ** p):
                    if in_range[k, m]:
                        n_assigned_seen += 1
                    if not static[r]:
                        n_assigned_moving += 1
                    loc += dr ** p
                    sq[0] += dr * dr
                    counters[2] += 1
                    trk = track_ids[r]
                    if in_range[k, m] and confirmed_at[m] != confirmed_at[m]:
                        confirmed_at[m] = t
                        confirm_order[m] = counters[1]
                        counters[1] += 1
                    if has_last[m] and last_id[m] != trk:
                        counters[0] += 1
                    last_id[m] = trk
                    has_last[m] = True
        missed, false = half * (n_seen - n_assigned_seen), half * (n_moving - n_assigned_moving)
        sums[0] += (loc + missed + false) ** inv_p
        sums[1] += loc
        sums[2] += missed
        sums[3] += false
    return n_t
