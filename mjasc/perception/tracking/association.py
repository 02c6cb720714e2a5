"""Gated global-nearest-neighbour association of one scan's detections with a vessel's tracks
(thesis §3.2.1; :mod:`mjasc.perception.tracking`, items 1–2). World ENU, SI.

1. **Prediction and gating.** Each track's combined estimate predicted to the scan time (one EKF
   step with ω̂), ẑ_i with covariance J P Jᵀ (a track with no course yet, V = 0, with var(V)·dt²
   on both axes: its velocity's direction is unknown), plus the detection's own isotropic
   variance σ_j²: ``S_ij = J_i P_i J_iᵀ + σ_j²·I`` and ``d²_ij = (z_j − ẑ_i)ᵀ S_ij⁻¹ (z_j − ẑ_i)``. A pair is
   admissible when ``d²_ij ≤ −2 ln(1 − gate_probability)`` (chi-square, 2 dof). (The bank then
   gates again on its own models when it updates.)
2. **Global nearest neighbour** association: ``scipy.optimize.linear_sum_assignment`` on the cost
   ``d²_ij + ln det S_ij`` (−2 log-likelihood up to a constant); inadmissible pairs cost a large
   constant and are dropped from the solution. Each track takes at most one detection per scan
   and vice versa.

**A fleet's vessels at once.** Each vessel associates only its own tracks with its own detections:
the pairs are the blocks (tracks of vessel q) × (detections of vessel q), listed row-major per block
(:func:`block_pairs`), and :func:`pair_costs` evaluates d² and the cost of every pair in one pass
(per pair the same arithmetic as the matrix). :func:`gnn_assign_blocks` solves each vessel's
problem: where no track and no detection has two admissible partners the admissible pairs *are*
the solution (the least-cost assignment of the full matrix contains every admissible pair of such a
problem, since one inadmissible pair costs more than any sum of admissible ones); only the other
vessels' matrices go to ``linear_sum_assignment``.
"""

from __future__ import annotations

import numpy as np

from mjasc.core.assignment import linear_sum_assignment
from mjasc.perception.tracking.pair_kernels import (arc_midpoints, block_pairs_loop, gate_terms, position_jacobians,
                                                   spread_courseless_into)
from mjasc.perception.tracking.step_kernels import admissible_pairs

__all__ = ["association_costs", "gnn_assign", "gnn_pairs", "BIG_COST", "block_pairs", "group_starts",
           "predicted_positions", "pair_costs", "indexed_pair_costs", "gnn_assign_blocks"]

#: Cost of an inadmissible pair in the assignment problems (never chosen over an admissible one).
BIG_COST = 1e9


def block_pairs(n_a: np.ndarray, n_b: np.ndarray):
    """Every pair (i, j), i < n_a[q], j < n_b[q], of every block q, row-major within a block,
    blocks in order: (q, i, j, start) with start (Q+1,) the first pair of each block
    (compiled: :func:`mjasc.perception.tracking.pair_kernels.block_pairs_loop`)."""
    return block_pairs_loop(np.ascontiguousarray(n_a, dtype=np.int64), np.ascontiguousarray(n_b, dtype=np.int64))


