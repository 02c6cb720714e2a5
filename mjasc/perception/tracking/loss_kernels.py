"""The compiled passes that decide which tracks go after a scan (track management's losses and
merges, :mod:`mjasc.perception.tracking.management`): one pass over the rows for the losses, then the
duplicates among the tracks kept.

* :func:`loss_rows` — a tentative track that can no longer reach M of N; a confirmed track not seen
  for ``max_coast_s`` (code 1), whose 1-σ position uncertainty is too large (code 2), or beyond its
  sensor's range + margin (code 3);
* :func:`drop_rows` — the losses, then the merges of close tracks of one vessel (:func:`drop_rows_into`:
  its per-row arrays written into the caller's);
* :func:`every_drop_rows`, :func:`every_drop_rows_into`, :func:`every_drops_into` — the same for
  every row of a fleet's tracker with each row's values gathered from its vessel's, returned as
  arrays, or packed into the caller's buffers (a fleet tracker's step);
* :func:`lost_reason` — the sentence for a loss code, as the tracks' events report it.

Each has its numpy form in tests/test_tracking_fleet_store.py.
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.compiled import kernel, maximum
from mjasc.perception.tracking.pair_kernels import merge_candidates

__all__ = ["lost_reason", "loss_rows", "drop_rows", "drop_rows_into", "every_drop_rows", "every_drop_rows_into",
           "every_drops_into"]


def lost_reason(code: int, lam: float, since: float, rng: float) -> str:
    """Why a confirmed track is lost, from :func:`loss_rows`' code (1, 2 or 3) and values: the time
    since its last update [s], its position variance's largest eigenvalue [m²], its distance from
    its sensor [m]."""
    return (f"not seen for {since:.1f} s" if code == 1 else
            f"position uncertainty {math.sqrt(lam):.1f} m" if code == 2 else
            f"out of range ({rng:.0f} m)")


@kernel
def loss_rows(idx, t, hist, scans, confirmed, last, popcount, Pc, pos, org, max_range, window, hits, max_coast,
              max_var, margin, drop, code, lam, since, rng):
    """The losses of :meth:`~mjasc.perception.tracking.management.TrackManagement.drops` per row
    k = idx[j] at t[j], in the order of its numpy form: a tentative track that can no longer reach M of N; a confirmed one not seen for
    ``max_coast`` (code 1), then one whose position variance's largest eigenvalue lam[j] exceeds
    ``max_var`` (code 2); then a track beyond its range + margin from its sensor, rng[j] (code 3;
    NaN: no test) with rng[j] = ``hypot(pos − org)`` of the row's position pos[j] and its sensor's
    origin org[j] [m] (NaN: no origin). Writes drop[j], code[j] (0: none or tentative), lam[j],
    since[j] and rng[j]."""
    for j in range(idx.size):
        k = idx[j]
        conf = confirmed[k]
        d = not conf and min(scans[k], window) - popcount[hist[k]] > window - hits
        a, b, c = Pc[j, 0, 0], Pc[j, 1, 1], Pc[j, 0, 1]
        tr = 0.5 * (a + b)
        lm = tr + math.sqrt(maximum(tr * tr - (a * b - c * c), 0.0))
        s = t[j] - last[k]
        dist = math.hypot(pos[j, 0] - org[j, 0], pos[j, 1] - org[j, 1])
        rng[j] = dist
        r = 0
        if conf and s > max_coast:
            d, r = True, 1
        if conf and not d and lm > max_var:
            d, r = True, 2
        if not d and dist > max_range[j] + margin:
            d, r = True, 3
        drop[j], code[j], lam[j], since[j] = d, r, lm, s


@kernel
def drop_rows(idx, t, group, hist, scans, confirmed, last, n_upd, radius, popcount, Pc, pos, org, max_range, window,
              hits, max_coast, max_var, margin, fraction):
    """:meth:`TrackManagement.drops` of the rows k = idx[j] (k,) in one pass: (drop, code, lam, since, rng
    (k,), go, kept (g,)) — the losses of :func:`loss_rows`, then the duplicates among the tracks not
    dropped: the live positions sorted stably by their vessel ``group`` (k,),
    :func:`~mjasc.perception.tracking.pair_kernels.merge_candidates` of them (positions pos (k, 2) [m],
    radii ``radius[idx]``), and each close pair whose tracks are both still kept, in the order found:
    the one with fewer updates goes (confirmed before tentative: ``(confirmed, n_upd)`` compared as
    tuples, the first kept on a tie); go, kept the positions of the confirmed ones that went and of
    the track each was merged into."""
    k = idx.size
    drop = np.empty(k, dtype=np.bool_)
    code = np.empty(k, dtype=np.int8)
    lam = np.empty(k)
    since = np.empty(k)
    rng = np.empty(k)
    go, kept = drop_rows_into(idx, t, group, hist, scans, confirmed, last, n_upd, radius, popcount, Pc, pos, org,
                              max_range, window, hits, max_coast, max_var, margin, fraction, drop, code, lam, since,
                              rng)
    return drop, code, lam, since, rng, go, kept


@kernel
def drop_rows_into(idx, t, group, hist, scans, confirmed, last, n_upd, radius, popcount, Pc, pos, org, max_range,
                   window, hits, max_coast, max_var, margin, fraction, drop, code, lam, since, rng):
    """:func:`drop_rows` (arguments idx … fraction as there) with its (k,) arrays drop, code, lam, since,
    rng written into the caller's (their first k rows): returns (go, kept)."""
    k = idx.size
    loss_rows(idx, t, hist, scans, confirmed, last, popcount, Pc, pos, org, max_range, window, hits, max_coast,
              max_var, margin, drop, code, lam, since, rng)
    n_live = 0
    for j in range(k):
        if not drop[j]:
            n_live += 1
    go = np.empty(0, dtype=np.int64)
    kept = np.empty(0, dtype=np.int64)
    if n_live <= 1:
        return go, kept
    live = np.empty(n_live, dtype=np.int64)
    c = 0
    for j in range(k):
        if not drop[j]:
            live[c] = j
            c += 1
    keys = np.empty(n_live, dtype=np.int64)
    for c in range(n_live):
        keys[c] = group[live[c]]
    order = np.argsort(keys, kind="mergesort")
    live_s = np.empty(n_live, dtype=np.int64)
    keys_s = np.empty(n_live, dtype=np.int64)
    for c in range(n_live):
        live_s[c] = live[order[c]]
        keys_s[c] = keys[order[c]]
    rad = np.empty(k)
    for j in range(k):
        rad[j] = radius[idx[j]]
    a, b = merge_candidates(live_s, keys_s, pos, rad, fraction)
    go = np.empty(a.size, dtype=np.int64)
    kept = np.empty(a.size, dtype=np.int64)
    m = 0
    for c in range(a.size):
        a_ = a[c]
        b_ = b[c]
        if drop[a_] or drop[b_]:
            continue
        ca, cb = confirmed[idx[a_]], confirmed[idx[b_]]
        if ca > cb or (ca == cb and n_upd[idx[a_]] >= n_upd[idx[b_]]):
            keep_, go_ = a_, b_
        else:
            keep_, go_ = b_, a_
        drop[go_] = True
        if confirmed[idx[go_]]:
            go[m] = go_
            kept[m] = keep_
            m += 1
    return go[:m], kept[:m]


