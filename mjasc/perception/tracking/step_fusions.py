"""A fleet tracker's association (:mod:`mjasc.perception.tracking.fleet`, step 1) as four compiled
kernels around numpy's cosine, sine, products and logarithm (the tracker runs them, with those
compiled in numpy's bits between them, as one call:
:func:`~mjasc.perception.tracking.step_buffers.gated_assignment_into`), instead of seven kernels and a
dozen numpy calls: each fused kernel runs the existing kernels it replaces, in their order, inside one
compiled call (the same code, hence the same bits; fewer dispatches and fewer arrays boxed —
every array a kernel returns costs a Python object):

* :func:`predicted_pairs` — :func:`~mjasc.perception.tracking.step_kernels.pair_setup` of the due
  rows, the rows' prediction fields (:func:`~mjasc.perception.imm.row_fields.row_fields` of the
  grouped rows, as the bank's ``prediction_fields``), their vessels' scan times
  ``t_o[row_pos[grouped]]`` and :func:`~mjasc.perception.tracking.pair_kernels.arc_midpoints`;
  the pairs' six index arrays (q, i, j, gi, db, ta) as the rows of one (6, P) array;
* numpy's cos and sin of θ_mid, then :func:`~mjasc.perception.tracking.pair_kernels.position_jacobians`
  and numpy's ``J P Jᵀ`` (:func:`~mjasc.perception.tracking.association.predicted_positions`);
* :func:`pair_gates` — :func:`~mjasc.perception.tracking.pair_kernels.gate_terms` of the pairs;
* numpy's ``ln det``, then :func:`assign_pairs` — the cost ``d² + ln det``, ``inside = d² ≤ gate``,
  :func:`~mjasc.perception.tracking.step_kernels.admissible_pairs` and, when no vessel's block needs
  ``linear_sum_assignment`` (the usual tick), :func:`~mjasc.perception.tracking.step_kernels.apply_assignment`
  and the hit rows' scan times; otherwise the caller solves the hard blocks
  (:func:`~mjasc.perception.tracking.association.gnn_assign_blocks`) and applies the assignment.

After the IMM cycle, :func:`cycled_scan` is :func:`~mjasc.perception.tracking.step_gathers.cycled_rows`,
the management's record of the scan (:func:`~mjasc.perception.tracking.management.scan_rows`, the
tracks confirmed now), the radii of the rows with returns (read after the scan's update of them) and
:func:`~mjasc.perception.tracking.step_kernels.last_assignments` in one call instead of three and the
management's Python layer.

:func:`predicted_pairs_packed`, :func:`assign_pairs_packed` and :func:`cycled_scan_packed` are those
three with their arrays packed by type (six arrays instead of nine, four instead of six, four instead of nine: each array a kernel returns is a Python
object made), the caller slicing the views out.
:func:`cycled_scan_grown` (what the step calls after the cycle) is :func:`cycled_scan_packed` and the
outlines' :func:`~mjasc.perception.tracking.outlines.grow_plan` of the rows with returns in one call; the
association's four calls write into the tracker's buffers (:mod:`mjasc.perception.tracking.step_buffers`).
tests/test_tracking_step_fusions.py compares each with the calls it replaces, bit for bit, on a
real run's steps.
"""

from __future__ import annotations

import numpy as np

from mjasc.core.compiled import kernel
from mjasc.perception.imm.row_fields import row_fields
from mjasc.perception.tracking.management import scan_rows
from mjasc.perception.tracking.outlines import grow_plan
from mjasc.perception.tracking.pair_kernels import arc_midpoints, gate_terms
from mjasc.perception.tracking.step_gathers import cycled_rows
from mjasc.perception.tracking.step_kernels import admissible_pairs, apply_assignment, last_assignments, pair_setup

