"""One vessel's perception: its range sensor, detections, static map and multi-target IMM tracks.

The component the runner attaches to a vessel with a ``[vessels.sensor]`` or ``[vessels.tracking]``
table (interface in :class:`mjasc.runs.agent.VesselAgent`)::

    sense(t, nav)          scan (at the sensor's rate) → detections; extended ones → static map
    update_tracks(t, nav)  the scan's target detections → MultiTargetTracker (one batched IMM bank)
    tracks()               confirmed tracks as TrackEstimate (world ENU, SI)
    static_polygons()      convex polygons of the mapped static structures
    set_team_positions(d)  {name: (t, position)} from the comms link: marks team-mate tracks
    drain_events()         [(t, text)]: tracks confirmed, lost, merged (births stay in the recording)
    log(recorder, t, name) Rerun (mjasc.perception.recording): tracks as labelled points, the map;
                           with full detail returns, detections, 2-σ ellipses, velocity arrows,
                           ω̂ and mode probabilities per track, track events
    summary()              counts and timings for summary.json

Which returns feed what: a cluster wider than a target (``detection.max_target_radius_m``) is a
static structure and goes to the map; so does a small, flat cluster lying on already mapped cells
(a fragment of a wall seen at grazing incidence). Returns within a tracked disc (a confirmed
moving track, or one that moved and stopped, predicted to the scan time) are kept out of the map,
and those of them that a wall's cluster swallowed are clustered again and given to the tracker (a
boat passing along a quay keeps its track). Each scan also frees the map cells its rays pass
through (:meth:`mjasc.perception.static_map.StaticMap.carve`). Everything else goes to the tracker. Nothing here reads
another body's state from the simulator: only the scan (ranges along known beams) and the vessel's
own pose.
"""

from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np

from mjasc.perception.detection import Detections, detect
from mjasc.perception.range_sensor import Scan, SensorConfig, sensor_for_vessel
from mjasc.perception.static_map import StaticMap
from mjasc.perception.tracking.config import TrackingConfig
from mjasc.perception.tracking.tracker import MultiTargetTracker

__all__ = ["Perception", "covariance_ellipse"]

#: A tracked disc (returns kept out of the map) is the track's radius + this + 2σ of its position [m]
_DISC_MARGIN_M = 1.0
#: ... at most this beyond its radius (a long-coasting track must not blank a whole wall) [m].
_DISC_MARGIN_MAX_M = 2.5
#: A small cluster on mapped cells is a fragment of the mapped structure only if its returns lie
#: within this (+ 2σ_ρ) RMS of a straight line (a 4 m hull seen over ≥ 60° of its side: ≥ 0.2 m) [m].
_FLAT_M = 0.15
#: A confirmed track that moved this far from where it was confirmed stays "moving" for the map [m].
_MOVED_M = 3.0


def covariance_ellipse(centre, cov, n_sigma: float = 2.0, points: int = 33) -> np.ndarray:
    """Closed contour (points, 2) of the n-σ ellipse of a 2×2 covariance, world frame: centre +
    n·L·[cos t, sin t] with L the Cholesky-like factor V·√Λ (so it is rotated correctly)."""
    lam, vec = np.linalg.eigh(np.asarray(cov, dtype=float))
    lam = np.maximum(lam, 0.0)
    t = np.linspace(0.0, 2.0 * np.pi, points)
    circle = np.stack([np.cos(t), np.sin(t)], axis=0)
    return np.asarray(centre) + (n_sigma * (vec * np.sqrt(lam)) @ circle).T


