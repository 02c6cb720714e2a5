"""Compiled bookkeeping of a fleet tracker's step (:mod:`mjasc.perception.tracking.fleet`): the
gathering, grouping and assignment around the arithmetic, each one call instead of a dozen numpy
calls on arrays of a few dozen numbers. No arithmetic is reordered: each loop evaluates the
expressions of the numpy form it replaced (``tests/test_tracking_step_kernels.py`` keeps those forms
as references, bit for bit):

* :func:`select_detections` — every vessel's selected detections stacked in vessel order: with the
  vessels' detections concatenated (``m_all`` (p,) per vessel) and ``sel`` the selection,
  ``gidx = flatnonzero(sel)``, ``d_pos = repeat(arange(p), m_all)[gidx]``,
  ``idx = gidx − starts(m_all)[d_pos]`` (the index in the vessel's own detections),
  ``z, var, rad, occ = centres[gidx], variances[gidx] (or R), radii[gidx], occluded[gidx]`` and
  ``m_q = bincount(d_pos, minlength=p)``.
* :func:`pair_setup` — the (track, detection) pairs of every vessel for association:
  ``n_q = bincount(rpos, minlength=p)``, ``grouped = rows[argsort(rpos, kind="stable")]``, the
  pairs of :func:`~mjasc.perception.tracking.pair_kernels.block_pairs_flat` (n_q, m_q),
  ``ta = grouped[gi]`` and each pair's detection variance inflated by the unseen part of the
  track's radius, ``var_p = var[db] + occ[db]·maximum(radius[ta] − rad[db], 0)²``.
* :func:`admissible_pairs` — the easy part of
  :func:`~mjasc.perception.tracking.association.gnn_assign_blocks`: the admissible pairs of the
  blocks where no track and no detection has two admissible partners (they are those blocks'
  assignment), and the other blocks.
* :func:`apply_assignment` — the assigned pairs ``got`` written back: ``hit = ta[got]``,
  ``assigned[hit] = db[got]``, ``var_row[hit] = var_p[got]``, ``claimed[db[inside]] = True``;
  returns hit and ``d2[got]``.
* :func:`birth_rows` — the detections that start tracks: those no track claimed and outside the
  disc of every track of their vessel, ``hypot(z_x − x_x, z_y − x_y) > R_track + r_det``
  (a NaN distance or radius: outside), in order; with their vessel position ``bp``, vessel ``own``, ids (the vessel's
  next ids in order), births per vessel ``born`` (the vessels' next ids advanced in place) and
  their ``t_o[bp]``, ``z``, ``var`` and ``rad``.
* :func:`confirmed_by_owner` — the confirmed rows grouped by vessel, bank order within
  (``rows = flatnonzero(confirmed)`` sorted stably by ``owner[rows]``), and each vessel's first
  position in them.
* :func:`add_counts` — a per-vessel counter column advanced, ``counts[owners, col] += values``
  (the scanning vessels are distinct); :func:`count_scans` — a scan and its detections counted,
  ``counts[owners, scans] += 1``, ``counts[owners, dets] += m_q``; :func:`count_used` — the rows used, per vessel,
  ``counts[owners, col] += bincount(row_pos[rows[used[rows]]], minlength=p)``.
* :func:`last_assignments` — each vessel's last assignment: the rows of ``rows`` that were
  ``hit``, ``got`` sorted stably by their vessel position ``row_pos[got]``, their ids
  ``local_id[got]`` and detections ``idx[assigned[got]]``, and each vessel's first position in them.
* :func:`measurement_rows` — the rows' measurements of the IMM cycle: ``meas = assigned >= 0``,
  ``zr`` NaN but ``zr[meas] = z[assigned[meas]]``.
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.compiled import kernel, maximum
from mjasc.perception.tracking.pair_kernels import block_pairs_flat

__all__ = ["measurement_rows_into", "select_detections", "pair_setup", "admissible_pairs", "apply_assignment", "birth_rows",
           "confirmed_by_owner", "add_counts", "count_scans", "count_used", "last_assignments",
           "measurement_rows"]


@kernel
def select_detections(m_all, sel, centres, variances, radii, occluded, use_var, R):
    """(d_pos, idx, z, var, rad, occ, m_q) of the selected detections (module docstring): m_all (p,)
    detections per vessel, sel (M_all,) bool, centres (M_all, 2) [m], variances (M_all,) [m²]
    (``use_var`` False: every selected one gets R), radii (M_all,) [m], occluded (M_all,) bool."""
    p = m_all.size
    n = 0
    for g in range(sel.size):
        n += sel[g]
    d_pos = np.empty(n, dtype=np.int64)
    idx = np.empty(n, dtype=np.int64)
    z = np.empty((n, 2))
    var = np.empty(n)
    rad = np.empty(n)
    occ = np.empty(n, dtype=np.bool_)
    m_q = np.zeros(p, dtype=np.int64)
    g = 0
    k = 0
    for q in range(p):
        for a in range(m_all[q]):
            if sel[g]:
                d_pos[k] = q
                idx[k] = a
                z[k, 0] = centres[g, 0]
                z[k, 1] = centres[g, 1]
                var[k] = variances[g] if use_var else R
                rad[k] = radii[g]
                occ[k] = occluded[g]
                m_q[q] += 1
                k += 1
            g += 1
    return d_pos, idx, z, var, rad, occ, m_q


@kernel
def pair_setup(rows, rpos, p, m_q, radius, var, rad, occ):
    """(n_q, grouped, q, i, j, start, gi, db, ta, var_p) for the due bank ``rows`` (k,) of vessels
    ``rpos`` (k,) (positions 0 … p−1), m_q (p,) detections per vessel; radius (n,) [m] per bank
    row; var, rad (M,) [m², m] and occ (M,) bool per detection (module docstring)."""
    k = rows.size
    n_q = np.zeros(p, dtype=np.int64)
    for a in range(k):
        n_q[rpos[a]] += 1
    first = np.zeros(p, dtype=np.int64)
    for b in range(1, p):
        first[b] = first[b - 1] + n_q[b - 1]
    grouped = np.empty(k, dtype=np.int64)  # stable counting sort by vessel
    for a in range(k):
        b = rpos[a]
        grouped[first[b]] = rows[a]
        first[b] += 1
    q, i, j, start, gi, db = block_pairs_flat(n_q, m_q)
    ta = np.empty(gi.size, dtype=np.int64)
    var_p = np.empty(gi.size)
    for c in range(gi.size):
        t = grouped[gi[c]]
        d = db[c]
        ta[c] = t
        e = maximum(radius[t] - rad[d], 0.0)
        var_p[c] = var[d] + (1.0 if occ[d] else 0.0) * (e * e)
    return n_q, grouped, q, i, j, start, gi, db, ta, var_p


@kernel
def admissible_pairs(inside, q, i, j, start, n_b):
    """(easy, hard): the admissible pairs (indices, ascending) of the blocks where no track (row
    key ``start[q] + i·n_b[q]``) and no detection (``start[q] + j``) has two admissible partners,
    and the other blocks (ascending), whose assignment problems are left to the caller."""
    total = start[start.size - 1]
    n_rows = np.zeros(total, dtype=np.int64)
    n_cols = np.zeros(total, dtype=np.int64)
    for c in range(inside.size):
        if inside[c]:
            b = q[c]
            n_rows[start[b] + i[c] * n_b[b]] += 1
            n_cols[start[b] + j[c]] += 1
    nq = start.size - 1
    hard = np.zeros(nq, dtype=np.bool_)
    n_in = 0
    for c in range(inside.size):
        if inside[c]:
            n_in += 1
            b = q[c]
            if n_rows[start[b] + i[c] * n_b[b]] > 1 or n_cols[start[b] + j[c]] > 1:
                hard[b] = True
    easy = np.empty(n_in, dtype=np.int64)
    m = 0
    for c in range(inside.size):
        if inside[c] and not hard[q[c]]:
            easy[m] = c
            m += 1
    return easy[:m], np.nonzero(hard)[0]


@kernel
def apply_assignment(got, inside, ta, db, var_p, d2, assigned, var_row, claimed):
    """Write the assigned pairs ``got`` in place (module docstring); returns (hit, d2[got])."""
    for c in range(inside.size):
        if inside[c]:
            claimed[db[c]] = True
    hit = np.empty(got.size, dtype=np.int64)
    d2g = np.empty(got.size)
    for a in range(got.size):
        c = got[a]
        t = ta[c]
        hit[a] = t
        assigned[t] = db[c]
        var_row[t] = var_p[c]
        d2g[a] = d2[c]
    return hit, d2g


@kernel
def birth_rows(claimed, rows, rpos, d_pos, z, var, rad, x, radius, owners, t_o, next_local):
    """(new, bp, own, local, born, t_b, z_b, var_b, rad_b) of the births (module docstring): claimed (M,)
    bool per detection, d_pos (M,) its vessel's position (sorted), z (M, 2) [m], var (M,) [m²],
    rad (M,) [m]; the vessels' bank ``rows`` (k,) with their positions ``rpos`` (k,); the bank's
    states x (n, ≥ 2) [m] and radii (n,) [m]; owners (p,) and times t_o (p,) [s] per vessel
    position; next_local (n_owners,) the vessels' next ids (advanced in place)."""
    M = claimed.size
    p = owners.size
    free = np.empty(M, dtype=np.bool_)
    for d in range(M):
        free[d] = not claimed[d]
    for a in range(rows.size):
        t = rows[a]
        q = rpos[a]
        for d in range(M):
            if free[d] and d_pos[d] == q:
                if math.hypot(z[d, 0] - x[t, 0], z[d, 1] - x[t, 1]) <= radius[t] + rad[d]:
                    free[d] = False
    k = 0
    for d in range(M):
        k += free[d]
    new = np.empty(k, dtype=np.int64)
    bp = np.empty(k, dtype=np.int64)
    own = np.empty(k, dtype=np.int64)
    local = np.empty(k, dtype=np.int64)
    born = np.zeros(p, dtype=np.int64)
    t_b = np.empty(k)
    z_b = np.empty((k, 2))
    var_b = np.empty(k)
    rad_b = np.empty(k)
    c = 0
    for d in range(M):
        if free[d]:
            q = d_pos[d]
            o = owners[q]
            new[c] = d
            bp[c] = q
            own[c] = o
            local[c] = next_local[o] + born[q]
            born[q] += 1
            t_b[c] = t_o[q]
            z_b[c, 0] = z[d, 0]
            z_b[c, 1] = z[d, 1]
            var_b[c] = var[d]
            rad_b[c] = rad[d]
            c += 1
    for q in range(p):
        next_local[owners[q]] += born[q]
    return new, bp, own, local, born, t_b, z_b, var_b, rad_b


