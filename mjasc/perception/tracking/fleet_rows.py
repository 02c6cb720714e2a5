"""FleetRows: a fleet tracker's rows dropped and born in a step (steps 4b and 5 of
:mod:`mjasc.perception.tracking.fleet`, with their events) — the mixin
:class:`~mjasc.perception.tracking.fleet.FleetTracker` inherits.

* ``_drops_births`` — the tracks management gives up (lost, hopeless, merged) leave the bank and the
  columns at once, then new tracks are born from the detections no track claimed, away from every
  track's disc: when every row's vessel scanned (the usual tick) and no dropped track is lost or merged
  (no event: a tentative clutter track given up, the step's common drop), the drops with both
  compactions, the births and management's moved marks are one compiled call, :func:`drops_births_into`
  (one ~60-argument call instead of four, and none of the Python between them: each call's dispatch
  costs ~2–3 µs at this size); else ``_prune`` and ``_births``:
* ``_prune`` — the drops read (:meth:`~mjasc.perception.tracking.management.TrackManagement.drops_every`),
  their events written, and the bank and the columns compacted by a compiled call each;
* ``_births`` — the births chosen (:func:`~mjasc.perception.tracking.step_gathers.births_of`), the bank's
  new rows (:func:`~mjasc.perception.imm.row_buffers.started_born_into`) and the columns' new rows
  (:func:`~mjasc.perception.tracking.track_columns.appended_columns`) written in one compiled call,
  :func:`births_into`, into room made beforehand for every detection (a birth step of a demo has a
  few rows and detections: the calls, arrays and glue between them cost more than their loops).

Both give the same rows as their separate calls — ``births_packed``, then ``IMMBank.append_tracks``
and ``TrackColumns.append_rows``; ``drops_every``, then ``IMMBank.keep_rows`` and ``TrackColumns.keep``
(tests/test_fleet_rows.py).

The mixin has no state of its own; it reads and writes the tracker's ``bank``, ``cols``, ``mgmt``,
``events``, ``version``, ``_counts``, ``_next_local``, ``_last_assign``, ``_max_range``, ``_use_var``,
set by ``FleetTracker.__init__``.
"""

from __future__ import annotations

import numpy as np

from mjasc.core.compiled import kernel
from mjasc.perception.imm.row_buffers import (birth_room, born_set, kept_into, kept_set, started_born_into,
                                              step_room)
from mjasc.perception.imm.row_fields import combine_covariance_rows
from mjasc.perception.tracking.fleet_views import _BORN, _LOST, _MERGED, TrackEvent
from mjasc.perception.tracking.loss_kernels import every_drops_into
from mjasc.perception.tracking.management import MOVED_M, moved_rows
from mjasc.perception.tracking.step_gathers import births_of
from mjasc.perception.tracking.track_columns import (ANCHOR_X, ANCHOR_Y, ANCHORED, CONFIRMED, HIST, LAST, MOVED, N_UPD,
                                                     OWNER, RADIUS, SCANS, appended_columns, kept_columns)

__all__ = ["FleetRows", "births_into", "drops_births_into"]