def group_starts(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The groups of a sorted 1-D array ``keys``: (values (g,), index of each group's first element
    (g,)) — ``np.unique(keys, return_index=True)`` for sorted input, without its sort."""
    if keys.size == 0:
        return keys[:0], np.zeros(0, dtype=np.intp)
    first = np.empty(keys.size, dtype=bool)
    first[0] = True
    np.not_equal(keys[1:], keys[:-1], out=first[1:])
    starts = first.nonzero()[0]
    return keys[starts], starts


def predicted_positions(states, covariances, times_s, turn_rates, t_s):
    """ẑ (n, 2) [m] and S = J P Jᵀ (n, 2, 2) [m²] of tracks predicted to t_s (scalar or (n,) [s])
    (the prediction of :func:`association_costs`): ``dt = maximum(t_s − t, 0)``,
    ``θ_mid = θ + 0.5·dt·ω̂``, ``ẑ = p + dt·V·[cos θ_mid, sin θ_mid]`` and J the position rows of
    the transition Jacobian — a track with V = 0 (no course yet) has var(V)·dt² on both axes
    (:func:`~mjasc.perception.tracking.pair_kernels.spread_courseless_into`). The cosine, the sine
    and the products J P Jᵀ are numpy's; the rest is compiled passes
    (:func:`mjasc.perception.tracking.pair_kernels.arc_midpoints`,
    :func:`~mjasc.perception.tracking.pair_kernels.position_jacobians`; tests/test_pair_kernels.py
    keeps the numpy form)."""
    x = states
    t = np.asarray(t_s, dtype=float)
    if t.shape != times_s.shape:
        t = np.broadcast_to(t, times_s.shape)
    dt, th_mid, dv = arc_midpoints(x, times_s, turn_rates, t)
    zhat, J = position_jacobians(x, dt, dv, np.cos(th_mid), np.sin(th_mid))
    S = J @ covariances @ np.swapaxes(J, 1, 2)
    spread_courseless_into(x, dt, covariances, S)
    return zhat, S


def pair_costs(zhat, S, z, var) -> tuple[np.ndarray, np.ndarray]:
    """d² and GNN cost of pairs: predicted positions zhat (p, 2) with covariances S (p, 2, 2) of the
    pairs' tracks, detections z (p, 2) with isotropic variances var (p,) (:func:`association_costs`)."""
    a = S[:, 0, 0] + var
    b = S[:, 0, 1]
    d = S[:, 1, 1] + var
    det = a * d - b * b
    y0, y1 = z[:, 0] - zhat[:, 0], z[:, 1] - zhat[:, 1]
    d2 = (d * y0 * y0 - 2.0 * b * y0 * y1 + a * y1 * y1) / det
    return d2, d2 + np.log(det)


def indexed_pair_costs(zhat, S, g, z, db, var) -> tuple[np.ndarray, np.ndarray]:
    """:func:`pair_costs` of the pairs (track row g[k], detection db[k]) without gathering them
    first: zhat (n, 2) [m] and S (n, 2, 2) [m²] per track row, z (M, 2) [m] per detection, var (P,)
    [m²] per pair (the same bits; compiled: :func:`mjasc.perception.tracking.pair_kernels.gate_terms`)."""
    d2, det = gate_terms(g, zhat, S, db, z, var)  # (integer indices, float arrays: no conversion per tick)
    return d2, d2 + np.log(det)


def gnn_assign_blocks(inside, cost, q, i, j, start, n_a, n_b) -> np.ndarray:
    """Global nearest neighbour in every block of :func:`block_pairs` (``inside``, ``cost`` per pair):
    the indices of the assigned pairs, ascending (each block's :func:`gnn_assign`). The blocks where
    no track and no detection has two admissible partners are sorted out in one compiled pass
    (:func:`mjasc.perception.tracking.step_kernels.admissible_pairs`)."""
    easy, hard = admissible_pairs(inside, q, i, j, start, np.ascontiguousarray(n_b, dtype=np.int64))
    if hard.size == 0:
        return easy
    out = [easy]
    for b in hard.tolist():
        na, nb, s0 = int(n_a[b]), int(n_b[b]), int(start[b])
        blk = slice(s0, s0 + na * nb)
        out.append(s0 + gnn_pairs(inside[blk].reshape(na, nb), cost[blk].reshape(na, nb)))
    return np.sort(np.concatenate(out))


def gnn_pairs(inside: np.ndarray, cost: np.ndarray) -> np.ndarray:
    """Flat indices (row-major) of the pairs :func:`gnn_assign` chooses in an (n, m) problem."""
    rows, cols = linear_sum_assignment(np.where(inside, cost, BIG_COST))
    ok = inside[rows, cols]
    return rows[ok] * inside.shape[1] + cols[ok]


def association_costs(states, covariances, times_s, turn_rates, z, var, t_s: float) -> tuple[np.ndarray, np.ndarray]:
    """(n_tracks, m) squared Mahalanobis distances d²_ij and GNN costs d² + ln det S_ij for
    detections z (m, 2) [m] with isotropic variances var (m,) or (n_tracks, m) [m²], of tracks
    whose combined estimates are ``states`` (n, 4) [x, y, θ, V], ``covariances`` (n, 4, 4), at
    ``times_s`` (n,) [s] with turn rates ω̂ ``turn_rates`` (n,) [rad/s].

    The prediction is that of each track's *combined* estimate (one EKF step of thesis eq. 3.3
    with ω̂, not the r models: association needs ẑ and S, not the mixture; 10× cheaper):
    ``ẑ = p + Ts·V·[cos, sin](θ + ω̂ Ts/2)``, ``S = J P Jᵀ + σ_j² I`` with J the position rows of
    the transition Jacobian.
    """
    zhat, S = predicted_positions(states, covariances, times_s, turn_rates, t_s)
    n, m = zhat.shape[0], z.shape[0]
    var = np.broadcast_to(var, (n, m)).reshape(-1)
    ii, jj = np.repeat(np.arange(n), m), np.tile(np.arange(m), n)
    d2, cost = pair_costs(zhat[ii], S[ii], z[jj], var)
    return d2.reshape(n, m), cost.reshape(n, m)


def gnn_assign(inside: np.ndarray, cost: np.ndarray) -> np.ndarray:
    """(n,) index of the detection assigned to each track (−1: none) by the global nearest
    neighbour: the least total ``cost`` (n, m) over the admissible pairs ``inside`` (n, m) bool,
    each track taking at most one detection and vice versa."""
    assigned = np.full(inside.shape[0], -1)
    if inside.any():
        rows, cols = linear_sum_assignment(np.where(inside, cost, BIG_COST))
        ok = inside[rows, cols]
        assigned[rows[ok]] = cols[ok]
    return assigned
