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

**The fleet in one call** (:mod:`~mjasc.avoidance.fleet_slots`). :func:`predict_slot` runs the
prediction slot of many vessels: each system prepares its query (its tracks as predicted, its
planned motion), all (vessel, track) pairs are predicted in one
:func:`~mjasc.avoidance.prediction.predict_fleet` call, then each system acts on its own result —
the same requests as vessel by vessel. The control tick is cheap in the common case (no new track,
no deviation): the deviation check runs on the last prediction's stacked track motions
(:class:`~mjasc.avoidance.prediction.TrackMotions`) in one array operation, once per new perception
report.

A manoeuvre ends when it is complete (the correction's goal time is reached, the end of the
detour is reached) and the latest prediction predicts no collision; then the mission resumes.
Every transition is an event. While on a detour, :meth:`mission_gamma_m` maps progress along the
detour linearly onto the obstructed stretch of the mission path it replaces, so the coordination
layer sees a continuous, monotone γ.

**Where the parts live.** This module holds the stage interface and the vessel's own plan; the
fleet's two slots are :mod:`~mjasc.avoidance.fleet_slots`; the class's other parts are its bases,
each one concept: a prediction's query and acting on its result
(:mod:`~mjasc.avoidance.prediction_step`), decision σ and the path switches
(:mod:`~mjasc.avoidance.manoeuvres`), the control tick's checks and a running manoeuvre's
references (:mod:`~mjasc.avoidance.control_tick`); the planned speed profile γ(t) is
:mod:`~mjasc.avoidance.speed_plan`.

World frame ENU, SI units, absolute simulation times [s].
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from mjasc.avoidance.config import AvoidanceConfig, check_avoidance, parse_avoidance_options
from mjasc.avoidance.control_tick import ControlTick
from mjasc.avoidance.decision import Correction
from mjasc.avoidance.fleet_slots import control_slot, predict_slot
from mjasc.avoidance.intent_plan import plan_offsets, planned_points
from mjasc.avoidance.manoeuvres import Manoeuvres
from mjasc.avoidance.prediction import PredictionQuery, TrackMotions, gamma_of_time
from mjasc.avoidance.prediction.conflicts import predict_fleet_lazy
from mjasc.avoidance.prediction_step import PredictionRecord, PredictionStep
from mjasc.avoidance.recording import AvoidanceLog
from mjasc.avoidance.replanning import Detour, merge_overlapping, swept_area
from mjasc.avoidance.request import MODES, AvoidanceRequest, PathSwitch
from mjasc.avoidance.speed_plan import correction_profile as _correction_profile
from mjasc.avoidance.speed_plan import correction_terms as _correction_terms
from mjasc.avoidance.static_conflicts import StaticConflict
from mjasc.avoidance.team_mates import PlannedTrack, TeamMates
from mjasc.core.compiled import clip_float
from mjasc.guidance.paths import Path
from mjasc.guidance.state import GuidanceState
from mjasc.plugins.stages import AvoidanceMethod

__all__ = ["AvoidanceConfig", "CollisionAvoidance", "StaticConflict", "Detour", "PlannedTrack", "PredictionRecord",
           "parse_avoidance_options", "MODES", "merge_overlapping", "swept_area", "predict_slot"]