class FleetRows:
    """The births and drops of :class:`~mjasc.perception.tracking.fleet.FleetTracker`'s step (a mixin:
    the tracker's base class; see the module docstring for the attributes it uses)."""

    _drops_in_one_call = True  # (False: drops read, then compacted by the bank's and the columns' own calls, and
    # the births a call of their own — the fused call's reference in tests/test_fleet_rows.py)

    def _drops_births(self, owners, pos_of, every, t_o, origins, z, var, rad, idx, d_pos, claimed) -> bool:
        """Steps 4b and 5: drop the tracks management gives up (lost, hopeless, merged), with events; then
        the births from the M detections z (M, 2) [m] no track claimed (``claimed`` (M,)). When every row's
        vessel scanned and no dropped track is lost or merged (the usual tick), the drops, the births and
        management's moved marks (``note_moved``) are one compiled call, :func:`drops_births_into`; else
        ``_prune``, then ``_births``. Returns True when the moved marks were set (the caller's
        ``note_moved`` done)."""
        org = _origins(origins)
        bank, cols = self.bank, self.cols
        n, M = cols.n, claimed.size
        if not (every and n and self._drops_in_one_call and bank._side is not None):
            self._prune(owners, pos_of, every, t_o, org)
            if M and False in claimed.tolist():  # (every detection inside a track's gate: no birth)
                self._births(owners, pos_of, t_o, z, var, rad, idx, d_pos, claimed)
            return False
        side, other, rb = step_room(bank, n + M)
        f, i, b = cols.reserve(n + M)
        mg, st = self.mgmt, bank._startup
        bufs = mg.drop_buffers(n)
        L, g, n_drop, m, n_active, ints, zb, one_time, off = drops_births_into(
            n, pos_of, t_o, org, self._max_range, *mg.drop_constants, *bufs, bank._Pc_stale, *side, *other, rb.ids,
            rb.t, rb.Pc, rb.n_gated, rb.reasons, rb.active, rb.cv_x, rb.cv_P, rb.n_meas, f, i, b, claimed, d_pos, z,
            var, rad, owners, self._next_local, idx, self._counts, _BORN, self._use_var, bank._R, bank._sv2,
            rb.zero_polar(M)[1], bank._mu0, bank._next_id, st.snr2, st.max_updates, cols.confirm_now, MOVED_M)
        bank._Pc_stale = False  # (the combined covariances computed in the call)
        if m < 0:  # (a dropped track lost or merged: its events, then the compactions and the births as before)
            self._dropped(every, None, cols.owner, pos_of, t_o, *mg.drops_read(bufs, n, L, g, n_drop))
            if M and False in claimed.tolist():
                self._births(owners, pos_of, t_o, z, var, rad, idx, d_pos, claimed)
            return False
        if n_drop:  # (dropped and compacted, none lost or merged: no events)
            kept_set(bank, m, n_active)
            cols.kept(~bufs[0][:n], m)  # (the object columns and the views)
            self.version += 1
        if zb.shape[0]:
            self._born(owners, t_o, ints, zb, one_time, off)
        return True

    def _prune(self, owners, pos_of, every, t_o, org) -> None:
        """Step 4b through the separate calls: drop the tracks management gives up (lost, hopeless, merged),
        with events (``org`` (p, 2) the vessels' sensor origins [m], NaN: none)."""
        bank = self.bank
        if every:  # every row: rows as a slice (no copies)
            if self.cols.n == 0:  # (the bank's number of rows)
                return
            rows, own = slice(None), self.cols.owner
            drop, n_drop, lost, merged = self.mgmt.drops_every(own, pos_of, t_o, bank.state_rows,
                                                               bank.covariance_rows(), org, self._max_range)
        else:
            rows = (pos_of[self.cols.owner] >= 0).nonzero()[0]
            if rows.size == 0:
                return
            own = self.cols.owner[rows]
            rpos = pos_of[own]
            pos, cov = bank.positions[rows], bank.position_covariances[rows]
            conf = self.cols.confirmed[rows]
            drop, reason, merged = self.mgmt.drops(rows, own, t_o[rpos], pos, cov, org[rpos], self._max_range[own])
            n_drop = np.count_nonzero(drop)
            lost = [(j, reason[j]) for j in drop.nonzero()[0].tolist() if conf[j] and reason[j]]
        self._dropped(every, None if every else rows, own, pos_of, t_o, drop, n_drop, lost, merged)

    def _dropped(self, every, rows, own, pos_of, t_o, drop, n_drop, lost, merged) -> None:
        """The drops' events and the compactions of the bank and the columns: ``drop`` (k,) bool of the rows
        ``rows`` (None: every row) of vessels ``own`` (k,), n_drop of them, ``lost`` (row, reason) and
        ``merged`` (row, kept row) pairs (indices into ``rows``)."""
        bank = self.bank
        ids = self.cols.local_id if rows is None else self.cols.local_id[rows]
        for go, keep in merged:
            o = int(own[go])
            t = float(t_o[pos_of[o]])
            self._counts[o, _MERGED] += 1
            self.events[o].append(TrackEvent(t, "merged", int(ids[go]), f"track {ids[go]} merged into track {ids[keep]}"))
        for j, why in lost:
            o = int(own[j])
            self._counts[o, _LOST] += 1
            self.events[o].append(TrackEvent(float(t_o[pos_of[o]]), "lost", int(ids[j]), f"track {ids[j]} lost: {why}"))
        if n_drop:
            if every:
                keep = ~drop
            else:
                keep = np.ones(len(bank), dtype=bool)
                keep[rows[drop]] = False
            bank.keep_rows(keep)
            self.cols.keep(keep)  # (every per-track column of management, manoeuvres, team and outlines)
            self.version += 1

    def _births(self, owners, pos_of, t_o, z, var, rad, idx, d_pos, claimed) -> None:
        """Step 5 through a call of its own: new tracks from the detections no track claimed, away from
        every track's disc (one compiled call, :func:`births_into`, into room for every detection)."""
        bank, cols = self.bank, self.cols
        n, M = cols.n, claimed.size
        (s, P, mu, x), rb = birth_room(bank, n + M)
        st = bank._startup
        f, i, b = cols.reserve(n + M)
        J = rb.zero_polar(M)[1]  # (the polar Jacobians of V = 0, :func:`started_born_into`)
        ints, zb, one_time, off = births_into(
            claimed, cols.owner, pos_of, d_pos, z, var, rad, bank.state_rows, cols.radius, owners, t_o,
            self._next_local, idx, self._counts, _BORN, self._use_var, bank._R, bank._sv2, J, rb.active, rb.cv_x,
            rb.cv_P, rb.n_meas, s, P, mu, x, bank._mu0, rb.ids, rb.t, rb.Pc, rb.n_gated, rb.reasons, bank._next_id,
            st.snr2, st.max_updates, f, i, b, cols.confirm_now)
        if zb.shape[0]:
            self._born(owners, t_o, ints, zb, one_time, off)

    def _born(self, owners, t_o, ints, zb, one_time, off) -> None:
        """After :func:`births_into` wrote k births past the bank's and the columns' rows (``ints`` (3, k),
        ``zb`` (k, 2) [m], ``one_time``, ``off``: its returns): they are rows now; their events and last
        assignments."""
        k = zb.shape[0]
        born_set(self.bank, k, one_time, off)
        # every per-track column of management, manoeuvres, team and outlines (the hull anchor: the
        # new rows' positions, which are zb)
        self.cols.appended(k)
        self.version += 1
        local, dets = ints[1], ints[2]
        bl, ll, _ = ints.tolist()
        zl = zb.tolist()
        a = 0
        while a < k:  # per vessel (bp is sorted): its events and last assignment
            q = bl[a]
            b = a + 1
            while b < k and bl[b] == q:
                b += 1
            o, t = int(owners[q]), float(t_o[q])
            events = self.events[o]
            for tid, zj in zip(ll[a:b], zl[a:b]):
                events.append(TrackEvent(t, "born", tid, f"track {tid} born at ({zj[0]:.1f}, {zj[1]:.1f}) m"))  # (as _fmt)
            self._last_assign[o].append((local, dets, a, b))
            a = b


