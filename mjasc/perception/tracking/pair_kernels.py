"""Compiled loops over the (track, detection) and (track, broadcast) pairs of a fleet's tracker
(:mod:`mjasc.perception.tracking.association`, :mod:`mjasc.perception.tracking.team`). World
frame ENU, metres and seconds.

A tick's pairs are a few dozen for a handful of vessels and ~10⁵ for a fleet of fifty; the numpy
forms these loops replace paid either numpy's cost per call (small ticks) or a temporary array per
operation (large ones). Each loop evaluates the same expressions, in the same order, as the numpy
form it replaced, so its results are bit-identical to it (``tests/test_pair_kernels.py`` keeps the
numpy forms as references):

* :func:`block_pairs_loop` — every pair (i, j), i < n_a[q], j < n_b[q], of every block q,
  row-major within a block, blocks in order; ``start`` (Q+1,) the first pair of each block
  (``start = [0, cumsum(n_a·n_b)]``, ``q = repeat(arange(Q), n_a·n_b)``,
  ``i = (k − start[q]) // n_b[q]``, ``j = (k − start[q]) − i·n_b[q]``).
* :func:`broadcast_distances` — per pair k of a vessel's confirmed track a = a_start[q] + i and
  its broadcast b = bsel[b_start[q] + j] (sent at t_b, at p_b), the distance of the broadcast to
  the track's position extrapolated back to t_b along its velocity (vx, vy)::

      Δt = t_s[q] − t_b[b]
      d  = hypot((x_a − vx_a·Δt) − p_b,x, (y_a − vy_a·Δt) − p_b,y)

  except that a pair whose squared offset exceeds ``far_m2`` gets d = +inf without the hypot (the
  caller's gate is far below: ``far_m2 = (2·gate)²``; such a pair is outside the gate either way and
  its distance is never used).

* :func:`gate_terms` — per pair k of track row g[k] (predicted position ẑ, covariance S) and
  detection db[k] (z, isotropic variance σ²_k): ``a = S₀₀ + σ²``, ``b = S₀₁``, ``d = S₁₁ + σ²``,
  ``det = a·d − b·b``, ``y = z − ẑ`` and ``d² = (d·y₀·y₀ − 2·b·y₀·y₁ + a·y₁·y₁) / det``; the
  cost ``d² + ln det`` is left to numpy's log (:func:`~mjasc.perception.tracking.association.pair_costs`).
* :func:`merge_candidates` — per vessel (a run of equal ``keys`` over the live tracks, sorted by
  vessel), every pair a = live[i], b = live[j], i < j, row-major, closer than the merge distance::

      hypot(p_a,x − p_b,x, p_a,y − p_b,y) < fraction · maximum(R_a, R_b)

  (numpy's ``maximum``: NaN if either radius is NaN).
* :func:`arc_midpoints` and :func:`position_jacobians` — the two halves of
  :func:`~mjasc.perception.tracking.association.predicted_positions` around numpy's cosine and
  sine: per track ``dt = maximum(t − t_last, 0)``, ``θ_mid = θ + (0.5·dt)·ω̂``, ``dV = dt·V``; then
  ``ẑ = (x + dV·c, y + dV·s)`` and the Jacobian rows ``[[1, 0, (−dV)·s, dt·c], [0, 1, dV·c, dt·s]]``.
* :func:`spread_courseless_into` — ``S = J P Jᵀ`` of a track with V = 0 has no course to map var(V)
  along: θ's column vanishes with dV and the V column is ``dt·(cos θ, sin θ)`` at an arbitrary θ, so
  var(V) lands on one axis only (a track of one measurement, whose start-up filter's velocity is still
  its zero prior, reports θ = 0: its gate was ±4.3·σ_V·dt along world x but only the detection's own
  noise along y, and a target crossing north–south lost its second detection). An unknown velocity's
  direction is any: ``S₁₁ += (dt·dt)·P_VV`` makes the gate round, its reach along y that along x.
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.compiled import kernel, maximum

__all__ = ["block_pairs_loop", "block_pairs_flat", "broadcast_distances", "gate_terms", "merge_candidates",
           "spread_courseless_into",
           "arc_midpoints", "position_jacobians", "position_jacobians_into", "gate_terms_into"]


@kernel
def block_pairs_loop(n_a, n_b):
    """(q, i, j, start) of :func:`mjasc.perception.tracking.association.block_pairs` for int64
    block sizes n_a (Q,), n_b (Q,)."""
    nq = n_a.size
    start = np.zeros(nq + 1, dtype=np.int64)
    for b in range(nq):
        start[b + 1] = start[b] + n_a[b] * n_b[b]
    total = start[nq]
    q = np.empty(total, dtype=np.int64)
    i = np.empty(total, dtype=np.int64)
    j = np.empty(total, dtype=np.int64)
    k = 0
    for b in range(nq):
        for ii in range(n_a[b]):
            for jj in range(n_b[b]):
                q[k] = b
                i[k] = ii
                j[k] = jj
                k += 1
    return q, i, j, start


@kernel
def block_pairs_flat(n_a, n_b):
    """:func:`block_pairs_loop` and each pair's flat positions: (q, i, j, start, ga, gb) with
    ga = (first a of block q) + i and gb = (first b of block q) + j (a and b grouped by block)."""
    q, i, j, start = block_pairs_loop(n_a, n_b)
    nq = n_a.size
    a0 = np.zeros(nq, dtype=np.int64)
    b0 = np.zeros(nq, dtype=np.int64)
    for b in range(1, nq):
        a0[b] = a0[b - 1] + n_a[b - 1]
        b0[b] = b0[b - 1] + n_b[b - 1]
    ga = np.empty(q.size, dtype=np.int64)
    gb = np.empty(q.size, dtype=np.int64)
    for k in range(q.size):
        ga[k] = a0[q[k]] + i[k]
        gb[k] = b0[q[k]] + j[k]
    return q, i, j, start, ga, gb


@kernel
def broadcast_distances(q, i, j, a_start, b_start, bsel, xa, vx, vy, t_s, t_b, p_b, far_m2):
    """(P,) distances [m] of the pairs (q, i, j) (module docstring): a vessel's confirmed tracks'
    states ``xa`` (A, 4) and velocities vx, vy (A,) [m/s], grouped by vessel from ``a_start``;
    broadcasts ``bsel`` (indices into t_b (B,) [s] and p_b (B, 2) [m]) from ``b_start``; t_s (Q,) [s];
    +inf beyond √far_m2 [m]."""
    out = np.empty(q.size)
    for k in range(q.size):
        qk = q[k]
        a = a_start[qk] + i[k]
        b = bsel[b_start[qk] + j[k]]
        dtb = t_s[qk] - t_b[b]
        dx = xa[a, 0] - vx[a] * dtb - p_b[b, 0]
        dy = xa[a, 1] - vy[a] * dtb - p_b[b, 1]
        if dx * dx + dy * dy > far_m2:
            out[k] = math.inf
        else:
            out[k] = math.hypot(dx, dy)
    return out


@kernel
def gate_terms(g, zhat, S, db, z, var):
    """(d² (P,), det (P,)) of the pairs (track row g[k], detection db[k]) (module docstring):
    ẑ (n, 2) [m], S (n, 2, 2) [m²] per track row; z (M, 2) [m] per detection; σ² var (P,) [m²] per pair."""
    p = g.size
    d2 = np.empty(p)
    det = np.empty(p)
    gate_terms_into(g, zhat, S, db, z, var, d2, det)
    return d2, det


@kernel
def gate_terms_into(g, zhat, S, db, z, var, d2, det):
    """:func:`gate_terms` (arguments g … var as there) written into the first P rows of d2 and det."""
    for k in range(g.size):
        r = g[k]
        m = db[k]
        a = S[r, 0, 0] + var[k]
        b = S[r, 0, 1]
        d = S[r, 1, 1] + var[k]
        dk = a * d - b * b
        y0 = z[m, 0] - zhat[r, 0]
        y1 = z[m, 1] - zhat[r, 1]
        d2[k] = (d * y0 * y0 - 2.0 * b * y0 * y1 + a * y1 * y1) / dk
        det[k] = dk


@kernel
def merge_candidates(live, keys, positions, radius, fraction):
    """(a (c,), b (c,)): the close pairs of the tracks ``live`` (indices into positions (k, 2) [m]
    and radius (k,) [m]) sorted by their vessel ``keys`` (module docstring), in row-major order
    within each vessel, vessels in order."""
    n = live.size
    total = 0
    f = 0
    while f < n:  # pairs i < j per run of equal keys
        e = f + 1
        while e < n and keys[e] == keys[f]:
            e += 1
        total += (e - f) * (e - f - 1) // 2
        f = e
    out_a = np.empty(total, dtype=np.int64)
    out_b = np.empty(total, dtype=np.int64)
    c = 0
    f = 0
    while f < n:
        e = f + 1
        while e < n and keys[e] == keys[f]:
            e += 1
        for i in range(f, e):
            a = live[i]
            for j in range(i + 1, e):
                b = live[j]
                dd = math.hypot(positions[a, 0] - positions[b, 0], positions[a, 1] - positions[b, 1])
                if dd < fraction * maximum(radius[a], radius[b]):
                    out_a[c] = a
                    out_b[c] = b
                    c += 1
        f = e
    return out_a[:c], out_b[:c]


@kernel
def arc_midpoints(x, t_last, w, t):
    """(dt, θ_mid, dV) (k,) of tracks with states x (k, 4) [x, y, θ, V], last times t_last (k,) [s]
    and turn rates w (k,) [rad/s] predicted to t (k,) [s] (module docstring)."""
    k = x.shape[0]
    dt = np.empty(k)
    th = np.empty(k)
    dv = np.empty(k)
    for a in range(k):
        d = maximum(t[a] - t_last[a], 0.0)
        dt[a] = d
        th[a] = x[a, 2] + (0.5 * d) * w[a]
        dv[a] = d * x[a, 3]
    return dt, th, dv


@kernel
def spread_courseless_into(x, dt, P, S):
    """Add ``(dt·dt)·P_VV`` to S₁₁ of the rows of S (k, 2, 2) whose state x (k, 4) has V = 0 (module
    docstring); dt (k,) [s] and P (k, 4, 4) those rows' prediction steps and covariances."""
    for a in range(S.shape[0]):
        if x[a, 3] == 0.0:
            S[a, 1, 1] += (dt[a] * dt[a]) * P[a, 3, 3]