class CollisionAvoidance(PredictionStep, Manoeuvres, ControlTick, AvoidanceMethod):
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
        self.station_keeping = False  # the mission leg is a line through a moving station (set_mission)
        self.mode = "mission"
        self.correction: Correction | None = None
        #: the correction that last ended at its goal (the prediction sheds a pass's extra speed after it)
        self.ended_correction: Correction | None = None
        self.detour: Detour | None = None
        self._detour_causes: set[int] | None = None  # the moving tracks a detour goes around (None: statics too)
        # a sharp turn on the detour: ("brake", heading), ("turn", way) or ("held", way)
        self._sharp_turn: tuple | None = None
        self.team_mates = TeamMates(self.name, self.team, self.radius_m, config.team_broadcast_max_age_s,
                                    config.track_deviation_m, config.window_s or 30.0)
        self._known_track_ids: set[int] = set()
        self._first_predicted_s: dict[int, float] = {}  # track id → time of its first prediction [s]
        self._first_position_m: dict[int, tuple] = {}  # track id → (x, y) at the first prediction that saw it [m]
        self._lagging_said: set[int] = set()  # tracks said to be predicted moving though flagged static
        self._clear_since_s: float | None = None  # a withdrawable yield's track clear at the mission speed since
        self._in_structure: set[int] = set()  # tracks centred inside mapped structure (its own returns)
        self._predicted_tracks: dict = {}
        self._stands_on: frozenset = frozenset()  # team mates the last prediction made it stand on toward
        self._stuck_since: dict[int, float] = {}  # stopped team mates inside the collision distance since [s]
        self._separating: Detour | None = None  # the leg away from a stopped team mate (a deadlock's way out)
        self._separation_asked_s = -np.inf  # the last time a way out of a deadlock was looked for [s]
        # The last prediction's tracks for the deviation check of the control tick: their stacked
        # motion, track id → row, and whether the row is checked (not a team mate on a broadcast).
        self._predicted_motion: TrackMotions | None = None
        self._predicted_row: dict[int, int] = {}
        self._predicted_ids = None  # the rows' track ids (int64 array), or None (not integers)
        self._checked_tracks = None  # the perceived tracks found on the last prediction's motion
        self._no_new_in = None  # perceived tracks found to hold no new track id
        self._last_predict_t = -np.inf
        self._look_again_until_s = -np.inf  # predict every second until then (way kept; a running correction kept colliding)
        self._way_kept_for: int | None = None  # the stranger's track id way was last kept against
        self._predicted_speed = None
        self._mission_moved = False  # the mission gave a new path: predict on it at the next control tick
        self._events: list[tuple[float, str]] = []
        self._last_control_t: float | None = None
        # The thesis's modes (it never steers a course: "avoidance:steer" is the velocity obstacles')
        self.mode_time_s = {m: 0.0 for m in MODES if m != "avoidance:steer"}
        self.detour_time_s = 0.0  # time on a detour in any mode (a correction sailed on one counts as the correction)
        self._on_detour = False  # a detour ran since the last control tick
        self.stats = {"predictions": 0, "predicted_conflicts": 0, "static_conflicts": 0, "yield": 0, "pass": 0,
                      "stand_on": 0, "replan": 0, "replan_failed": 0, "monitor_only": 0,
                      "deviation_predictions": 0, "emergency": 0, "lane_change": 0, "checked_choice": 0,
                      "withdrawn": 0, "sharp_turn": 0, "detour_rejected": 0, "in_structure": 0, "turn_away": 0,
                      "turn_held": 0, "separate": 0, "separate_refused": 0, "stopped_mate_ahead": 0}
        self.min_predicted_distance_m = float("inf")
        self.conflict_log: list[dict] = []
        self.logged_now: list[dict] = []  # the conflict records of the latest prediction (their triage answers)
        self._answers: dict = {}  # each track's latest triage answer (an event when it changes)
        self.last_conflict: dict | None = None  # the latest conflict's record (the video's HUD shows it)
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
        return AvoidanceRequest.of(self.mode, None, self._switch, tuple(conflicts), None)

    def control(self, t, nav, guidance: GuidanceState, perceived=None, team=None) -> AvoidanceRequest:
        """Control tick: the speed override (a velocity correction's law) and the path to follow
        (back on the mission path when a detour is finished); predicts at once on a new track, a
        deviating track or plan, or a changed mission speed. ``perceived`` None: no perception."""
        self._begin(guidance, perceived, team)
        override, mode, course = self._control_refs(float(t), nav)
        return AvoidanceRequest.of(mode, override, self._switch, (), course)

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
        self.mission_path, self.station_keeping = leg.path, bool(getattr(leg, "station_keeping", False))
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
    def _predict(self, t, nav, tracks, static_polygons, after_replan: bool = False, grown=()) -> list:
        """Predict conflicts with the vessel's tracks and static polygons and act on them.
        Returns the conflicts with a predicted collision (PredictedConflict / StaticConflict).
        ``grown``: ids of tracks checked with their radius grown by ``replan_margin_m`` (a fresh
        detour's check against the team mates it gives way to: :meth:`Manoeuvres._decide`)."""
        pending = self._prediction_query(t, tracks, grown)
        all_c = predict_fleet_lazy([pending.query])[0] if pending.query is not None else []
        return self._act_on_prediction(t, nav, pending, all_c, static_polygons, after_replan)

    # ------------------------------------------------------------------ control (one vessel)
    def _control_refs(self, t, nav) -> tuple[float | None, str, float | None]:
        """(speed override [m/s] or None, mode, course override [rad] or None) for this control
        tick (one vessel's :func:`control_slot`)."""
        pending = self._control_query(t)
        if pending is not None:
            query = pending[0].query
            self._control_predict(t, nav, pending, predict_fleet_lazy([query])[0] if query is not None else [])
        return self._control_rest(t, nav)

    # ------------------------------------------------------------------ summary and recording
    def summary(self) -> dict:
        total = sum(self.mode_time_s.values())
        return {
            "method": self.method,
            "enabled": self.config.enabled,
            "predictions": self.stats["predictions"],
            "predictions_on_track_deviation": self.stats["deviation_predictions"],
            "predictions_on_team_clearance": self.team_mates.clearance_changes,
            "predicted_conflicts": self.stats["predicted_conflicts"],
            "static_conflicts": self.stats["static_conflicts"],
            "actions": {k: self.stats[k] for k in ("yield", "pass", "stand_on", "replan", "lane_change", "checked_choice",
                                                          "replan_failed", "emergency", "withdrawn", "sharp_turn",
                                                          "detour_rejected", "in_structure", "turn_away", "turn_held", "separate",
                                                          "separate_refused", "stopped_mate_ahead")},
            "mode_time_s": {k: round(v, 2) for k, v in self.mode_time_s.items()},
            "mode_share": {k: round(v / total, 4) if total > 0 else 0.0 for k, v in self.mode_time_s.items()},
            "detour_time_s": round(self.detour_time_s, 2),
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
