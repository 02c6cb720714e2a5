"""The perception of a whole fleet in one pass per tick: every vessel's scan → detections → static
map → tracks, as arrays over the vessels (world ENU, SI).

Each vessel keeps its own :class:`mjasc.perception.pipeline.Perception` (what the agent calls:
``sense``, ``update_tracks``, ``tracks``, ``static_polygons``, ``set_team_positions``); the vessels
of one :class:`~mjasc.physics.world.World` share a :class:`PerceptionFleet` (``fleet_of(world)``)
that holds what can be shared: one :class:`~mjasc.perception.static_map.StaticMapStore` for all
their maps and one :class:`~mjasc.perception.tracking.fleet.FleetTracker` (one IMM bank) per
tracking configuration. A vessel's ``sense`` casts its own fan at once (``mj_multiRay``, MuJoCo's
floor, per vessel) and makes its draws into the fleet's :class:`~mjasc.perception.scan_batch.ScanBatch`;
``update_tracks`` queues the tracking step. The fleet then processes the queue in one pass:

* **sensing**: the tracked discs of every vessel's tracks at its scan time (arrays over the
  fleet's tracks); then one compiled call (:func:`~mjasc.perception.sense_pass.scan_detect_map`)
  makes every queued cast a :class:`~mjasc.perception.range_sensor.Scan`, detects over all scans
  (their returns stacked as the batch made them) and makes the map step up to the carving (wall
  fragments among the targets, static returns into the maps, the carving's candidates), and a
  second one carves the free space (:func:`~mjasc.perception.map_pass.carve_stacked`); when a
  wall's cluster swallowed a tracked boat's returns, the first call stops after the detection, those
  returns are re-clustered (only for the vessels where that happens) and the map step follows in
  two compiled calls (:func:`~mjasc.perception.map_pass.sense_map`);
* **tracking**: one :meth:`FleetTracker.step` for all vessels of a tracking configuration; a vessel
  with a plugin tracker (``[vessels.tracking] method``) gets its own ``update`` call, and its
  tracked discs come from its plugin's tracks (:func:`estimate_discs`).

A queue is processed when the fleet's last vessel (in the order they joined, which is the order the
runner calls them in) has been asked for the slot, or as soon as anything reads a result or changes
a vessel's inputs (``tracks()``, ``scan``, ``set_team_positions`` …), so a caller that drives one
vessel at a time sees exactly the per-vessel semantics. Every step is per return, per cluster, per
cell or per track, so each vessel's detections, map and tracks are the same bits as those of a
vessel processed alone (tests/test_fleet_perception.py).
"""

from __future__ import annotations

import time
import weakref
from dataclasses import dataclass

import numpy as np

from mjasc.perception.detection import detection_constants, empty_batch, packed_batch
from mjasc.perception.map_pass import carve_stacked, map_steps, sense_map
from mjasc.perception.owned_discs import inside_owned_discs
from mjasc.perception.scan_batch import ScanBatch
from mjasc.perception.sense_kernels import tracked_in_walls
from mjasc.perception.sense_pass import DETECTED, MAPPED, OUT_OF_RANGE, scan_detect_map, unpack
from mjasc.perception.static_map import StaticMap, StaticMapStore
from mjasc.perception.tracked_discs import DISC_MARGIN_M, DISC_MARGIN_MAX_M, estimate_discs, tracker_discs
from mjasc.perception.tracked_returns import split_in_pass
from mjasc.perception.tracking.fleet import FleetTracker
from mjasc.perception.tracking.tracker import MultiTargetTracker

__all__ = ["PerceptionFleet", "fleet_of", "DISC_MARGIN_M", "DISC_MARGIN_MAX_M", "FLAT_M", "estimate_discs"]

#: A small cluster on mapped cells is a fragment of the mapped structure only if its returns lie
#: within this (+ 2σ_ρ) RMS of a straight line (a 4 m hull seen over ≥ 60° of its side: ≥ 0.2 m) [m].
FLAT_M = 0.15

_FLEETS: dict[int, tuple] = {}