@kernel
def position_jacobians(x, dt, dv, c, s):
    """(ẑ (k, 2) [m], J (k, 2, 4)) from states x (k, 4), dt, dV (k,) and c, s (k,) the cosine and
    sine of θ_mid (module docstring)."""
    k = x.shape[0]
    zhat = np.empty((k, 2))
    J = np.empty((k, 2, 4))
    position_jacobians_into(x, dt, dv, c, s, zhat, J)
    return zhat, J


@kernel
def position_jacobians_into(x, dt, dv, c, s, zhat, J):
    """:func:`position_jacobians` (arguments x … s as there, k rows) written into the first k rows of zhat
    and J (every entry of J's rows: its zeros too)."""
    for a in range(x.shape[0]):
        zhat[a, 0] = x[a, 0] + dv[a] * c[a]
        zhat[a, 1] = x[a, 1] + dv[a] * s[a]
        J[a, 0, 0] = 1.0
        J[a, 0, 1] = 0.0
        J[a, 1, 0] = 0.0
        J[a, 1, 1] = 1.0
        J[a, 0, 2] = -dv[a] * s[a]
        J[a, 0, 3] = dt[a] * c[a]
        J[a, 1, 2] = dv[a] * c[a]
        J[a, 1, 3] = dt[a] * s[a]
