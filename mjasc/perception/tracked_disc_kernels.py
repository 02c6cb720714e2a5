"""Compiled loops behind the tracked discs (:mod:`mjasc.perception.tracked_discs`): the discs of a fleet's
tracks whose returns must not reach their vessel's map, at each vessel's scan time (world ENU,
metres, seconds, radians).

* :func:`disc_rows` — the tracker's rows that get a disc: confirmed, moving (or moved since they
  stopped), of a vessel that scanned (its scan time ``t_own[owner]`` not NaN).
* :func:`disc_courses` — one step of the combined estimate's arc, ``dt = max(t_s − t, 0)`` and
  the course at its middle ``θ + ½·dt·ω̂``; numpy then takes its cosine and sine.
* :func:`disc_geometry` — the centre ``p + dt·V·(cos, sin)`` and the radius ``R +
  min(DISC_MARGIN_M + 2√λ, DISC_MARGIN_MAX_M)``, λ the major eigenvalue of the position
  covariance, ``tr + √max(tr² − det, 0)`` with ``tr = ½(P₀₀ + P₁₁)``, ``det = P₀₀P₁₁ − P₀₁²``.
* :func:`disc_rows_at` and :func:`disc_table` — the same for one sensing pass, with each row's
  scan time and slot gathered and the discs ordered by slot.
* :func:`pass_discs` — all of it for one tracker in one call, from the IMM bank's own arrays
  (:meth:`~mjasc.perception.imm.bank_views.BankViews.prediction_arrays`, gathered by
  :func:`~mjasc.perception.imm.row_fields.row_fields` as ``estimate_fields`` does), with the
  courses' cosine and sine taken by ``math.cos`` / ``math.sin`` (numpy's float64 ``cos`` / ``sin``
  give the same bits here: docs/architecture.md, "Compiled kernels"; its test asserts it).

These are the expressions of the numpy form ``tracked_discs`` had (kept in
``tests/test_tracked_disc_kernels.py`` as the reference, with :func:`mjasc.perception.tracked_discs.disc_margin`),
in the same order; min and max propagate NaN as ``np.minimum`` / ``np.maximum`` do.
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.compiled import kernel, maximum, minimum
from mjasc.perception.imm.row_fields import row_fields

__all__ = ["disc_rows", "disc_courses", "disc_geometry", "disc_rows_at", "disc_table", "pass_discs"]


@kernel
def disc_rows(confirmed, static, moved, owner, t_own):
    """(k,) ascending rows r with ``confirmed[r] ∧ (¬static[r] ∨ moved[r])`` and
    ``t_own[owner[r]]`` not NaN."""
    n = owner.shape[0]
    out = np.empty(n, dtype=np.int64)
    k = 0
    for r in range(n):
        if confirmed[r] and (not static[r] or moved[r]) and not np.isnan(t_own[owner[r]]):
            out[k] = r
            k += 1
    return out[:k].copy()


@kernel
def disc_courses(t_s, t, th, w):
    """``dt = max(t_s − t, 0)`` [s] and ``θ + ½·dt·ω̂`` [rad], each (k,): the rows of one (2, k)
    array (``dt, mid = disc_courses(…)``; one array to unbox instead of two)."""
    k = t.shape[0]
    out = np.empty((2, k))
    dt, mid = out[0], out[1]
    for i in range(k):
        d = maximum(t_s[i] - t[i], 0.0)
        dt[i] = d
        mid[i] = th[i] + 0.5 * d * w[i]
    return out


@kernel
def disc_geometry(pos, dt, v, cos_th, sin_th, radius, P, margin_m, margin_max_m):
    """Centres (k, 2) [m] and radii (k,) [m] of the discs (module docstring): positions ``pos``
    (k, 2), steps ``dt`` (k,) at speeds ``v`` (k,) along the courses of cosine / sine ``cos_th``,
    ``sin_th``; track radii ``radius`` (k,), position covariances ``P`` (k, 2, 2)."""
    k = pos.shape[0]
    c = np.empty((k, 2))
    r = np.empty(k)
    for i in range(k):
        step = dt[i] * v[i]
        c[i, 0] = pos[i, 0] + step * cos_th[i]
        c[i, 1] = pos[i, 1] + step * sin_th[i]
        p00, p01, p11 = P[i, 0, 0], P[i, 0, 1], P[i, 1, 1]
        tr = 0.5 * (p00 + p11)
        lam = tr + math.sqrt(maximum(tr * tr - (p00 * p11 - p01 * p01), 0.0))
        r[i] = radius[i] + minimum(margin_m + 2.0 * math.sqrt(lam), margin_max_m)
    return c, r


@kernel
def disc_rows_at(confirmed, static, moved, owner, owner_slot, slot_time):
    """:func:`disc_rows` for the vessels of one sensing pass: the rows (k,) ascending whose owner
    scanned (``owner_slot[owner] ≥ 0``, its slot in the pass) and their slots (k,), the rows of
    one (2, k) array, and their scan times (k,) [s] (the slot's ``slot_time``):
    ``(rows, slots), t_s = disc_rows_at(…)`` (two arrays to unbox instead of three)."""
    n = owner.shape[0]
    rows = np.empty(n, dtype=np.int64)
    t_s = np.empty(n)
    slots = np.empty(n, dtype=np.int64)
    k = 0
    for r in range(n):
        q = owner_slot[owner[r]]
        if confirmed[r] and (not static[r] or moved[r]) and q >= 0:
            rows[k], t_s[k], slots[k] = r, slot_time[q], q
            k += 1
    ints = np.empty((2, k), dtype=np.int64)
    ints[0] = rows[:k]
    ints[1] = slots[:k]
    return ints, t_s[:k].copy()


@kernel
def disc_table(pos, dt, v, cos_th, sin_th, radius_all, rows, P, margin_m, margin_max_m, slots, n_slots):
    """:func:`disc_geometry` of the rows ``rows`` (their radii gathered from ``radius_all``), the
    discs ordered by slot (``slots`` (k,) < ``n_slots``; stable: within a slot in row order, as
    ``np.argsort(kind="stable")``): centres (k, 2), radii (k,), slots (k,)."""
    k = rows.shape[0]
    radius = np.empty(k)
    for i in range(k):
        radius[i] = radius_all[rows[i]]
    c, r = disc_geometry(pos, dt, v, cos_th, sin_th, radius, P, margin_m, margin_max_m)
    start = np.zeros(n_slots + 1, dtype=np.int64)
    for i in range(k):
        start[slots[i] + 1] += 1
    for q in range(n_slots):
        start[q + 1] += start[q]
    oc = np.empty((k, 2))
    orr = np.empty(k)
    ok = np.empty(k, dtype=np.int64)
    for i in range(k):
        j = start[slots[i]]
        start[slots[i]] += 1
        oc[j, 0], oc[j, 1], orr[j], ok[j] = c[i, 0], c[i, 1], r[i], slots[i]
    return oc, orr, ok


@kernel
def pass_discs(confirmed, static, moved, owner, owner_slot, slot_time, x, t, mu, omega, active, Pc, radius_all,
               margin_m, margin_max_m, n_slots):
    """The discs of one tracker's rows for a sensing pass (:func:`disc_rows_at`, the bank's
    ``estimate_fields`` of those rows — x (n, 4), t (n,), μ (n, r), ω (r,), start-up flags (n,) and
    combined covariances Pc (n, 4, 4) as :func:`~mjasc.perception.imm.row_fields.row_fields` takes
    them —, :func:`disc_courses`, the courses' ``math.cos`` / ``math.sin``, :func:`disc_table`):
    centres (k, 2) [m], radii (k,) [m] and slots (k,), ordered by slot."""
    ints, t_s = disc_rows_at(confirmed, static, moved, owner, owner_slot, slot_time)
    rows, slots = ints[0], ints[1]
    tt, xs, th, w, P = row_fields(rows, x, t, mu, omega, active, Pc, False)
    dt_mid = disc_courses(t_s, tt, th, w)
    dt, mid = dt_mid[0], dt_mid[1]
    k = rows.shape[0]
    cos_th = np.empty(k)
    sin_th = np.empty(k)
    v = np.empty(k)
    for i in range(k):
        cos_th[i] = math.cos(mid[i])
        sin_th[i] = math.sin(mid[i])
        v[i] = xs[i, 3]
    return disc_table(xs[:, :2], dt, v, cos_th, sin_th, radius_all, rows, P, margin_m, margin_max_m, slots, n_slots)