@kernel
def confirmed_by_owner(confirmed, owner, n_owners):
    """(rows, first): the rows where ``confirmed`` (n,) grouped by their vessel ``owner`` (n,), bank
    order within a vessel, and first (n_owners + 1,) each vessel's first position in rows (module
    docstring)."""
    first = np.zeros(n_owners + 1, dtype=np.int64)
    for k in range(confirmed.size):
        if confirmed[k]:
            first[owner[k] + 1] += 1
    for o in range(n_owners):
        first[o + 1] += first[o]
    rows = np.empty(first[n_owners], dtype=np.int64)
    fill = first[:n_owners].copy()
    for k in range(confirmed.size):
        if confirmed[k]:
            o = owner[k]
            rows[fill[o]] = k
            fill[o] += 1
    return rows, first


@kernel
def add_counts(counts, owners, col, values):
    """``counts[owners, col] += values`` in place (owners (p,) distinct vessels, values (p,) int)."""
    for q in range(owners.size):
        counts[owners[q], col] += values[q]


@kernel
def count_scans(counts, owners, scans, dets, m_q):
    """``counts[owners, scans] += 1`` and ``counts[owners, dets] += m_q`` in place (owners (p,) distinct)."""
    for q in range(owners.size):
        counts[owners[q], scans] += 1
        counts[owners[q], dets] += m_q[q]