@kernel
def every_drop_rows(group, pos_of, t_o, x, Pc, org_o, max_range_o, hist, scans, confirmed, last, n_upd, radius,
                    popcount, window, hits, max_coast, max_var, margin, fraction):
    """:func:`drop_rows` of every row (idx = 0 … n − 1) with each row's time ``t_o[pos_of[group]]``,
    position ``x[:, :2]``, position covariance ``Pc[:, :2, :2]``, sensor origin ``org_o[pos_of[group]]``
    and range ``max_range_o[group]`` gathered first (:meth:`TrackManagement.drops_all`)."""
    n = group.size
    drop = np.empty(n, dtype=np.bool_)
    code = np.empty(n, dtype=np.int8)
    lam = np.empty(n)
    since = np.empty(n)
    rng = np.empty(n)
    go, kept = every_drop_rows_into(group, pos_of, t_o, x, Pc, org_o, max_range_o, hist, scans, confirmed, last,
                                    n_upd, radius, popcount, window, hits, max_coast, max_var, margin, fraction, drop,
                                    code, lam, since, rng)
    return drop, code, lam, since, rng, go, kept


@kernel
def every_drop_rows_into(group, pos_of, t_o, x, Pc, org_o, max_range_o, hist, scans, confirmed, last, n_upd, radius,
                         popcount, window, hits, max_coast, max_var, margin, fraction, drop, code, lam, since, rng):
    """:func:`every_drop_rows` (arguments group … fraction as there) with its (n,) arrays drop, code, lam,
    since, rng written into the caller's (:func:`drop_rows_into`): returns (go, kept)."""
    n = group.size
    idx = np.arange(n)
    t = np.empty(n)
    pos = np.empty((n, 2))
    P = np.empty((n, 2, 2))
    org = np.empty((n, 2))
    mr = np.empty(n)
    for k in range(n):
        o = group[k]
        q = pos_of[o]
        t[k] = t_o[q]
        pos[k, 0] = x[k, 0]
        pos[k, 1] = x[k, 1]
        for a in range(2):
            for b in range(2):
                P[k, a, b] = Pc[k, a, b]
        org[k, 0] = org_o[q, 0]
        org[k, 1] = org_o[q, 1]
        mr[k] = max_range_o[o]
    return drop_rows_into(idx, t, group, hist, scans, confirmed, last, n_upd, radius, popcount, P, pos, org, mr, window,
                          hits, max_coast, max_var, margin, fraction, drop, code, lam, since, rng)


