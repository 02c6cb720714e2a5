"""A fleet tracker's association (:mod:`mjasc.perception.tracking.fleet`, step 1) written into buffers the
tracker keeps: the fused kernels of :mod:`mjasc.perception.tracking.step_fusions` —
:func:`~mjasc.perception.tracking.step_fusions.predicted_pairs_packed`,
:func:`~mjasc.perception.tracking.pair_kernels.position_jacobians`,
:func:`~mjasc.perception.tracking.step_fusions.pair_gates` and
:func:`~mjasc.perception.tracking.step_fusions.assign_pairs_packed` — with their values written into the
first rows of :class:`AssociationBuffers` (from the unpacked kernels' arrays, or straight from the loops:
the ``*_into`` forms of ``position_jacobians`` and ``gate_terms``), nothing returned but sizes: each array a
kernel returns is a Python object made (~1.5 µs each, fourteen per step); the buffers' views are
C-contiguous as the returned arrays were. The views are the step's arrays, valid until the next
step (nothing keeps them). tests/test_tracking_step_buffers.py compares each with the returning form,
bit for bit, on real runs.

:func:`gated_assignment_into` is the whole association in one call: the four kernels with numpy's
cosine, sine, ``J P Jᵀ`` and logarithm compiled between them, giving numpy's bits — ``math.cos``,
``math.sin`` and ``math.log`` are glibc's, as numpy's are on this machine class with mjasc's
portable-math pin, and each 2×4·4×4·4×2 product is summed as OpenBLAS's per-matrix dgemm sums it
(over k in order from +0 by fused multiply-adds: :func:`~mjasc.core.small_products.sandwich_into`). The tests check
every value it writes against the numpy form, bit for bit, on real runs and random stacks.
:func:`gated_manoeuvres_into` is that call and, when no vessel's block needs ``linear_sum_assignment``, the
manoeuvre detection of the hit rows (:func:`~mjasc.perception.tracking.manoeuvre.manoeuvre_noise`), the
tracker's next call, in one (tests/test_tracking_manoeuvre_noise.py: against the two calls, on a real run).
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.compiled import kernel
from mjasc.core.small_products import sandwich_into
from mjasc.perception.tracking.manoeuvre import manoeuvre_noise
from mjasc.perception.tracking.pair_kernels import gate_terms_into, position_jacobians_into, spread_courseless_into
from mjasc.perception.tracking.step_fusions import DB, GI, assign_pairs, predicted_pairs

__all__ = ["AssociationBuffers", "predicted_pairs_into", "position_jacobians_into", "pair_gates_into",
           "assign_pairs_into", "gated_assignment_into", "gated_manoeuvres_into"]


class AssociationBuffers:
    """Room for ``n_pairs`` (track, detection) pairs, ``n_rows`` grouped rows and ``p`` scanning vessels:
    flat buffers whose first rows the kernels of this module write (:meth:`fit` grows them)."""

    def __init__(self, n_pairs: int = 0, n_rows: int = 0, p: int = 0):
        P, k = n_pairs, n_rows
        self.n_pairs, self.n_rows, self.p = P, k, p
        self.blocks = np.empty(2 * p + 1, dtype=np.int64)
        self.pairs = np.empty(6 * P, dtype=np.int64)  # (6, P) row-major: pairs[:6·P].reshape(6, P)
        self.var_p, self.d2, self.det, self.cost = np.empty(P), np.empty(P), np.empty(P), np.empty(P)
        self.log_det = np.empty(P)
        self.inside = np.empty(P, dtype=bool)
        self.xs, self.P, self.arcs = np.empty((k, 4)), np.empty((k, 4, 4)), np.empty(3 * k)
        self.zhat, self.J, self.S = np.empty((k, 2)), np.empty((k, 2, 4)), np.empty((k, 2, 2))
        self.cs = np.empty(2 * k)  # (cos θ_mid then sin θ_mid)
        self.rows, self.vals = np.empty(p + k, dtype=np.int64), np.empty(2 * k)
        # the buffers gated_assignment_into writes, in its argument order (blocks … vals)
        self.association = (self.blocks, self.pairs, self.var_p, self.xs, self.P, self.arcs, self.cs, self.zhat,
                            self.J, self.S, self.d2, self.det, self.log_det, self.inside, self.cost, self.rows,
                            self.vals)

    def fits(self, n_pairs: int, n_rows: int, p: int) -> bool:
        return n_pairs <= self.n_pairs and n_rows <= self.n_rows and p <= self.p


def grown(bufs: AssociationBuffers | None, n_pairs: int, n_rows: int, p: int) -> AssociationBuffers:
    """``bufs`` if it has room for these sizes, else buffers with room for half as much again."""
    if bufs is not None and bufs.fits(n_pairs, n_rows, p):
        return bufs
    more = lambda m: m + max(16, m // 2)
    if bufs is not None:
        n_pairs, n_rows, p = max(n_pairs, bufs.n_pairs), max(n_rows, bufs.n_rows), max(p, bufs.p)
    return AssociationBuffers(more(n_pairs), more(n_rows), p)


@kernel
def predicted_pairs_into(rows, rpos, p, m_q, radius, var, rad, occ, x, t, mu, omega, active, Pc, t_o, row_pos,
                         blocks, pairs, var_p, xs, P, arcs):
    """:func:`~mjasc.perception.tracking.step_fusions.predicted_pairs_packed` (arguments rows … row_pos as
    there) written into the buffers blocks, pairs (6·cap, flat), var_p, xs, P, arcs (3·k, flat) when they
    have room, from :func:`~mjasc.perception.tracking.step_fusions.predicted_pairs`' arrays: (number of
    pairs, number of grouped rows k, written) — nothing written when the buffers are too small (sizes
    returned)."""
    n_q, start, pr, vp, xs_, P_, dt, th, dv = predicted_pairs(rows, rpos, p, m_q, radius, var, rad, occ, x, t, mu,
                                                              omega, active, Pc, t_o, row_pos)
    npairs = vp.size
    k = xs_.shape[0]
    if npairs > var_p.size or k > xs.shape[0] or n_q.size + start.size > blocks.size:
        return npairs, k, False
    for a in range(n_q.size):
        blocks[a] = n_q[a]
    for a in range(start.size):
        blocks[n_q.size + a] = start[a]
    for r in range(6):
        for c in range(npairs):
            pairs[r * npairs + c] = pr[r, c]
    for c in range(npairs):
        var_p[c] = vp[c]
    for a in range(k):
        for b in range(4):
            xs[a, b] = xs_[a, b]
            for d in range(4):
                P[a, b, d] = P_[a, b, d]
    for a in range(k):
        arcs[a] = dt[a]
        arcs[k + a] = th[a]
        arcs[2 * k + a] = dv[a]
    return npairs, k, True


@kernel
def pair_gates_into(pairs, zhat, S, z, var_p, d2, det):
    """:func:`~mjasc.perception.tracking.step_fusions.pair_gates` (arguments pairs … var_p as there) written
    into the first P rows of d2 and det (:func:`~mjasc.perception.tracking.pair_kernels.gate_terms_into`)."""
    gate_terms_into(pairs[GI], zhat, S, pairs[DB], z, var_p, d2, det)


@kernel
def assign_pairs_into(d2, log_det, gate, pairs, start, n_b, var_p, assigned, var_row, claimed, t_o, row_pos, inside,
                      cost, rows, vals):
    """:func:`~mjasc.perception.tracking.step_fusions.assign_pairs_packed` (arguments d2 … row_pos as there;
    assigned, var_row, claimed written in place as there) with its arrays written into the first rows of
    inside, cost (P), rows (h + m) and vals (2·m, flat: d2_hit then t_hit), from
    :func:`~mjasc.perception.tracking.step_fusions.assign_pairs`' arrays: (h, m)."""
    ins, cst, hard, hit, d2g, t_hit = assign_pairs(d2, log_det, gate, pairs, start, n_b, var_p, assigned, var_row,
                                                   claimed, t_o, row_pos)
    for c in range(ins.size):
        inside[c] = ins[c]
        cost[c] = cst[c]
    h, m = hard.size, hit.size
    for a in range(h):
        rows[a] = hard[a]
    for a in range(m):
        rows[h + a] = hit[a]
        vals[a] = d2g[a]
        vals[m + a] = t_hit[a]
    return h, m