class Perception:
    def __init__(self, world, vessel_index: int, sensor_config: SensorConfig | None,
                 tracking_config: TrackingConfig | None, rng: np.random.Generator):
        self.sensor_config = SensorConfig() if sensor_config is None else sensor_config
        self.config = TrackingConfig() if tracking_config is None else tracking_config
        self.world = world
        self.vessel_index = int(vessel_index)
        self.name = world.vessel_names[vessel_index]
        self.sensor = sensor_for_vessel(world, vessel_index, self.sensor_config)
        self.rng = rng
        self.tracker = MultiTargetTracker(self.config, self.sensor_config.max_range_m)
        self.map = StaticMap(self.config.map_cell_m, self.config.map_min_hits)
        self.scan: Scan | None = None
        self.detections: Detections | None = None
        self._target_mask = np.zeros(0, dtype=bool)
        self._anchor: dict[int, np.ndarray] = {}  # confirmed track id → where it was first confirmed
        self._moved: set[int] = set()  # ids of confirmed tracks that have moved _MOVED_M from there
        self._next_scan_t = -math.inf
        self._pending = False  # a scan not yet given to the tracker
        self._drain: list[tuple[float, str]] = []
        self._log_events: list = []
        self._log = None  # PerceptionLog (mjasc.perception.recording), made at the first log()
        self.keep_history = False
        self.history: list[tuple] = []  # (t, id, x, y, θ, V, ω, team, static) of confirmed tracks
        self._stats = {"scans": 0, "returns": 0, "detections": 0, "target_detections": 0,
                       "sense_s": 0.0, "track_s": 0.0, "track_updates": 0, "max_tracks": 0}

    # ---------------------------------------------------------------- slots
    def sense(self, t_s: float, nav=None) -> None:
        """Take a scan if one is due and turn it into detections."""
        if t_s < self._next_scan_t - 1e-9:
            return
        w0 = time.perf_counter()
        self._next_scan_t = t_s + 1.0 / self.sensor_config.rate_hz
        scan = self.sensor.scan(self.world.data, self.rng)
        det = detect(scan, self.config.detection, self.sensor_config.range_noise_std_m)
        pts = scan.hit_points_world
        discs = self._tracked_discs(scan.time_s)
        if len(det) and det.extended.any() and discs[0].shape[0]:
            det = self._split_tracked(scan, det, discs)
        targets = det.targets.copy()
        labels = det.labels
        if len(det):
            if self.map.n_occupied and targets.any():
                occ = self.map.occupied(pts)
                good = labels >= 0
                frac = np.bincount(labels[good], weights=occ[good], minlength=len(det)) / np.maximum(det.n_points, 1)
                on_map = targets & (frac >= 0.5) & ~_inside(det.centres_m, *discs)
                if on_map.any():  # a wall fragment is flat; a hull's returns curve round it
                    on_map &= _thickness(pts, labels, len(det)) <= _FLAT_M + 2.0 * self.sensor_config.range_noise_std_m
                targets &= ~on_map
            static = ~targets
            good_static = (labels >= 0) & static[np.maximum(labels, 0)]
            if good_static.any():
                p = pts[good_static]
                self.map.add_scan(p[~_inside(p, *discs)])
        if self.map.miss_weight > 0:
            self.map.carve(scan.origin_m, scan.angles_body + scan.heading_rad, scan.ranges, scan.hit,
                           scan.max_range_m, scan.full_circle, self.sensor_config.range_noise_std_m, pts)
        self.scan, self.detections, self._target_mask = scan, det, targets
        self._pending = True
        st = self._stats
        st["scans"] += 1
        st["returns"] += int(scan.hit_beams.size)
        st["detections"] += len(det)
        st["target_detections"] += int(targets.sum())
        st["sense_s"] += time.perf_counter() - w0

    def _tracked_discs(self, t_s: float) -> tuple[np.ndarray, np.ndarray]:
        """Centres (q, 2) and radii (q,) [m] of the confirmed tracks whose returns must never reach
        the map, predicted to the scan time t_s: every moving track, and every static one that was
        seen to move (a boat that stopped; ``_MOVED_M`` from where it was confirmed). The centre is
        the combined estimate advanced along its arc (thesis eq. 3.3 with ω̂, one step of dt = t_s −
        its last update: a coasting track is predicted, not left where it was last seen); the
        radius is the track's radius + 1 m + 2σ of its position (at most ``_DISC_MARGIN_MAX_M``)."""
        tr = self.tracker
        if len(tr) == 0:
            return np.zeros((0, 2)), np.zeros(0)
        bank = tr.bank
        ids = bank.track_ids
        moved = np.fromiter((int(i) in self._moved for i in ids), dtype=bool, count=ids.size)
        sel = tr.confirmed & (~tr.static | moved)
        if not sel.any():
            return np.zeros((0, 2)), np.zeros(0)
        x = bank.states[sel]
        dt = np.maximum(t_s - bank.times_s[sel], 0.0)
        th = x[:, 2] + 0.5 * dt * bank.turn_rates[sel]
        c = x[:, :2] + (dt * x[:, 3])[:, None] * np.stack([np.cos(th), np.sin(th)], axis=-1)
        P = bank.position_covariances[sel]
        tr_ = 0.5 * (P[:, 0, 0] + P[:, 1, 1])
        lam = tr_ + np.sqrt(np.maximum(tr_**2 - (P[:, 0, 0] * P[:, 1, 1] - P[:, 0, 1] ** 2), 0.0))
        r = tr.radii_m[sel] + np.minimum(_DISC_MARGIN_M + 2.0 * np.sqrt(lam), _DISC_MARGIN_MAX_M)
        return c, r

    def _split_tracked(self, scan: Scan, det: Detections, discs) -> Detections:
        """The returns of extended clusters that lie in a tracked disc (``_tracked_discs``) taken out
        of their cluster and clustered again on their own, as target detections: a boat close to a
        wall (or to another boat) whose returns joined the wall's cluster keeps its track updated
        instead of being written into the map as part of the wall."""
        lab = det.labels
        good = lab >= 0
        take = good & det.extended[np.maximum(lab, 0)] & _inside(scan.hit_points_world, *discs)
        if take.any() and self.map.n_occupied:  # the wall behind, where it is mapped, stays the wall's
            take[take] = ~self.map.occupied(scan.hit_points_world[take])
        if not take.any():
            return det
        mask = np.zeros_like(scan.hit)
        beams = scan.hit_beams[take]
        mask[beams] = True
        sub = replace(scan, hit=mask, ranges=np.where(mask, scan.ranges, scan.max_range_m), hit_beams=beams,
                      hit_points_body=scan.hit_points_body[take], hit_points_world=scan.hit_points_world[take])
        extra = detect(sub, self.config.detection, self.sensor_config.range_noise_std_m)
        if len(extra) == 0:
            return det
        # only what looks like a tracked object: a disc no larger than the track's, centred within
        # its radius of the predicted centre (a piece of the wall beside it stays the wall's)
        c, r = discs
        d = np.hypot(*(extra.centres_m[:, None, :] - c[None, :, :]).transpose(2, 0, 1))
        core = r - _DISC_MARGIN_M
        fits = ((d <= core[None, :]) & (extra.radii_m[:, None] <= core[None, :] + 0.5)).any(axis=1) & ~extra.extended
        if not fits.any():
            return det
        keep = np.flatnonzero(fits)
        new = np.full(len(extra), -1)
        new[keep] = np.arange(keep.size) + len(det)
        sub_lab = np.where(extra.labels >= 0, new[np.maximum(extra.labels, 0)], -1)
        labels = lab.copy()
        labels[take] = np.where(sub_lab >= 0, sub_lab, lab[take])
        extra = _subset(extra, keep)
        cat = lambda a, b: np.concatenate([a, b])  # noqa: E731
        occ = None if det.occluded is None else cat(det.occluded, extra.occluded)
        return Detections(det.time_s, det.origin_m, det.heading_rad, cat(det.centres_m, extra.centres_m),
                          cat(det.centres_body, extra.centres_body), cat(det.radii_m, extra.radii_m),
                          cat(det.variances_m2, extra.variances_m2), cat(det.n_points, extra.n_points),
                          cat(det.ranges_m, extra.ranges_m), cat(det.extended, extra.extended), labels, occ)

    def update_tracks(self, t_s: float, nav=None) -> None:
        """Give the latest scan's target detections to the tracker (nothing new: nothing to do)."""
        if not self._pending:
            return
        w0 = time.perf_counter()
        self._pending = False
        det = self.detections
        self.tracker.step(det.time_s if det is not None else t_s, det, self.scan.origin_m, self._target_mask,
                          points_m=self.scan.hit_points_world)
        self._note_moved_tracks()
        for ev in self.tracker.drain_events():
            self._log_events.append(ev)
            if ev.kind != "born":
                self._drain.append((ev.time_s, ev.text))
        st = self._stats
        st["track_s"] += time.perf_counter() - w0
        st["track_updates"] += 1
        st["max_tracks"] = max(st["max_tracks"], len(self.tracker))
        if self.keep_history:
            self._append_history()

    def _note_moved_tracks(self) -> None:
        """Remember the confirmed tracks that have moved ``_MOVED_M`` from where they were first
        seen confirmed (their returns stay out of the map even after they stop)."""
        tr = self.tracker
        ids = tr.bank.track_ids
        conf = tr.confirmed
        pos = tr.bank.positions
        live = set()
        for k in np.flatnonzero(conf):
            i = int(ids[k])
            live.add(i)
            a = self._anchor.setdefault(i, pos[k].copy())
            if i not in self._moved and np.hypot(*(pos[k] - a)) >= _MOVED_M:
                self._moved.add(i)
        if len(self._anchor) > len(live):
            self._anchor = {i: a for i, a in self._anchor.items() if i in live}
            self._moved &= live

    def _append_history(self) -> None:
        tr = self.tracker
        if len(tr) == 0:
            return
        bank = tr.bank
        x, w, ids, t = bank.states, bank.turn_rates, bank.track_ids, bank.times_s
        conf, team, static = tr.confirmed, tr.team_members, tr.static
        for k in np.flatnonzero(conf):
            self.history.append((float(t[k]), int(ids[k]), *map(float, x[k]), float(w[k]), team[k], bool(static[k])))

    def tracks(self):
        """Confirmed tracks (list of :class:`mjasc.core.estimates.TrackEstimate`)."""
        return self.tracker.estimates()

    def static_polygons(self) -> list[np.ndarray]:
        """Convex polygons (k, 2) [m] of the static structures mapped so far."""
        return self.map.polygons()

    def set_team_positions(self, positions: dict) -> None:
        self.tracker.set_team_positions(positions)

    def drain_events(self) -> list[tuple[float, str]]:
        ev, self._drain = self._drain, []
        return ev

    def history_arrays(self) -> dict:
        """The kept history (``keep_history = True``) as arrays: t, id, x, y, heading, speed, omega."""
        h = self.history
        cols = ("t", "id", "x", "y", "heading", "speed", "omega")
        if not h:
            return {c: np.zeros(0) for c in cols}
        a = np.array([row[:7] for row in h], dtype=float)
        out = {c: a[:, i] for i, c in enumerate(cols)}
        out["id"] = out["id"].astype(int)
        return out

    # ---------------------------------------------------------------- recording
    def log(self, recorder, t_s: float, vessel_name: str) -> None:
        """Draw this vessel's perception in the recording (:mod:`mjasc.perception.recording`)."""
        if self._log is None:
            from mjasc.perception.recording import PerceptionLog

            self._log = PerceptionLog()
        self._log.log(recorder, t_s, self, vessel_name)

    # ---------------------------------------------------------------- results
    def summary(self) -> dict:
        st = self._stats
        c = self.tracker.counts
        scans = max(st["scans"], 1)
        ups = max(st["track_updates"], 1)
        ests = self.tracks()
        return {
            "scans": st["scans"],
            "mean_returns_per_scan": round(st["returns"] / scans, 2),
            "mean_detections_per_scan": round(st["detections"] / scans, 3),
            "mean_target_detections_per_scan": round(st["target_detections"] / scans, 3),
            "tracks_born": c["born"],
            "tracks_confirmed": c["confirmed"],
            "tracks_lost": c["lost"],
            "tracks_merged": c["merged"],
            "confirmed_tracks_now": len(ests),
            "team_tracks_now": sum(e.team_member is not None for e in ests),
            "static_tracks_now": sum(e.is_static for e in ests),
            "max_tracks_in_bank": st["max_tracks"],
            "static_polygons": len(self.static_polygons()),
            "mapped_cells": self.map.n_occupied,
            "mean_sense_us": round(1e6 * st["sense_s"] / scans, 1),
            "mean_tracking_us": round(1e6 * st["track_s"] / ups, 1),
        }