__all__ = ["predicted_pairs", "predicted_pairs_packed", "pair_gates", "assign_pairs", "assign_pairs_packed",
           "cycled_scan", "cycled_scan_packed", "cycled_scan_grown", "Q", "I", "J", "GI", "DB", "TA"]

#: Rows of the pairs' index table (6, P): block, track in block, detection in block, grouped row
#: position, detection, bank row.
Q, I, J, GI, DB, TA = range(6)


@kernel
def predicted_pairs(rows, rpos, p, m_q, radius, var, rad, occ, x, t, mu, omega, active, Pc, t_o, row_pos):
    """(n_q (p,), start (Q+1,), pairs (6, P), var_p (P,), xs (k, 4), P (k, 4, 4), dt, θ_mid, dV (k,)) —
    module docstring: :func:`pair_setup` (rows … occ as there), the bank's prediction fields of the
    grouped rows (x (n, 4), t (n,), μ (n, r), ω (r,), active (n,), Pc (n, 4, 4): the bank's arrays,
    covariances current) and their arcs to their vessels' times ``t_o[row_pos[grouped]]``."""
    n_q, grouped, q, i, j, start, gi, db, ta, var_p = pair_setup(rows, rpos, p, m_q, radius, var, rad, occ)
    npairs = gi.size
    pairs = np.empty((6, npairs), dtype=np.int64)
    for c in range(npairs):
        pairs[Q, c] = q[c]
        pairs[I, c] = i[c]
        pairs[J, c] = j[c]
        pairs[GI, c] = gi[c]
        pairs[DB, c] = db[c]
        pairs[TA, c] = ta[c]
    tt, xs, _, w, P = row_fields(grouped, x, t, mu, omega, active, Pc, True)
    k = grouped.size
    t_new = np.empty(k)
    for a in range(k):
        t_new[a] = t_o[row_pos[grouped[a]]]
    dt, th, dv = arc_midpoints(xs, tt, w, t_new)
    return n_q, start, pairs, var_p, xs, P, dt, th, dv


@kernel
def pair_gates(pairs, zhat, S, z, var_p):
    """:func:`gate_terms` of the pairs (grouped row position ``pairs[GI]``, detection ``pairs[DB]``):
    (d² (P,), det (P,))."""
    return gate_terms(pairs[GI], zhat, S, pairs[DB], z, var_p)


@kernel
def assign_pairs(d2, log_det, gate, pairs, start, n_b, var_p, assigned, var_row, claimed, t_o, row_pos):
    """(inside (P,), cost (P,), hard, hit, d2_hit, t_hit): ``cost = d2 + log_det`` (numpy's ln det),
    ``inside = d2 ≤ gate``, :func:`admissible_pairs` (n_b (p,) detections per vessel); when no block
    is hard, :func:`apply_assignment` of the admissible pairs (assigned, var_row (n,) and claimed
    (M,) written in place) with its hit rows, their d² and their vessels' times ``t_o[row_pos[hit]]``;
    else (hard non-empty) nothing written and hit, d2_hit, t_hit empty."""
    npairs = d2.size
    cost = np.empty(npairs)
    inside = np.empty(npairs, dtype=np.bool_)
    for c in range(npairs):
        cost[c] = d2[c] + log_det[c]
        inside[c] = d2[c] <= gate
    easy, hard = admissible_pairs(inside, pairs[Q], pairs[I], pairs[J], start, n_b)
    if hard.size:
        return inside, cost, hard, easy[:0], cost[:0], cost[:0]
    hit, d2g = apply_assignment(easy, inside, pairs[TA], pairs[DB], var_p, d2, assigned, var_row, claimed)
    t_hit = np.empty(hit.size)
    for a in range(hit.size):
        t_hit[a] = t_o[row_pos[hit[a]]]
    return inside, cost, hard, hit, d2g, t_hit


