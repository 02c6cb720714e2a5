"""A fleet tracker's step (:mod:`mjasc.perception.tracking.fleet`) gathers what its stages read in
three compiled calls — before association, after the IMM cycle and for the births — instead of a
dozen numpy calls each on arrays of a few dozen numbers. No arithmetic (``tests/test_tracking_step_kernels.py``
keeps the numpy forms they replaced as references, bit for bit):

* :func:`step_rows` — a step's arrays before association: each vessel's time ``t_own`` (NaN for
  vessels that did not scan, ``t_own[owners] = t_o``), :func:`count_scans`, each row's vessel
  position ``row_pos = pos_of[owner]``, whether every row is due, the due rows (every row, or
  ``flatnonzero(row_pos >= 0)``) and their positions ``row_pos[rows]``, and the step's fresh
  ``claimed`` (M,) False, ``assigned`` (n,) −1 and ``var_row`` (n,) R.
* :func:`cycled_rows` — what the step reads of the cycled rows ``rows``, gathered in one pass:
  :func:`~mjasc.perception.tracking.step_kernels.count_used`; ``t_rows = t_o[row_pos[rows]]``, ``speeds = x[rows, 3]``, ``used[rows]``,
  ``assigned[rows]``, ``hit = used & meas`` (n,), and the rows of vessels with returns
  ``orows = rows[with_pts[row_pos[rows]]]`` with ``hit[orows]``, ``x[orows, 3]`` and ``x[orows, :2]``.
* :func:`step_inputs` — :func:`~mjasc.perception.tracking.step_kernels.select_detections` then
  :func:`step_rows` in one call, their fourteen arrays returned as four (one per type, the
  caller slicing each array's views out of them).
* :func:`births_of` — :func:`birth_rows` of the rows of the scanning vessels (``rows =
  flatnonzero(pos_of[owner] >= 0)``, ``rpos = pos_of[owner[rows]]``), the births counted
  (:func:`add_counts`) and their detections' indices ``idx[new]``; :func:`births_packed` returns its
  eight arrays as three.
"""

from __future__ import annotations

import numpy as np

from mjasc.core.compiled import kernel
from mjasc.perception.tracking.step_kernels import add_counts, birth_rows, count_scans, select_detections

__all__ = ["step_inputs_into", "step_rows", "step_inputs", "cycled_rows", "births_of", "births_packed"]


@kernel
def step_rows(owner, pos_of, every, owners, t_o, n_owners, counts, scans, dets, m_q, M, R):
    """(t_own (n_owners,), row_pos (n,), all_due, rows, rpos, claimed (M,), assigned (n,), var_row (n,)) of a
    step (module docstring), with ``counts[owners, scans] += 1`` and ``counts[owners, dets] += m_q``
    in place: owner (n,) each row's vessel, pos_of (n_owners,) each vessel's position among the
    scanning ``owners`` (p,) (−1: not scanning), ``every``: every vessel scanned; t_o (p,) [s]."""
    n = owner.size
    row_pos = np.empty(n, dtype=np.int64)
    due = 0
    for k in range(n):
        r = pos_of[owner[k]]
        row_pos[k] = r
        if r >= 0:
            due += 1
    all_due = every or due == n
    rows = np.empty(n if all_due else due, dtype=np.int64)
    rpos = np.empty(rows.size, dtype=np.int64)
    c = 0
    for k in range(n):
        if all_due or row_pos[k] >= 0:
            rows[c] = k
            rpos[c] = row_pos[k]
            c += 1
    t_own = np.empty(n_owners)
    t_own.fill(np.nan)
    for q in range(owners.size):
        t_own[owners[q]] = t_o[q]
    count_scans(counts, owners, scans, dets, m_q)
    claimed = np.zeros(M, dtype=np.bool_)
    assigned = np.empty(n, dtype=np.int64)
    assigned.fill(-1)
    var_row = np.empty(n)
    var_row.fill(R)
    return t_own, row_pos, all_due, rows, rpos, claimed, assigned, var_row


