"""What a fleet tracker's reports hand on (:meth:`mjasc.perception.tracking.fleet.FleetTracker.report_rows`):
every vessel's confirmed tracks as :class:`~mjasc.core.estimates.TrackRows`, their columns gathered
in one compiled call with few arrays returned (the report read ~25 numpy calls and returned arrays
per step: the confirmed rows grouped by vessel, the bank's estimate fields, the columns' static
flags, radii and ids, each then made a list). :func:`report_columns` and :func:`report_estimates`
are bound as the tracker's ``_report_columns`` and ``_report_estimates``;
:func:`report_columns_numpy` is the readable form (any number of models).

:func:`report_fields` runs :func:`~mjasc.perception.tracking.step_kernels.confirmed_by_owner` and
:func:`~mjasc.perception.imm.row_fields.row_fields` (the bank's ``estimate_fields``) — the same code,
hence the same bits — and packs what the caller makes lists of into one array per type. The slow
flag is the reference's ``static | (V < static_speed)``. tests/test_tracking_report_fields.py keeps
the readable form (those calls and numpy's indexing) as the reference, bit for bit, on a real run.
"""

from __future__ import annotations

import numpy as np

from mjasc.core.compiled import kernel
from mjasc.core.estimates import TrackRows
from mjasc.perception.imm.row_fields import row_fields
from mjasc.perception.tracking.step_kernels import confirmed_by_owner

__all__ = ["report_fields", "report_fields_into", "report_columns", "report_columns_numpy", "report_estimates"]


def report_estimates(ft, cols: tuple) -> dict:
    """{owner: :class:`~mjasc.core.estimates.TrackRows` of its confirmed tracks} of the fleet tracker
    ``ft`` from the columns ``cols`` (:func:`report_columns`), the vessels without one left out. A
    slow track's outline is :meth:`~mjasc.perception.tracking.outlines.TrackOutlines.pending` (made
    now: it holds the row's hull now; the outline itself on first read)."""
    if len(cols) == 1:
        return {}
    spans, k_rows, ids, t, pos, th, v, w, radius, radius_l, P, static, team, slow, id_array, time_array = cols
    outlines = ft.outlines.pendings(k_rows, slow, pos, radius)  # (= ft.outline(k) on first read)
    fields = (ids, t, pos, th, v, w, radius_l, P, static, team, outlines)  # (every field's column but source)
    of_span = TrackRows.of_span
    return {o: of_span(fields, a, b, id_array, time_array) for o, (a, b) in spans.items()}


