"""FleetTracker: the tracks of many vessels (owners) in one IMM bank, one :meth:`~FleetTracker.step`
for every vessel that scanned at a tick (thesis §3.2.1, docs/thesis.md §2; the procedure of
:mod:`mjasc.perception.tracking`).

Each bank row belongs to one vessel (``owner``) and carries that vessel's own track id (the ids a
vessel hands on count from 0 per vessel). Nothing mixes vessels: a vessel's detections are
associated only with its own tracks, merges pair only its own tracks, team mates are matched
against its own broadcasts; but each stage runs once for all vessels, over arrays of rows or of
(track, detection) pairs grouped by vessel (:func:`mjasc.perception.tracking.association.block_pairs`):

1. gated GNN association of every vessel's target detections with its tracks, a partly hidden
   detection's variance inflated by the unseen part of the track's radius; a
   ``linear_sum_assignment`` only for a vessel whose gates overlap
   (:func:`~mjasc.perception.tracking.association.gnn_assign_blocks`);
2. manoeuvre detection on the associated tracks (:mod:`~mjasc.perception.tracking.manoeuvre`);
3. **one IMM cycle** for the tracks of every vessel that scanned (each vessel's group of rows at its
   own Ts when the vessels' times differ: :meth:`mjasc.perception.imm.IMMBank.update_rows`);
4. management (:mod:`~mjasc.perception.tracking.management`): confirmation, radius, static test,
   outlines of slow tracks (:mod:`~mjasc.perception.tracking.outlines`), losses and merges (the
   dropped rows leave the bank at once);
5. births from the detections no track claimed and outside every track's gate and disc (added
   to the bank at once);
6. team mates matched from each vessel's broadcasts (:mod:`~mjasc.perception.tracking.team`).

Every per-track column that is not the bank's — each row's vessel and id, management, manoeuvres,
team mates, outlines — lives in one :class:`~mjasc.perception.tracking.track_columns.TrackColumns`
that the components share: a step's births are one compiled append to it (and one to the bank),
its drops one compiled compaction of it (and one of the bank).

A vessel's results do not depend on the other vessels in the bank: every step is per row or per
pair, and the IMM cycle's rows are independent (:mod:`mjasc.perception.imm.compiled_cycle`); a fleet's
tracker gives each vessel the same tracks, bit for bit, as a tracker of its own
(tests/test_fleet_perception.py). :class:`mjasc.perception.tracking.tracker.MultiTargetTracker` is
one vessel's view. What the tracker hands out — a vessel's rows, counters, reports, estimates,
outlines — is :class:`~mjasc.perception.tracking.fleet_views.FleetViews`, its base class.
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.perception.imm.bank import IMMBank
from mjasc.perception.tracking.association import (
    gnn_assign_blocks, indexed_pair_costs, predicted_positions)
from mjasc.perception.tracking.config import TrackingConfig
from mjasc.perception.tracking.fleet_rows import FleetRows
from mjasc.perception.tracking.fleet_views import (_ASSOC, _CONF, _DETS, _SCANS, COUNT_KEYS, FleetViews,
                                                  TrackEvent)
from mjasc.perception.tracking.management import TrackManagement
from mjasc.perception.tracking.manoeuvre import ManoeuvreDetector
from mjasc.perception.tracking.outlines import TrackOutlines
from mjasc.perception.tracking.step_buffers import AssociationBuffers, gated_manoeuvres_into, grown
from mjasc.perception.tracking.step_fusions import cycled_scan_grown
from mjasc.perception.tracking.step_gathers import step_inputs_into, step_rows
from mjasc.perception.tracking.step_kernels import apply_assignment, measurement_rows_into, pair_setup
from mjasc.perception.tracking.team import TeamMatcher
from mjasc.perception.tracking.track_columns import TrackColumns

__all__ = ["FleetTracker", "TrackEvent", "COUNT_KEYS"]

def _fmt(p) -> str:
    return f"({p[0]:.1f}, {p[1]:.1f}) m"


class FleetTracker(FleetRows, FleetViews):
    """The tracks of many vessels; ``add_owner(max_range)`` per vessel, then ``step(owners, ...)``
    once per tick for the vessels that scanned."""

    def __init__(self, config: TrackingConfig = TrackingConfig()):
        if not isinstance(config, TrackingConfig):
            raise ValueError(f"config: expected a TrackingConfig, got {type(config).__name__}")
        self.config = config
        self.bank = IMMBank(config.imm)
        self._R = float(config.imm.measurement_variance_m2)
        self._gate = config.gate_threshold
        self._static_speed = float(config.static_speed_m_s)
        self._use_var = bool(config.use_detection_variance)
        cols = self.cols = TrackColumns(config.confirm_hits <= 1)  # every per-track column but the bank's
        self.mgmt = TrackManagement(config, cols)
        self.manoeuvres = ManoeuvreDetector(config, cols)
        self.team = TeamMatcher(config, cols)
        self.outlines = TrackOutlines(config, cols)
        self.version = 0  # changes whenever rows are added or removed
        self._rows_cache: dict[int, tuple[int, np.ndarray]] = {}
        self._sizes: tuple = (-1, [], 0)  # (version, each vessel's number of rows, n_owners): n_rows
        self._owner_plans: dict[tuple, tuple] = {}  # (n_owners, *owners) → (owners, pos_of, every, owners list)
        self._reports: dict | None = None  # every vessel's confirmed tracks since the last step (_report_estimates)
        self._max_range = np.zeros(0)
        self._next_local = np.zeros(0, dtype=np.int64)
        self._counts = np.zeros((0, len(COUNT_KEYS)), dtype=np.int64)
        self.events: list[list[TrackEvent]] = []
        self._last_assign: list[list] = []  # per vessel: its last scan's (ids, detections, a, b) pieces — ids[a:b]
        # and detections[a:b] (updates, births; sliced when read)
        self._bufs = None  # the step's buffers (_step_buffers)
        self._made_views: dict[tuple, tuple] = {}  # (M, n, k, p, no) → the step's views of those buffers (_step_views)
        self._report_bufs = (np.empty(0, dtype=np.int64), np.empty(0), np.empty(0, dtype=bool))  # (report_columns)
        self._assoc = AssociationBuffers()  # the association's buffers (step_buffers; grown when too small)
        self._meas_bufs = (np.empty((0, 2)), np.empty(0, dtype=bool))  # the cycle's measurement rows (_meas_buffers)
        self._all_true: dict[int, np.ndarray] = {}  # p → (p,) all True (_every_scan)

    # ------------------------------------------------------------------ vessels
    def add_owner(self, max_range_m: float = math.inf) -> int:
        """A vessel with no tracks yet and this sensor range [m] (tracks beyond it are dropped)."""
        k = self._max_range.size
        self._reports = None
        self._max_range = np.append(self._max_range, float(max_range_m))
        self._next_local = np.append(self._next_local, 0)
        self._counts = np.vstack([self._counts, np.zeros((1, len(COUNT_KEYS)), dtype=np.int64)])
        self.events.append([])
        self._last_assign.append([])
        return k

    def set_team_positions(self, owner: int, positions: dict) -> None:
        """``{name: (t_b [s], position (2,) [m])}``: the team's broadcasts as vessel ``owner`` has them."""
        self.team.set_positions(owner, positions)

    # ------------------------------------------------------------------ one tick
    def step(self, owners, t_s, detections, origins=None, use=None, points=None, stacked=None, labels=None) -> None:
        """One scan for each vessel of ``owners`` (p,) at its time t_s (p,) [s]: its ``detections``
        (a :class:`~mjasc.perception.detection.Detections` or None: coast), sensor origin (2,) [m]
        or None (no out-of-range test), ``use`` (m,) bool or None (default: the non-extended
        detections), and its scan's returns (k, 2) [m] in the order of ``detections.labels`` or None
        (for the outlines of slow tracks). Lists of p. ``stacked``: None, or every vessel's
        detections already stacked in vessel order, as the sensing pass has them (its detection
        batch: no stacking again) — (detections per vessel (p,) int64, ``use`` (M,) bool, centres
        (M, 2) [m], variances (M,) [m²], radii (M,) [m], occluded (M,) bool), the same values as
        ``detections`` and ``use`` stacked. ``labels``: None, or every vessel's returns' labels as the
        sensing pass has them — (labels (R,) int64, offsets (p + 1) list): vessel q's ``points[q]`` have
        the labels ``labels[offsets[q]:offsets[q + 1]]``, the same values as ``detections[q].labels``
        (read only for the outlines: a pass's detections are made on first read, every field at once)."""
        self._reports = None
        p = len(owners)
        no = self._max_range.size  # (n_owners)
        key = (no, *owners) if type(owners) is list else None
        got = self._owner_plans.get(key) if key is not None else None
        if got is None:  # the scanning vessels' arrays (the same few combinations tick after tick)
            owners_a = np.asarray(owners, dtype=np.int64)
            pos_of = np.full(no, -1)
            pos_of[owners_a] = np.arange(p)
            got = (owners_a, pos_of, p == no and bool((pos_of >= 0).all()),  # every vessel scanned: every row is due
                   owners_a.tolist())
            if key is not None:
                if len(self._owner_plans) >= 64:
                    self._owner_plans.clear()
                self._owner_plans[key] = got
        owners, pos_of, every, owners_l = got
        t_o = np.array(t_s, dtype=float)
        if t_o.shape != (p,):
            t_o = t_o.reshape(p)
        origins = [None] * p if origins is None else origins
        use = [None] * p if use is None else use
        points = [None] * p if points is None else points
        # every vessel's selected detections, stacked in vessel order (one compiled pass)
        dets = list(detections)
        if stacked is None:
            lens = [0 if d is None else d.centres_m.shape[0] for d in dets]
            if any(lens):
                live = [(d, u) for d, u, m in zip(dets, use, lens) if m]
                cat = np.concatenate
                stacked = (np.array(lens, dtype=np.int64),
                           cat([d.targets if u is None else np.asarray(u, dtype=bool) for d, u in live]),
                           cat([d.centres_m for d, _ in live]), cat([d.variances_m2 for d, _ in live]),
                           cat([d.radii_m for d, _ in live]),
                           cat([d.occluded if d.occluded is not None else np.zeros(len(d), bool) for d, _ in live]))
        own = self.cols.owner
        if stacked is not None and stacked[1].size:  # (select_detections and step_rows in one call, into buffers)
            S, n = stacked[1].size, own.size
            ints, z, floats, flags = self._step_buffers(S, n, p, no)
            M, all_due, k = step_inputs_into(*stacked, self._use_var, own, pos_of, every, owners, t_o, no,
                                             self._counts, _SCANS, _DETS, self._R, ints, z, floats, flags)
            (z, d_pos, idx, m_q, row_pos, rows, rpos, assigned, var, rad, t_own, var_row, occ,
             claimed) = self._step_views(M, n, k, p, no)
        else:
            d_pos = idx = np.zeros(0, dtype=np.int64)
            z, var, rad, occ = np.zeros((0, 2)), np.zeros(0), np.zeros(0), np.zeros(0, dtype=bool)
            m_q = np.zeros(p, dtype=np.int64)
            M = 0
            t_own, row_pos, all_due, rows, rpos, claimed, assigned, var_row = step_rows(
                own, pos_of, every, owners, t_o, no, self._counts, _SCANS, _DETS, m_q, M, self._R)
        for o in owners_l:
            self._last_assign[o] = []
        if rows.size:
            self._update(rows, rpos, all_due, row_pos, owners, t_o, z, var, rad, occ, idx, d_pos, m_q, dets, points,
                         claimed, assigned, var_row, labels)
        moved = self._drops_births(owners, pos_of, every, t_o, origins, z, var, rad, idx, d_pos, claimed)
        bank = self.bank
        if every:  # (every row is a row of a vessel that scanned)
            self.team.match(slice(None), self.cols.owner, t_own, bank.state_rows, self.cols.confirmed, no, False)
        else:
            rows = (pos_of[self.cols.owner] >= 0).nonzero()[0]
            self.team.match(rows, self.cols.owner[rows], t_own, bank.states_of(rows), self.cols.confirmed[rows], no)
        if not moved:  # (set by the drops and births' call when it ran)
            self.mgmt.note_moved(bank.state_rows)  # (its first two columns: the positions)

    def _update(self, rows, rpos, all_due, row_pos, owners, t_o, z, var, rad, occ, idx, d_pos, m_q, dets, points,
                claimed, assigned, var_row, labels=None) -> None:
        """Steps 1–4a: association, manoeuvres, the IMM cycle, confirmation and outlines (``assigned``
        (n,) −1 and ``var_row`` (n,) R: filled here; ``labels`` as :meth:`step`'s)."""
        bank = self.bank
        M = z.shape[0]
        p = owners.size
        arrays = bank.prediction_arrays() if M else None
        if arrays is not None:  # (the association and the hit rows' manoeuvres in one compiled call, written
            # into the tracker's buffers: step_buffers.gated_manoeuvres_into)
            ab = self._assoc
            args = (rows, rpos, p, m_q, self.cols.radius, var, rad, occ, *arrays, t_o, row_pos, z, self._gate,
                    assigned, var_row, claimed)
            man = self.manoeuvres
            warm = np.empty(assigned.size, dtype=np.int64)  # (the manoeuvring rows in start-up: ≤ the hits)
            noise = (*man.noise_args(bank), warm)  # (with the manoeuvres of the hit rows when no block is hard)
            npairs, k, ok, h, nh, n_full, n_warm = gated_manoeuvres_into(*args, *ab.association, *noise)
            if not ok:  # (too small: larger buffers, the same call again)
                ab = self._assoc = grown(ab, npairs, k, p)
                npairs, k, ok, h, nh, n_full, n_warm = gated_manoeuvres_into(*args, *ab.association, *noise)
            if npairs:
                hit = ab.rows[h:h + nh]  # (ab.rows[:h]: the blocks whose gates overlap, re-solved below)
                t_hit = ab.vals[nh:2 * nh]
                if h:  # (a vessel's gates overlap: its block to linear_sum_assignment)
                    n_q, start = ab.blocks[:p], ab.blocks[p:2 * p + 1]
                    q, i, j, _, db, ta = ab.pairs[:6 * npairs].reshape(6, npairs)
                    inside, d2, var_p = ab.inside[:npairs], ab.d2[:npairs], ab.var_p[:npairs]
                    got = gnn_assign_blocks(inside, ab.cost[:npairs], q, i, j, start, n_q, m_q)
                    hit, d2_hit = apply_assignment(got, inside, ta, db, var_p, d2, assigned, var_row, claimed)
                    man.detect(hit, d2_hit, self._gate, t_o[row_pos[hit]], bank)
                elif n_full >= 0:  # (detected in the call)
                    man.noise_added(hit, t_hit, bank, n_full, n_warm, warm)
        elif M:
            n_q, grouped, q, i, j, start, gi, db, ta, var_p = pair_setup(rows, rpos, p, m_q, self.cols.radius, var,
                                                                          rad, occ)
            if q.size:
                zhat, S = predicted_positions(*bank.prediction_fields(grouped), t_o[row_pos[grouped]])
                d2, cost = indexed_pair_costs(zhat, S, gi, z, db, var_p)
                inside = d2 <= self._gate
                got = gnn_assign_blocks(inside, cost, q, i, j, start, n_q, m_q)
                hit, d2_hit = apply_assignment(got, inside, ta, db, var_p, d2, assigned, var_row, claimed)
                self.manoeuvres.detect(hit, d2_hit, self._gate, t_o[row_pos[hit]], bank)
        n = assigned.size
        zr, meas = self._meas_buffers(n)
        measurement_rows_into(assigned, z, zr, meas)
        vr = var_row if self._use_var else None  # (changed in place by the cycle: its unusable σ² replaced)
        used = self._cycle(rows, all_due, row_pos, t_o, zr, meas, vr)
        x = bank.state_rows
        flags = [pt is not None and d is not None for pt, d in zip(points, dets)]
        with_pts = self._every_scan(p) if all(flags) else np.array(flags, dtype=bool)
        c = self.cols  # (the cycled rows' gathers, management's record of the scan, last assignments and the
        # outlines' plan of the rows with returns: one call)
        outlines = self.outlines
        ints, new_conf, geo, n_conf, g, m, n_reset, g2 = cycled_scan_grown(
            rows, row_pos, t_o, used, meas, x, with_pts, self._counts, owners, _ASSOC, assigned, rad, occ, c.hist,
            c.scans, c.n_upd, c.last, c.radius, c.confirmed, c.static, c.born, *self.mgmt.scan_constants, c.local_id,
            idx, p, c.hull_anchor, *outlines.plan_constants)
        if n_conf:
            pos, born = bank.positions, self.cols.born
            for k in rows[new_conf].tolist():
                o, tid, t = int(self.cols.owner[k]), int(self.cols.local_id[k]), float(t_o[row_pos[k]])
                self._counts[o, _CONF] += 1
                self.events[o].append(TrackEvent(t, "confirmed", tid, f"track {tid} confirmed at {_fmt(pos[k])} "
                                                                      f"(born {t - born[k]:.1f} s ago)"))
        e = g + 2 * m + p + 1  # (the outlines' plan from here)
        if n_reset or g2:
            orows = ints[:g]
            scans = {}

            def returns_of(j, orows=orows):  # (a vessel's returns and labels: once per step)
                k = orows[j]
                q = row_pos[k]
                got = scans.get(q)
                if got is None:  # (as they are when already contiguous (k, 2) float and int64: no calls)
                    if labels is None:
                        pts, lab = points[q], dets[q].labels
                    else:  # (the pass's labels: its detections not made)
                        off = labels[1]
                        pts, lab = points[q], labels[0][off[q]:off[q + 1]]
                    if not (type(pts) is np.ndarray and pts.dtype == np.float64 and pts.ndim == 2 and pts.shape[1] == 2
                            and pts.flags.c_contiguous):
                        pts = np.ascontiguousarray(pts, dtype=float).reshape(-1, 2)
                    if not (type(lab) is np.ndarray and lab.dtype == np.int64 and lab.flags.c_contiguous):
                        lab = np.ascontiguousarray(lab, dtype=np.int64)
                    got = scans[q] = (pts, lab)
                return got[0], got[1], int(idx[assigned[k]])

            outlines.grow_planned(ints[e:], geo, n_reset, g2, returns_of)
        if m:
            ids, det = ints[g:g + m], ints[g + m:g + 2 * m]
            f = ints[g + 2 * m:e].tolist()
            la = self._last_assign
            for q, o in enumerate(owners.tolist()):
                a, b = f[q], f[q + 1]
                if b > a:
                    la[o] = [(ids, det, a, b)]

    def _step_buffers(self, S: int, n: int, p: int, no: int) -> tuple:
        """The step's buffers for :func:`step_inputs_into` (S detections, n rows, p scanning vessels, no
        vessels): (ints, z, floats, flags), grown when too small. Views of them are the step's arrays,
        valid until the next step (nothing keeps them)."""
        got = self._bufs
        ni, nf = 2 * S + p + 4 * n, 2 * S + no + n
        if got is None or got[0].size < ni or got[1].shape[0] < S or got[2].size < nf or got[3].size < 2 * S:
            grow = lambda m: m + max(16, m // 2)
            self._made_views.clear()  # (views of the old buffers)
            got = self._bufs = (np.empty(grow(ni), dtype=np.int64), np.empty((grow(S), 2)), np.empty(grow(nf)),
                                np.empty(grow(2 * S), dtype=bool))
        return got

    def _step_views(self, M: int, n: int, k: int, p: int, no: int) -> tuple:
        """The step's arrays as views of its buffers (:meth:`_step_buffers`, as :func:`step_inputs_into` wrote
        them: M detections, n rows, k due rows, p scanning vessels, no vessels): (z, d_pos, idx, m_q, row_pos,
        rows, rpos, assigned, var, rad, t_own, var_row, occ, claimed) — made once per sizes and buffers (a
        tracker's steps repeat a few sizes), the same view objects for the same sizes."""
        key = (M, n, k, p, no)
        got = self._made_views.get(key)
        if got is None:
            ints, z, floats, flags = self._bufs
            c = 2 * M + p
            f = 2 * M + no
            if len(self._made_views) >= 256:
                self._made_views.clear()
            got = self._made_views[key] = (
                z[:M], ints[:M], ints[M:2 * M], ints[2 * M:c], ints[c:c + n], ints[c + n:c + n + k],
                ints[c + n + k:c + n + 2 * k], ints[c + n + 2 * k:c + 2 * n + 2 * k], floats[:M], floats[M:2 * M],
                floats[2 * M:f], floats[f:f + n], flags[:M], flags[M:2 * M])
        return got

    def _every_scan(self, p: int) -> np.ndarray:
        """(p,) all True, made once per p (never written): every vessel of a step has its returns."""
        got = self._all_true.get(p)
        if got is None:
            got = self._all_true[p] = np.ones(p, dtype=bool)
        return got

    def _meas_buffers(self, n: int) -> tuple:
        """(zr (n, 2), meas (n,)): the cycle's measurement rows, views of buffers grown when too small
        (valid until the next step)."""
        got = self._meas_bufs
        if got[1].size < n:
            m = n + max(16, n // 2)
            got = self._meas_bufs = (np.empty((m, 2)), np.empty(m, dtype=bool))
        return got[0][:n], got[1][:n]

    def _cycle(self, rows, all_due, row_pos, t_o, zr, meas, vr) -> np.ndarray:
        """Step 3: one IMM cycle of ``rows``, per group of vessels sharing their last and new time
        (one group, the whole bank, in the usual tick). Returns (n,) bool, the rows used."""
        bank = self.bank
        if all_due and bank.common_time_s is not None:  # every row's last cycle at one time (the bank's invariant)
            tl = t_o.tolist()  # (... and every vessel's scan at one time: (t_o == t_o[0]).all() on a short list)
            t0 = tl[0]
            if t0 == t0 and tl.count(t0) == len(tl):
                return bank.update_measured(zr, t0, meas, vr)  # (the step's arrays: update without checks)
        t_last = bank.times_s[rows]
        t_new = t_o[row_pos[rows]]
        if all_due and (t_last == t_last[0]).all() and (t_new == t_new[0]).all():
            return bank.update_measured(zr, float(t_new[0]), meas, vr)
        used = np.zeros(len(bank), dtype=bool)
        keys = np.stack([t_last, t_new], axis=-1)
        for tl, tn in np.unique(keys, axis=0).tolist():
            g = rows[(t_last == tl) & (t_new == tn)]
            used[g] = bank.update_rows(g, zr[g], tn, meas[g], None if vr is None else vr[g])
        return used