@kernel
def every_drops_into(group, pos_of, t_o, x, Pc, org_o, max_range_o, hist, scans, confirmed, last, n_upd, radius,
                     popcount, window, hits, max_coast, max_var, margin, fraction, drop, ints, vals):
    """:func:`every_drop_rows` (arguments group … fraction as there) packed into the first rows of the
    caller's buffers: ``drop`` (≥ n) the rows dropped; ``ints`` the rows j of the L confirmed tracks lost
    (code ≠ 0, in row order), their codes, then go and kept of the g merges (2L + 2g); ``vals`` lam,
    since, rng of the L rows (flat: (3, L) row-major). Returns (L, g, the number dropped) — g = −1 (drop
    written, ints and vals not) when ints or vals have no room; 4n ints and 3n vals always have room
    (L ≤ n, and each merge drops a row not dropped before: g ≤ n)."""
    n = group.size
    code = np.empty(n, dtype=np.int8)
    lam = np.empty(n)
    since = np.empty(n)
    rng = np.empty(n)
    go, kept = every_drop_rows_into(group, pos_of, t_o, x, Pc, org_o, max_range_o, hist, scans, confirmed, last,
                                    n_upd, radius, popcount, window, hits, max_coast, max_var, margin, fraction, drop,
                                    code, lam, since, rng)
    L = 0
    n_drop = 0
    for j in range(n):
        n_drop += drop[j]
        if code[j] != 0 and confirmed[j]:
            L += 1
    g = go.size
    if 2 * L + 2 * g > ints.size or 3 * L > vals.size:
        return L, -1, n_drop
    a = 0
    for j in range(n):
        if code[j] != 0 and confirmed[j]:
            ints[a] = j
            ints[L + a] = code[j]
            vals[a] = lam[j]
            vals[L + a] = since[j]
            vals[2 * L + a] = rng[j]
            a += 1
    for c in range(g):
        ints[2 * L + c] = go[c]
        ints[2 * L + g + c] = kept[c]
    return L, g, n_drop