def _subset(d: Detections, keep: np.ndarray) -> Detections:
    """The detections ``keep`` of d (labels not remapped: the caller does)."""
    return Detections(d.time_s, d.origin_m, d.heading_rad, d.centres_m[keep], d.centres_body[keep], d.radii_m[keep],
                      d.variances_m2[keep], d.n_points[keep], d.ranges_m[keep], d.extended[keep], d.labels,
                      None if d.occluded is None else d.occluded[keep])


def _thickness(p: np.ndarray, labels: np.ndarray, m: int) -> np.ndarray:
    """(m,) RMS distance [m] of each cluster's returns from their principal line (0 for 1–2 returns)."""
    good = labels >= 0
    lab, q = labels[good], p[good]
    n = np.maximum(np.bincount(lab, minlength=m), 1)
    mean = np.stack([np.bincount(lab, q[:, i], m) for i in (0, 1)], axis=-1) / n[:, None]
    d = q - mean[lab]
    sxx, syy, sxy = (np.bincount(lab, w, m) / n for w in (d[:, 0] ** 2, d[:, 1] ** 2, d[:, 0] * d[:, 1]))
    tr = 0.5 * (sxx + syy)
    return np.sqrt(np.maximum(tr - np.sqrt(np.maximum(tr**2 - (sxx * syy - sxy**2), 0.0)), 0.0))


def _inside(p: np.ndarray, centres: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """(k,) bool: point p (k, 2) lies in one of the discs (centres (q, 2), radii (q,))."""
    if p.shape[0] == 0 or centres.shape[0] == 0:
        return np.zeros(p.shape[0], dtype=bool)
    d2 = ((p[:, None, :] - centres[None, :, :]) ** 2).sum(-1)
    return (d2 <= radii[None, :] ** 2).any(axis=1)

