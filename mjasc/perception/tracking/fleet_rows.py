"""FleetRows: a fleet tracker's rows dropped and born in a step (steps 4b and 5 of
:mod:`mjasc.perception.tracking.fleet`, with their events) — the mixin
:class:`~mjasc.perception.tracking.fleet.FleetTracker` inherits.

* ``_prune`` — the tracks management gives up (lost, hopeless, merged) leave the bank and the
  columns at once: when every row's vessel scanned (the usual tick) and no dropped track is lost or
  merged (no event: a tentative clutter track given up, the step's common drop), the drops and both
  compactions are one compiled call, :func:`drops_kept_into`; else the drops are read
  (:meth:`~mjasc.perception.tracking.management.TrackManagement.drops_every`), their events written,
  and the bank and the columns compacted by a compiled call each;
* ``_births`` — new tracks from the detections no track claimed, away from every track's disc: the
  births chosen (:func:`~mjasc.perception.tracking.step_gathers.births_of`), the bank's new rows
  (:func:`~mjasc.perception.imm.row_buffers.started_born_into`) and the columns' new rows
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
from mjasc.perception.imm.row_buffers import birth_room, born_set, kept_into, kept_room, kept_set, started_born_into
from mjasc.perception.tracking.fleet_views import _BORN, _LOST, _MERGED, TrackEvent
from mjasc.perception.tracking.loss_kernels import every_drops_into
from mjasc.perception.tracking.step_gathers import births_of
from mjasc.perception.tracking.track_columns import appended_columns, kept_columns

__all__ = ["FleetRows", "births_into", "drops_kept_into"]


class FleetRows:
    """The births and drops of :class:`~mjasc.perception.tracking.fleet.FleetTracker`'s step (a mixin:
    the tracker's base class; see the module docstring for the attributes it uses)."""

    _drops_in_one_call = True  # (False: drops read, then compacted by the bank's and the columns' own calls — the
    # fused call's reference in tests/test_fleet_rows.py)

    def _prune(self, owners, pos_of, every, t_o, origins) -> None:
        """Step 4b: drop the tracks management gives up (lost, hopeless, merged), with events."""
        bank = self.bank
        if every:  # every row: rows as a slice (no copies)
            if self.cols.n == 0:  # (the bank's number of rows)
                return
            rows, own = slice(None), self.cols.owner
            rpos = None
        else:
            rows = (pos_of[self.cols.owner] >= 0).nonzero()[0]
            if rows.size == 0:
                return
            own = self.cols.owner[rows]
            rpos = pos_of[own]
            pos, cov = bank.positions[rows], bank.position_covariances[rows]
        if (type(origins) is np.ndarray and origins.dtype == np.float64 and origins.ndim == 2
                and origins.shape[1] == 2 and origins.flags.c_contiguous):
            org = origins  # (the sensing pass's (p, 2) origins: read as they are)
        else:
            try:  # (every vessel's origin given, as the perception fleet does: one conversion)
                org = np.array(origins, dtype=float)
                if org.ndim != 2:
                    org = org.reshape(-1, 2)
            except (TypeError, ValueError):
                org = None
        if org is None or org.shape[0] != len(origins):
            org = np.array([(np.nan, np.nan) if o is None else np.asarray(o, dtype=float).reshape(2) for o in origins])
        if rpos is None and self._drops_in_one_call and bank._side is not None:
            # (every row's time, position, covariance, origin and range gathered by the kernel; the rows
            # dropped without an event compacted in the same call)
            Pc = bank.covariance_rows()
            (s, P, mu, x), rb = kept_room(bank)
            cols, mg = self.cols, self.mgmt
            n = cols.n
            bufs = mg.drop_buffers(n)
            args = mg.drop_args(own, pos_of, t_o, bank.state_rows, Pc, org, self._max_range)
            L, g, n_drop, m, n_active = drops_kept_into(
                *args, *bufs, bank._s, bank._P, bank._mu, bank._x, s, P, mu, x, rb.ids, rb.t, rb.Pc, rb.n_gated,
                rb.reasons, rb.active, rb.cv_x, rb.cv_P, rb.n_meas, *cols.reserve(n))
            if m >= 0:  # (dropped and compacted, none lost or merged: no events)
                kept_set(bank, m, n_active)
                cols.kept(~bufs[0][:n], m)  # (the object columns and the views)
                self.version += 1
                return
            drop, n_drop, lost, merged = mg.drops_read(args, bufs, n, L, g, n_drop)
        elif rpos is None:
            drop, n_drop, lost, merged = self.mgmt.drops_every(own, pos_of, t_o, bank.state_rows,
                                                               bank.covariance_rows(), org, self._max_range)
        else:
            conf = self.cols.confirmed[rows]
            drop, reason, merged = self.mgmt.drops(rows, own, t_o[rpos], pos, cov, org[rpos], self._max_range[own])
            n_drop = np.count_nonzero(drop)
            lost = [(j, reason[j]) for j in drop.nonzero()[0].tolist() if conf[j] and reason[j]]
        ids = self.cols.local_id[rows]
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
        """Step 5: new tracks from the detections no track claimed, away from every track's disc (one
        compiled call, :func:`births_into`, into room for every detection)."""
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
        k = zb.shape[0]
        if k == 0:
            return
        born_set(bank, k, one_time, off)
        # every per-track column of management, manoeuvres, team and outlines (the hull anchor: the
        # new rows' positions, which are zb)
        cols.appended(k)
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
def drops_kept_into(group, pos_of, t_o, x_rows, Pc_rows, org_o, max_range_o, hist, scans, confirmed, last, n_upd, radius,
                    popcount, window, hits, max_coast, max_var, margin, fraction, drop, ints, vals, s, P, mu, x, s_out,
                    P_out, mu_out, x_out, ids, t, Pc, n_gated, reasons, active, cv_x, cv_P, n_meas, f, i, b):
    """A fleet step's drops (every row's vessel scanned) in one call:
    :func:`~mjasc.perception.tracking.loss_kernels.every_drops_into` (its arguments first, as there, into
    drop, ints, vals); when rows are dropped and none is lost or merged (no event to write: the step's
    common drop, a tentative track given up), the bank compacted to the kept rows
    (:func:`~mjasc.perception.imm.row_buffers.kept_into`: its state s, P, μ, x into the other side's
    s_out … x_out, its per-track arrays and start-up filters in place) and the columns' tables f, i, b
    (:func:`~mjasc.perception.tracking.track_columns.kept_columns`). Returns (L, g, the number dropped,
    m, the number of start-up rows kept) — m = −1 when nothing was compacted (the caller reads the
    drops and compacts, as before)."""
    L, g, n_drop = every_drops_into(group, pos_of, t_o, x_rows, Pc_rows, org_o, max_range_o, hist, scans, confirmed,
                                    last, n_upd, radius, popcount, window, hits, max_coast, max_var, margin, fraction,
                                    drop, ints, vals)
    if n_drop == 0 or L != 0 or g != 0:
        return L, g, n_drop, -1, 0
    n = group.size
    keep = np.empty(n, dtype=np.bool_)
    for k in range(n):
        keep[k] = not drop[k]
    m, n_active = kept_into(keep, s, P, mu, x, s_out, P_out, mu_out, x_out, ids, t, Pc, n_gated, reasons, active, cv_x,
                            cv_P, n_meas)
    kept_columns(keep, f, i, b)
    return L, g, n_drop, m, n_active
