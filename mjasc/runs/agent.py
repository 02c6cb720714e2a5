"""One vessel's onboard pipeline, run by the runner at each slot of the schedule.

Data flows one way through a tick (slot order in :data:`~mjasc.runs.schedule.SLOT_ORDER`); each
stage takes typed values and returns typed values, and the agent — the only object that holds
the vessel's components — hands them on::

    sensing    perception.sense(t, nav)                      own range scan → detections
    tracking   perception.update_tracks(t, nav)              detections → IMM tracks
               → PerceptionReport (tracks, static polygons; with ``share_tracks`` the team's
                 broadcast tracks fused in: perception.report_tracks, mjasc.perception.track_fusion)
    comms      avoidance.planned_trajectory(t, nav, guidance) → the plan to broadcast
               coordination.exchange(t, nav, γ, guidance, plan[, tracks]) → TeamMessage out; TeamPicture in
               (with ``share_tracks``: the own confirmed tracks out, the team's to perception.set_team_tracks)
    prediction avoidance.predict(t, nav, guidance, report, team) → AvoidanceRequest
    control    mission.update(t, nav, γ, report, team, mode)  → MissionLeg (a new phase, line or speed), or None
               (with a [mission]: mjasc.missions; the leg goes to the follower, avoidance and coordination)
               coordination.speed_correction(t, nav, γ)      → factor on the mission speed
               avoidance.control(t, nav, guidance, report, team) → AvoidanceRequest
               (these two are :meth:`VesselAgent.control_request`; the tick asks every vessel's
               coordination first, then its avoidance methods for the fleet at once, control_many)
               the fleet's path followers, all at once       → propeller commands

``nav`` is the vessel's own :class:`~mjasc.core.navigation.OwnNavigation`; ``guidance`` its
:class:`~mjasc.guidance.state.GuidanceState` (the path it follows now, γ on it, the mission speed
with the coordination factor); an :class:`~mjasc.avoidance.request.AvoidanceRequest` (speed
override, course override, path switch) is applied by the agent to its path follower. A vessel knows its own state
(its navigation system) and nothing else of the simulator's truth: other bodies reach it only
through its sensor and its comms link. Components are optional: a vessel without a
``[vessels.sensor]`` table has no perception, and so on; :func:`~mjasc.runs.agent_build.build_agent` attaches what the
vessel's scenario table asks for. Each component logs itself with ``log(recorder, t, name)`` and
reports events with ``drain_events()``.
"""

from __future__ import annotations

import functools
import inspect
import math
from dataclasses import dataclass

import numpy as np

from mjasc.core.estimates import Deferred, PerceptionReport
from mjasc.core.navigation import OwnNavigation
from mjasc.guidance.path_following import PathFollower, PathFollowingConfig, PathFollowingStatus
from mjasc.guidance.state import GuidanceState
from mjasc.physics.vessels import VesselType
from mjasc.plugins.answers import (avoidance_answer, events_answer, factor_answer, steer_answer,
                                   team_picture_answer)
from mjasc.plugins.context import StageContext
from mjasc.plugins.registry import builtin_method
from mjasc.runs.scenario import VesselConfig

__all__ = ["OwnNavigation", "VesselAgent", "ControlOutput"]


@dataclass(frozen=True)
class ControlOutput:
    """What one control tick produced: commands (2,) normalized port, starboard shaft speeds in
    [−1, 1]; the path follower's status (None in open loop); the speed reference [m/s]; the mode."""

    commands: np.ndarray
    status: PathFollowingStatus | None
    speed_ref_m_s: float
    mode: str