def fleet_of(world) -> "PerceptionFleet":
    """The :class:`PerceptionFleet` of a world (created on first use, dropped with the world)."""
    key = id(world)
    got = _FLEETS.get(key)
    if got is None or got[0]() is not world:
        got = (weakref.ref(world), PerceptionFleet())
        _FLEETS[key] = got
        weakref.finalize(world, _FLEETS.pop, key, None)
    return got[1]


def _starts(counts: np.ndarray) -> np.ndarray:
    out = np.zeros(counts.size, dtype=np.int64)
    np.cumsum(counts[:-1], out=out[1:])
    return out


def inside_owned(points, point_owner, centres, radii, disc_owner) -> np.ndarray:
    """(k,) bool: point k lies in one of its owner's discs. ``points`` (k, 2) grouped by owner
    (ascending), ``centres`` (q, 2) / ``radii`` (q,) grouped likewise; owners as small ints."""
    return inside_owned_discs(points, np.asarray(point_owner, dtype=np.int64), centres, radii,
                              np.asarray(disc_owner, dtype=np.int64))


def thickness(p: np.ndarray, labels: np.ndarray, m: int) -> np.ndarray:
    """(m,) RMS distance [m] of each cluster's returns from their principal line (0 for 1–2 returns)."""
    good = labels >= 0
    lab, q = labels[good], p[good]
    n = np.maximum(np.bincount(lab, minlength=m), 1)
    mean = np.stack([np.bincount(lab, q[:, i], m) for i in (0, 1)], axis=-1) / n[:, None]
    d = q - mean[lab]
    sxx, syy, sxy = (np.bincount(lab, w, m) / n for w in (d[:, 0] ** 2, d[:, 1] ** 2, d[:, 0] * d[:, 1]))
    tr = 0.5 * (sxx + syy)
    return np.sqrt(np.maximum(tr - np.sqrt(np.maximum(tr**2 - (sxx * syy - sxy**2), 0.0)), 0.0))