def report_columns(ft) -> tuple:
    """What the fleet tracker ``ft`` hands on, for every vessel's confirmed tracks, grouped by vessel
    (bank order within): ({owner: (first, end)}, rows, ids, times, positions (k, 2), courses,
    speeds, ω̂, radii (array and list), position covariances (k, 2, 2), static flags, team
    mates, slow flags, ids (k,) int64 and times (k,) [s] as new arrays) — per-track values as its
    ``_estimates_of`` makes them (one compiled gather, :func:`report_fields`)."""
    c, no = ft.cols, ft._max_range.size
    arrays = ft.bank.prediction_arrays()
    if arrays is None:  # (ω̂ not the compiled sum: r > 7 models)
        return report_columns_numpy(ft)
    n = c.n
    bufs = ft._report_bufs
    if bufs[2].size < 2 * n or bufs[0].size < 2 * n + no + 1:  # (room for every row: grown when too small)
        m = n + max(16, n // 2)
        bufs = ft._report_bufs = (np.empty(2 * m + no + 1, dtype=np.int64), np.empty(5 * m),
                                  np.empty(2 * m, dtype=bool))
    xs, P, k = report_fields_into(c.confirmed, c.owner, no, *arrays, c.static, c.radius, c.local_id, ft._static_speed,
                                  *bufs)
    if k == 0:
        return ({},)
    ints, floats, flags = bufs[0][:2 * k + no + 1], bufs[1][:5 * k].reshape(5, k), bufs[2][:2 * k].reshape(2, k)
    il = ints.tolist()
    f = il[2 * k:]
    spans = {o: (a, b) for o, (a, b) in enumerate(zip(f, f[1:])) if b > a}
    t, th, v, w, radius_l = floats.tolist()
    static, slow = flags.tolist()
    return (spans, il[:k], il[k:2 * k], t, xs[:, :2], th, v, w, floats[4], radius_l, P, static,
            c.team[ints[:k]].tolist(), slow, ints[k:2 * k].copy(), floats[0].copy())  # (team.members(rows))


def report_columns_numpy(ft) -> tuple:
    """:func:`report_columns` through the bank's ``estimate_fields`` (any number of models; the
    readable form of its compiled gather)."""
    rows, first = confirmed_by_owner(ft.cols.confirmed, ft.cols.owner, ft.n_owners)
    if rows.size == 0:
        return ({},)
    f = first.tolist()
    spans = {o: (a, b) for o, (a, b) in enumerate(zip(f, f[1:])) if b > a}
    t, pos, th, v, w, P = ft.bank.estimate_fields(rows)
    static = ft.cols.static[rows]
    slow = (static | (v < ft.config.static_speed_m_s)).tolist()
    radius = ft.cols.radius[rows]
    id_array = ft.cols.local_id[rows]
    return (spans, rows.tolist(), id_array.tolist(), t.tolist(), pos, th.tolist(), v.tolist(), w.tolist(),
            radius, radius.tolist(), P, static.tolist(), ft.team.members(rows), slow, id_array, t)


@kernel
def report_fields(confirmed, owner, n_owners, x, t, mu, omega, active, Pc, static, radius, local_id, static_speed):
    """The confirmed rows (``confirmed`` (n,)) grouped by vessel ``owner`` (n,), bank order within, and
    their report fields: (ints, floats, xs, P, flags) — ints (2k + n_owners + 1,) int64: the rows, their
    ids ``local_id[rows]`` and each vessel's first position in rows (n_owners + 1); floats (5, k): times
    [s], courses in (−π, π], speeds [m/s], ω̂ [rad/s] (row_fields' of the bank's x (n, 4), t, μ, ω,
    active, Pc (n, 4, 4) current) and radii ``radius[rows]`` [m]; xs (k, 4) the wrapped states; P (k, 2,
    2) the position covariances; flags (2, k): ``static[rows]`` and slow (static or V < static_speed)."""
    rows, first = confirmed_by_owner(confirmed, owner, n_owners)
    k = rows.size
    tt, xs, th, w, P = row_fields(rows, x, t, mu, omega, active, Pc, False)
    ints = np.empty(2 * k + n_owners + 1, dtype=np.int64)
    floats = np.empty((5, k))
    flags = np.empty((2, k), dtype=np.bool_)
    for a in range(k):
        r = rows[a]
        ints[a] = r
        ints[k + a] = local_id[r]
        floats[0, a] = tt[a]
        floats[1, a] = th[a]
        floats[2, a] = xs[a, 3]
        floats[3, a] = w[a]
        floats[4, a] = radius[r]
        s = static[r]
        flags[0, a] = s
        flags[1, a] = s or xs[a, 3] < static_speed
    for o in range(n_owners + 1):
        ints[2 * k + o] = first[o]
    return ints, floats, xs, P, flags


@kernel
def report_fields_into(confirmed, owner, n_owners, x, t, mu, omega, active, Pc, static, radius, local_id, static_speed,
                       ints, floats, flags):
    """:func:`report_fields` (arguments confirmed … static_speed as there) with its ints, floats and flags
    written into the first rows of the caller's buffers ints (≥ 2n + n_owners + 1), floats (≥ 5n, flat:
    (5, k) row-major) and flags (≥ 2n, flat: (2, k)), n = confirmed.size: (xs, P, k) — the arrays handed
    on (positions, covariances) still new ones; the others only read into lists."""
    i_, f_, xs, P, b_ = report_fields(confirmed, owner, n_owners, x, t, mu, omega, active, Pc, static, radius, local_id,
                                      static_speed)
    k = xs.shape[0]
    for a in range(i_.size):
        ints[a] = i_[a]
    for r in range(5):
        for a in range(k):
            floats[r * k + a] = f_[r, a]
    for r in range(2):
        for a in range(k):
            flags[r * k + a] = b_[r, a]
    return xs, P, k
