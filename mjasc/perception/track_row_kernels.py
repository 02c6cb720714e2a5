"""The compiled part of a record tick of :class:`~mjasc.perception.track_rows.FleetTrackRows`: which
vessels stepped, the fleet's confirmed rows grouped by vessel, their positions copied into the
buffered rows and each stepped vessel's label key (ids, static flags) checked against its previous
row's — one call a record tick instead of a dozen numpy calls (each ~1–3 µs in a run, cold).

The grouping is :func:`~mjasc.perception.tracking.step_kernels.confirmed_by_owner`'s (bank order within
a vessel); the positions are the bank's ``x[row, 0:2]`` copied (no arithmetic: the same bits).
"""

from __future__ import annotations

import numpy as np

from mjasc.core.compiled import kernel

__all__ = ["track_rows_into"]


@kernel
def track_rows_into(confirmed, owner, local_id, static, x, ours, scans, logged_scans, never, entered, key_first,
                    key_ids, key_static, rows, first, xy, xy_at, tick_first, updated, has_row, changed):
    """One record tick's rows (:class:`~mjasc.perception.track_rows.FleetTrackRows`).

    Inputs, per track (n,): ``confirmed``, ``owner``, ``local_id``, ``static``; the bank's states
    ``x`` (n, ≥ 2) [m]; per vessel (no,): ``ours`` (written by the caller), ``scans`` (its tracker's
    steps), ``entered`` (its rows registered with the recorder since its last flush). State, per
    vessel: ``logged_scans`` (the steps at its previous row; set to ``scans`` for the vessels that
    stepped), ``never`` (no row yet; cleared for those), and the previous rows' label keys grouped
    by vessel: ``key_first`` (no + 1,), ``key_ids``, ``key_static`` (read only).

    Outputs: ``rows`` (≥ n,) the confirmed rows grouped by vessel (bank order within one),
    ``first`` (no + 1,) each vessel's first position in them, ``xy[xy_at:xy_at + k]`` their
    positions [m] and ``tick_first`` = ``first + xy_at``; per vessel ``updated`` (it stepped since
    its previous row), ``changed`` (updated and its ids or static flags differ from its previous
    row's, or it has none yet) and ``has_row`` (updated and changed or tracking something).

    Returns (k, rows written, any changed, aligned, any new): k the number of confirmed rows, −1
    when no vessel stepped (nothing else written then); ``aligned``: every vessel has as many
    confirmed rows as its previous row's key (``first`` = ``key_first``); any new: a vessel has a
    row and is not ``entered``."""
    no = scans.size
    any_up = False
    for o in range(no):
        up = ours[o] and scans[o] != logged_scans[o]
        updated[o] = up
        if up:
            any_up = True
            logged_scans[o] = scans[o]
    if not any_up:
        return -1, 0, False, False, False
    for o in range(no + 1):
        first[o] = 0
    n = confirmed.size
    for r in range(n):
        if confirmed[r]:
            first[owner[r] + 1] += 1
    for o in range(no):
        first[o + 1] += first[o]
    fill = np.empty(no, dtype=np.int64)
    for o in range(no):
        fill[o] = first[o]
    for r in range(n):
        if confirmed[r]:
            o = owner[r]
            rows[fill[o]] = r
            fill[o] += 1
    k = first[no]
    for j in range(k):
        xy[xy_at + j, 0] = x[rows[j], 0]
        xy[xy_at + j, 1] = x[rows[j], 1]
    n_rows = 0
    any_changed = False
    any_new = False
    aligned = first[no] == key_first[no]
    for o in range(no + 1):
        tick_first[o] = first[o] + xy_at
    for o in range(no):
        aligned = aligned and first[o] == key_first[o]
        ch = False
        row = False
        if updated[o]:
            a, b, la, lb = first[o], first[o + 1], key_first[o], key_first[o + 1]
            ch = never[o] or b - a != lb - la
            if not ch:
                for j in range(b - a):
                    r = rows[a + j]
                    if local_id[r] != key_ids[la + j] or static[r] != key_static[la + j]:
                        ch = True
                        break
            never[o] = False
            row = ch or b > a
        changed[o] = ch
        has_row[o] = row
        if row:
            n_rows += 1
            any_new = any_new or not entered[o]
        any_changed = any_changed or ch
    return k, n_rows, any_changed, aligned, any_new