@kernel
def gated_assignment_into(rows, rpos, p, m_q, radius, var, rad, occ, x, t, mu, omega, active, Pc, t_o, row_pos, z,
                          gate, assigned, var_row, claimed, blocks, pairs, var_p, xs, P, arcs, cs, zhat, J, S, d2, det,
                          log_det, inside, cost, out_rows, vals):
    """The association in one call (module docstring): :func:`predicted_pairs_into` (rows … row_pos and
    blocks … arcs as there), then, when it wrote and found pairs, :func:`position_jacobians_into` of
    cos θ_mid, sin θ_mid (into cs (2k,)), :func:`~mjasc.core.small_products.sandwich_into` (J P Jᵀ into S, then
    :func:`~mjasc.perception.tracking.pair_kernels.spread_courseless_into`), :func:`pair_gates_into` (z (M, 2)
    the detections; into d2, det), ln det (into log_det) and :func:`assign_pairs_into` (gate … claimed
    and inside … vals (out_rows its rows) as there). Returns (number of pairs, grouped rows k, written,
    h, m) — h = m = 0 when nothing was written or there are no pairs."""
    npairs, k, ok = predicted_pairs_into(rows, rpos, p, m_q, radius, var, rad, occ, x, t, mu, omega, active, Pc,
                                         t_o, row_pos, blocks, pairs, var_p, xs, P, arcs)
    if not ok or npairs == 0:
        return npairs, k, ok, 0, 0
    for a in range(k):
        th = arcs[k + a]
        cs[a] = math.cos(th)
        cs[k + a] = math.sin(th)
    position_jacobians_into(xs[:k], arcs[:k], arcs[2 * k:3 * k], cs[:k], cs[k:2 * k], zhat, J)
    sandwich_into(J, P, k, S)
    spread_courseless_into(xs[:k], arcs[:k], P[:k], S[:k])
    pr = pairs[:6 * npairs].reshape((6, npairs))
    pair_gates_into(pr, zhat[:k], S[:k], z, var_p[:npairs], d2, det)
    for c in range(npairs):
        log_det[c] = math.log(det[c])
    h, m = assign_pairs_into(d2[:npairs], log_det[:npairs], gate, pr, blocks[p:2 * p + 1], m_q, var_p[:npairs],
                             assigned, var_row, claimed, t_o, row_pos, inside, cost, out_rows, vals)
    return npairs, k, ok, h, m


