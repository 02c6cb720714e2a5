"""One vessel's collision avoidance system: prediction → decision → manoeuvre → mission again.

docs/thesis.md §1, §3–5 (thesis ch. 3–4). The vessel runs in one of two modes with a strict hierarchy:
**mission** (path following at the mission speed, possibly corrected by coordination) and
**collision avoidance**, which overrides the mission. Avoidance has three actions, shown in the
mode string (:data:`~mjasc.avoidance.request.MODES`)::

    "mission"             no action
    "avoidance:yield"     velocity correction, goal (γ_A − margin, t_f): slow down, let it pass
    "avoidance:pass"      velocity correction, goal (γ_B + margin, t_i): speed up, pass first
    "avoidance:detour"    re-planned path (potential-field streamline) spliced into the mission

**A stage with typed inputs and outputs.** :meth:`CollisionAvoidance.predict` (the prediction slot)
and :meth:`CollisionAvoidance.control` (every control tick) take the vessel's own navigation
(:class:`~mjasc.core.navigation.OwnNavigation`), its guidance state (the path it follows now and
γ on it, :class:`~mjasc.guidance.state.GuidanceState`), what its perception reports
(:class:`~mjasc.core.estimates.PerceptionReport`) and what it knows of its team
(:class:`~mjasc.cooperation.messages.TeamPicture`), and return an
:class:`~mjasc.avoidance.request.AvoidanceRequest` (mode, speed override, path switch) that the
vessel's agent applies. The system holds no reference to the agent, the path follower or another
component.

Prediction (at the prediction rate, and at once when a new track appears) runs
:func:`~mjasc.avoidance.prediction.predict_conflicts` with the vessel's **planned** motion: its
current path (a detour while on one) at its speed profile (the virtual target while a velocity
correction runs, the mission speed after it), against each of its own tracks (never the
simulator's truth), plus the static polygons its perception reports
(:mod:`~mjasc.avoidance.static_conflicts`). Team mates are re-based on their own broadcasts when
fresh (:mod:`~mjasc.avoidance.team_mates`). Decision σ (thesis eq. 3.17) per conflict:

- REPLAN (long obstruction, or a static obstacle): a detour along a potential-field streamline
  (:mod:`~mjasc.avoidance.replanning`), spliced in front of the rest of the mission path; at its
  end the vessel is switched back to the mission path at the matching γ.
- VELOCITY_CORRECTION: right of way (docs/thesis.md §5): always yield to a non-team obstacle; between
  team mates :func:`~mjasc.avoidance.right_of_way.gives_way` decides and the stand-on vessel keeps
  its speed. Yielding that is impossible becomes passing first when feasible
  (:mod:`~mjasc.avoidance.decision`), else a re-plan around the swept area (a give-way vessel
  stops instead of going around a team mate). Which conflict goes where is
  :func:`~mjasc.avoidance.triage.triage`; what is left unresolved makes the emergency stop a
  candidate, and every candidate speed plan is checked against all tracks (``_checked_choice``).

**The fleet in one call.** :func:`predict_slot` runs the prediction slot of many vessels: each
system prepares its query (its tracks as predicted, its planned motion), all (vessel, track) pairs
are predicted in one :func:`~mjasc.avoidance.prediction.predict_fleet` call, then each system acts
on its own result — the same requests as vessel by vessel. The control tick is cheap in the common
case (no new track, no deviation): the deviation check runs on the last prediction's stacked track
motions (:class:`~mjasc.avoidance.prediction.TrackMotions`) in one array operation, once per new
perception report.

A manoeuvre ends when it is complete (the correction's goal time is reached, the end of the
detour is reached) and the latest prediction predicts no collision; then the mission resumes.
Every transition is an event. While on a detour, :meth:`mission_gamma_m` maps progress along the
detour linearly onto the obstructed stretch of the mission path it replaces, so the coordination
layer sees a continuous, monotone γ.

World frame ENU, SI units, absolute simulation times [s].
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from operator import attrgetter

import numpy as np

from mjasc.avoidance.config import AvoidanceConfig, check_avoidance, parse_avoidance_options
from mjasc.avoidance.decision import Correction, emergency_yield, velocity_correction_for
from mjasc.avoidance.intent_plan import plan_offsets, planned_points
from mjasc.avoidance.lane_change import plan_lane_change
from mjasc.avoidance.prediction import (PredictedConflict, PredictionQuery, TrackMotions, gamma_of_time,
                                        predict_fleet)
from mjasc.avoidance.prediction.conflicts import ConflictList, predict_fleet_lazy
from mjasc.avoidance.recording import AvoidanceLog
from mjasc.avoidance.replanning import Detour, merge_overlapping, plan_detour, swept_area
from mjasc.avoidance.request import MODES, AvoidanceRequest, PathSwitch
from mjasc.avoidance.static_conflicts import StaticConflict, static_conflicts, static_conflicts_of, track_outline
from mjasc.avoidance.structure import detour_onto_structure, structure_tracks
from mjasc.avoidance.team_mates import PlannedTrack, TeamMates
from mjasc.avoidance.triage import swept, triage
from mjasc.core.compiled import clip_float
from mjasc.core.estimates import TrackRows, track_columns
from mjasc.core.frames import wrap_angle
from mjasc.guidance.paths import Path
from mjasc.guidance.state import GuidanceState
from mjasc.plugins.stages import AvoidanceMethod

__all__ = ["AvoidanceConfig", "CollisionAvoidance", "StaticConflict", "Detour", "PlannedTrack", "PredictionRecord",
           "parse_avoidance_options", "MODES", "merge_overlapping", "swept_area", "predict_slot"]


@dataclass(frozen=True, eq=False)
class PredictionRecord:
    """What the latest prediction saw (for the recording and figures): its time, the path and γ it
    predicted along, every track's result (``all``, collision or not, sorted by t_c: a read-only
    sequence whose clear entries are made on first read,
    :class:`~mjasc.avoidance.prediction.conflicts.ConflictList`), the conflicts with a collision,
    the static conflicts, the tracks by id, and the triage's answer per track id
    (:attr:`~mjasc.avoidance.triage.Triage.roles`; empty when nothing was decided)."""

    time_s: float
    path: Path
    gamma_m: float
    all: Sequence
    conflicts: tuple
    statics: tuple
    tracks: dict
    roles: tuple = ()  # ((track id, answer), ...)


@dataclass(frozen=True, eq=False)
class _Pending:
    """A prediction between its query and its result (:meth:`CollisionAvoidance._prediction_query`)."""

    query: PredictionQuery | None
    tracks: list
    outlined: dict
    path: Path
    gamma: float
    profile: object


def predict_slot(calls) -> list[AvoidanceRequest]:
    """The prediction slot of many vessels at once: ``calls`` is a sequence of (system, t, nav,
    guidance, perceived, team), the arguments of :meth:`CollisionAvoidance.predict` per vessel.
    Returns each vessel's request — the same as calling ``predict`` vessel by vessel (the systems
    share no state) — with every vessel's (vessel, track) pairs predicted in one
    :func:`~mjasc.avoidance.prediction.predict_fleet` call. Predictions a decision triggers
    (after a re-plan) run per vessel."""
    pending = []
    for system, t, nav, guidance, perceived, team in calls:
        system._begin(guidance, perceived, team)
        pending.append(system._prediction_query(float(t), list(perceived.tracks)))
    results = iter(predict_fleet_lazy([p.query for p in pending if p.query is not None]))
    out = []
    for (system, t, nav, guidance, perceived, team), p in zip(calls, pending):
        system._begin(guidance, perceived, team)
        all_c = next(results) if p.query is not None else []
        conflicts = system._act_on_prediction(float(t), nav, p, all_c, list(perceived.static_polygons))
        out.append(AvoidanceRequest(system.mode, None, system._switch, tuple(conflicts)))
    return out


def control_slot(calls) -> list[AvoidanceRequest]:
    """The control tick of many vessels at once: ``calls`` is a sequence of (system, t, nav,
    guidance, perceived, team), the arguments of :meth:`CollisionAvoidance.control` per vessel.
    Returns each vessel's request — the same as calling ``control`` vessel by vessel (the systems
    share no state) — with the predictions the tick triggers (a new track, a deviating track or
    team plan, a changed mission speed, an emergency) of every vessel in one
    :func:`~mjasc.avoidance.prediction.predict_fleet` call. Predictions a decision triggers (after a
    re-plan, a finished velocity correction) run per vessel."""
    pending, queries = [], []
    for system, t, nav, guidance, perceived, team in calls:
        system._guidance, system._switch, system._perceived, system._team = guidance, None, perceived, team  # _begin
        p = system._control_query(float(t))
        pending.append(p)
        if p is not None and p[0].query is not None:
            queries.append(p[0].query)
    results = iter(predict_fleet_lazy(queries) if queries else ())  # (most ticks predict nothing)
    out = []
    for (system, t, nav, _, _, _), p in zip(calls, pending):
        t = float(t)
        if p is not None:
            system._control_predict(t, nav, p, next(results) if p[0].query is not None else [])
        override, mode, course = system._control_rest(t, nav)
        out.append(AvoidanceRequest.of(mode, override, system._switch, (), course))
    return out


def _outlines(tracks) -> dict:
    """Track id → outline polygon of the static tracks that carry one (checked like a mapped
    polygon; the other tracks are predicted as discs)."""
    outlined = {tr.track_id: track_outline(tr) for tr in tracks if tr.is_static and tr.outline_m is not None}
    return {k: o for k, o in outlined.items() if o is not None}


def _correction_profile(correction: Correction | None, t_now: float, gamma_now: float, mission_speed_m_s: float):
    """γ(t) [m] for t ≥ t_now under ``correction``: its V_d until its goal time, the mission speed
    after; None → the mission speed [m/s] itself (a constant profile)."""
    terms = _correction_terms(correction, t_now, mission_speed_m_s)
    if terms[0] == 0:
        return terms[1]
    _, v_d, span, v_m, t_start = terms

    def gamma_fn(t):
        t = np.asarray(t, dtype=float)
        return gamma_now + v_d * np.clip(t - t_now, 0.0, span) + v_m * np.maximum(t - t_start, 0.0)

    return gamma_fn


def _correction_terms(correction: Correction | None, t_now: float, mission_speed_m_s: float) -> tuple:
    """The numbers of :func:`_correction_profile`: ``(0, v_m)`` without a correction, else
    ``(1, V_d, span, v_m, t_start)`` for
    γ(t) = γ_now + V_d·clip(t − t_now, 0, span) + v_m·max(t − t_start, 0)."""
    v_m = float(mission_speed_m_s)
    if correction is None:
        return 0, v_m
    t_g, v_d = correction.law.t_goal, max(correction.law.desired_speed, 0.0)
    return 1, v_d, max(t_g - t_now, 0.0), v_m, max(t_g, t_now)


_TRACK_ID = attrgetter("track_id")

#: When every candidate speed plan collides, another is taken over the first choice only if its
#: worst predicted miss distance is larger by this much [m] (estimates are not finer than that).
_MARGIN_GAIN_M = 0.5


class CollisionAvoidance(AvoidanceMethod):
    """The thesis's method: collision prediction, velocity correction, potential-field re-planning.

    Collision avoidance of one vessel (see the module docstring), registered as the avoidance
    method ``"thesis"`` (options: :class:`AvoidanceConfig`).

    name: the vessel's name; vessel: its :class:`~mjasc.physics.vessels.VesselType` (radius, beam,
    top speed); mission_path: its mission path; config: :class:`AvoidanceConfig` or a raw table;
    team_names: names of all vessels of the team (tracks whose ``team_member`` is one of them are
    team mates); rng: the component's random stream (unused: the system is deterministic).
    """

    method = "thesis"
    Options = AvoidanceConfig
    check_options = staticmethod(check_avoidance)

    @classmethod
    def from_context(cls, context, options) -> "CollisionAvoidance":
        """The method for one vessel from its :class:`~mjasc.plugins.context.StageContext`."""
        return cls(context.vessel_name, context.vessel, context.mission_path, options, context.team_names,
                   context.rng)

    @classmethod
    def predict_many(cls, calls) -> list[AvoidanceRequest]:
        """Several vessels' prediction slot in one batched call (:func:`predict_slot`)."""
        return predict_slot(calls)

    @classmethod
    def control_many(cls, calls) -> list[AvoidanceRequest]:
        """Several vessels' control tick, their triggered predictions in one batched call
        (:func:`control_slot`)."""
        return control_slot(calls)

    def __init__(self, name: str, vessel, mission_path: Path | None, config, team_names, rng=None):
        if isinstance(config, dict):
            config = parse_avoidance_options(config)
        if not isinstance(config, AvoidanceConfig):
            raise ValueError(f"config: expected an AvoidanceConfig, got {type(config).__name__}")
        self.config = config
        self.name = str(name)
        self.team = {str(n) for n in team_names} - {self.name}
        self.rng = rng
        self.radius_m = float(vessel.radius_m)
        self.speed_max_m_s = float(config.speed_max_m_s if config.speed_max_m_s is not None else vessel.top_speed_m_s)
        self.static_inflation_m = float(config.static_inflation_m if config.static_inflation_m is not None
                                        else 0.5 * vessel.beam_m + config.safety_distance_m)
        self.prediction_config = config.prediction
        self.mission_path = mission_path
        self.mode = "mission"
        self.correction: Correction | None = None
        self.detour: Detour | None = None
        self._detour_causes: set[int] | None = None  # the moving tracks a detour goes around (None: statics too)
        self._sharp_turn: tuple | None = None  # a sharp turn on the detour: ("brake", heading) or ("turn", None)
        self.team_mates = TeamMates(self.name, self.team, self.radius_m, config.team_broadcast_max_age_s,
                                    config.track_deviation_m, config.window_s or 30.0)
        self._known_track_ids: set[int] = set()
        self._in_structure: set[int] = set()  # tracks centred inside mapped structure (its own returns)
        self._predicted_tracks: dict = {}
        # The last prediction's tracks for the deviation check of the control tick: their stacked
        # motion, track id → row, and whether the row is checked (not a team mate on a broadcast).
        self._predicted_motion: TrackMotions | None = None
        self._predicted_row: dict[int, int] = {}
        self._checked_tracks = None  # the perceived tracks found on the last prediction's motion
        self._no_new_in = None  # perceived tracks found to hold no new track id
        self._last_predict_t = -np.inf
        self._predicted_speed = None
        self._mission_moved = False  # the mission gave a new path: predict on it at the next control tick
        self._events: list[tuple[float, str]] = []
        self._last_control_t: float | None = None
        # The thesis's modes (it never steers a course: "avoidance:steer" is the velocity obstacles')
        self.mode_time_s = {m: 0.0 for m in MODES if m != "avoidance:steer"}
        self.stats = {"predictions": 0, "predicted_conflicts": 0, "static_conflicts": 0, "yield": 0, "pass": 0,
                      "stand_on": 0, "replan": 0, "replan_failed": 0, "monitor_only": 0,
                      "deviation_predictions": 0, "emergency": 0, "lane_change": 0, "checked_choice": 0,
                      "withdrawn": 0, "sharp_turn": 0, "detour_rejected": 0, "in_structure": 0}
        self.min_predicted_distance_m = float("inf")
        self.conflict_log: list[dict] = []
        self._conflict_keys: set = set()
        self._last: PredictionRecord | None = None
        self._last_query: PredictionQuery | None = None  # the latest prediction's query (its disc tracks)
        self._team_track_ids: set[int] = set()  # ... and which of its tracks are team mates
        self._log = AvoidanceLog()
        # The inputs of the call in progress (set by predict / control; the guidance state follows
        # the path switches this call requests, so a re-prediction sees the new path).
        self._guidance: GuidanceState | None = None
        self._switch: PathSwitch | None = None
        self._team = None
        self._perceived = None

    # ------------------------------------------------------------------ stage interface
    def predict(self, t, nav, guidance: GuidanceState, perceived, team=None) -> AvoidanceRequest:
        """Prediction slot: predict conflicts with the perceived tracks and static polygons and act
        on them. ``perceived``: :class:`~mjasc.core.estimates.PerceptionReport`; ``team``:
        :class:`~mjasc.cooperation.messages.TeamPicture` or None. The request's ``conflicts`` are
        those with a predicted collision."""
        self._begin(guidance, perceived, team)
        conflicts = self._predict(float(t), nav, list(perceived.tracks), list(perceived.static_polygons))
        return AvoidanceRequest(self.mode, None, self._switch, tuple(conflicts))

    def control(self, t, nav, guidance: GuidanceState, perceived=None, team=None) -> AvoidanceRequest:
        """Control tick: the speed override (a velocity correction's law) and the path to follow
        (back on the mission path when a detour is finished); predicts at once on a new track, a
        deviating track or plan, or a changed mission speed. ``perceived`` None: no perception."""
        self._begin(guidance, perceived, team)
        override, mode, course = self._control_refs(float(t), nav)
        return AvoidanceRequest(mode, override, self._switch, (), course)

    def _begin(self, guidance, perceived, team) -> None:
        self._guidance, self._switch, self._perceived, self._team = guidance, None, perceived, team

    def _set_path(self, path: Path, gamma_m: float, reason: str) -> None:
        self._guidance = replace(self._guidance, path=path, gamma_m=float(gamma_m))
        self._switch = PathSwitch(path, float(gamma_m), reason)

    def drain_events(self) -> list[tuple[float, str]]:
        ev, self._events = self._events, []
        return ev

    def _event(self, t: float, text: str) -> None:
        self._events.append((float(t), text))

    @property
    def last_prediction(self) -> PredictionRecord | None:
        """What the latest prediction saw (None before the first)."""
        return self._last

    def set_mission(self, t_s: float, leg) -> None:
        """A new mission leg (:class:`~mjasc.missions.legs.MissionLeg`, a chained mission): its path
        is the mission path from now (the one a detour returns to); a detour still running is left
        (the mission hands over only in mission mode, so this is rare) and the next control tick
        predicts along the new path."""
        if not leg.new_path:
            return
        self.mission_path = leg.path
        if self.detour is not None:
            self.detour, self._detour_causes, self._sharp_turn = None, None, None
            self._log.prediction_pending()
        self._mission_moved = True

    # ------------------------------------------------------------------ own plan
    def mission_gamma_m(self, guidance: GuidanceState) -> float:
        """Progress along the ORIGINAL mission path [m], also while on a detour."""
        if self.detour is not None and guidance.path is self.detour.path:
            return self.detour.mission_gamma(guidance.gamma_m)
        return float(guidance.gamma_m)

    def planned_gamma(self, t_now: float, gamma_now: float, mission_speed_m_s: float):
        """γ(t) [m] on the current path for absolute times t ≥ t_now: the virtual target's speed V_d
        until its goal time while a correction runs, the mission speed [m/s] after."""
        return _correction_profile(self.correction, t_now, gamma_now, mission_speed_m_s)

    def planned_trajectory(self, t, nav, guidance: GuidanceState | None, horizon_s: float, step_s: float):
        """Where this vessel intends to be: (times (k,) absolute [s], points (k, 2) world [m]) every
        ``step_s`` over ``horizon_s``, along the path it follows now (the detour while on one) at its
        planned speed (:meth:`planned_gamma`: the virtual target while a velocity correction runs).
        The first point is the vessel's position; its offset from the path fades out over 10 s
        (the path follower's convergence). Broadcast to the team by the coordination layer."""
        t = float(t)
        if guidance is not None and type(self).planned_gamma is CollisionAvoidance.planned_gamma:
            path = guidance.path  # the compiled form, the same bits
            g0 = clip_float(float(guidance.gamma_m), 0.0, path.length)
            fast = planned_points(path, t, g0, _correction_terms(self.correction, t, guidance.mission_speed_m_s),
                                  plan_offsets(float(horizon_s), float(step_s)), nav.position_m)
            if fast is not None:
                return fast
        times = t + np.arange(0.0, float(horizon_s) + 0.5 * float(step_s), float(step_s))
        if guidance is None:  # no path follower: it intends to stay where it is
            return times, np.tile(np.asarray(nav.position_m, dtype=float)[:2], (times.size, 1))
        path = guidance.path
        g0 = float(np.clip(guidance.gamma_m, 0.0, path.length))
        g = np.clip(gamma_of_time(self.planned_gamma(t, g0, guidance.mission_speed_m_s), g0, t)(times), 0.0, path.length)
        pts = np.asarray(path.point(g), dtype=float).reshape(-1, 2)
        off = np.asarray(nav.position_m, dtype=float)[:2] - pts[0]
        pts = pts + np.clip(1.0 - (times - t) / 10.0, 0.0, 1.0)[:, None] * off
        return times, pts

    # ------------------------------------------------------------------ prediction
    def _predict(self, t, nav, tracks, static_polygons, after_replan: bool = False) -> list:
        """Predict conflicts with the vessel's tracks and static polygons and act on them.
        Returns the conflicts with a predicted collision (PredictedConflict / StaticConflict)."""
        pending = self._prediction_query(t, tracks)
        all_c = predict_fleet_lazy([pending.query])[0] if pending.query is not None else []
        return self._act_on_prediction(t, nav, pending, all_c, static_polygons, after_replan)

    def _prediction_query(self, t, tracks) -> "_Pending":
        """The first half of :meth:`_predict`: the tracks as predicted (team mates from their
        broadcasts, slow tracks static, a mapped structure's own returns static and no larger than it:
        :func:`~mjasc.avoidance.structure.structure_tracks`) and the query of the disc tracks."""
        g_state = self._guidance
        tracks = self.team_mates.tracks([tr for tr in tracks if tr.team_member != self.name], t, self._team,
                                        self._event)
        fresh = self.team_mates.fresh(self._team, t)
        v_static = self.config.static_speed_m_s
        inside, on_structure = structure_tracks(
            tracks, list(self._perceived.static_polygons) if self._perceived is not None else [],
            self.config.structure_speed_m_s)
        if set(inside) - self._in_structure:
            self._in_structure |= set(inside)
            self.stats["in_structure"] = len(self._in_structure)
            self._event(t, f"track(s) {sorted(inside)} centred inside mapped structure: the structure's own returns, "
                           f"static and no larger than the structure around their centre")
        tracks = [replace(tr, is_static=True, speed_m_s=0.0, turn_rate_rad_s=0.0,
                          radius_m=min(tr.radius_m, inside.get(tr.track_id, np.inf)))
                  if (not tr.is_static and (tr.speed_m_s < v_static or tr.track_id in on_structure
                                            or tr.track_id in inside)
                      and not self.team_mates.broadcast_based(tr, fresh))
                  else tr for tr in tracks]
        self._known_track_ids |= {tr.track_id for tr in tracks}
        self._predicted_tracks = {tr.track_id: tr for tr in tracks}
        self._predicted_motion, self._checked_tracks = None, None
        outlined = _outlines(tracks)
        self.team_mates.remember_prediction(fresh)
        self._last_predict_t = t
        self._predicted_speed = g_state.mission_speed_m_s
        path = g_state.path
        gamma = float(np.clip(g_state.gamma_m, 0.0, path.length))
        profile = self.planned_gamma(t, gamma, g_state.mission_speed_m_s)
        self.stats["predictions"] += 1
        discs = [tr for tr in tracks if tr.track_id not in outlined]
        query = PredictionQuery(path, gamma, t, profile, self.radius_m, discs, self.prediction_config,
                                include_clear=True) if discs else None
        return _Pending(query, tracks, outlined, path, gamma, profile)

    def _act_on_prediction(self, t, nav, pending: "_Pending", all_c, static_polygons, after_replan=False) -> list:
        """The second half of :meth:`_predict`: record the predicted conflicts (``all_c``, one per
        disc track), check the static ones and decide."""
        tracks, outlined, path, gamma, profile = (pending.tracks, pending.outlined, pending.path, pending.gamma,
                                                  pending.profile)
        if isinstance(all_c, ConflictList):  # the clear conflicts are made only when read
            distances, conflicts = all_c.min_distances, list(all_c.collisions)
        else:
            all_c = tuple(all_c)
            distances, conflicts = [c.min_distance_m for c in all_c], [c for c in all_c if c.collision]
        m = self.min_predicted_distance_m
        for d in distances:
            m = min(m, d)
        self.min_predicted_distance_m = m
        # the mapped polygons, then the static tracks' outlines (checked like a mapped polygon), in one pass
        # (each polygon's conflict is the one it has alone)
        polys = list(static_polygons)
        n_mapped = len(polys)
        tids = list(outlined)
        statics = [c if k < n_mapped else replace(c, track_id=tids[k - n_mapped]) for k, c in
                   static_conflicts_of(t, path, gamma, profile, polys + list(outlined.values()), self.radius_m,
                                       self.prediction_config)]
        by_id = {tr.track_id: tr for tr in tracks}
        if not after_replan and self._perceived is not None and \
                self._withdraw_detour(t, nav, by_id, static_polygons):
            return self._predict(t, nav, list(self._perceived.tracks), static_polygons)
        self._last_query = pending.query
        self._team_track_ids = {tr.track_id for tr in tracks if tr.team_member in self.team}
        self._last = PredictionRecord(t, path, gamma, all_c, tuple(conflicts), tuple(statics), by_id)
        self._log.prediction_pending()
        for c in conflicts:
            self._record_conflict(t, c, by_id.get(c.track_id))
        for s in statics:
            self._record_static(t, s)
        if not conflicts and not statics:
            return []
        if not self.config.enabled:
            self.stats["monitor_only"] += 1
            return conflicts + statics
        self._decide(t, nav, conflicts, statics, by_id, static_polygons, allow_replan=not after_replan,
                     static_outlines=list(outlined.values()))
        return conflicts + statics

    def _record_conflict(self, t, c: PredictedConflict, track) -> None:
        key = (c.track_id, round(c.t_i), c.decision.value)
        new = not any(k[0] == c.track_id and abs(k[1] - round(c.t_i)) <= 10 for k in self._conflict_keys)
        self._conflict_keys.add(key)
        if new:
            self.stats["predicted_conflicts"] += 1
        who = f"team mate {track.team_member}" if track is not None and track.team_member in self.team else \
            f"track {c.track_id}"
        tf = "∞" if not np.isfinite(c.t_f) else f"{c.t_f:.1f}"
        text = (f"collision predicted with {who} at t_c = {c.t_closest_s:.1f} s (d = {c.min_distance_m:.1f} m < "
                f"{c.collision_distance_m:.1f} m), obstruction [t_i, t_f] = [{c.t_i:.1f}, {tf}] s on "
                f"γ in [{c.gamma_a:.1f}, {c.gamma_b:.1f}] m → {c.decision.value}")
        self._event(t, text)
        if len(self.conflict_log) < 50:
            self.conflict_log.append({"time_s": round(t, 2), "track_id": int(c.track_id),
                                      "team_member": getattr(track, "team_member", None),
                                      "t_c": round(c.t_closest_s, 2), "d_min_m": round(c.min_distance_m, 2),
                                      "t_i": round(c.t_i, 2), "t_f": round(c.t_f, 2) if np.isfinite(c.t_f) else None,
                                      "gamma_a": round(c.gamma_a, 2), "gamma_b": round(c.gamma_b, 2),
                                      "decision": c.decision.value})

    def _record_static(self, t, s: StaticConflict) -> None:
        key = ("static", round(float(np.mean(s.polygon[:, 0]))), round(float(np.mean(s.polygon[:, 1])))) \
            if s.track_id is None else ("static track", s.track_id)
        if key not in self._conflict_keys:
            self._conflict_keys.add(key)
            self.stats["static_conflicts"] += 1
            self.stats["predicted_conflicts"] += 1
            what = "static obstacle" if s.track_id is None else f"static track {s.track_id} (its outline)"
            self._event(t, f"{what} obstructs the path on γ in [{s.gamma_a:.1f}, {s.gamma_b:.1f}] m "
                           f"(reached at t ≈ {s.t_i:.1f} s) → replan")
            if len(self.conflict_log) < 50:
                self.conflict_log.append({"time_s": round(t, 2), "static": True, "gamma_a": round(s.gamma_a, 2),
                                          "gamma_b": round(s.gamma_b, 2), "decision": "replan"})

    # ------------------------------------------------------------------ decision σ
    def _decide(self, t, nav, conflicts, statics, by_id, static_polygons, allow_replan=True,
                static_outlines=()) -> None:
        gamma = float(self._guidance.gamma_m)
        cfg = self.config
        tri = triage(t, nav, gamma, conflicts, statics, by_id, self.team, cfg, self.speed_max_m_s, self.correction)
        self._last = replace(self._last, roles=tuple(tri.roles.items()))  # for the threat panel
        for stat, text in tri.notes:
            if stat is not None:
                self.stats[stat] += 1
            self._event(t, text)
        candidates, svos, unresolved, starboard = tri.candidates, tri.svos, tri.unresolved, tri.starboard
        if starboard and allow_replan:
            if self._lane_change_to_starboard(t, nav, starboard, static_polygons, static_outlines):
                self.correction = None
                self._predict(t, nav, list(by_id.values()), static_polygons, after_replan=True)
                return
            for c in starboard:  # no starboard lane: as the thesis would
                svos.append((c.svo_polygon if c.svo_polygon is not None else swept(by_id[c.track_id], c, t, cfg), c))
        if svos and allow_replan:
            if self._replan(t, nav, svos, static_polygons, by_id, static_outlines):
                # The path changed: predict again on the detour (velocity corrections only).
                self.correction = None
                self._predict(t, nav, list(by_id.values()), static_polygons, after_replan=True)
                return
        # No detour (none found, or this is the check of a fresh one): the path sailed is known to
        # conflict — in the stressed dock a moored boat's track moving by noise; in the stressed
        # head-on a detour around a team mate led back into the oncoming vessel's swept area. Slow
        # down and look again every second (a re-plan then sees every conflict) rather than sail on.
        unresolved += tri.go_around
        for c in tri.overtaken:  # no lane to leave: speed up and let it pass astern, else stop (Imazu case 16)
            corr = velocity_correction_for(t, gamma, c, cfg, self.speed_max_m_s, pass_only=True)
            if corr is not None:
                candidates.append(corr)
            else:
                unresolved.append(c)
        # The emergency stop (for the nearest unresolved conflict) is a candidate whenever a conflict
        # is left unresolved: beside corrections for other tracks (Imazu case 12: a yield to one
        # target was taken while a conflict with another, 5 s ahead, was left; the checked choice
        # weighs them all), and in place of a running yield planned on an earlier estimate (in
        # the §6.4.3 bottleneck one kept a give-way vessel creeping into its team mate's lane).
        # A running emergency stop with nothing else to choose from is simply kept.
        if unresolved:
            nearest = min(unresolved, key=lambda u: u.t_closest_s)
            emergency_running = self.correction is not None and self.correction.emergency
            if candidates or not emergency_running:
                candidates.append(emergency_yield(t, gamma, nearest, cfg, self.speed_max_m_s))
            if not emergency_running:
                self.stats["emergency"] += 1
                self._event(t, f"no manoeuvre clears track {nearest.track_id}: " + (
                    f"emergency slow-down to {cfg.emergency_speed_m_s:g} m/s" if cfg.emergency_speed_m_s > 0.0
                    else "emergency stop (all way off)"))
        if candidates:
            yields = [c for c in candidates if c.kind == "yield"]
            chosen = min(yields, key=lambda c: c.law.desired_speed) if yields else \
                max(candidates, key=lambda c: c.law.desired_speed)
            chosen = self._checked_choice(t, chosen, candidates, conflicts)
            if chosen is None:
                self.correction = None
                return
            self.correction = chosen
            self.stats[chosen.kind] += 1
            law = chosen.law
            self._event(t, f"velocity correction ({chosen.kind}) for track {chosen.track_id}: virtual target "
                           f"γ {law.gamma0:.1f} → {law.gamma_goal:.1f} m by t = {law.t_goal:.1f} s, "
                           f"V_d = {law.desired_speed:.2f} m/s, k = {law.gain_k:g}")

    def _lane_change_to_starboard(self, t, nav, conflicts, static_polygons, static_outlines) -> bool:
        """COLREG rule 14 (head-on): leave the target's lane to starboard. True when switched."""
        lane = plan_lane_change(t, nav.position_m, self.mission_path, self.mission_gamma_m(self._guidance),
                                self._guidance.mission_speed_m_s, conflicts,
                                list(static_polygons) + list(static_outlines), self.config, self.static_inflation_m,
                                starboard_only=True)
        if isinstance(lane, str):
            self._event(t, f"head-on: {lane}")
            return False
        self._take_detour(t, lane, f"head-on (COLREG rule 14): lane change to starboard of {lane.detour_length_m:.1f} m, "
                                   f"rejoining the mission path at γ = {lane.mission_gamma_goal_m:.1f} m")
        return True

    def _checked_choice(self, t, chosen: Correction, candidates: list[Correction], conflicts) -> Correction | None:
        """``chosen``, unless the speed it plans runs into another track. Every option's planned
        motion (its V_d until its goal time, the mission speed after) is predicted against all the
        disc tracks in one call (conflicts with strangers only: between team mates the right of way
        and the broadcast plans decide); the options are ``chosen``, the other candidates (slowest first),
        passing first for each conflict where feasible, and keeping the mission speed (None). The
        first with no predicted collision is taken; when every one collides, the one whose worst
        predicted miss distance is largest (``chosen``, the thesis's choice, unless another keeps
        :data:`_MARGIN_GAIN_M` more: an emergency stop in a crossing ferry's path waits for it to
        arrive). (In Imazu case 19 the slow-down for one target put the vessel in the path of
        another 5 s later.)"""
        query = self._last_query
        if query is None or len(query.tracks) < 2 or any(
                getattr(c, "track_id", None) in self._team_track_ids for c in conflicts):
            return chosen  # team mates coordinate by right of way and their broadcast plans
        g_state = self._guidance
        gamma = float(np.clip(g_state.gamma_m, 0.0, g_state.path.length))
        options = [chosen] + sorted((c for c in candidates if c is not chosen), key=lambda c: c.law.desired_speed)
        for c in conflicts:
            if isinstance(c, PredictedConflict) and not any(o.kind == "pass" and o.track_id == c.track_id
                                                             for o in options):
                alt = velocity_correction_for(t, gamma, c, self.config, self.speed_max_m_s, pass_only=True)
                if alt is not None:
                    options.append(alt)
        options.append(None)
        queries = [replace(query, vessel_path=g_state.path, gamma_now=gamma, t_now=float(t),
                           speed_profile=_correction_profile(c, float(t), gamma, g_state.mission_speed_m_s),
                           include_clear=True) for c in options]
        results = predict_fleet(queries)
        clear = [k for k, res in enumerate(results) if not any(r.collision for r in res)]
        if clear:
            k = clear[0]
        else:  # every plan collides: the one that keeps the most distance (the thesis's choice on ties)
            margin = [min((r.min_distance_m - r.collision_distance_m for r in res if r.collision), default=np.inf)
                      for res in results]
            best = int(np.argmax(margin))
            k = best if margin[best] > margin[0] + _MARGIN_GAIN_M else 0
        if k != 0:
            self.stats["checked_choice"] += 1
            what = "keep the mission speed" if options[k] is None else \
                f"{options[k].kind} for track {options[k].track_id}"
            self._event(t, f"{chosen.kind} for track {chosen.track_id} still leaves a predicted collision (with it or "
                           f"another track): {what} instead" + ("" if clear else " (no plan clears every track: "
                                                                 "this one keeps the most distance)"))
        return options[k]

    def _replan(self, t, nav, svos, static_polygons, by_id=None, static_outlines=()) -> bool:
        """Plan a detour (:func:`~mjasc.avoidance.replanning.plan_detour`) and switch to it. True on success."""
        mission = self.mission_path
        g_now_m = self.mission_gamma_m(self._guidance)
        out = plan_detour(t, nav.position_m, mission, g_now_m, svos, static_polygons, by_id, static_outlines,
                          self.config, self.radius_m, self.static_inflation_m, self._event)
        dynamic = [c for _, c in svos if not isinstance(c, StaticConflict) and not c.is_static]
        if not isinstance(out, str) and dynamic:
            why = detour_onto_structure(t, nav.position_m, out, list(static_polygons) + list(static_outlines),
                                        self._guidance.mission_speed_m_s, self.radius_m, self.prediction_config,
                                        self.config.detour_structure_slack_m)
            if why is not None:
                self.stats["detour_rejected"] += 1
                out = why
        if isinstance(out, str) and dynamic:  # the swept area cannot be gone around: leave the threat's lane
            lane = plan_lane_change(t, nav.position_m, mission, g_now_m, self._guidance.mission_speed_m_s, dynamic,
                                    list(static_polygons) + list(static_outlines), self.config,
                                    self.static_inflation_m)
            if isinstance(lane, str):
                out = f"{out}; {lane}"
            else:
                self._event(t, f"potential-field detour impossible ({out}): lane change instead")
                out = lane
        if isinstance(out, str):
            self.stats["replan_failed"] += 1
            self._event(t, f"re-planning failed: {out}")
            return False
        fld = out.field
        if fld is None:
            what = f"re-planned: lane change of {out.detour_length_m:.1f} m"
        else:
            what = (f"re-planned: detour of {out.detour_length_m:.1f} m around {len(out.obstacles)} obstacle(s) "
                    f"(potential field, {len(fld.panels) if fld.panels is not None else 0} panels, "
                    f"r = {fld.safety_ratio}, λ_g = {fld.sink_strength:.0f})")
        self._take_detour(t, out, f"{what}, rejoining the mission path at γ = {out.mission_gamma_goal_m:.1f} m")
        self._detour_causes = None if len(dynamic) < len(svos) else {int(c.track_id) for c in dynamic}
        return True

    def _withdraw_detour(self, t, nav, by_id, static_polygons) -> bool:
        """Leave a detour whose causes are gone — every track it went around is no longer among the
        predicted tracks (a team mate's stale copy set aside once its broadcast was heard, or a
        track lost) — for the mission path, when the vessel is within ``withdraw_offset_m`` of it
        and the mission path from there is clear of every track and mapped structure. (Thesis
        §6.4.1 under packet loss: a team mate's track, not yet matched to its broadcast, sent a
        vessel onto a 98 m detour that it sailed for 88 s after the track was set aside, into the
        crossing ship's path.) True when it switched back."""
        d, causes, g = self.detour, self._detour_causes, self._guidance
        if (d is None or causes is None or g.path is not d.path or self.config.withdraw_offset_m <= 0.0
                or any(k in by_id for k in causes) or self.mission_path is None):
            return False
        mission = self.mission_path
        g_m = float(mission.project(nav.position_m))
        if float(np.hypot(*(mission.point(g_m) - nav.position_m))) > self.config.withdraw_offset_m:
            return False
        profile = self.planned_gamma(t, g_m, g.mission_speed_m_s)
        outlined = _outlines(by_id.values())
        discs = [tr for k, tr in by_id.items() if k not in outlined]
        if discs:
            q = PredictionQuery(mission, g_m, t, profile, self.radius_m, discs, self.prediction_config)
            if any(c.collision for c in predict_fleet([q])[0]):
                return False
        if static_conflicts(t, mission, g_m, profile, list(static_polygons) + list(outlined.values()), self.radius_m,
                            self.prediction_config):
            return False
        self.stats["withdrawn"] += 1
        self._back_to_mission(t, g_m, f"detour withdrawn: the track(s) {sorted(causes)} it went around are gone (a "
                                      f"team mate's stale copy, or lost) and the mission path is clear: back on it at "
                                      f"γ = {g_m:.1f} m")
        return True

    def _back_to_mission(self, t, gamma_m: float, event: str) -> None:
        """Leave the detour for the mission path at γ = ``gamma_m`` [m] (a running velocity
        correction's virtual target kept in the follower's new γ frame)."""
        if self.correction is not None:
            self.correction.gamma_offset_m += self._guidance.gamma_m - gamma_m
        self._set_path(self.mission_path, gamma_m, "mission")
        self.detour, self._detour_causes = None, None
        self._event(t, event)
        self._log.prediction_pending()

    def _take_detour(self, t, detour: Detour, event: str) -> None:
        """Switch to ``detour`` (a streamline's, or a lane change's when its ``field`` is None) and count it."""
        self.detour = detour
        self._detour_causes = None  # statics or unknown: the detour is sailed to its end
        self._set_path(detour.path, 0.0, "detour")
        self.stats["replan"] += 1
        if detour.field is None:
            self.stats["lane_change"] += 1
        self._event(t, event)
        self._log.prediction_pending()

    # ------------------------------------------------------------------ control
    def _predict_on_perceived(self, t, nav) -> None:
        p = self._perceived
        self._predict(t, nav, list(p.tracks), list(p.static_polygons))

    def _prediction_due(self, t) -> set | None:
        """Whether the control tick predicts at once: None (no), the new track ids (a new track),
        or an empty set (an emergency not yet cleared, the own mission speed changed, a team mate
        re-planned, a track deviates); the event and counters are noted here."""
        perceived = self._perceived
        if perceived is None:
            return None
        tracks = perceived.tracks
        if tracks is not self._no_new_in:
            if self._known_track_ids.issuperset(tracks.track_ids if type(tracks) is TrackRows
                                                else map(_TRACK_ID, tracks)):
                self._no_new_in = tracks  # known ids only grow: these tracks stay known
            else:
                new = set(track_columns(tracks)[0]) - self._known_track_ids
                self._event(t, f"new track(s) {sorted(new)}: predicting now")
                return new
        if t - self._last_predict_t < 1.0:
            return None
        if self._mission_moved:  # a new mission leg (mjasc.missions): look along it
            self._mission_moved = False
            return set()
        if self.correction is not None and self.correction.emergency:  # nothing cleared it: look again
            self.stats["deviation_predictions"] += 1
            return set()
        if self.correction is None and self._predicted_speed is not None and \
                abs(self._guidance.mission_speed_m_s - self._predicted_speed) > self.config.speed_change_m_s:
            self.stats["deviation_predictions"] += 1  # own plan changed (coordination): predict again
            return set()
        team, mates = self._team, self.team_mates
        if team is not None and team.intentions is not mates.compared_intentions and mates.plans_changed(t, team):
            self.stats["deviation_predictions"] += 1  # a team mate re-planned or changed its speed
            return set()  # (the mapping compared in full last holds nothing new: plans_changed False)
        # a track that left the motion the last prediction assumed (tracks checked already: no)
        if tracks is not self._checked_tracks and self._deviating(tracks):
            self.stats["deviation_predictions"] += 1
            return set()
        return None

    def _control_query(self, t) -> tuple | None:
        """The control tick up to its prediction: the team polled, and when a prediction is due
        (:meth:`_prediction_due`) its query and the new track ids, else None."""
        team = self._team
        if team is not None and team.intentions is not self.team_mates.polled_intentions:
            self.team_mates.poll(team)  # (the mapping polled last holds nothing new)
        new = self._prediction_due(t)
        if new is None:
            return None
        return self._prediction_query(t, list(self._perceived.tracks)), new

    def _control_predict(self, t, nav, pending, all_c) -> None:
        """Act on the control tick's prediction (``pending`` from :meth:`_control_query`, its
        conflicts ``all_c``)."""
        query, new = pending
        self._act_on_prediction(t, nav, query, all_c, list(self._perceived.static_polygons))
        self._known_track_ids |= new  # also those the prediction set aside (a team mate's stale copy)

    def _deviating(self, tracks) -> bool:
        """Some track is farther than ``track_deviation_m`` from where the last prediction put it
        at the track's time (team mates on a fresh broadcast excepted: their plans are compared
        instead). All tracks in one array operation on the last prediction's stacked motion; the
        same tracks are not checked twice against the same prediction."""
        if tracks is self._checked_tracks or not tracks:
            return False
        self._checked_tracks = tracks
        if self._predicted_motion is None:
            from_broadcast = self.team_mates.predicted_names()
            checked = [tr for tr in self._predicted_tracks.values() if tr.team_member not in from_broadcast]
            self._predicted_motion = TrackMotions(checked)
            self._predicted_row = {tr.track_id: k for k, tr in enumerate(checked)}
        row = self._predicted_row
        ids, times, pos = track_columns(tracks)  # (a TrackRows' own columns: no estimate made)
        sel = [(row[i], k) for k, i in enumerate(ids) if i in row]
        if not sel:
            return False
        rows, ks = zip(*sel)
        if len(ks) < len(ids):
            times, pos = [times[k] for k in ks], [pos[k] for k in ks]
        return self._predicted_motion.farther_than(rows, times, pos, self.config.track_deviation_m)

    def _control_refs(self, t, nav) -> tuple[float | None, str, float | None]:
        """(speed override [m/s] or None, mode, course override [rad] or None) for this control
        tick (one vessel's :func:`control_slot`)."""
        pending = self._control_query(t)
        if pending is not None:
            query = pending[0].query
            self._control_predict(t, nav, pending, predict_fleet_lazy([query])[0] if query is not None else [])
        return self._control_rest(t, nav)

    def _control_rest(self, t, nav) -> tuple[float | None, str, float | None]:
        """The control tick after its prediction: :meth:`_control_refs`' result; switches back to
        the mission path when a detour is finished. (On the mission, without a detour, a velocity
        correction or a sharp turn to leave, there are no overrides: the mode is noted only.)"""
        override = course = None
        if self.detour is not None or self.correction is not None or self._sharp_turn is not None:
            override, course = self._manoeuvre_refs(t, nav)
        if self.correction is not None:
            mode = f"avoidance:{self.correction.kind}"
        elif self.detour is not None:
            mode = "avoidance:detour"
        else:
            mode = "mission"
        if self._last_control_t is not None:
            self.mode_time_s[self.mode] += max(t - self._last_control_t, 0.0)
        self._last_control_t = t
        if mode != self.mode:
            self._event(t, f"mode {self.mode} → {mode}")
            self.mode = mode
        return override, mode, course

    def _manoeuvre_refs(self, t, nav) -> tuple[float | None, float | None]:
        """(speed override [m/s] or None, course override [rad] or None) of a running manoeuvre:
        back on the mission path at a detour's end, a velocity correction's law (a finished one
        ended, the planned motion predicted again), a sharp turn on a detour."""
        d = self.detour
        g = self._guidance
        if d is not None and g.path is d.path and g.gamma_m >= d.detour_length_m - 0.5:
            g_m = d.mission_gamma(g.gamma_m)
            self._back_to_mission(t, g_m, f"detour finished: back on the mission path at γ = {g_m:.1f} m")
        elif d is not None and g.path is not d.path:
            self.detour = None
        override = None
        c = self.correction
        if c is not None:
            if c.law.finished(t):
                self._event(t, f"velocity correction ({c.kind}) complete: mission speed resumed")
                self.correction = None
                if self._perceived is not None:  # the planned motion changed: check it before it is sailed
                    self.stats["deviation_predictions"] += 1
                    self._predict_on_perceived(t, nav)
                c = self.correction
            if c is not None and not c.law.finished(t):
                override = c.law.command(self._guidance.gamma_m + c.gamma_offset_m, t)
        course = None
        if self.detour is not None and self.correction is None:
            override, course = self._sharp_turn_speed(t, nav, override)
        elif self._sharp_turn is not None:
            self._sharp_turn = None
        return override, course

    def _sharp_turn_speed(self, t, nav, override) -> tuple[float | None, float | None]:
        """Brake, then turn, when a detour asks for a sharp turn: its point 5 m ahead more than
        ``sharp_turn_deg`` off the heading. While the hull is faster than ``sharp_turn_speed_m_s``
        it takes all way off holding its heading (course override); then it turns at that speed.
        Returns (speed override, course override [rad] or None). A saturated turn at speed leaves
        forward thrust (a full differential: reverse is the weaker propeller direction) and
        advances the hull several metres — thesis §6.2 and §6.4.3 under 30 % dropout: a re-plan 7 m
        from the pontoon / the south island asked for a 92° turn and the Otter, still at 0.55 m/s,
        ran into it; it stops from 1 m/s within a metre."""
        g, cfg = self._guidance, self.config
        x, y, _, _ = g.path.at(min(g.gamma_m + 5.0, g.path.length))
        err = abs(float(wrap_angle(np.arctan2(y - nav.position_m[1], x - nav.position_m[0]) - nav.heading_rad)))
        if err <= np.radians(cfg.sharp_turn_deg):
            self._sharp_turn = None
            return override, None
        limit = cfg.sharp_turn_speed_m_s
        if self._sharp_turn is None:  # onset: brake first when faster than the turn speed
            self.stats["sharp_turn"] += 1
            fast = float(nav.body_velocity[0]) > limit
            self._sharp_turn = ("brake", float(nav.heading_rad)) if fast else ("turn", None)
            self._event(t, f"sharp turn on the detour ({np.degrees(err):.0f}° off the heading): "
                           + ("all way off on the heading, then " if fast else "") + f"turning at {limit:g} m/s")
        if self._sharp_turn[0] == "brake":
            if float(nav.body_velocity[0]) > limit:
                return 0.0, self._sharp_turn[1]
            self._sharp_turn = ("turn", None)
        return (limit if override is None else min(override, limit)), None

    # ------------------------------------------------------------------ summary and recording
    def summary(self) -> dict:
        total = sum(self.mode_time_s.values())
        return {
            "method": self.method,
            "enabled": self.config.enabled,
            "predictions": self.stats["predictions"],
            "predictions_on_track_deviation": self.stats["deviation_predictions"],
            "predicted_conflicts": self.stats["predicted_conflicts"],
            "static_conflicts": self.stats["static_conflicts"],
            "actions": {k: self.stats[k] for k in ("yield", "pass", "stand_on", "replan", "lane_change", "checked_choice",
                                                          "replan_failed", "emergency", "withdrawn", "sharp_turn",
                                                          "detour_rejected", "in_structure")},
            "mode_time_s": {k: round(v, 2) for k, v in self.mode_time_s.items()},
            "mode_share": {k: round(v / total, 4) if total > 0 else 0.0 for k, v in self.mode_time_s.items()},
            "min_predicted_distance_m": round(self.min_predicted_distance_m, 3)
            if np.isfinite(self.min_predicted_distance_m) else None,
            "conflicts": self.conflict_log,
        }

    @property
    def logs_guidance(self) -> bool:
        """Does :meth:`log` draw anything of ``guidance`` now (the virtual target: only while a
        velocity correction runs)? The agent builds the guidance state for it only then."""
        return self.correction is not None

    def log(self, recorder, t, vessel_name, guidance: GuidanceState | None = None) -> None:
        """Log to the recording: the mode, the virtual target (on ``guidance``'s path, the path
        follower's state now), and what the latest prediction and re-plan produced."""
        self._log.log(recorder, t, vessel_name, self.mode, self.correction, guidance, self._last, self.detour,
                      self.team)
