"""One vessel's perception: its range sensor, detections, static map and multi-target IMM tracks.

The component the runner attaches to a vessel with a ``[vessels.sensor]`` or ``[vessels.tracking]``
table (interface in :class:`mjasc.runs.agent.VesselAgent`)::

    sense(t, nav)          scan (at the sensor's rate) → detections; extended ones → static map
    update_tracks(t, nav)  the scan's target detections → MultiTargetTracker (the fleet's IMM bank)
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

**Tracking methods.** ``tracking_config`` is the scenario's choice
(:class:`~mjasc.plugins.registry.MethodChoice` of ``[vessels.tracking] method``), or a
:class:`~mjasc.perception.tracking.config.TrackingConfig` / None for the built-in ``imm``. The
built-in runs on the fleet path below. Any other :class:`~mjasc.plugins.stages.TrackingMethod` (a
plugin) is built from ``context`` (:class:`~mjasc.plugins.context.StageContext`) and gets, at each
tracking step, ``update(t, nav, detections)`` with the scan's target detections only (not the
structures that went to the map; no scan, no truth); its ``tracks()`` are this perception's tracks.
The sensor, the detection, the static map and the team-mate marking stay here: a plugin's confirmed
moving tracks (predicted to the scan time, radius + margin) keep their returns out of the map, and
its tracks are matched to the team's broadcasts as the built-in's are (by position, extrapolated
back to the broadcast time). A plugin's ``Options`` may carry ``detection``, ``map_cell_m``,
``map_min_hits``, ``team_match_distance_m`` and ``team_max_age_s`` (as in
:class:`~mjasc.perception.tracking.config.TrackingConfig`) to set what the perception does around
it; otherwise their defaults.

**Fleet.** A vessel's perception is a member of its world's
:class:`~mjasc.perception.fleet.PerceptionFleet`: ``sense`` casts the fan at once and queues the
scan, ``update_tracks`` queues the tracking step, and the fleet processes every vessel's queued
work in one pass (after the last vessel was asked, or when a result is read: ``scan``,
``detections``, ``tracker``, ``map``, ``tracks()`` … flush the queue first). The map and the
tracker are views of the fleet's (one store of cells, one IMM bank per tracking configuration).
"""

from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np

from mjasc.core.estimates import predicted_to
from mjasc.core.geometry import covariance_ellipse  # noqa: F401  (re-exported: its home before core.geometry)
from mjasc.perception.detection import Detections
from mjasc.perception.fleet import PerceptionFleet, fleet_of
from mjasc.perception.plugin_tracks import TracksView, mark_team
from mjasc.plugins.answers import events_answer, tracks_answer
from mjasc.plugins.registry import builtin_method
from mjasc.perception.range_sensor import Scan, SensorConfig, sensor_for_vessel
from mjasc.perception.static_map import StaticMap
from mjasc.perception.track_history import history_arrays, history_rows, plugin_history_rows
from mjasc.perception.tracked_discs import estimate_discs
from mjasc.perception.tracked_returns import split_tracked, targets_only
from mjasc.perception.tracking.config import TrackingConfig
from mjasc.perception.tracking.fleet import TrackEvent
from mjasc.perception.tracking.method import IMMMethod
from mjasc.perception.tracking.team import TeamMatcher
from mjasc.plugins.context import StageContext
from mjasc.plugins.registry import MethodChoice

#: Fields of a tracking plugin's ``Options`` that set the perception around it (as in TrackingConfig).
PERCEPTION_FIELDS = ("detection", "map_cell_m", "map_min_hits", "team_match_distance_m", "team_max_age_s")

__all__ = ["Perception", "covariance_ellipse"]