@kernel
def count_used(counts, owners, col, row_pos, rows, used):
    """``counts[owners, col] += bincount(row_pos[rows[used[rows]]], minlength=p)`` in place: per
    vessel position q (p,), the rows of ``rows`` it owns (``row_pos``) that were ``used``."""
    for a in range(rows.size):
        k = rows[a]
        if used[k]:
            counts[owners[row_pos[k]], col] += 1


@kernel
def measurement_rows(assigned, z):
    """(zr (n, 2), meas (n,)): ``meas = assigned >= 0``; zr NaN, but z[assigned[k]] where meas."""
    n = assigned.size
    zr = np.empty((n, 2))
    meas = np.empty(n, dtype=np.bool_)
    measurement_rows_into(assigned, z, zr, meas)
    return zr, meas


@kernel
def measurement_rows_into(assigned, z, zr, meas):
    """:func:`measurement_rows` written into the first n rows of the caller's buffers zr (≥ n, 2) and
    meas (≥ n,) (n = assigned.size; nothing returned)."""
    for k in range(assigned.size):
        d = assigned[k]
        m = d >= 0
        meas[k] = m
        if m:
            zr[k, 0] = z[d, 0]
            zr[k, 1] = z[d, 1]
        else:
            zr[k, 0] = np.nan
            zr[k, 1] = np.nan


@kernel
def last_assignments(rows, hit, row_pos, local_id, idx, assigned, p):
    """(ids (g,), det (g,), first (p + 1,)) of the rows of ``rows`` where ``hit`` (n,), grouped by
    their vessel position ``row_pos`` (p positions; in the order of ``rows`` within one): their
    ``local_id`` and detection ``idx[assigned]``, and each position's first entry."""
    first = np.zeros(p + 1, dtype=np.int64)
    for a in range(rows.size):
        k = rows[a]
        if hit[k]:
            first[row_pos[k] + 1] += 1
    for q in range(p):
        first[q + 1] += first[q]
    g = first[p]
    ids = np.empty(g, dtype=local_id.dtype)
    det = np.empty(g, dtype=idx.dtype)
    fill = first[:p].copy()
    for a in range(rows.size):
        k = rows[a]
        if hit[k]:
            q = row_pos[k]
            c = fill[q]
            ids[c] = local_id[k]
            det[c] = idx[assigned[k]]
            fill[q] = c + 1
    return ids, det, first