@kernel
def step_inputs(m_all, sel, centres, variances, radii, occluded, use_var, owner, pos_of, every, owners, t_o, n_owners,
                counts, scans, dets, R):
    """:func:`~mjasc.perception.tracking.step_kernels.select_detections` (m_all … occluded, use_var, R as
    there) and then :func:`step_rows` of its detections (owner … dets as there): (ints, z, floats, flags,
    all_due, k) — ints (2M + p + n + 2k + n,) int64: d_pos, idx (M,), m_q (p,), row_pos (n,), rows, rpos
    (k,), assigned (n,); z (M, 2); floats (2M + n_owners + n,): var, rad (M,), t_own (n_owners,), var_row
    (n,); flags (2M,) bool: occ, claimed (M,) (the same values as the two calls' arrays; the returning
    form of :func:`step_inputs_into`, into buffers of the largest sizes, sliced)."""
    S, p, n = sel.size, owners.size, owner.size
    ints = np.empty(2 * S + p + 4 * n, dtype=np.int64)
    z = np.empty((S, 2))
    floats = np.empty(2 * S + n_owners + n)
    flags = np.empty(2 * S, dtype=np.bool_)
    M, all_due, k = step_inputs_into(m_all, sel, centres, variances, radii, occluded, use_var, owner, pos_of, every,
                                     owners, t_o, n_owners, counts, scans, dets, R, ints, z, floats, flags)
    return (ints[:2 * M + p + 2 * n + 2 * k], z[:M], floats[:2 * M + n_owners + n], flags[:2 * M], all_due, k)


@kernel
def step_inputs_into(m_all, sel, centres, variances, radii, occluded, use_var, owner, pos_of, every, owners, t_o,
                     n_owners, counts, scans, dets, R, ints, z, floats, flags):
    """:func:`step_inputs` (arguments m_all … R as there) written straight into the first rows of the
    caller's buffers ints, z, floats, flags (at least 2·S + p + 4n, (S, 2), 2·S + n_owners + n and 2·S
    rows, S = sel.size; nothing returned but sizes — each array a kernel returns is a Python object made):
    (M, all_due, k), the arrays' first 2M + p + 2n + 2k, M, 2M + n_owners + n and 2M rows those of
    step_inputs."""
    d_pos, idx, z_, var, rad, occ, m_q = select_detections(m_all, sel, centres, variances, radii, occluded, use_var, R)
    M = z_.shape[0]
    t_own, row_pos, all_due, rows, rpos, claimed, assigned, var_row = step_rows(owner, pos_of, every, owners, t_o,
                                                                                n_owners, counts, scans, dets, m_q, M,
                                                                                R)
    p = m_q.size
    n = owner.size
    k = rows.size
    for a in range(M):
        ints[a] = d_pos[a]
        ints[M + a] = idx[a]
        z[a, 0] = z_[a, 0]
        z[a, 1] = z_[a, 1]
        floats[a] = var[a]
        floats[M + a] = rad[a]
        flags[a] = occ[a]
        flags[M + a] = claimed[a]
    c = 2 * M
    for a in range(p):
        ints[c + a] = m_q[a]
    c += p
    for a in range(n):
        ints[c + a] = row_pos[a]
    c += n
    for a in range(k):
        ints[c + a] = rows[a]
        ints[c + k + a] = rpos[a]
    c += 2 * k
    for a in range(n):
        ints[c + a] = assigned[a]
    for a in range(n_owners):
        floats[2 * M + a] = t_own[a]
    for a in range(n):
        floats[2 * M + n_owners + a] = var_row[a]
    return M, all_due, k