class Perception:
    """One vessel's perception (see the module docstring); a member of its world's
    :class:`~mjasc.perception.fleet.PerceptionFleet` (``fleet``: another one to join).
    ``tracking_config``: a :class:`~mjasc.plugins.registry.MethodChoice`, a TrackingConfig or None
    (the built-in ``imm``); ``context``: what a plugin tracker is built from (default: the
    vessel's name, type and sensor, a stream seeded by the vessel index)."""

    def __init__(self, world, vessel_index: int, sensor_config: SensorConfig | None,
                 tracking_config: TrackingConfig | MethodChoice | None, rng: np.random.Generator,
                 fleet: PerceptionFleet | None = None, context: StageContext | None = None):
        self.sensor_config = SensorConfig() if sensor_config is None else sensor_config
        self.world = world
        self._data = world.data  # (its MjData, what the scans read: the world's physics is never reloaded)
        self.vessel_index = int(vessel_index)
        self.name = world.vessel_names[vessel_index]
        self.method = None  # a plugin TrackingMethod (None: the built-in fleet IMM)
        if isinstance(tracking_config, MethodChoice):
            if tracking_config.cls is IMMMethod:
                tracking_config = tracking_config.options
            else:
                if context is None:
                    context = StageContext(self.name, world.vessel_types[vessel_index], sensor=self.sensor_config,
                                           rng=np.random.default_rng([self.vessel_index, 4]))
                elif context.sensor is None:  # no [vessels.sensor] table: the default sensor it runs
                    context = replace(context, sensor=self.sensor_config)
                self.method = tracking_config.build(context)
                opts = tracking_config.options
                tracking_config = TrackingConfig(**{k: getattr(opts, k) for k in PERCEPTION_FIELDS if hasattr(opts, k)})
        self.config = TrackingConfig() if tracking_config is None else tracking_config
        self.sensor = sensor_for_vessel(world, vessel_index, self.sensor_config)
        self.rng = rng
        if self.method is not None:
            self._method_tracks: tuple = ()
            self._method_view = None
            self._method_ids: set = set()  # the ids of its tracks now
            self._method_seen: set = set()  # every id it ever reported
            self._method_lost = 0
            self._team = TeamMatcher(self.config)
            self._has_team = False
            self._nav = None
        self.fleet = fleet_of(world) if fleet is None else fleet
        self._map, self._tracker = self.fleet.join(self)
        self._scan: Scan | None = None
        self._det: Detections | None = None
        self._targets = np.zeros(0, dtype=bool)
        self._next_scan_t = -math.inf
        self._pending = False  # a scan not yet given to the tracker
        self._drain: list[tuple[float, str]] = []
        self._log_events: list = []
        self._log = None  # PerceptionLog (mjasc.perception.recording), made at the first log()
        self._fusion = None  # TeamTrackFusion, made when team tracks first arrive (share_tracks)
        self.keep_history = False
        self.history: list[tuple] = []  # (t, id, x, y, θ, V, ω, team, static) of confirmed tracks
        self._stats = {"scans": 0, "returns": 0, "detections": 0, "target_detections": 0,
                       "non_finite_detections_dropped": 0, "sense_s": 0.0, "track_s": 0.0, "track_updates": 0,
                       "max_tracks": 0}

    # ---------------------------------------------------------------- state (read after the fleet's pass)
    @property
    def scan(self) -> Scan | None:
        """The latest scan."""
        self.fleet.flush()
        return self._scan

    @property
    def detections(self) -> Detections | None:
        """The latest scan's detections."""
        self.fleet.flush()
        return self._det

    @property
    def tracker(self):
        """The vessel's :class:`~mjasc.perception.tracking.MultiTargetTracker` (a view of the fleet's);
        with a plugin tracker, its confirmed tracks read the same way (what the recording draws)."""
        self.fleet.flush()
        if self.method is not None:
            if self._method_view is None:
                self._method_view = TracksView(self._method_tracks)
            return self._method_view
        return self._tracker

    @property
    def map(self) -> StaticMap:
        """The vessel's :class:`~mjasc.perception.static_map.StaticMap` (a view of the fleet's store)."""
        self.fleet.flush()
        return self._map

    def target_detections(self) -> Detections | None:
        """The latest scan's target detections (the structures that went to the map left out,
        returns' labels renumbered): what a tracker is given (a plugin's ``update``)."""
        self.fleet.flush()
        return None if self._det is None else targets_only(self._det, self._targets)

    @property
    def _target_mask(self) -> np.ndarray:
        self.fleet.flush()
        return self._targets

    # ---------------------------------------------------------------- slots
    def sense(self, t_s: float, nav=None) -> None:
        """Take a scan if one is due (the fan is cast now) and queue it for the fleet's pass, which
        turns it into detections and map updates."""
        fleet = self.fleet
        if t_s >= self._next_scan_t - 1e-9:
            w0 = time.perf_counter()
            # the next scan is due one period after this one was (not after the slot that took it): a rate
            # that does not divide the slots' keeps its mean (2 Hz on 5 Hz slots: 0, 0.6, 1.0, 1.6, …), and
            # one a slot late never falls further behind than the slot it is taken at
            period = 1.0 / self.sensor_config.rate_hz
            due = self._next_scan_t
            self._next_scan_t = t_s + period if due == -math.inf else max(due + period, t_s)
            fleet.queue_scan(self, self._data, self.rng)  # (its previous scan, if still queued, processed first)
            self._stats["sense_s"] += time.perf_counter() - w0
            self._pending = True
        if self is fleet.members[-1]:  # (fleet.asked(self), inline: the last member's call ends the slot)
            fleet.flush()

    def _scanned(self, scan: Scan, det: Detections, targets: np.ndarray, counts) -> None:
        """The fleet's sensing pass is done with this vessel's scan: its detections, the targets
        among them (non-finite ones already dropped: the boundary, a non-finite detection never
        reaches the tracker) and ``counts`` (returns, detections, targets, non-finite targets
        dropped; :func:`mjasc.perception.sense_kernels.sort_returns`)."""
        st = self._stats
        n_ret, n_det, n_tgt, n_bad = counts
        if n_bad:
            st["non_finite_detections_dropped"] += n_bad
        self._scan, self._det, self._targets = scan, det, targets
        st["scans"] += 1
        st["returns"] += n_ret
        st["detections"] += n_det
        st["target_detections"] += n_tgt

    def _split_tracked(self, scan: Scan, det: Detections, discs) -> Detections:
        """The returns of extended clusters that lie in a tracked disc taken out of their cluster
        and clustered again on their own, as target detections
        (:func:`mjasc.perception.tracked_returns.split_tracked`, with this vessel's map and settings)."""
        return split_tracked(scan, det, discs, self._map, self.config.detection, self.sensor_config.range_noise_std_m,
                             self.sensor_config.dropout_probability)

    def update_tracks(self, t_s: float, nav=None) -> None:
        """Queue the latest scan's target detections for the fleet's tracking pass (nothing new:
        nothing to do)."""
        if self._pending:
            self._pending = False
            if self.method is not None:
                self._nav = nav
            self.fleet.queue_track(self)
        fleet = self.fleet
        if self is fleet.members[-1]:  # (fleet.asked(self) without its call: the last member's ends the slot)
            fleet.flush()

    def _track_with_method(self) -> None:
        """The tracking step of a plugin tracker (the fleet's tracking pass calls it): the scan's
        target detections to ``update``, then its tracks, marked with team mates."""
        det = self._det
        self.method.update(det.time_s, self._nav, targets_only(det, self._targets))
        tracks = tracks_answer(self.method, self.name, det.time_s)
        if self._has_team and tracks:
            tracks = mark_team(self._team, tracks, det.time_s)
        ids = {e.track_id for e in tracks}
        self._method_lost += len(self._method_ids - ids)
        self._method_ids = ids
        self._method_seen |= ids
        self._method_tracks, self._method_view = tracks, None

    def _tracked(self) -> None:
        """The fleet's tracking pass is done with this vessel's scan."""
        if self.method is not None:
            drained = self.method.drain_events()
            if not builtin_method(type(self.method)):
                drained = events_answer(self.method, drained)
            events = [TrackEvent(t, "event", -1, text) for t, text in drained]
            n = len(self._method_tracks)
        else:
            tr = self._tracker
            ft, o = tr.fleet, tr.owner
            events = ft.events[o]  # (tr.drain_events() without its call)
            if events:
                ft.events[o] = []
            n = ft.n_rows(o)  # (= len(tr))
        for ev in events:
            self._log_events.append(ev)
            if ev.kind != "born":
                self._drain.append((ev.time_s, ev.text))
        st = self._stats
        st["track_updates"] += 1
        if n > st["max_tracks"]:
            st["max_tracks"] = n
        if self.keep_history:
            self._append_history()

    def _append_history(self) -> None:
        self.history.extend(plugin_history_rows(self._method_tracks) if self.method is not None
                            else history_rows(self.tracker))

    def tracks(self):
        """Confirmed tracks (list of :class:`mjasc.core.estimates.TrackEstimate`)."""
        if self.method is not None:
            self.fleet.flush()
            return list(self._method_tracks)
        return self.tracker.estimates()

    def scored_tracks(self, t_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Ids (k,), positions (k, 2) [m] predicted to ``t_s`` along each track's velocity
        (:func:`~mjasc.core.estimates.predicted_to`) and static flags (k,) of the confirmed
        tracks, in the order of :meth:`tracks` (those estimates' ``track_id``, ``position_m`` moved on
        to t_s, ``is_static``): what a run's evaluation compares with the truth at a record tick."""
        if self.method is not None:
            tracks = self.tracks()
            return (np.array([e.track_id for e in tracks], dtype=np.int64),
                    predicted_to([e.position_m for e in tracks], [e.time_s for e in tracks],
                                 [e.heading_rad for e in tracks], [e.speed_m_s for e in tracks], t_s),
                    np.array([e.is_static for e in tracks], dtype=bool))
        return self.tracker.scored_positions(t_s)

    def tracked_discs(self, t_s: float) -> tuple[np.ndarray, np.ndarray]:
        """A plugin tracker's discs whose returns never reach the map: its confirmed moving tracks
        predicted to t_s, radius + margin (:func:`mjasc.perception.tracked_discs.estimate_discs`)."""
        return estimate_discs(self._method_tracks, t_s)

    def static_polygons(self) -> list[np.ndarray]:
        """Convex polygons (k, 2) [m] of the static structures mapped so far."""
        return self.map.polygons()

    def set_team_positions(self, positions: dict) -> None:
        """``{name: (t_b [s], position (2,) [m])}`` from the comms link: marks team-mate tracks."""
        if self.method is not None:
            self.fleet.flush()
            self._team.set_positions(0, positions)
            self._has_team = True
            return
        fleet = self.fleet
        if fleet._scans or fleet._tracks:  # (self.tracker.set_team_positions without its three hops)
            fleet.flush()
        tr = self._tracker
        tr.fleet.team.set_positions(tr.owner, positions)

    # ---------------------------------------------------------------- team-shared perception
    def shareable_tracks(self, own_position_m, max_tracks: int) -> tuple:
        """The confirmed own tracks this vessel may broadcast (not team mates, not team tracks),
        nearest first, at most ``max_tracks`` (:func:`mjasc.perception.track_fusion.shareable`)."""
        from mjasc.perception.track_fusion import shareable

        return shareable(self.tracks(), own_position_m, max_tracks)

    def set_team_tracks(self, t_s: float, by_sender: dict, own_position_m, team_positions: dict, settings,
                        team: list[str]) -> None:
        """The team's shared tracks from the comms link (name → (sent time, SharedTrack tuple)),
        cleared of this vessel and its team mates (``team_positions`` {name: (t_b, position)}) and
        kept for :meth:`report_tracks` (:class:`~mjasc.perception.track_fusion.TeamTrackFusion`)."""
        if self._fusion is None:
            from dataclasses import replace as _replace

            from mjasc.perception.track_fusion import TeamTrackFusion

            settings = _replace(settings, team_match_distance_m=self.config.team_match_distance_m)
            self._fusion = TeamTrackFusion(self.name, list(team), self.world.vessel_types[self.vessel_index].radius_m,
                                           settings)
        self._fusion.receive(t_s, by_sender, own_position_m, team_positions)

    def report_tracks(self, t_s: float):
        """The tracks this vessel's report hands on (a read-only sequence): its confirmed tracks —
        with the built-in tracker as :class:`~mjasc.core.estimates.TrackRows`, the estimates made
        on first read —, fused with the newest team tracks when it shares perception
        (:meth:`set_team_tracks` was called)."""
        if self.method is None:  # (tracks() without its calls: the fleet's queue flushed, the tracker's rows)
            fleet = self.fleet
            if fleet._scans or fleet._tracks:  # (flush() only when something is queued)
                fleet.flush()
            tr = self._tracker
            own = tr.fleet.report_rows(tr.owner)
        else:
            own = tuple(self.tracks())
        if self._fusion is None:
            return own
        return self._fusion.fuse(own, t_s)

    def drain_events(self) -> list[tuple[float, str]]:
        fleet = self.fleet
        if fleet._scans or fleet._tracks:  # (flush() only when something is queued)
            fleet.flush()
        ev, self._drain = self._drain, []
        if self._fusion is not None:
            ev.extend(self._fusion.drain_events())
        return ev

    def history_arrays(self) -> dict:
        """The kept history (``keep_history = True``) as arrays (:func:`~mjasc.perception.track_history.history_arrays`)."""
        return history_arrays(self.history)

    # ---------------------------------------------------------------- recording
    def log(self, recorder, t_s: float, vessel_name: str) -> None:
        """Draw this vessel's perception in the recording (:mod:`mjasc.perception.recording`)."""
        if self._log is None:
            from mjasc.perception.recording import PerceptionLog

            self._log = PerceptionLog()
        self._log.log(recorder, t_s, self, vessel_name)
        if self.method is not None:  # a plugin tracker may add its own drawings
            self.method.log(recorder, t_s, vessel_name)

    # ---------------------------------------------------------------- results
    def summary(self) -> dict:
        st = self._stats
        if self.method is not None:
            ms = self.method.summary()
            seen = len(self._method_seen)
            c = {"born": ms.get("born", seen), "confirmed": ms.get("confirmed", seen),
                 "lost": ms.get("lost", self._method_lost), "merged": ms.get("merged", 0)}
        else:
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
            # only when it happened (summaries of sound runs stay as they were)
            **({"non_finite_detections_dropped": st["non_finite_detections_dropped"]}
               if st["non_finite_detections_dropped"] else {}),
            "tracking_method": self.method.method if self.method is not None else "imm",
            **({"tracker": ms} if self.method is not None else {}),
            **({"team_shared": self._fusion.summary()} if self._fusion is not None else {}),
        }
