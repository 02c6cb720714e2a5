"""One vessel's collision avoidance system: prediction → decision → manoeuvre → mission again.

Digest §1, §3–5 (thesis ch. 3–4). The vessel runs in one of two modes with a strict hierarchy:
**mission** (path following at the mission speed, possibly corrected by coordination) and
**collision avoidance**, which overrides the mission. Avoidance has three actions, shown in the
mode string::

    "mission"             no action
    "avoidance:yield"     velocity correction, goal (γ_A − margin, t_f): slow down, let it pass
    "avoidance:pass"      velocity correction, goal (γ_B + margin, t_i): speed up, pass first
    "avoidance:detour"    re-planned path (potential-field streamline) spliced into the mission

Prediction (``predict``, at the prediction rate and at once when a new track appears) runs
:func:`~mjasc.avoidance.prediction.predict_conflicts` with the vessel's **planned** motion: its
current path (a detour while on one) at its speed profile (the virtual target while a velocity
correction runs, the mission speed after it), against each of its own tracks (never the
simulator's truth), plus the static polygons its perception reports (checked directly against
the path ahead). Team mates' tracks are re-based on their own broadcast navigation (position,
velocity, heading rate over the comms link) when it is fresh: the IMM's ω̂ of a vessel on a straight
leg wanders enough to predict phantom collisions between parallel lanes. Decision σ (thesis eq.
3.17) per conflict:

- REPLAN (long obstruction, or a static obstacle): a :class:`~mjasc.avoidance.potential_field.PotentialField`
  around the static virtual obstacles (SVO: each swept area, already grown by R_vh + safety) and
  the static polygons near the route (grown by half the beam + safety distance), with the goal
  back on the mission path beyond the obstruction and the robust rule V_j = r·a_max·L_j
  (safety ratio r); the streamline becomes a :class:`~mjasc.guidance.paths.Path`, is spliced in front of
  the rest of the mission path and handed to the path follower. When the vessel reaches the end
  of the streamline, the follower is switched back to the mission path at the matching γ.
- VELOCITY_CORRECTION: right of way (digest §5): always yield to a non-team obstacle; between
  team mates :func:`~mjasc.avoidance.right_of_way.gives_way` decides and the stand-on vessel keeps its
  speed. Yielding that is impossible (the vessel is already at γ_A, or would have to go slower
  than its minimum speed) becomes passing first when that is feasible, else a re-plan around
  the swept area.

A manoeuvre ends when it is complete (the correction's goal time is reached, the end of the
detour is reached) and the latest prediction predicts no collision; then the mission resumes.
Every transition is an event. While on a detour, :meth:`mission_gamma_m` maps progress along the
detour linearly onto the obstructed stretch of the mission path it replaces, so the coordination
layer sees a continuous, monotone γ.

World frame ENU, SI units, absolute simulation times [s].
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import rerun as rr

from mjasc.avoidance.prediction import (
    CollisionPredictionConfig,
    Decision,
    PredictedConflict,
    gamma_of_time,
    predict_conflicts,
    swept_disc_polygon,
)
from mjasc.core.config_tables import ConfigError, boolean, dataclass_from_table, number, show
from mjasc.core.estimates import TrackEstimate
from mjasc.core.geometry import (
    clean_polygon,
    convex_hull,
    disc_hull,
    distance_to_polygon,
    inflate_polygon,
    point_in_polygon,
)
from mjasc.guidance.paths import Path
from mjasc.avoidance.potential_field import PotentialField
from mjasc.avoidance.right_of_way import gives_way, relative_bearing
from mjasc.avoidance.velocity_correction import VelocityCorrection

__all__ = ["AvoidanceConfig", "CollisionAvoidance", "StaticConflict", "Detour", "PlannedTrack",
           "parse_avoidance_options", "MODES", "merge_overlapping"]

#: How far back [s] the team mates' broadcast positions are kept to recognise their stale tracks.
TEAM_HISTORY_S = 20.0

#: Mode strings and their codes in the ``plots/mode/<vessel>`` time series.
MODES = {"mission": 0, "avoidance:yield": 1, "avoidance:pass": 2, "avoidance:detour": 3}


# ------------------------------------------------------------------------------------------ config
@dataclass(frozen=True)
class AvoidanceConfig:
    """Parameters of one vessel's collision avoidance (the ``[vessels.avoidance]`` table).

    enabled: False → predict and record conflicts but never act (monitor only).
    Prediction (digest §3, defaults thesis §6.1): window_s (None = dynamic δ = v/a_brake + ζ),
    brake_decel_m_s2, margin_s, safety_distance_m, obstruction_threshold_s (Δt_threshold of σ),
    time_step_s, max_range_m (tracks farther away are ignored; None = all).
    Velocity correction (digest §5): gain_k [1/s], speed_min_m_s, speed_max_m_s (None = the
    vessel's top speed), correction_margin_m (goal γ_A − margin / γ_B + margin), allow_pass_first.
    Re-planning (digest §4): safety_ratio r of the robust rule, sink_strength λ_g [m²/s] (None =
    scaled to the obstacles: max(30, 2 U (width + 10 m))), uniform_speed U, goal_margin_m (goal
    this far beyond the obstruction on the mission path), streamline_step_m, static_inflation_m
    (None = half beam + safety distance), static_range_m (static polygons this close to the
    route enter the field), max_panel_length_m. track_deviation_m: predict again at once when a
    track (e.g. a team mate that re-planned) is this far from where the last prediction put it, or
    when the mission speed (with the coordination factor) changed by more than speed_change_m_s.
    static_speed_m_s: tracks estimated slower than this are taken as static (a moored boat's IMM
    speed is noise around zero; predicting it forward would sweep it about). replan_margin_m: the
    SVOs handed to the planner are grown by this much, so that the detour, followed with some
    cross-track error, is not itself flagged by the next prediction (hysteresis against re-plan churn).
    last_resort_s: a stand-on vessel acts too when the collision is this close in time (COLREG
    rule 17: the give-way vessel's view of the conflict may differ, or it may be unable to act).
    When no action is possible at all, the vessel slows to speed_min (an emergency yield).
    A stand-on vessel whose team mate is abaft its beam never slows down (that would let the
    give-way vessel, coming from behind, run into it; COLREG rule 13): at the last resort it may
    only speed up (pass first). team_broadcast_max_age_s: a team mate's track is predicted from its
    own broadcast navigation (position, velocity, heading rate from successive headings) when
    that broadcast is at most this old [s]; 0 → from the IMM track only.
    """

    enabled: bool = True
    window_s: float | None = 30.0
    brake_decel_m_s2: float = 0.1
    margin_s: float = 10.0
    safety_distance_m: float = 1.0
    obstruction_threshold_s: float = 15.0
    time_step_s: float = 0.5
    max_range_m: float | None = None
    gain_k: float = 0.3
    speed_min_m_s: float = 0.2
    speed_max_m_s: float | None = None
    correction_margin_m: float = 2.0
    allow_pass_first: bool = True
    safety_ratio: float = 0.5
    sink_strength: float | None = None
    uniform_speed: float = 1.0
    goal_margin_m: float = 10.0
    streamline_step_m: float = 0.5
    static_inflation_m: float | None = None
    static_range_m: float = 60.0
    max_panel_length_m: float = 3.0
    track_deviation_m: float = 5.0
    speed_change_m_s: float = 0.2
    static_speed_m_s: float = 0.15
    replan_margin_m: float = 1.0
    last_resort_s: float = 10.0
    team_broadcast_max_age_s: float = 3.0

    def __post_init__(self):
        _check_avoidance(self, "avoidance")

    def prediction_config(self) -> CollisionPredictionConfig:
        return CollisionPredictionConfig(
            window_s=self.window_s, brake_decel_m_s2=self.brake_decel_m_s2, margin_s=self.margin_s,
            safety_distance_m=self.safety_distance_m, obstruction_threshold_s=self.obstruction_threshold_s,
            time_step_s=self.time_step_s, max_range_m=self.max_range_m)


#: AvoidanceConfig's own numeric fields by their bounds (the prediction fields are checked by
#: CollisionPredictionConfig); None is allowed for those in _OPTIONAL.
_POSITIVE = ("gain_k", "speed_max_m_s", "sink_strength", "uniform_speed", "streamline_step_m", "static_range_m",
             "max_panel_length_m", "track_deviation_m", "speed_change_m_s")
_NONNEG = ("speed_min_m_s", "correction_margin_m", "goal_margin_m", "static_inflation_m", "static_speed_m_s",
           "replan_margin_m", "last_resort_s", "team_broadcast_max_age_s")
_OPTIONAL = ("speed_max_m_s", "sink_strength", "static_inflation_m")


def _check_avoidance(c: AvoidanceConfig, where: str) -> None:
    """Validate an :class:`AvoidanceConfig` (ConfigError, a ValueError, naming ``f"{where}.{key}"``)."""
    boolean(c.enabled, f"{where}.enabled")
    boolean(c.allow_pass_first, f"{where}.allow_pass_first")
    try:
        c.prediction_config()  # the prediction fields, validated by collision_prediction itself
    except ValueError as exc:
        raise ConfigError(f"{where}.{exc}") from None
    for key in _POSITIVE + _NONNEG:
        value = getattr(c, key)
        if not (value is None and key in _OPTIONAL):
            number(value, f"{where}.{key}", positive=key in _POSITIVE, nonneg=key in _NONNEG)
    number(c.safety_ratio, f"{where}.safety_ratio", nonneg=True, maximum=1.0)
    if c.speed_max_m_s is not None and c.speed_max_m_s <= c.speed_min_m_s:
        raise ConfigError(f"{where}.speed_max_m_s: must exceed speed_min_m_s ({c.speed_min_m_s}), "
                          f"got {show(c.speed_max_m_s)}")


def _window(value: Any, where: str) -> float | None:
    """Reader of ``window_s``: ``"dynamic"`` → None (δ = v/a_brake + ζ), else a number [s] (its
    sign is checked with the other prediction fields)."""
    if isinstance(value, str):
        if value != "dynamic":
            raise ConfigError(f'{where}: must be a number [s] or "dynamic", got {show(value)}')
        return None
    return number(value, where)


def parse_avoidance_options(table: dict, where: str = "avoidance") -> AvoidanceConfig:
    """Validate a ``[vessels.avoidance]`` table into an :class:`AvoidanceConfig`.

    ``window_s = "dynamic"`` selects the dynamic window δ = v/a_brake + ζ; every other field is a
    number or a boolean as in :class:`AvoidanceConfig`. Unknown keys, wrong types and out-of-range
    values raise ValueError naming ``f"{where}.{key}"`` (:func:`mjasc.core.config_tables.dataclass_from_table`)."""
    return dataclass_from_table(AvoidanceConfig, table, where, {"window_s": _window}, check=_check_avoidance)


# ------------------------------------------------------------------------------------------ values
@dataclass(frozen=True, eq=False)
class StaticConflict:
    """A static polygon obstructing the path ahead: stretch [γ_A, γ_B] of the current path whose
    points are closer than R_vh + safety to ``polygon`` (k, 2). Always → re-planning."""

    gamma_a: float
    gamma_b: float
    point_a: np.ndarray
    point_b: np.ndarray
    polygon: np.ndarray
    t_i: float
    min_distance_m: float
    decision: Decision = Decision.REPLAN
    track_id: int | None = None  # the static track whose outline this is (None: a static-map polygon)


@dataclass(frozen=True, eq=False)
class Detour:
    """A re-planned path: ``path`` = streamline (length ``detour_length_m``) + the rest of the
    mission path from ``mission_gamma_goal_m``; it replaced the mission path from
    ``mission_gamma_start_m``. ``obstacles`` the field's polygons, ``field`` the field itself."""

    path: Path
    detour_length_m: float
    mission_gamma_start_m: float
    mission_gamma_goal_m: float
    streamline: np.ndarray
    obstacles: tuple
    field: PotentialField
    time_s: float

    def mission_gamma(self, gamma_m: float) -> float:
        """Mission-path γ [m] for γ on this path: linear over the detour, then one to one."""
        s, L = float(gamma_m), self.detour_length_m
        if s <= L:
            return self.mission_gamma_start_m + (self.mission_gamma_goal_m - self.mission_gamma_start_m) * max(s, 0.0) / L
        return self.mission_gamma_goal_m + (s - L)


@dataclass
class _Correction:
    law: VelocityCorrection
    kind: str  # "yield" | "pass"
    track_id: int
    gamma_offset_m: float = 0.0  # γ in the law's frame = follower γ + offset


@dataclass(frozen=True, eq=False)
class PlannedTrack(TrackEstimate):
    """A team mate predicted from its own broadcast plan (:class:`mjasc.cooperation.coordination.TeamIntention`):
    ``predict_positions`` follows the plan (its path, a detour included, at its planned speed)
    instead of constant speed and turn rate. ``speed_m_s`` is the plan's largest speed (the
    prediction samples the swept stretch with it), position/heading/time are the broadcast's."""

    intention: Any = None

    def predict_positions(self, times_s: np.ndarray) -> np.ndarray:
        return self.intention.positions(times_s)


def swept_area(track: TrackEstimate, t_a: float, t_b: float, radius_m: float) -> np.ndarray:
    """Polygon (k, 2) containing the disc of ``radius_m`` swept along the track's prediction over
    [t_a, t_b]: :func:`~mjasc.avoidance.prediction.swept_disc_polygon` for constant speed and turn
    rate, the convex hull of discs every 0.5 s along a :class:`PlannedTrack`'s plan."""
    if not isinstance(track, PlannedTrack):
        return swept_disc_polygon(track, t_a, t_b, radius_m)
    ts = np.linspace(t_a, t_b, max(2, int(np.ceil((t_b - t_a) / 0.5)) + 1))
    return disc_hull(track.predict_positions(ts), radius_m, 16)


def merge_overlapping(polygons: list[np.ndarray], clearance_m: float = 0.0) -> list[np.ndarray]:
    """Replace polygons that overlap (or come closer than ``clearance_m``) by their convex hull,
    until none do. The potential field needs disjoint obstacles."""
    polys = [np.asarray(p, dtype=float) for p in polygons]
    changed = True
    while changed and len(polys) > 1:
        changed = False
        for i in range(len(polys)):
            for j in range(i + 1, len(polys)):
                a, b = polys[i], polys[j]
                close = (np.any(point_in_polygon(a, b)) or np.any(point_in_polygon(b, a))
                         or float(np.min(distance_to_polygon(a, b))) <= clearance_m
                         or float(np.min(distance_to_polygon(b, a))) <= clearance_m)
                if close:
                    pts = np.vstack([a, b])
                    hull = convex_hull(pts, canonical=False)
                    polys = [p for k, p in enumerate(polys) if k not in (i, j)] + [hull]
                    changed = True
                    break
            if changed:
                break
    return polys


def _outline(track: TrackEstimate) -> np.ndarray | None:
    """A static track's outline (k ≥ 3, 2) [m], or None when it is degenerate (then its disc is used)."""
    p = np.asarray(track.outline_m, dtype=float).reshape(-1, 2)
    if p.shape[0] < 3 or not np.all(np.isfinite(p)):
        return None
    return p


# ------------------------------------------------------------------------------------------ system
class CollisionAvoidance:
    """Collision avoidance of one vessel (see the module docstring).

    agent: the :class:`~mjasc.runs.agent.VesselAgent` (its follower, vessel type, mission speed and
    perception are used; nothing else). config: :class:`AvoidanceConfig` or a raw table.
    team_names: names of all vessels of the team (tracks whose ``team_member`` is one of them are
    team mates). rng: the component's random stream (unused: the system is deterministic).
    """

    def __init__(self, agent, config, team_names, rng=None):
        if isinstance(config, dict):
            config = parse_avoidance_options(config)
        if not isinstance(config, AvoidanceConfig):
            raise ValueError(f"config: expected an AvoidanceConfig, got {type(config).__name__}")
        self.agent = agent
        self.config = config
        self.name = getattr(agent, "name", "vessel")
        self.team = {str(n) for n in team_names} - {self.name}
        self.rng = rng
        vt = agent.vessel
        self.radius_m = float(vt.radius_m)
        self.speed_max_m_s = float(config.speed_max_m_s if config.speed_max_m_s is not None else vt.top_speed_m_s)
        self.static_inflation_m = float(config.static_inflation_m if config.static_inflation_m is not None
                                        else 0.5 * vt.beam_m + config.safety_distance_m)
        self.prediction_config = config.prediction_config()
        follower = agent.follower
        self.mission_path: Path | None = follower.path if follower is not None else None
        self.mode = "mission"
        self.correction: _Correction | None = None
        self.detour: Detour | None = None
        self._known_track_ids: set[int] = set()
        self._predicted_tracks: dict[int, TrackEstimate] = {}
        self._last_predict_t = -np.inf
        self._predicted_speed = None
        self._events: list[tuple[float, str]] = []
        self._last_control_t: float | None = None
        self.mode_time_s = {m: 0.0 for m in MODES}
        self.stats = {"predictions": 0, "predicted_conflicts": 0, "static_conflicts": 0, "yield": 0, "pass": 0,
                      "stand_on": 0, "replan": 0, "replan_failed": 0, "monitor_only": 0,
                      "deviation_predictions": 0, "emergency": 0}
        self.min_predicted_distance_m = float("inf")
        self.conflict_log: list[dict] = []
        self._conflict_keys: set = set()
        self._last: dict | None = None  # what the latest prediction saw, for the recording
        self._log_pending = False
        self._styled = False
        self._team_nav: dict[str, tuple] = {}  # name → (sent t, heading, ω) from successive broadcasts
        self._predicted_intentions: dict = {}  # name → TeamIntention the last prediction used
        self._team_history: dict[str, list] = {}  # name → [(sent t, position, radius)] over TEAM_HISTORY_S
        self._plan_checked: dict[str, float] = {}  # name → sent time of the last message compared
        self._ghosts: set[int] = set()  # track ids found to be a team mate's stale copy (reported once)
        self._repredict = False  # the planned motion changed (a correction ended): predict again

    # ------------------------------------------------------------------ interface
    def drain_events(self) -> list[tuple[float, str]]:
        ev, self._events = self._events, []
        return ev

    def _event(self, t: float, text: str) -> None:
        self._events.append((float(t), text))

    def mission_gamma_m(self, follower) -> float:
        """Progress along the ORIGINAL mission path [m], also while on a detour."""
        if self.detour is not None and follower.path is self.detour.path:
            return self.detour.mission_gamma(follower.gamma_m)
        return float(follower.gamma_m)

    def mission_speed_now(self) -> float:
        """The speed the mission asks for now [m/s]: the mission speed times the coordination
        controller's latest correction factor (when the vessel has one)."""
        factor = getattr(getattr(self.agent, "coordination", None), "last_factor", 1.0)
        return float(self.agent.mission_speed_m_s) * float(factor if np.isfinite(factor) else 1.0)

    def planned_gamma(self, t_now: float, gamma_now: float):
        """γ(t) [m] on the follower's current path for absolute times t ≥ t_now: the virtual
        target's speed V_d until its goal time while a correction runs, the mission speed after."""
        v_m = self.mission_speed_now()
        c = self.correction
        if c is None:
            return float(v_m)
        t_g, v_d = c.law.t_goal, max(c.law.desired_speed, 0.0)

        def gamma_fn(t):
            t = np.asarray(t, dtype=float)
            return gamma_now + v_d * np.clip(t - t_now, 0.0, max(t_g - t_now, 0.0)) + v_m * np.maximum(t - max(t_g, t_now), 0.0)

        return gamma_fn

    # ------------------------------------------------------------------ own plan, team mates' plans
    def planned_trajectory(self, t, nav, horizon_s: float, step_s: float):
        """Where this vessel intends to be: (times (k,) absolute [s], points (k, 2) world [m]) every
        ``step_s`` over ``horizon_s``, along the path it follows now (the detour while on one) at its
        planned speed (:meth:`planned_gamma`: the virtual target while a velocity correction runs).
        The first point is the vessel's position; its offset from the path fades out over 10 s
        (the path follower's convergence). Broadcast to the team by the coordination layer."""
        t = float(t)
        times = t + np.arange(0.0, float(horizon_s) + 0.5 * float(step_s), float(step_s))
        follower = self.agent.follower
        if follower is None:
            return times, np.tile(np.asarray(nav.position_m, dtype=float)[:2], (times.size, 1))
        path = follower.path
        g0 = float(np.clip(follower.gamma_m, 0.0, path.length))
        g = np.clip(gamma_of_time(self.planned_gamma(t, g0), g0, t)(times), 0.0, path.length)
        pts = np.asarray(path.point(g), dtype=float).reshape(-1, 2)
        off = np.asarray(nav.position_m, dtype=float)[:2] - pts[0]
        pts = pts + np.clip(1.0 - (times - t) / 10.0, 0.0, 1.0)[:, None] * off
        return times, pts

    def _intentions(self, t: float) -> dict:
        """The team mates' fresh intentions (``Coordination.team_intentions``), at most
        ``team_broadcast_max_age_s`` old; empty without coordination or when that age is 0."""
        max_age = self.config.team_broadcast_max_age_s
        coord = getattr(self.agent, "coordination", None)
        if coord is None or max_age <= 0.0 or not hasattr(coord, "team_intentions"):
            return {}
        return {n: i for n, i in coord.team_intentions(t, max_age).items() if n in self.team}

    def _poll_team(self, t: float | None = None) -> None:
        """Heading rate ω of each team mate from two successive broadcasts [rad/s] (used when a
        team mate sends no plan)."""
        coord = getattr(self.agent, "coordination", None)
        if coord is None or not hasattr(coord, "team_intentions"):
            return
        for name, it in coord.team_intentions().items():
            old = self._team_nav.get(name)
            if name not in self.team or (old is not None and it.sent_time_s <= old[0]):
                continue
            hist = self._team_history.setdefault(name, [])
            hist.append((it.sent_time_s, np.asarray(it.position_m, dtype=float).copy(),
                         float(it.radius_m) if it.radius_m else self.radius_m))
            while hist and hist[0][0] < it.sent_time_s - TEAM_HISTORY_S:
                hist.pop(0)
            w = 0.0
            if old is not None and 0.0 < it.sent_time_s - old[0] <= 3.0:
                w = float(np.angle(np.exp(1j * (it.heading_rad - old[1])))) / (it.sent_time_s - old[0])
            self._team_nav[name] = (it.sent_time_s, it.heading_rad, w)

    def _from_intention(self, it, track: TrackEstimate | None, track_id: int) -> TrackEstimate:
        """A track of team mate ``it.name`` from its own broadcast: along its plan when it sent one
        (:class:`PlannedTrack`), else constant velocity and the heading rate of successive messages."""
        vel = it.velocity_m_s
        speed = float(np.hypot(*vel))
        course = float(np.arctan2(vel[1], vel[0])) if speed > 0.05 else it.heading_rad
        radius = float(track.radius_m) if track is not None else float(it.radius_m if it.radius_m else self.radius_m)
        w = self._team_nav.get(it.name, (None, None, 0.0))[2]
        base = dict(track_id=track_id, time_s=it.sent_time_s, position_m=np.asarray(it.position_m, dtype=float).copy(),
                    heading_rad=course, radius_m=radius, is_static=False, team_member=it.name,
                    position_covariance=np.zeros((2, 2)) if track is None else track.position_covariance)
        if it.has_plan:
            return PlannedTrack(speed_m_s=max(it.max_speed_m_s(), 1e-3), turn_rate_rad_s=w, intention=it, **base)
        return TrackEstimate(speed_m_s=speed, turn_rate_rad_s=w, **base)

    def _broadcast_based(self, track, t: float) -> bool:
        """The track is a team mate predicted from its fresh broadcast (its speed is measured, not
        IMM noise: a slow team mate is not taken as static)."""
        return track.team_member in self.team and track.team_member in self._intentions(t)

    def _team_tracks(self, tracks, t: float) -> list:
        """Team mates predicted from their own broadcasts (digest §6: the team exchanges its
        navigation over comms). A track matched to a team mate with a fresh message (at most
        ``team_broadcast_max_age_s`` old) is replaced by that team mate's intention: its plan —
        the path it follows, a detour included, at its planned speed — or, without a plan, its
        velocity and heading rate. A team mate with a fresh message but no track (not yet matched,
        or lost by the tracker) is added from the message. Why: the IMM's ω̂ of a vessel on a
        straight leg wanders by ±0.01 rad/s, which over a 30 s window bends the prediction by
        metres (phantom collisions between parallel lanes 10 m apart), a team mate's re-planned
        detour or speed correction shows in its track only after it has begun, and a team mate
        that brakes hard can be lost by the tracker for seconds. Team mates without a fresh
        message keep their IMM track."""
        self._poll_team(t)
        intents = self._intentions(t)
        out, seen = [], set()
        for tr in tracks:
            it = intents.get(tr.team_member) if tr.team_member in self.team else None
            if it is None or tr.team_member in seen:
                if it is None:
                    out.append(tr)
                continue
            seen.add(tr.team_member)
            out.append(self._from_intention(it, tr, tr.track_id))
        order = sorted(self.team)
        for name, it in intents.items():
            if name not in seen:
                out.append(self._from_intention(it, None, -1 - order.index(name)))
        return [tr for tr in out if tr.team_member is not None or not self._is_team_ghost(tr, t)]

    def _is_team_ghost(self, track, t: float) -> bool:
        """An unmatched track that, followed back along its own motion, lay on a team mate's
        broadcast position (closer than the larger of the two radii: the discs deeply overlap) at
        one of that team mate's messages of the last ``TEAM_HISTORY_S`` is that team mate: a copy
        the tracker kept coasting at the old velocity when the team mate braked, or a second
        track of it. Anything else that close to a team mate would have been in collision with it."""
        for name, hist in self._team_history.items():
            if not hist or t - hist[-1][0] > TEAM_HISTORY_S:
                continue
            tb = np.array([h[0] for h in hist])
            pb = np.array([h[1] for h in hist])
            rb = np.array([h[2] for h in hist])
            back = track.predict_positions(tb)
            if np.any(np.hypot(*(back - pb).T) <= np.maximum(rb, track.radius_m)):
                if track.track_id not in self._ghosts:
                    self._ghosts.add(track.track_id)
                    self._event(t, f"track {track.track_id} retraces team mate {name}'s broadcast positions: "
                                   f"it is {name} (stale copy), ignored")
                return True
        return False

    def _team_plans_changed(self, t: float) -> bool:
        """A team mate's newest plan differs by more than ``track_deviation_m`` from the one the
        last prediction used, within the prediction window (it re-planned or changed its speed)."""
        intents = self._intentions(t)
        horizon = self.config.window_s or 30.0
        ts = t + np.linspace(0.0, horizon, 16)
        for name, it in intents.items():
            if self._plan_checked.get(name) == it.sent_time_s:
                continue  # this message was compared already
            self._plan_checked[name] = it.sent_time_s
            old = self._predicted_intentions.get(name)
            if old is None:
                if it.has_plan:
                    return True
                continue
            if it.sent_time_s <= old.sent_time_s:
                continue
            if float(np.max(np.hypot(*(it.positions(ts) - old.positions(ts)).T))) > self.config.track_deviation_m:
                return True
        return False

    # ------------------------------------------------------------------ prediction
    def predict(self, t, nav, tracks, static_polygons=(), _after_replan: bool = False) -> list:
        """Predict conflicts with the vessel's tracks and static polygons and act on them.
        Returns the conflicts with a predicted collision (PredictedConflict / StaticConflict)."""
        follower = self.agent.follower
        if follower is None:
            return []
        t = float(t)
        tracks = self._team_tracks([tr for tr in tracks if tr.team_member != self.name], t)
        v_static = self.config.static_speed_m_s
        tracks = [replace(tr, is_static=True, speed_m_s=0.0, turn_rate_rad_s=0.0)
                  if (not tr.is_static and tr.speed_m_s < v_static and not self._broadcast_based(tr, t)) else tr
                  for tr in tracks]
        self._known_track_ids |= {tr.track_id for tr in tracks}
        self._predicted_tracks = {tr.track_id: tr for tr in tracks}
        outlined = {tr.track_id: _outline(tr) for tr in tracks if tr.is_static and tr.outline_m is not None}
        outlined = {k: o for k, o in outlined.items() if o is not None}
        self._predicted_intentions = self._intentions(t)
        self._last_predict_t = t
        self._predicted_speed = self.mission_speed_now()
        path = follower.path
        gamma = float(np.clip(follower.gamma_m, 0.0, path.length))
        profile = self.planned_gamma(t, gamma)
        self.stats["predictions"] += 1
        discs = [tr for tr in tracks if tr.track_id not in outlined]
        all_c = predict_conflicts(path, gamma, t, profile, self.radius_m, discs, self.prediction_config,
                                  include_clear=True) if discs else []
        for c in all_c:
            self.min_predicted_distance_m = min(self.min_predicted_distance_m, c.min_distance_m)
        conflicts: list = [c for c in all_c if c.collision]
        statics = self._static_conflicts(t, path, gamma, profile, static_polygons)
        for tid, poly in outlined.items():  # static tracks: their outline, checked like a mapped polygon
            statics += [replace(c, track_id=tid) for c in self._static_conflicts(t, path, gamma, profile, [poly])]
        by_id = {tr.track_id: tr for tr in tracks}
        self._last = {"t": t, "path": path, "gamma": gamma, "all": all_c, "conflicts": conflicts,
                      "statics": statics, "tracks": by_id}
        self._log_pending = True
        for c in conflicts:
            self._record_conflict(t, c, by_id.get(c.track_id))
        for s in statics:
            self._record_static(t, s)
        if not conflicts and not statics:
            return []
        if not self.config.enabled:
            self.stats["monitor_only"] += 1
            return conflicts + statics
        self._decide(t, nav, conflicts, statics, by_id, static_polygons, allow_replan=not _after_replan,
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
                f"γ ∈ [{c.gamma_a:.1f}, {c.gamma_b:.1f}] m → {c.decision.value}")
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
            self._event(t, f"{what} obstructs the path on γ ∈ [{s.gamma_a:.1f}, {s.gamma_b:.1f}] m "
                           f"(reached at t ≈ {s.t_i:.1f} s) → replan")
            if len(self.conflict_log) < 50:
                self.conflict_log.append({"time_s": round(t, 2), "static": True, "gamma_a": round(s.gamma_a, 2),
                                          "gamma_b": round(s.gamma_b, 2), "decision": "replan"})

    def _static_conflicts(self, t, path: Path, gamma, profile, polygons) -> list[StaticConflict]:
        """Stretches of the path ahead (within the distance covered in the window) closer than
        R_vh + safety to a static polygon."""
        polygons = [np.asarray(p, dtype=float) for p in polygons or ()]
        if not polygons:
            return []
        from mjasc.avoidance.prediction import gamma_of_time, prediction_window

        cfg = self.prediction_config
        gfn = gamma_of_time(profile, gamma, t)
        v_now = max(0.0, float(gfn(t + 1e-3) - gfn(t)) / 1e-3)
        delta = prediction_window(max(v_now, 1e-3), cfg.brake_decel_m_s2, max(cfg.margin_s, 1.0), cfg.window_s)
        reach = float(gfn(t + delta))
        g_end = min(path.length, max(reach, gamma) + self.radius_m)
        if g_end - gamma < 0.25:
            return []
        limit = self.radius_m + cfg.safety_distance_m
        gs = np.arange(gamma, path.length + 1e-9, 0.25)
        pts = path.point(gs)
        n_ahead = int(np.searchsorted(gs, g_end, side="right"))
        out = []
        for poly in polygons:
            near = pts[:n_ahead]  # the path beyond the window only matters for a stretch that starts in it
            if not ((distance_to_polygon(near, poly) < limit) | point_in_polygon(near, poly)).any():
                continue
            d = distance_to_polygon(pts, poly)
            blocked = (d < limit) | point_in_polygon(pts, poly)
            ahead = blocked & (gs <= g_end)
            if not ahead.any():
                continue
            a = int(np.argmax(ahead))
            b = a
            while b + 1 < gs.size and blocked[b + 1]:
                b += 1
            t_i = float(t + (gs[a] - gamma) / max(v_now, 1e-3))
            out.append(StaticConflict(float(gs[a]), float(gs[b]), pts[a], pts[b], poly, t_i, float(d[a:b + 1].min())))
        return out

    # ------------------------------------------------------------------ decision σ
    def _decide(self, t, nav, conflicts, statics, by_id, static_polygons, allow_replan=True,
                static_outlines=()) -> None:
        follower = self.agent.follower
        gamma = float(follower.gamma_m)
        cfg = self.config
        svos: list[tuple[np.ndarray, PredictedConflict | StaticConflict]] = []
        candidates: list[_Correction] = []
        unresolved: list[PredictedConflict] = []
        for c in conflicts:
            track = by_id.get(c.track_id)
            is_team = track is not None and track.team_member in self.team and not c.is_static
            if c.decision == Decision.REPLAN and not is_team:
                svos.append((c.svo_polygon, c))
                continue
            pass_only = False
            if is_team and not gives_way(nav.position_m, nav.heading_rad, track.position_m, track.heading_rad, True):
                astern = np.cos(relative_bearing(nav.position_m, nav.heading_rad, track.position_m)) < 0.0
                if c.t_closest_s - t > cfg.last_resort_s:
                    self.stats["stand_on"] += 1
                    self._event(t, f"stand-on vessel towards team mate {track.team_member}: keeps its speed")
                    continue
                if astern:  # last resort with the give-way vessel abaft the beam: never slow down
                    corr = self._velocity_correction(t, gamma, c, pass_only=True)
                    if corr is not None:
                        candidates.append(corr)
                    else:
                        self.stats["stand_on"] += 1
                        self._event(t, f"stand-on vessel towards team mate {track.team_member} (abaft the beam): "
                                       f"keeps its speed")
                    continue
            corr = self._velocity_correction(t, gamma, c)
            if corr is not None:
                candidates.append(corr)
            else:
                unresolved.append(c)
            if corr is None and track is not None:  # neither slowing down nor speeding up works: go around
                r_col = c.collision_distance_m
                t_f = c.t_f if np.isfinite(c.t_f) else c.t_i + cfg.obstruction_threshold_s
                svos.append((swept_area(track, max(c.t_i, t), max(t_f, t + 1.0), r_col), c))
        for s in statics:
            svos.append((s.polygon, s))
        if svos and allow_replan:
            if self._replan(t, nav, svos, static_polygons, by_id, static_outlines):
                # The path changed: predict again on the detour (velocity corrections only).
                self.correction = None
                tracks = list(by_id.values())
                self.predict(t, nav, tracks, static_polygons, _after_replan=True)
                return
        if not candidates and unresolved and (self.correction is None or self.correction.kind != "yield"):
            c = unresolved[0]
            hold = float(np.clip((c.t_f if np.isfinite(c.t_f) else c.t_i) - t, 5.0, 30.0))
            vmin = cfg.speed_min_m_s
            law = VelocityCorrection(gamma, t, gamma + vmin * hold, t + hold, cfg.gain_k, vmin, self.speed_max_m_s)
            candidates.append(_Correction(law, "yield", c.track_id))
            self.stats["emergency"] += 1
            self._event(t, f"no manoeuvre clears track {c.track_id}: emergency slow-down to {vmin:g} m/s")
        if candidates:
            yields = [c for c in candidates if c.kind == "yield"]
            chosen = min(yields, key=lambda c: c.law.desired_speed) if yields else \
                max(candidates, key=lambda c: c.law.desired_speed)
            self.correction = chosen
            self.stats[chosen.kind] += 1
            law = chosen.law
            self._event(t, f"velocity correction ({chosen.kind}) for track {chosen.track_id}: virtual target "
                           f"γ {law.gamma0:.1f} → {law.gamma_goal:.1f} m by t = {law.t_goal:.1f} s, "
                           f"V_d = {law.desired_speed:.2f} m/s, k = {law.gain_k:g}")

    def _velocity_correction(self, t, gamma, c: PredictedConflict, pass_only: bool = False) -> _Correction | None:
        """Yield if possible (not when ``pass_only``), else pass first if allowed and feasible, else None."""
        cfg = self.config
        vmin, vmax, k, m = cfg.speed_min_m_s, self.speed_max_m_s, cfg.gain_k, cfg.correction_margin_m
        if np.isfinite(c.t_f) and not pass_only:
            try:
                law = VelocityCorrection.yield_to(c, gamma, t, k, vmin, vmax, margin_m=m)
                if law.desired_speed >= vmin - 1e-9:
                    return _Correction(law, "yield", c.track_id)
            except ValueError:
                pass
        if cfg.allow_pass_first:
            try:
                law = VelocityCorrection.pass_first(c, gamma, t, k, vmin, vmax, margin_m=m)
                if law.feasible:
                    return _Correction(law, "pass", c.track_id)
            except ValueError:
                pass
        return None

    # ------------------------------------------------------------------ re-planning
    @staticmethod
    def _shrink_to_exclude(poly, point, margin_m: float = 0.5):
        """``poly`` scaled about its vertex centroid so that ``point`` lies ``margin_m`` outside."""
        poly = np.asarray(poly, dtype=float)
        c = poly.mean(axis=0)
        lo, hi = 0.0, 1.0
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            q = c + mid * (poly - c)
            ok = not point_in_polygon(point[None], q)[0] and distance_to_polygon(point[None], q)[0] >= margin_m
            lo, hi = (mid, hi) if ok else (lo, mid)
        return c + max(lo, 0.05) * (poly - c)

    def _svo_clear_of(self, start, track, c, t):
        """The swept area cut short where the obstacle's disc would reach the vessel's present
        position (a head-on obstacle sweeps over the vessel's own place; by then the vessel has
        left it on the detour). None when the obstacle is already there."""
        r_col = c.collision_distance_m
        t_f = c.t_f if np.isfinite(c.t_f) else c.t_i + self.config.obstruction_threshold_s
        t_a = max(c.t_i, t)
        ts = np.arange(t_a, t_f, 0.25)
        if ts.size < 2:
            return None
        d = np.hypot(*(track.predict_positions(ts) - start).T)
        near = np.flatnonzero(d <= r_col + 1.0)
        t_cut = ts[near[0] - 1] if near.size else t_f
        if near.size and near[0] < 2:
            return None
        return swept_area(track, t_a, t_cut, r_col)

    def _replan(self, t, nav, svos, static_polygons, by_id=None, static_outlines=()) -> bool:
        """Build the field, trace the streamline, splice the detour. True on success.

        Mapped static polygons are grown by ``static_inflation_m``; the outlines of static tracks
        by R_vh + safety (the distance at which prediction flags them, exactly as a static disc's
        SVO is R_vh + R_ob + safety) plus ``replan_margin_m`` (the hysteresis the SVOs get)."""
        cfg, follower, mission = self.config, self.agent.follower, self.mission_path
        by_id = by_id or {}
        start = np.asarray(nav.position_m, dtype=float)
        g_now_m = self.mission_gamma_m(follower)
        # End of the obstruction on the mission path.
        g_end = g_now_m
        for poly, c in svos:
            for p in (c.point_b, *np.asarray(poly)):
                g, d = mission.closest_points(np.asarray(p)[None], g_now_m, mission.length)
                if d[0] <= 3.0 * (self.radius_m + cfg.safety_distance_m) + 5.0:
                    g_end = max(g_end, float(g[0]))
            g_end = max(g_end, float(mission.project(c.point_b, gamma_hint=g_now_m,
                                                     search_window_m=max(mission.length, 1.0))))
        obstacles = []
        for poly, c in svos:
            if isinstance(c, StaticConflict):
                continue
            poly = np.asarray(poly, dtype=float)
            track = by_id.get(c.track_id)
            if track is not None and not c.is_static and point_in_polygon(start[None], poly)[0]:
                poly = self._svo_clear_of(start, track, c, t)
                if poly is None:
                    self._fail(t, f"track {c.track_id} is already at the vessel")
                    return False
            if cfg.replan_margin_m > 0:
                try:
                    grown = inflate_polygon(clean_polygon(poly, "svo"), cfg.replan_margin_m)
                    if not point_in_polygon(start[None], grown)[0]:
                        poly = grown
                except ValueError:
                    pass
            obstacles.append(poly)
        statics_near = self._statics_near(start, mission, g_now_m, g_end + cfg.goal_margin_m + 20.0, static_polygons)
        try:
            obstacles += [inflate_polygon(clean_polygon(p, "static obstacle"), self.static_inflation_m) for p in statics_near]
        except ValueError as exc:
            self._fail(t, f"static polygon unusable: {exc}")
            return False
        check = self.radius_m + cfg.safety_distance_m
        for p in self._statics_near(start, mission, g_now_m, g_end + cfg.goal_margin_m + 20.0, static_outlines):
            try:
                p = clean_polygon(p, "static track outline")
                grown = inflate_polygon(p, check + cfg.replan_margin_m)
                obstacles.append(grown if not point_in_polygon(start[None], grown)[0] else inflate_polygon(p, check))
            except ValueError as exc:
                self._fail(t, f"static track outline unusable: {exc}")
                return False
        obstacles = merge_overlapping(obstacles, clearance_m=0.5)
        for k, p in enumerate(obstacles):  # inside a safety region: shrink it to just exclude the vessel
            if point_in_polygon(start[None], p)[0]:
                obstacles[k] = self._shrink_to_exclude(p, start)
                self._event(t, "the vessel is inside an obstacle's safety region: that region is shrunk to "
                               "leave it outside")
        obstacles = merge_overlapping(obstacles, clearance_m=0.5)
        if any(point_in_polygon(start[None], p)[0] for p in obstacles):
            self._fail(t, "the vessel is inside an obstacle's safety region")
            return False
        # Goal: on the mission path beyond the obstruction, clear of every obstacle.
        g_goal = min(g_end + cfg.goal_margin_m, mission.length)
        clear = self.radius_m + cfg.safety_distance_m
        while True:
            goal = mission.point(g_goal)
            d = min(float(distance_to_polygon(goal[None], p)[0]) if not point_in_polygon(goal[None], p)[0] else -1.0
                    for p in obstacles) if obstacles else np.inf
            if d >= clear or g_goal >= mission.length:
                break
            g_goal = min(g_goal + 1.0, mission.length)
        if d < clear:
            self._fail(t, "no goal on the mission path clear of the obstacles")
            return False
        if np.hypot(*(goal - start)) < 2.0 * cfg.streamline_step_m:
            self._fail(t, "goal too close to re-plan")
            return False
        sl, fld = self._streamline(start, goal, obstacles)
        if sl is None:
            self._fail(t, "no streamline of the potential field reaches the goal")
            return False
        pts = sl
        keep = np.concatenate([[True], np.hypot(*np.diff(pts, axis=0).T) > 0.05])
        pts = pts[keep]
        detour_only = Path.from_points(pts)
        full = detour_only
        if g_goal < mission.length - 1e-6:
            rest = mission.sub_path(g_goal, mission.length)
            full = detour_only.concatenate(rest)
        self.detour = Detour(full, detour_only.length, g_now_m, g_goal, pts, tuple(obstacles), fld, t)
        follower.set_path(full, 0.0)
        self.stats["replan"] += 1
        self._event(t, f"re-planned: detour of {detour_only.length:.1f} m around {len(obstacles)} obstacle(s) "
                       f"(potential field, {len(fld.panels) if fld.panels is not None else 0} panels, "
                       f"r = {fld.safety_ratio}, λ_g = {fld.sink_strength:.0f}), rejoining the mission path at "
                       f"γ = {g_goal:.1f} m")
        self._log_pending = True
        return True

    def _fail(self, t, why: str) -> None:
        self.stats["replan_failed"] += 1
        self._event(t, f"re-planning failed: {why}")

    def _statics_near(self, start, mission: Path, g_a, g_b, polygons) -> list[np.ndarray]:
        polys = [np.asarray(p, dtype=float) for p in polygons or ()]
        if not polys:
            return []
        g_b = min(max(g_b, g_a + 1.0), mission.length)
        route = np.vstack([start[None], mission.point(np.linspace(g_a, g_b, 60))])
        rng = self.config.static_range_m
        return [p for p in polys if float(np.min(distance_to_polygon(route, p))) <= rng]

    def _streamline(self, start, goal, obstacles):
        """The streamline from start to goal of the robust field; retries with a stronger sink, a
        smaller safety ratio and slightly shifted starts (off a stagnation saddle)."""
        cfg = self.config
        U = cfg.uniform_speed
        if cfg.sink_strength is not None:
            sink = cfg.sink_strength
        else:
            d = goal - start
            n = np.array([-d[1], d[0]]) / max(np.hypot(*d), 1e-9)
            width = max((float(np.ptp(p @ n)) for p in obstacles), default=0.0)
            sink = max(30.0, 2.0 * U * (width + 10.0))
        attempts = [(cfg.safety_ratio, sink), (cfg.safety_ratio, 2 * sink), (0.5 * cfg.safety_ratio, 2 * sink),
                    (0.5 * cfg.safety_ratio, 4 * sink)]
        step = cfg.streamline_step_m
        span = np.hypot(*(goal - start))
        d = (goal - start) / span
        normal = np.array([-d[1], d[0]])
        for ratio, lam in attempts:
            try:
                fld = PotentialField(obstacles, goal=goal, start=start, uniform_speed=U, sink_strength=lam,
                                     safety_ratio=ratio if obstacles else None,
                                     max_panel_length=cfg.max_panel_length_m)
            except ValueError:
                continue
            offsets = [0.0, 0.3, -0.3, 1.0, -1.0]
            starts = [start + o * normal for o in offsets]
            starts = [s for s in starts if fld.obstacle_containing(s) is None]
            lines = fld.streamlines(np.array(starts), step=step, max_length=6.0 * span + 100.0)
            for s0, line in zip(starts, lines):
                if line.reached_goal:
                    pts = line.points if np.allclose(s0, start) else np.vstack([start[None], line.points])
                    return pts, fld
        return None, None

    # ------------------------------------------------------------------ control
    def _check_new_tracks(self, t, nav) -> None:
        perception = getattr(self.agent, "perception", None)
        if perception is None:
            return
        tracks = perception.tracks()
        new = {tr.track_id for tr in tracks} - self._known_track_ids
        if new:
            self._event(t, f"new track(s) {sorted(new)}: predicting now")
            self.predict(t, nav, tracks, perception.static_polygons())
            return
        if t - self._last_predict_t < 1.0:
            return
        if self.correction is None and self._predicted_speed is not None and \
                abs(self.mission_speed_now() - self._predicted_speed) > self.config.speed_change_m_s:
            self.stats["deviation_predictions"] += 1  # own plan changed (coordination): predict again
            self.predict(t, nav, tracks, perception.static_polygons())
            return
        if self._team_plans_changed(t):  # a team mate re-planned or changed its speed
            self.stats["deviation_predictions"] += 1
            self.predict(t, nav, tracks, perception.static_polygons())
            return
        for tr in tracks:  # a track that left the motion the last prediction assumed
            old = self._predicted_tracks.get(tr.track_id)
            if old is None or old.team_member in self._predicted_intentions:
                continue  # team mates on a fresh broadcast: their plans are checked above
            dev = float(np.hypot(*(old.predict_positions(np.array([tr.time_s]))[0] - tr.position_m)))
            if dev > self.config.track_deviation_m:
                self.stats["deviation_predictions"] += 1
                self.predict(t, nav, tracks, perception.static_polygons())
                return

    def _repredict_now(self, t, nav) -> None:
        perception = getattr(self.agent, "perception", None)
        if perception is not None:
            self.stats["deviation_predictions"] += 1
            self.predict(t, nav, perception.tracks(), perception.static_polygons())

    def control_refs(self, t, nav) -> tuple[float | None, str]:
        """(speed override [m/s] or None, mode) for this control tick; switches the follower back
        to the mission path when a detour is finished."""
        t = float(t)
        follower = self.agent.follower
        if follower is None:
            return None, "mission"
        self._poll_team()
        self._check_new_tracks(t, nav)
        d = self.detour
        if d is not None and follower.path is d.path and follower.gamma_m >= d.detour_length_m - 0.5:
            g_m = d.mission_gamma(follower.gamma_m)
            if self.correction is not None:  # keep the virtual target in the follower's new γ frame
                self.correction.gamma_offset_m += follower.gamma_m - g_m
            follower.set_path(self.mission_path, g_m)
            self.detour = None
            self._event(t, f"detour finished: back on the mission path at γ = {g_m:.1f} m")
            self._log_pending = True
        elif d is not None and follower.path is not d.path:
            self.detour = None
        override = None
        c = self.correction
        if c is not None:
            if c.law.finished(t):
                self._event(t, f"velocity correction ({c.kind}) complete: mission speed resumed")
                self.correction = None
                self._repredict_now(t, nav)  # the planned motion changed: check it before it is sailed
                c = self.correction
            if c is not None and not c.law.finished(t):
                override = c.law.command(follower.gamma_m + c.gamma_offset_m, t)
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
        return override, mode

    # ------------------------------------------------------------------ summary and recording
    def summary(self) -> dict:
        total = sum(self.mode_time_s.values())
        return {
            "enabled": self.config.enabled,
            "predictions": self.stats["predictions"],
            "predictions_on_track_deviation": self.stats["deviation_predictions"],
            "predicted_conflicts": self.stats["predicted_conflicts"],
            "static_conflicts": self.stats["static_conflicts"],
            "actions": {k: self.stats[k] for k in ("yield", "pass", "stand_on", "replan", "replan_failed",
                                                          "emergency")},
            "mode_time_s": {k: round(v, 2) for k, v in self.mode_time_s.items()},
            "mode_share": {k: round(v / total, 4) if total > 0 else 0.0 for k, v in self.mode_time_s.items()},
            "min_predicted_distance_m": round(self.min_predicted_distance_m, 3)
            if np.isfinite(self.min_predicted_distance_m) else None,
            "conflicts": self.conflict_log,
        }

    def log(self, recorder, t, vessel_name) -> None:
        base = f"world/vessels/{vessel_name}/avoidance"
        if not self._styled:
            recorder.series_style(f"plots/speed/{vessel_name}/virtual_target", f"{vessel_name} virtual target",
                                  (230, 60, 60), 1.0)
            recorder.series_style(f"plots/mode/{vessel_name}", f"{vessel_name} mode (0 mission, 1 yield, 2 pass, "
                                  f"3 detour)", (200, 200, 200), 1.5)
            recorder.static(f"{base}/virtual_target", rr.Points3D.from_fields(colors=[(230, 60, 60)], radii=[0.4]))
            self._styled = True
        recorder.scalar(f"plots/mode/{vessel_name}", t, MODES[self.mode])
        follower = self.agent.follower
        c = self.correction
        if c is not None and follower is not None:
            g_d = c.law.gamma_desired(t) - c.gamma_offset_m
            recorder.scalar(f"plots/speed/{vessel_name}/virtual_target", t, c.law.desired_speed)
            recorder.scalar(f"plots/gamma/{vessel_name}/virtual_target", t, c.law.gamma_desired(t))
            recorder.scalar(f"plots/gamma/{vessel_name}/actual", t, follower.gamma_m + c.gamma_offset_m)
            recorder.points(f"{base}/virtual_target", t, follower.path.point(float(np.clip(g_d, 0, follower.path.length))),
                            z=0.4)
        if self._log_pending:
            self._log_prediction(recorder, t, base)
            self._log_pending = False

    def _log_prediction(self, recorder, t, base) -> None:
        def xyz(p, z):
            p = np.asarray(p, dtype=float).reshape(-1, 2)
            return np.column_stack([p, np.full(len(p), z)])

        def closed(p):
            p = np.asarray(p, dtype=float)
            return np.vstack([p, p[:1]])

        last = self._last
        if last is not None and last["t"] <= t:
            conflicts, statics = last["conflicts"], last["statics"]
            own = last["all"][0].vessel_positions if last["all"] else None
            if own is not None:
                recorder.log(f"{base}/predicted_own", rr.LineStrips3D([xyz(own, 0.3)], colors=[(120, 220, 120)],
                                                                      radii=[0.08]), t)
                recorder.log(f"{base}/predicted_tracks", rr.LineStrips3D(
                    [xyz(c.obstacle_positions, 0.3) for c in last["all"]],
                    colors=[(230, 80, 80) if c.collision else (230, 160, 160) for c in last["all"]], radii=[0.08]), t)
            pts, labels = [], []
            for c in conflicts:
                k = int(np.argmin(np.abs(c.times - c.t_closest_s)))
                pts.append(c.vessel_positions[k])
                tf = "inf" if not np.isfinite(c.t_f) else f"{c.t_f:.0f}"
                labels.append(f"t_c {c.t_closest_s:.0f}s [{c.t_i:.0f}, {tf}] s")
            recorder.log(f"{base}/collision_points", rr.Points3D(xyz(np.array(pts).reshape(-1, 2), 0.5),
                                                                 colors=[(255, 0, 0)], radii=[0.6], labels=labels), t)
            stretches = [xyz(last["path"].point(np.linspace(s.gamma_a, s.gamma_b, 30)), 0.35)
                         for s in list(conflicts) + list(statics) if s.gamma_b > s.gamma_a]
            recorder.log(f"{base}/obstructed", rr.LineStrips3D(stretches, colors=[(255, 140, 0)], radii=[0.3]), t)
            svos = [xyz(closed(c.svo_polygon), 0.3) for c in conflicts if c.svo_polygon is not None]
            recorder.log(f"{base}/svo", rr.LineStrips3D(svos, colors=[(255, 200, 0)], radii=[0.12]), t)
        d = self.detour
        if d is not None:
            recorder.log(f"{base}/detour", rr.LineStrips3D([xyz(d.streamline, 0.25)], colors=[(0, 220, 255)],
                                                           radii=[0.15]), t)
            recorder.log(f"{base}/field_obstacles", rr.LineStrips3D([xyz(closed(p), 0.25) for p in d.obstacles],
                                                                    colors=[(200, 120, 255)], radii=[0.1]), t)
            lo = np.min(np.vstack([d.streamline, *d.obstacles]), axis=0) - 5.0
            hi = np.max(np.vstack([d.streamline, *d.obstacles]), axis=0) + 5.0
            gx, gy = np.meshgrid(np.linspace(lo[0], hi[0], 15), np.linspace(lo[1], hi[1], 15))
            grid = np.column_stack([gx.ravel(), gy.ravel()])
            outside = np.array([d.field.obstacle_containing(p) is None for p in grid])
            grid = grid[outside]
            u = d.field.velocity(grid)
            n = np.hypot(*u.T)
            ok = np.isfinite(n) & (n > 0)
            scale = 0.6 * float(np.min(hi - lo)) / 15.0
            recorder.log(f"{base}/field", rr.Arrows3D(origins=xyz(grid[ok], 0.2),
                                                      vectors=xyz(scale * u[ok] / n[ok, None], 0.0),
                                                      colors=[(160, 160, 255, 150)], radii=[0.04]), t)
        else:
            for e in ("detour", "field_obstacles", "field"):
                recorder.log(f"{base}/{e}", rr.Clear(recursive=False), t)