class VesselAgent:
    """Mission control of one vessel with its optional perception, avoidance and coordination.

    Components (each optional; :func:`build_agent` sets them from the scenario):

    ``perception``: ``sense(t, nav)``, ``update_tracks(t, nav)``, ``tracks() -> list[TrackEstimate]``,
    ``static_polygons() -> list[(k, 2) array]``, ``set_team_positions(dict[name, (t, position)])``.

    ``avoidance``: ``predict(t, nav, guidance, report, team)`` and ``control(t, nav, guidance,
    report, team)`` → :class:`~mjasc.avoidance.request.AvoidanceRequest`, ``mission_gamma_m(guidance)``,
    ``planned_trajectory(t, nav, guidance, horizon_s, step_s)``.

    ``coordination``: ``plan_request()``, ``exchange(t, nav, γ, guidance, plan)``,
    ``speed_correction(t, nav, γ) -> float`` (multiplies the mission speed), ``team_picture(t)``,
    ``team_positions()``, ``last_factor``.

    All three: ``drain_events()``, ``log(recorder, t, vessel_name)``, ``summary()``.
    """

    def __init__(self, config: VesselConfig, vessel: VesselType, total_mass: np.ndarray, lateral_offset_m: float,
                 rng: np.random.Generator | None = None, team_names: tuple[str, ...] | None = None):
        self.name = config.name
        self.config = config
        self.vessel = vessel
        self.mission_speed_m_s = config.cruise_speed_m_s
        self.mode = "mission"
        self.follower: PathFollower | None = None
        self.perception = None
        self.avoidance = None
        self.coordination = None
        self.mission = None  # the chained mission (mjasc.missions.sequencer.MissionSequencer), with a [mission]
        self._report: PerceptionReport | None = None
        self.team_names: tuple[str, ...] = tuple(team_names) if team_names is not None else (config.name,)
        if config.controller != "none":
            from mjasc.plugins.registry import MethodChoice

            choice = config.options.get("control") or MethodChoice("control", config.controller, PathFollowingConfig())
            self.follower = choice.build(StageContext(config.name, vessel, config.path, self.team_names,
                                                      config.options.get("sensor"), rng, config.cruise_speed_m_s,
                                                      total_mass=total_mass, propeller_lateral_m=lateral_offset_m))
            self.follower.gamma_m = config.path.project(config.position_m)
        #: A plugin control method (not the built-in follower): its drain_events, log and summary are called
        #: as the other stages' are (docs/plugins.md); None for the built-in one, which has none of its own.
        self.control_plugin = self.follower if self.follower is not None and \
            not builtin_method(type(self.follower)) else None

    # ---------------------------------------------------------------- typed values handed to the stages
    def speed_factor(self) -> float:
        """The coordination law's latest factor on the mission speed (1 without coordination)."""
        factor = self.coordination.last_factor if self.coordination is not None else 1.0
        return float(factor) if math.isfinite(factor) else 1.0

    def guidance_state(self) -> GuidanceState | None:
        """The path follower's path and γ now, and the mission speed × the coordination factor
        (None without a path follower)."""
        follower = self.follower
        if follower is None:
            return None
        return self.guidance_of(follower.path, follower.gamma_m)

    def guidance_of(self, path, gamma_m: float) -> GuidanceState:
        """:meth:`guidance_state` from the follower's path and γ [m] read by the caller (the
        control tick reads the fleet's rows once)."""
        c = self.coordination
        factor = c.last_factor if c is not None else 1.0
        if not (type(factor) is float and -math.inf < factor < math.inf):  # (speed_factor without its calls)
            factor = float(factor) if math.isfinite(factor) else 1.0
        speed = self.mission_speed_m_s
        return GuidanceState.of(path, gamma_m, (speed if type(speed) is float else float(speed)) * factor)

    def perception_report(self, t_s: float) -> PerceptionReport | None:
        """What the perception reports now (None without perception); rebuilt only after a slot that
        changed the perception's state (sensing, tracking; comms only with ``share_tracks``: the
        team's tracks fused in — otherwise the comms slot changes neither the tracks, the same
        objects until the next tracking step, nor the map, and the report, a frozen value, is handed
        out again: its ``time_s`` is that of the control tick that built it). The static polygons are computed
        when a prediction first asks for them. With ``share_tracks`` the tracks are the own ones
        fused with the team's newest (:meth:`~mjasc.perception.pipeline.Perception.report_tracks`)."""
        report = self._report
        if report is None:
            perception = self.perception
            if perception is None:
                return None
            t = t_s if type(t_s) is float else float(t_s)
            # PerceptionReport(t, tracks, Deferred(...)) without the frozen __init__'s three setattr calls
            report = self._report = object.__new__(PerceptionReport)
            report.__dict__.update(time_s=t, tracks=perception.report_tracks(t),
                                   static_polygons=Deferred(perception.static_polygons))
        return report

    def team_picture(self, t_s: float):
        """What the coordination layer knows of the team now (None without coordination)."""
        c = self.coordination
        if c is None:
            return None
        picture = c.team_picture(t_s)
        return picture if builtin_method(type(c)) else team_picture_answer(c, picture)

    def mission_gamma_m(self) -> float:
        """Progress along the mission path [m] (the coordination variable γ)."""
        if self.follower is None:
            return 0.0
        if self.avoidance is not None:
            return self.avoidance.mission_gamma_m(self.guidance_state())
        return self.follower.gamma_m

    def apply_leg(self, t_s: float, leg) -> None:
        """Apply a :class:`~mjasc.missions.legs.MissionLeg`: a new path for the follower (from the
        leg's γ), the mission speed, and the leg to avoidance and coordination (``set_mission``)."""
        if leg.new_path:
            self.follower.set_path(leg.path, leg.gamma_m)
        self.mission_speed_m_s = float(leg.speed_m_s)
        for comp in (self.avoidance, self.coordination):
            if comp is not None:
                comp.set_mission(t_s, leg)

    def apply_request(self, request) -> None:
        """Apply an avoidance request's path switch to the path follower."""
        sw = request.path_switch
        if sw is not None:
            self.follower.set_path(sw.path, sw.gamma_m)

    # ---------------------------------------------------------------- slots
    def on_sensing(self, nav: OwnNavigation) -> None:
        if self.perception is not None:
            self.perception.sense(nav.time_s, nav)
            self._report = None

    def on_tracking(self, nav: OwnNavigation) -> None:
        if self.perception is not None:
            self.perception.update_tracks(nav.time_s, nav)
            self._report = None

    def on_comms(self, nav: OwnNavigation) -> None:
        c = self.coordination
        if c is None:
            return
        gamma, guidance, plan, extra, sharing = self._comms_message(nav)
        c.exchange(nav.time_s, nav, gamma, guidance, plan, **extra)
        self._comms_taken_in(nav, sharing)

    def comms_send(self, nav: OwnNavigation) -> tuple:
        """The first half of :meth:`on_comms` for the thesis coordination
        (:class:`~mjasc.cooperation.coordination.Coordination`, needs one): broadcast this
        vessel's message. Returns what :meth:`comms_receive` needs, its message id first. (The tick
        sends every vessel's message, decides the link for all at once, then lets each take in what
        arrived: the same as :meth:`on_comms` vessel by vessel.)"""
        gamma, guidance, plan, extra, sharing = self._comms_message(nav)
        return self.coordination.broadcast(nav.time_s, nav, gamma, guidance, plan, **extra), gamma, sharing

    def comms_receive(self, nav: OwnNavigation, sent: tuple, taken_in: bool = False) -> None:
        """The second half of :meth:`on_comms` (after :meth:`comms_send` returned ``sent`` and the
        link was decided for this vessel): take in what arrived (``taken_in``: the coordination
        took it in already, :meth:`~mjasc.cooperation.coordination.Coordination.take_in_fleet`;
        only the perception's part is left)."""
        _, gamma, sharing = sent
        if not taken_in:
            self.coordination.take_in(nav.time_s, nav, gamma, decided=True)
        self._comms_taken_in(nav, sharing)

    def _comms_message(self, nav: OwnNavigation) -> tuple:
        """(γ on the mission path, the guidance state, the plan, the message's other parts
        (shared tracks, mission broadcast), the track-sharing settings or None)."""
        c = self.coordination
        guidance = self.guidance_state()
        plan, req = None, c.plan_request()
        if req is not None and self.avoidance is not None:
            plan = self.avoidance.planned_trajectory(nav.time_s, nav, guidance, *req)
        sharing = c.track_sharing() if self.perception is not None else None
        extra = {}
        if sharing is not None:  # team-shared perception: the own confirmed tracks go out, the team's are fused in
            extra["tracks"] = self.perception.shareable_tracks(nav.position_m, sharing.max_tracks)
        if self.mission is not None:  # the mission's part: phase, arrival time, target estimate
            extra["mission"] = self.mission.broadcast()
        if self.avoidance is not None and c.takes_right_of_way:  # whom it gives way to / stands on toward now
            extra["gives_way_to"] = self.avoidance.gives_way_to()
            extra["stands_on_to"] = self.avoidance.stands_on_to()
        if guidance is not None and self.avoidance is not None:  # mission_gamma_m() from the state read above
            return self.avoidance.mission_gamma_m(guidance), guidance, plan, extra, sharing
        return self.mission_gamma_m(), guidance, plan, extra, sharing

    def _comms_taken_in(self, nav: OwnNavigation, sharing) -> None:
        """After the exchange: the team's positions (and tracks) to the perception."""
        if self.perception is not None:
            c = self.coordination
            positions = c.team_positions()
            self.perception.set_team_positions(positions)
            if sharing is not None:
                self.perception.set_team_tracks(nav.time_s, c.team_tracks(), nav.position_m, positions, sharing,
                                                list(self.team_names))
                self._report = None  # (the fused tracks changed; the own tracks and the map did not)

    def prediction_call(self, nav: OwnNavigation) -> tuple | None:
        """The arguments of this vessel's prediction, ``(avoidance, t, nav, GuidanceState,
        PerceptionReport, TeamPicture)`` (:func:`mjasc.avoidance.fleet_slots.predict_slot`), or None when
        it predicts nothing (no avoidance, perception or path follower)."""
        if self.avoidance is None or self.perception is None or self.follower is None:
            return None
        t = nav.time_s
        return (self.avoidance, t, nav, self.guidance_state(), self.perception_report(t), self.team_picture(t))

    def on_prediction(self, nav: OwnNavigation) -> None:
        call = self.prediction_call(nav)
        if call is not None:
            self.apply_request(avoidance_answer(call, "predict"))

    def control_request(self, nav: OwnNavigation) -> tuple[float, str, float]:
        """The control slot's per-vessel part, before the (fleet's) path following: the speed
        reference [m/s] — the mission speed × the coordination factor, or avoidance's override —,
        the mode and the course override [rad] (NaN: none, the follower steers its LOS course);
        avoidance's path switch is applied to the follower. Needs a path follower. (The tick runs
        it in two halves, :meth:`control_call` and :meth:`control_answer`, so that it can ask the
        vessels' avoidance methods together.)"""
        speed, call = self.control_call(nav)
        return self.control_answer(speed, avoidance_answer(call, "control") if call is not None else None)

    def control_call(self, nav: OwnNavigation) -> tuple[float, tuple | None]:
        """The first half of :meth:`control_request`: the mission speed × the coordination factor
        [m/s] (the coordination law asked now), and the arguments of the avoidance method's control
        tick ``(avoidance, t, nav, GuidanceState, PerceptionReport, TeamPicture)`` (None without
        avoidance)."""
        self.control_mission(nav)
        factor = None
        c = self.coordination
        if c is not None:
            factor = c.speed_correction(nav.time_s, nav, self.mission_gamma_m())
            if not builtin_method(type(c)):  # (a plugin's law, checked: the factor the guidance state and the
                c.last_factor = factor = factor_answer(c, factor)  # team picture read, as the built-in keeps it)
        return self.avoidance_call(nav, factor)

    def control_mission(self, nav: OwnNavigation) -> None:
        """The mission's part of :meth:`control_call`: its update, and the new leg applied if it
        gives one."""
        if self.mission is not None:
            t = nav.time_s
            leg = self.mission.update(t, nav, self.mission_gamma_m(), self.perception_report(t), self.team_picture(t),
                                      self.mode)
            if leg is not None:
                self.apply_leg(t, leg)

    def avoidance_call(self, nav: OwnNavigation, factor: float | None) -> tuple[float, tuple | None]:
        """The rest of :meth:`control_call` after the coordination's factor on the mission speed
        (None without coordination; the tick asks the fleet's coordination together)."""
        speed = self.mission_speed_m_s
        if factor is not None:
            speed *= factor
        if self.avoidance is None:
            return speed, None
        t = nav.time_s
        return speed, (self.avoidance, t, nav, self.guidance_state(), self.perception_report(t), self.team_picture(t))

    def control_answer(self, speed: float, req) -> tuple[float, str, float]:
        """The second half of :meth:`control_request`: avoidance's request ``req`` (None without
        avoidance) applied to the speed from :meth:`control_call` and to the follower's path."""
        mode = "mission"
        course = math.nan
        if req is not None:
            self.apply_request(req)
            mode = req.mode
            if req.speed_override_m_s is not None:
                speed = req.speed_override_m_s
            if req.course_override_rad is not None:
                course = float(req.course_override_rad)
        self.mode = mode
        return speed, mode, course

    def control_output(self, commands: np.ndarray, status: PathFollowingStatus, mode: str) -> ControlOutput:
        """The control slot's output from the follower's commands (2,) and status."""
        out = object.__new__(ControlOutput)  # ControlOutput(commands, status, speed, mode) without the frozen __init__
        out.__dict__.update(commands=commands, status=status, speed_ref_m_s=status.speed_ref_m_s, mode=mode)
        return out

    def control(self, nav: OwnNavigation, dt_s: float) -> ControlOutput:
        """This vessel's whole control slot (its follower alone; the tick runs the fleet's
        followers together, with the same result)."""
        if self.follower is None:
            return ControlOutput(np.asarray(self.config.commands, dtype=float), None, 0.0, "open_loop")
        speed, mode, course = self.control_request(nav)
        cmd, status = self.steered(self.follower.steer(nav, self.guidance_state(), speed,
                                                       None if math.isnan(course) else course, dt_s))
        return self.control_output(cmd, status, mode)

    def steered(self, answer) -> tuple:
        """The follower's ``steer`` answer; a plugin's checked (:func:`mjasc.plugins.answers.steer_answer`)."""
        if self.control_plugin is None:
            return answer
        return steer_answer(self.follower, self.name, answer)

    # ---------------------------------------------------------------- recording
    def components(self) -> list:
        return [c for c in (self.perception, self.coordination, self.avoidance, self.mission) if c is not None]

    def drain_events(self) -> list[tuple[float, str]]:
        events = []
        for c in (self.perception, self.coordination, self.avoidance, self.mission, self.control_plugin):
            if c is not None:  # (components(), per record tick)
                drained = c.drain_events()
                if not builtin_method(type(c)):
                    drained = events_answer(c, drained)
                if drained:  # (most record ticks drain nothing)
                    events.extend(drained)
        return events

    def log(self, recorder, t_s: float) -> None:
        """Each component logs itself, in the order of :meth:`components` (unrolled: a call per
        vessel and record tick)."""
        name = self.name
        if (c := self.perception) is not None:
            c.log(recorder, t_s, name)
        if (c := self.coordination) is not None:
            c.log(recorder, t_s, name)
        if (c := self.avoidance) is not None:  # (the guidance state only for a method that draws it now, and
            # only to a log that takes it: a plugin's log(recorder, t, vessel_name) as docs/plugins.md shows it)
            if _log_takes_guidance(type(c)):
                guidance = self.guidance_state() if getattr(c, "logs_guidance", True) else None
                c.log(recorder, t_s, name, guidance=guidance)
            else:
                c.log(recorder, t_s, name)
        if (c := self.mission) is not None:
            c.log(recorder, t_s, name)
        if (c := self.control_plugin) is not None:
            c.log(recorder, t_s, name)


@functools.lru_cache(maxsize=None)
def _log_takes_guidance(cls: type) -> bool:
    """Does ``cls.log`` take a ``guidance`` keyword (by name or ``**kwargs``)?"""
    try:
        params = inspect.signature(cls.log).parameters
    except (TypeError, ValueError, AttributeError):
        return False
    return "guidance" in params or any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values())