@kernel
def cycled_rows(rows, row_pos, t_o, used, meas, x, with_pts, counts, owners, col, assigned):
    """(t_rows, speeds, used_rows, assigned_rows (k,), hit (n,), orows, hit_o, speeds_o (g,), pos_o (g, 2))
    of the cycled ``rows`` (k,) (module docstring), with ``counts[owners[row_pos[r]], col] += 1`` for
    each used row r of them (:func:`count_used`). x (n, ≥ 4) the bank's states, used and meas (n,)
    bool, with_pts (p,) bool per vessel position, t_o (p,) [s], assigned (n,)."""
    k = rows.size
    n = used.size
    t_rows = np.empty(k)
    speeds = np.empty(k)
    u_rows = np.empty(k, dtype=np.bool_)
    a_rows = np.empty(k, dtype=assigned.dtype)
    hit = np.empty(n, dtype=np.bool_)
    for r in range(n):
        hit[r] = used[r] and meas[r]
    g = 0
    for a in range(k):
        r = rows[a]
        q = row_pos[r]
        t_rows[a] = t_o[q]
        speeds[a] = x[r, 3]
        u_rows[a] = used[r]
        a_rows[a] = assigned[r]
        if used[r]:
            counts[owners[q], col] += 1
        if with_pts[q]:
            g += 1
    orows = np.empty(g, dtype=rows.dtype)
    hit_o = np.empty(g, dtype=np.bool_)
    speeds_o = np.empty(g)
    pos_o = np.empty((g, 2))
    c = 0
    for a in range(k):
        r = rows[a]
        if with_pts[row_pos[r]]:
            orows[c] = r
            hit_o[c] = hit[r]
            speeds_o[c] = x[r, 3]
            pos_o[c, 0] = x[r, 0]
            pos_o[c, 1] = x[r, 1]
            c += 1
    return t_rows, speeds, u_rows, a_rows, hit, orows, hit_o, speeds_o, pos_o


@kernel
def births_of(claimed, owner, pos_of, d_pos, z, var, rad, x, radius, owners, t_o, next_local, idx, counts, col):
    """(bp, own, local, t_b, z_b, var_b, rad_b, dets) of the births (module docstring; :func:`birth_rows`
    with the rows of the scanning vessels: owner (n,) each row's vessel, pos_of (n_owners,) its
    position among ``owners`` or −1), ``counts[owners, col] += born`` in place and dets = idx[new]."""
    n = owner.size
    due = 0
    for k in range(n):
        if pos_of[owner[k]] >= 0:
            due += 1
    rows = np.empty(due, dtype=np.int64)
    rpos = np.empty(due, dtype=np.int64)
    c = 0
    for k in range(n):
        r = pos_of[owner[k]]
        if r >= 0:
            rows[c] = k
            rpos[c] = r
            c += 1
    new, bp, own, local, born, t_b, z_b, var_b, rad_b = birth_rows(claimed, rows, rpos, d_pos, z, var, rad, x, radius,
                                                                   owners, t_o, next_local)
    add_counts(counts, owners, col, born)
    dets = np.empty(new.size, dtype=idx.dtype)
    for a in range(new.size):
        dets[a] = idx[new[a]]
    return bp, own, local, t_b, z_b, var_b, rad_b, dets


@kernel
def births_packed(claimed, owner, pos_of, d_pos, z, var, rad, x, radius, owners, t_o, next_local, idx, counts, col):
    """:func:`births_of` (arguments as there) with its arrays packed by type: (ints (4, k): bp, own, local,
    dets; floats (3, k): t_b, var_b, rad_b; z_b (k, 2))."""
    bp, own, local, t_b, z_b, var_b, rad_b, dets = births_of(claimed, owner, pos_of, d_pos, z, var, rad, x, radius,
                                                             owners, t_o, next_local, idx, counts, col)
    k = bp.size
    ints = np.empty((4, k), dtype=np.int64)
    floats = np.empty((3, k))
    for a in range(k):
        ints[0, a] = bp[a]
        ints[1, a] = own[a]
        ints[2, a] = local[a]
        ints[3, a] = dets[a]
        floats[0, a] = t_b[a]
        floats[1, a] = var_b[a]
        floats[2, a] = rad_b[a]
    return ints, floats, z_b