def _origins(origins) -> np.ndarray:
    """The vessels' sensor origins as one (p, 2) float array [m] (NaN: no origin, no out-of-range test):
    the sensing pass's array as it is, else made from the list of (2,) or None."""
    if (type(origins) is np.ndarray and origins.dtype == np.float64 and origins.ndim == 2
            and origins.shape[1] == 2 and origins.flags.c_contiguous):
        return origins  # (the sensing pass's (p, 2) origins: read as they are)
    try:  # (every vessel's origin given, as the perception fleet does: one conversion)
        org = np.array(origins, dtype=float)
        if org.ndim != 2:
            org = org.reshape(-1, 2)
    except (TypeError, ValueError):
        org = None
    if org is None or org.shape[0] != len(origins):
        org = np.array([(np.nan, np.nan) if o is None else np.asarray(o, dtype=float).reshape(2) for o in origins])
    return org


@kernel
def births_into(claimed, owner, pos_of, d_pos, z, var, rad, x_rows, radius, owners, t_o, next_local, idx, counts, col,
                use_var, R, sv2, J, active, cv_x, cv_P, n_meas, s, P, mu, x, mu0, ids, t, Pc, n_gated, reasons, id0,
                snr2, max_updates, f, i, b, confirm_now):
    """A fleet step's births in one call: :func:`~mjasc.perception.tracking.step_gathers.births_of` (its
    arguments first, as there: x_rows the bank's (n, ≥ 2) states; ``counts[owners, col]`` and next_local
    advanced in place), then the k births' bank rows after its n (:func:`started_born_into`: σ² var of
    each birth's detection if ``use_var``, else R; J (≥ k, 4, 4) the polar Jacobians of V = 0; the start-up
    filters' active, cv_x, cv_P, n_meas, the state's s, P, μ, x and the per-track ids, t, Pc, n_gated,
    reasons: the row buffers of room n + k or more; ids id0, id0 + 1, …) and their columns' rows
    (:func:`~mjasc.perception.tracking.track_columns.appended_columns` into the tables f, i, b).
    Returns (ints (3, k): each birth's vessel position, id and detection index; z_b (k, 2) [m];
    one_time, off of :func:`started_born_into`)."""
    bp, own, local, t_b, z_b, var_b, rad_b, dets = births_of(claimed, owner, pos_of, d_pos, z, var, rad, x_rows, radius,
                                                             owners, t_o, next_local, idx, counts, col)
    k = bp.size
    ints = np.empty((3, k), dtype=np.int64)
    for a in range(k):
        ints[0, a] = bp[a]
        ints[1, a] = local[a]
        ints[2, a] = dets[a]
    one_time, off = True, 0
    if k:
        n0 = owner.size
        one_time, off = started_born_into(active, cv_x, cv_P, n_meas, z_b, R, sv2, var_b, use_var, J[:k], s, P, mu, x,
                                          n0, mu0, ids, t, Pc, n_gated, reasons, np.empty(0, dtype=np.int64), id0,
                                          t_b, np.zeros(k), snr2, max_updates)
        appended_columns(f, i, b, n0, t_b, rad_b, z_b, own, local, confirm_now)
    return ints, z_b, one_time, off