class PerceptionFleet:
    """The shared engine of the :class:`~mjasc.perception.pipeline.Perception` components of one world."""

    #: The sensing pass's map step inside its compiled call (False: after it, in Python and
    #: :func:`~mjasc.perception.map_pass.sense_map`: the reference form of tests/test_sense_pass.py).
    map_in_pass = True

    def __init__(self):
        self.members: list = []
        self.map_store = StaticMapStore()
        self._trackers: list[FleetTracker] = []
        self._batch = ScanBatch()  # the casts of the queued scans
        self._scans: list = []  # members queued for the sensing pass (their casts in _batch, in order)
        self._tracks: list = []  # members queued for the tracking pass
        self._plans: dict = {}  # _plan per combination of members
        self._sensed = None  # the last sensing pass's (members, detections, cut, their stack for FleetTracker.step, scans, return labels)
        self._busy = False

    def join(self, member) -> tuple[StaticMap, MultiTargetTracker | None]:
        """Register a vessel's perception; returns its map and tracker (views of the fleet's; no
        tracker for a vessel with a plugin tracker, ``member.method``)."""
        cfg = member.config
        if member.method is not None:
            self.members.append(member)
            return StaticMap(cfg.map_cell_m, cfg.map_min_hits, store=self.map_store), None
        ft = next((f for f in self._trackers if f.config == cfg), None)
        if ft is None:
            ft = FleetTracker(cfg)
            self._trackers.append(ft)
        self.members.append(member)
        return (StaticMap(cfg.map_cell_m, cfg.map_min_hits, store=self.map_store),
                MultiTargetTracker(cfg, member.sensor_config.max_range_m, fleet=ft))

    # ------------------------------------------------------------------ the queue
    def pending(self, member) -> bool:
        """The member has queued work."""
        return member in self._scans or member in self._tracks  # (a few members: identity tests in C)

    def queue_scan(self, member, data, rng) -> None:
        """Cast ``member``'s fan in ``data`` now (its draws from ``rng``) and queue the scan for the
        sensing pass (:class:`~mjasc.perception.scan_batch.ScanBatch`)."""
        if member in self._scans or member in self._tracks:  # (pending(member): processed first)
            self.flush()
        self._batch.add(member.sensor, data, rng)
        self._scans.append(member)

    def queue_track(self, member) -> None:
        if member in self._tracks:
            self.flush()
        self._tracks.append(member)

    def asked(self, member) -> None:
        """A slot call of ``member`` is done: the last member's ends the slot (process the queue)."""
        if member is self.members[-1]:
            self.flush()

    def flush(self) -> None:
        """Process the queued scans (sensing pass), then the queued tracking steps."""
        if self._busy or not (self._scans or self._tracks):
            return
        self._busy = True
        try:
            if self._scans:
                members, self._scans = self._scans, []
                w0 = time.perf_counter()
                self._sense(members, self._batch)
                share = (time.perf_counter() - w0) / len(members)
                for m in members:
                    m._stats["sense_s"] += share
            if self._tracks:
                members, self._tracks = self._tracks, []
                w0 = time.perf_counter()
                self._track(members)
                share = (time.perf_counter() - w0) / len(members)
                for m in members:
                    m._stats["track_s"] += share
        finally:
            self._busy = False

    # ------------------------------------------------------------------ sensing pass
    def _sense(self, members, casts: ScanBatch) -> None:
        """The sensing pass over the casts queued in ``casts`` (one per member, in order): the
        scans, detections and map update in one compiled call (:mod:`mjasc.perception.sense_pass`)
        with the carving after it, or, when a wall's cluster swallowed a tracked boat's returns,
        the detections split again and the map pass after them."""
        plan = self._plan(members)
        S = plan.index.shape[0]
        args, parts = casts.kernel_inputs()
        dc, dr, d_k = self._discs(members, parts[0][0], parts[3], plan)
        store = self.map_store
        slot = plan.slot  # map member of each slot
        c = plan.detection
        t = store.pass_tables(int(parts[2][1][S]))  # (room for every beam's return)
        cell_m = t[0]
        # (t[:11]: the store's cell_m, keys, key_rows, cells, member, score, n, cap, min_hits, n_occ, version)
        status, floats, points, hit, geom, ints, K, d, nc, bools, p_ints, p_floats, p_points, keys, key_rows, n = \
            scan_detect_map(*args, *plan.detection_args, self.map_in_pass, plan.sigma, dc, dr, d_k, FLAT_M, slot,
                            plan.carve_all, parts[2][6], *t[:11])
        dpoints, dfloats, dints, dflags, swallowed, targets, counts, cand, geo, rel = unpack(
            status, S, K, d, nc, bools, p_ints, p_floats, p_points)
        stack = casts.stack(parts, floats, points, hit, geom, ints, K)
        scans = stack.scans
        ret_off = stack.ret_off
        batch = packed_batch(scans, ret_off, K, dpoints, dfloats, dints, dflags, d) if K else \
            empty_batch(scans, ret_off)
        dets = batch.split()
        restacked = False
        pts = stack.hit_points_world
        det_off = batch.det_offsets
        extended, n_pts, centres = batch.extended, batch.n_points, batch.centres_m
        radii, variances, occluded, lab = batch.radii_m, batch.variances_m2, batch.occluded, batch.labels
        if status == MAPPED:
            carve_stacked(store, t, keys, key_rows, n, cand, geo, rel, stack, plan.sigma)
        else:  # (DETECTED: the map step not made in the compiled call, the reference form of tests/test_sense_pass.py)
            if status == DETECTED and d_k.size and extended.any():
                swallowed = tracked_in_walls(batch.labels, ret_off, det_off, extended, pts, dc, dr, d_k)
            if swallowed.any():  # a wall's cluster may have swallowed a tracked boat's returns
                d_cnt = np.bincount(d_k, minlength=S)
                d_off = _starts(d_cnt).tolist()
                for k in np.flatnonzero(swallowed).tolist():  # (split_tracked of each, compiled)
                    a, b = d_off[k], d_off[k] + int(d_cnt[k])
                    det = split_in_pass(k, dets[k], batch, stack, (dc, dr), a, b, c, (cell_m, keys, key_rows, *t[3:]),
                                        int(slot[k]), lambda: members[k]._split_tracked(scans[k], dets[k],
                                                                                         (dc[a:b], dr[a:b])))
                    restacked |= det is not dets[k]
                    dets[k] = det
            if restacked:  # stacked again
                n_det = np.array([len(d) for d in dets], dtype=np.int64)
                det_off = np.zeros(S + 1, dtype=np.int64)
                np.cumsum(n_det, out=det_off[1:])
                cat = np.concatenate
                lab = cat([d.labels for d in dets])
                extended = cat([d.extended for d in dets])
                n_pts = cat([d.n_points for d in dets])
                centres = cat([d.centres_m for d in dets])
                radii = cat([d.radii_m for d in dets])
                variances = cat([d.variances_m2 for d in dets])
                occluded = cat([d.occluded for d in dets])
            got = None if status == OUT_OF_RANGE else sense_map(
                store, lab, ret_off, det_off, extended, n_pts, centres, radii, variances, pts, plan.sigma, FLAT_M, dc,
                dr, d_k, slot, stack, plan.carve_all)
            if got is None:  # a return out of the map's range: the steps one by one raise the one-line error
                targets, counts = map_steps(store, lab, ret_off, det_off, extended, n_pts, centres, radii, variances,
                                            pts, plan.sigma, FLAT_M, dc, dr, d_k, slot, stack, plan.carve_all)
            else:
                targets, counts = got
        carve = plan.carve
        if carve and not plan.carve_all:
            sc = [scans[k] for k in carve]
            store.carve(slot[carve].tolist(), [s.origin_m for s in sc], [s.angles_body + s.heading_rad for s in sc],
                        [s.ranges for s in sc], [s.hit for s in sc], [s.max_range_m for s in sc],
                        [s.full_circle for s in sc], [members[k].sensor_config.range_noise_std_m for k in carve],
                        [s.hit_points_world for s in sc])
        # the pass's detections as the tracker stacks them (its tracking step takes them as they are; stacked
        # again when a split added some)
        cut = det_off.tolist()
        self._sensed = (members, dets, cut, (det_off[1:] - det_off[:-1], targets, centres, variances, radii, occluded),
                        stack, lab)
        for k, (m, c) in enumerate(zip(members, counts.tolist())):
            m._scanned(scans[k], dets[k], targets[cut[k]:cut[k + 1]], c)

    def _discs(self, members, scan_times: list, times: np.ndarray, plan: "_Plan"
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Centres (q, 2) and radii (q,) [m] of the tracks whose returns must never reach their
        vessel's map (:meth:`mjasc.perception.pipeline.Perception.tracked_discs`), at the vessel's
        scan time (``scan_times[k]``, ``times`` (S,) [s]), and the slot of that vessel (q,) (grouped by
        slot, ascending; within a slot in the order of its tracker's rows)."""
        parts = []
        for k in plan.plugins:
            c, r = members[k].tracked_discs(scan_times[k])
            parts.append((np.full(r.shape[0], k, dtype=np.int64), c, r))
        for ft, owner_slot in plan.trackers:
            if len(ft.bank) == 0:
                continue
            c, r, k = tracker_discs(ft, owner_slot, times)
            if k.size:
                parts.append((k, c, r))
        if not parts:
            return np.zeros((0, 2)), np.zeros(0), np.zeros(0, dtype=np.int64)
        if len(parts) == 1:  # (each part is in slot order already)
            k, c, r = parts[0]
            return c, r, k
        else:
            k = np.concatenate([p[0] for p in parts])
            c = np.concatenate([p[1] for p in parts])
            r = np.concatenate([p[2] for p in parts])
        order = np.argsort(k, kind="stable")
        return c[order], r[order], k[order]

    def _plan(self, members) -> "_Plan":
        """The constants of a sensing pass over these members, made once per combination of
        members (and of the trackers' owners)."""
        key = tuple(members)
        size = [ft.n_owners for ft in self._trackers]  # (a list: a generator is resumed once per tracker)
        got = self._plans.get(key)
        if got is None or got[0] != size:
            if len(self._plans) >= 64:
                self._plans.clear()
            trackers = []
            for ft in self._trackers:
                slots = [k for k, m in enumerate(members) if m._tracker is not None and m._tracker.fleet is ft]
                if slots:
                    owner_slot = np.full(ft.n_owners, -1, dtype=np.int64)
                    owner_slot[[members[k]._tracker.owner for k in slots]] = slots
                    trackers.append((ft, owner_slot))
            noise = [m.sensor_config.range_noise_std_m for m in members]
            dropout = [m.sensor_config.dropout_probability for m in members]
            c = detection_constants([m.sensor for m in members], [m.config.detection for m in members], noise, dropout)
            got = self._plans[key] = (size, _Plan(
                detection=c, detection_args=(*c.cluster_scan, c.beam_off, *c.per_scan[1:], *c.keep_scan),
                noise=noise, sigma=np.array(noise, dtype=float), dropout=dropout,
                slot=np.array([m._map.member for m in members], dtype=np.int64),
                carve=[k for k, m in enumerate(members) if m._map.miss_weight > 0],
                carve_all=all(m._map.miss_weight > 0 for m in members),
                index=np.arange(len(members)), plugins=[k for k, m in enumerate(members) if m.method is not None],
                trackers=trackers))
        return got[1]

    # ------------------------------------------------------------------ tracking pass
    def _track(self, members) -> None:
        for ft in self._trackers:
            ms = [m for m in members if m._tracker is not None and m._tracker.fleet is ft]
            if not ms:
                continue
            dets = [m._det for m in ms]
            got = self._from_pass(ms, dets)
            if got is None:  # (each member's inputs: owners, times, origins, targets, returns)
                owners, times, origins, targets, returns = map(list, zip(*[
                    (m._tracker.owner, m._det.time_s, m._scan.origin_m, m._targets, m._scan.hit_points_world)
                    for m in ms]))
                stacked = labels = None
            else:  # (the sensing pass's arrays: the scans' and detections' fields not made)
                times, origins, returns, stacked, labels = got
                owners = [m._tracker.owner for m in ms]
                targets = [m._targets for m in ms]
            ft.step(owners, times, dets, origins, targets, returns, stacked, labels)
        for m in members:
            if m.method is not None:
                m._track_with_method()
        for m in members:
            m._tracked()

    def _from_pass(self, ms, dets) -> tuple | None:
        """What :meth:`FleetTracker.step` takes of the members ``ms`` with the detections ``dets``,
        read from the last sensing pass's arrays when they are consecutive slots of it and its
        detections: the scan times (p,) [s], origins (p, 2) [m], each scan's returns (k, 2) [m] and
        the detections stacked as the step takes them (views of the pass's arrays: no stacking
        again) and the pass's return labels with these scans' return offsets into them (the step's
        ``labels``); None otherwise."""
        sensed = self._sensed
        if sensed is None:
            return None
        members, got, cut, full, stack, labels = sensed
        p, S = len(ms), len(members)
        k0 = 0
        if p != S:
            for k0 in range(S - p + 1):
                if members[k0] is ms[0]:
                    break
            else:
                return None
        for j in range(p):
            if members[k0 + j] is not ms[j] or got[k0 + j] is not dets[j]:
                return None
        if p == S:
            stacked = full
        else:
            a, b = cut[k0], cut[k0 + p]
            lens, sel, cen, var, rad, occ = full
            stacked = lens[k0:k0 + p], sel[a:b], cen[a:b], var[a:b], rad[a:b], occ[a:b]
        ro, world = stack.ret_off[k0:k0 + p + 1].tolist(), stack.hit_points_world
        returns = [world[ro[j]:ro[j + 1]] for j in range(p)]
        return stack.times_s[k0:k0 + p], stack.origins_m[k0:k0 + p], returns, stacked, (labels, ro)


@dataclass(frozen=True, eq=False)
class _Plan:
    """What a sensing pass over one combination of members (slots 0 … S−1) needs of them: the
    detection's per-scan constants (:func:`~mjasc.perception.detection.detection_constants`) and
    those as :func:`~mjasc.perception.sense_pass.scan_detect_map` takes them (one tuple); per
    slot σ_ρ (list and array), dropout probability, map member, the slot index; the slots whose
    maps carve (``carve_all``: every slot's); the slots with a plugin tracker; per fleet tracker with members among them
    (tracker, the slot of each of its owner indices, −1: not among them)."""

    detection: object
    detection_args: tuple
    noise: list
    sigma: np.ndarray
    dropout: list
    slot: np.ndarray
    carve: list
    carve_all: bool
    index: np.ndarray
    plugins: list
    trackers: list