@kernel
def cycled_scan(rows, row_pos, t_o, used, meas, x, with_pts, counts, owners, col, assigned, rad, occ, hist, scans,
                n_upd, last, radius, confirmed, static, born, popcount, window_mask, grow_gain, shrink_gain,
                confirm_hits, min_age, static_speed, local_id, idx, p):
    """After the IMM cycle of ``rows`` (module docstring): :func:`cycled_rows` (rows … assigned as
    there; counts in place), :func:`scan_rows` of the rows with their times, used flags, detections
    and speeds (rad, occ per detection; hist … static_speed: the management's columns, written in
    place, and constants), the radii ``radius[orows]`` after it and :func:`last_assignments` (local_id,
    idx, p as there). Returns (new_conf (k,), the number confirmed now, orows, hit_o, speeds_o, pos_o,
    radius_o (g,), ids, det, first)."""
    t_rows, speeds, u_rows, a_rows, hit, orows, hit_o, speeds_o, pos_o = cycled_rows(
        rows, row_pos, t_o, used, meas, x, with_pts, counts, owners, col, assigned)
    new_conf = np.empty(rows.size, dtype=np.bool_)
    scan_rows(rows, t_rows, u_rows, a_rows, rad, occ, speeds, hist, scans, n_upd, last, radius, confirmed, static, born,
              popcount, window_mask, grow_gain, shrink_gain, confirm_hits, min_age, static_speed, new_conf)
    n_conf = 0
    for a in range(rows.size):
        n_conf += new_conf[a]
    radius_o = np.empty(orows.size)
    for a in range(orows.size):
        radius_o[a] = radius[orows[a]]
    ids, det, first = last_assignments(rows, hit, row_pos, local_id, idx, assigned, p)
    return new_conf, n_conf, orows, hit_o, speeds_o, pos_o, radius_o, ids, det, first


@kernel
def predicted_pairs_packed(rows, rpos, p, m_q, radius, var, rad, occ, x, t, mu, omega, active, Pc, t_o, row_pos):
    """:func:`predicted_pairs` (arguments as there) packed: (blocks (2p + 1,): n_q (p,) then start
    (p + 1,); pairs (6, P); var_p (P,); xs (k, 4); P (k, 4, 4); arcs (3, k): dt, θ_mid, dV)."""
    n_q, start, pairs, var_p, xs, P, dt, th, dv = predicted_pairs(rows, rpos, p, m_q, radius, var, rad, occ, x, t, mu,
                                                                  omega, active, Pc, t_o, row_pos)
    blocks = np.empty(n_q.size + start.size, dtype=np.int64)
    for a in range(n_q.size):
        blocks[a] = n_q[a]
    for a in range(start.size):
        blocks[n_q.size + a] = start[a]
    k = dt.size
    arcs = np.empty((3, k))
    for a in range(k):
        arcs[0, a] = dt[a]
        arcs[1, a] = th[a]
        arcs[2, a] = dv[a]
    return blocks, pairs, var_p, xs, P, arcs


@kernel
def cycled_scan_packed(rows, row_pos, t_o, used, meas, x, with_pts, counts, owners, col, assigned, rad, occ, hist,
                       scans, n_upd, last, radius, confirmed, static, born, popcount, window_mask, grow_gain,
                       shrink_gain, confirm_hits, min_age, static_speed, local_id, idx, p):
    """:func:`cycled_scan` (arguments as there) packed: (ints, floats (2, g): speeds_o, radius_o, flags,
    pos_o (g, 2), n_conf, g, m) — ints (g + 2m + p + 1,): orows (g,), ids, det (m,), first (p + 1,);
    flags (k + g,): new_conf (k,), hit_o (g,)."""
    new_conf, n_conf, orows, hit_o, speeds_o, pos_o, radius_o, ids, det, first = cycled_scan(
        rows, row_pos, t_o, used, meas, x, with_pts, counts, owners, col, assigned, rad, occ, hist, scans, n_upd, last,
        radius, confirmed, static, born, popcount, window_mask, grow_gain, shrink_gain, confirm_hits, min_age,
        static_speed, local_id, idx, p)
    g = orows.size
    m = ids.size
    k = new_conf.size
    ints = np.empty(g + 2 * m + first.size, dtype=np.int64)
    floats = np.empty((2, g))
    flags = np.empty(k + g, dtype=np.bool_)
    for a in range(k):
        flags[a] = new_conf[a]
    for a in range(g):
        ints[a] = orows[a]
        floats[0, a] = speeds_o[a]
        floats[1, a] = radius_o[a]
        flags[k + a] = hit_o[a]
    for a in range(m):
        ints[g + a] = ids[a]
        ints[g + m + a] = det[a]
    for a in range(first.size):
        ints[g + 2 * m + a] = first[a]
    return ints, floats, flags, pos_o, n_conf, g, m