@kernel
def drops_births_into(n, pos_of, t_o, org_o, max_range_o, popcount, window, hits, max_coast, max_var, margin, fraction,
                      drop, ints, vals, stale, s, P, mu, x, s_out, P_out, mu_out, x_out, ids, t, Pc, n_gated, reasons,
                      active, cv_x, cv_P, n_meas, f, i, b, claimed, d_pos, z, var, rad, owners, next_local, idx, counts,
                      col, use_var, R, sv2, J, mu0, id0, snr2, max_updates, confirm_now, moved_m):
    """A fleet step's drops and births (every row's vessel scanned) in one call, on a bank of n rows in its
    buffers — the state's side s, P, μ, x and the other side s_out … x_out (every row of each), the row
    buffers ids … n_meas — and the columns' tables f, i, b (room for n + M rows each): the combined
    covariances of the bank's rows first when ``stale`` (``combine_covariance_rows`` into Pc), then
    :func:`~mjasc.perception.tracking.loss_kernels.every_drops_into` (the rows' vessels, positions,
    covariances and columns read from those buffers; the vessels' arguments pos_of … fraction and its
    buffers drop, ints, vals as there). When a dropped track is lost or merged (events to write), nothing
    more: returns (L, g, the number dropped, −1, …) and the caller compacts and adds the births. Else the
    dropped rows compacted as :func:`~mjasc.perception.imm.row_buffers.kept_into` (the state into the other
    side, which is then the state's) and :func:`~mjasc.perception.tracking.track_columns.kept_columns` do,
    the births of the M detections (``claimed`` … ``confirm_now``: :func:`births_into`'s arguments after
    the rows') written past the m rows kept when a detection is unclaimed, and management's moved marks
    set on the m + k rows (:func:`~mjasc.perception.tracking.management.moved_rows`, MOVED_M ``moved_m``).
    Returns (L, g, the number dropped, m, the number of start-up rows kept (when rows were dropped), then
    :func:`births_into`'s ints (3, k), z_b (k, 2), one_time, off)."""
    if stale:
        combine_covariance_rows(s[:n], P[:n], mu[:n], active[:n], Pc[:n])
    L, g, n_drop = every_drops_into(i[OWNER, :n], pos_of, t_o, x[:n], Pc[:n], org_o, max_range_o, i[HIST, :n],
                                    i[SCANS, :n], b[CONFIRMED, :n], f[LAST, :n], i[N_UPD, :n], f[RADIUS, :n],
                                    popcount, window, hits, max_coast, max_var, margin, fraction, drop, ints, vals)
    if n_drop != 0 and (L != 0 or g != 0):
        return L, g, n_drop, -1, 0, np.empty((3, 0), dtype=np.int64), np.empty((0, 2)), True, 0
    m, n_active = n, 0
    if n_drop != 0:
        keep = np.empty(n, dtype=np.bool_)
        for k in range(n):
            keep[k] = not drop[k]
        m, n_active = kept_into(keep, s, P, mu, x, s_out, P_out, mu_out, x_out, ids, t, Pc, n_gated, reasons, active,
                                cv_x, cv_P, n_meas)
        kept_columns(keep, f, i, b)
        s, P, mu, x = s_out, P_out, mu_out, x_out
    born = False
    for j in range(claimed.size):
        if not claimed[j]:
            born = True
            break
    if born:
        bi, zb, one_time, off = births_into(claimed, i[OWNER, :m], pos_of, d_pos, z, var, rad, x[:m], f[RADIUS, :m],
                                            owners, t_o, next_local, idx, counts, col, use_var, R, sv2, J, active,
                                            cv_x, cv_P, n_meas, s, P, mu, x, mu0, ids, t, Pc, n_gated, reasons, id0,
                                            snr2, max_updates, f, i, b, confirm_now)
    else:
        bi, zb, one_time, off = np.empty((3, 0), dtype=np.int64), np.empty((0, 2)), True, 0
    e = m + zb.shape[0]
    moved_rows(x[:e], b[CONFIRMED, :e], b[ANCHORED, :e], f[ANCHOR_X:ANCHOR_Y + 1, :e].T, b[MOVED, :e], moved_m)
    return L, g, n_drop, m, n_active, bi, zb, one_time, off