@kernel
def gated_manoeuvres_into(rows, rpos, p, m_q, radius, var, rad, occ, x, t, mu, omega, active, Pc, t_o, row_pos, z,
                          gate, assigned, var_row, claimed, blocks, pairs, var_p, xs, P, arcs, cs, zhat, J, S, d2, det,
                          log_det, inside, cost, out_rows, vals, detect, a, start, end, nis, man, P_bank, q_heading,
                          q_speed, warm):
    """:func:`gated_assignment_into` (arguments rows … vals as there) and then, when ``detect``, it wrote pairs
    and no block is hard (h = 0), :func:`~mjasc.perception.tracking.manoeuvre.manoeuvre_noise` of its m hit
    rows ``out_rows[:m]``, their d² ``vals[:m]`` and times ``vals[m:2m]`` [s] (the association's gate; a … man,
    q_heading, q_speed: the detector's; t, active: the bank's, as above; P_bank the bank's model covariances,
    changed in place; warm (≥ m,) written). Returns (number of pairs, grouped rows k, written, h, m, the number
    of rows noise was added to, the number in start-up) — −1 rows when the detection was not made here."""
    npairs, k, ok, h, m = gated_assignment_into(rows, rpos, p, m_q, radius, var, rad, occ, x, t, mu, omega, active,
                                                Pc, t_o, row_pos, z, gate, assigned, var_row, claimed, blocks, pairs,
                                                var_p, xs, P, arcs, cs, zhat, J, S, d2, det, log_det, inside, cost,
                                                out_rows, vals)
    if not detect or not ok or npairs == 0 or h > 0:
        return npairs, k, ok, h, m, -1, 0
    n_full, n_warm = manoeuvre_noise(out_rows[:m], vals[:m], gate, a, start, end, nis, man, vals[m:2 * m], t, P_bank,
                                     active, q_heading, q_speed, warm)
    return npairs, k, ok, h, m, n_full, n_warm