@kernel
def assign_pairs_packed(d2, log_det, gate, pairs, start, n_b, var_p, assigned, var_row, claimed, t_o, row_pos):
    """:func:`assign_pairs` (arguments as there) packed: (inside, cost, rows (h + m,): hard (h,) then
    hit (m,), hit_values (2, m): d2_hit, t_hit, h)."""
    inside, cost, hard, hit, d2g, t_hit = assign_pairs(d2, log_det, gate, pairs, start, n_b, var_p, assigned, var_row,
                                                       claimed, t_o, row_pos)
    h, m = hard.size, hit.size
    rows = np.empty(h + m, dtype=np.int64)
    vals = np.empty((2, m))
    for a in range(h):
        rows[a] = hard[a]
    for a in range(m):
        rows[h + a] = hit[a]
        vals[0, a] = d2g[a]
        vals[1, a] = t_hit[a]
    return inside, cost, rows, vals, h


@kernel
def cycled_scan_grown(rows, row_pos, t_o, used, meas, x, with_pts, counts, owners, col, assigned, rad, occ, hist,
                      scans, n_upd, last, radius, confirmed, static, born, popcount, window_mask, grow_gain,
                      shrink_gain, confirm_hits, min_age, static_speed, local_id, idx, p, hull_anchor, reset_m, fast,
                      slow):
    """:func:`cycled_scan` (arguments rows … p as there) and the outlines' :func:`grow_plan` of the rows with
    returns (orows, their hit flags, speeds, positions and radii: what
    :meth:`~mjasc.perception.tracking.outlines.TrackOutlines.grow` hands it; ``hull_anchor`` (n, 2) written
    in place; reset_m, fast, slow its constants) in one call: (ints, new_conf (k,), geo (g2, 3), n_conf, g,
    m, r, g2) — ints (g + 2m + p + 1 + r + 2·g2,): orows (g,), ids, det (m,), first (p + 1,), then
    grow_plan's ints (r + 2·g2,); geo grow_plan's."""
    new_conf, n_conf, orows, hit_o, speeds_o, pos_o, radius_o, ids, det, first = cycled_scan(
        rows, row_pos, t_o, used, meas, x, with_pts, counts, owners, col, assigned, rad, occ, hist, scans, n_upd, last,
        radius, confirmed, static, born, popcount, window_mask, grow_gain, shrink_gain, confirm_hits, min_age,
        static_speed, local_id, idx, p)
    g = orows.size
    m = ids.size
    gi, geo, r, g2 = grow_plan(orows, speeds_o, pos_o, hull_anchor, reset_m, fast, slow, hit_o, radius_o)
    c = g + 2 * m + first.size
    ints = np.empty(c + gi.size, dtype=np.int64)
    for a in range(g):
        ints[a] = orows[a]
    for a in range(m):
        ints[g + a] = ids[a]
        ints[g + m + a] = det[a]
    for a in range(first.size):
        ints[g + 2 * m + a] = first[a]
    for a in range(gi.size):
        ints[c + a] = gi[a]
    return ints, new_conf, geo, n_conf, g, m, r, g2
