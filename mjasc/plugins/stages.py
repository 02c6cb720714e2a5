"""The interface of each pluggable onboard stage: what it may read, what it returns.

Every stage method is a class with a registered ``method`` name, an ``Options`` dataclass (fields
declared with :func:`mjasc.core.config_tables.param`: default, bounds, unit, doc — the scenario's
table is validated from it) and a constructor ``(context, options)``
(:class:`~mjasc.plugins.context.StageContext`: the vessel's own particulars and random stream,
nothing of the world). Each call hands it typed values and it answers with a typed value:

========================  ==========================================================  =====================================
stage (scenario key)      called with                                                 returns
========================  ==========================================================  =====================================
tracking                  ``update(t, nav, detections)``: own navigation, own          nothing; ``tracks()`` → confirmed
(``[vessels.tracking]``)  sensor's target detections (world frame)                    :class:`TrackEstimate` tuple
avoidance                 ``predict`` / ``control(t, nav, guidance, report, team)``:  :class:`AvoidanceRequest` (speed
(``[vessels.avoidance]``) own navigation, :class:`GuidanceState`,                     override, course override, path
                          :class:`PerceptionReport` (own tracks and mapped            switch, mode)
                          structures), :class:`TeamPicture` (what the link
                          delivered) or None
control                   ``steer(nav, guidance, speed_ref, course_ref, dt)``: own     propeller commands (2,) and a
(``[vessels.controller]`` navigation, :class:`GuidanceState` (path, γ), the speed    :class:`PathFollowingStatus`
``type``)                 to track [m/s], a course override [rad] or None
coordination              ``exchange(t, nav, γ, guidance, plan)``: own navigation,     nothing (it broadcasts on its
(``[vessels.comms]``)     γ on the mission path, :class:`GuidanceState`, own plan;    :class:`LinkEndpoint`);
                          ``speed_correction(t, nav, γ)``                             a factor on the mission speed;
                                                                                      ``team_picture(t)`` →
                                                                                      :class:`TeamPicture`
========================  ==========================================================  =====================================

All methods may report events (``drain_events``), draw themselves in the Rerun recording
(``log``) and add to the vessel's summary (``summary``). The defaults here do nothing.
"""

from __future__ import annotations

import abc
from typing import Any, ClassVar

from mjasc.plugins.context import StageContext

__all__ = ["StageMethod", "AvoidanceMethod", "TrackingMethod", "CoordinationMethod", "ControlMethod"]


class StageMethod(abc.ABC):
    """Common part of every stage method.

    ``method``: the registered name; ``Options``: the frozen options dataclass (None: the method
    takes no options); ``check_options(options, where)``: an optional cross-field validator run
    after the fields' own bounds (raise ValueError naming ``where.<key>``)."""

    stage: ClassVar[str] = ""
    method: ClassVar[str] = ""
    Options: ClassVar[type | None] = None

    def __init__(self, context: StageContext, options: Any = None):
        """``options`` None: the method's defaults (``Options()``)."""
        self.context = context
        self.options = options if options is not None or self.Options is None else self.Options()

    @classmethod
    def from_context(cls, context: StageContext, options: Any) -> "StageMethod":
        """Build the method for one vessel (the registry calls this)."""
        return cls(context, options)

    @staticmethod
    def check_options(options: Any, where: str) -> None:
        """Cross-field checks of the options beyond each field's declared bounds (none here)."""

    def drain_events(self) -> list[tuple[float, str]]:
        """Events since the last call, ``[(t [s], text)]``, for the recording's event log (summary.json
        does not list them)."""
        return []

    def log(self, recorder, t_s: float, vessel_name: str, **kwargs) -> None:
        """Draw the method's state in the Rerun recording (``recorder``: :class:`mjasc.runs.recording.Recorder`)."""

    def summary(self) -> dict:
        """What the method adds to the vessel's entry in summary.json (JSON-serializable)."""
        return {"method": self.method}

    def set_mission(self, t_s: float, leg) -> None:
        """The vessel's mission changed (a scenario with a ``[mission]``): ``leg`` is a
        :class:`~mjasc.missions.legs.MissionLeg` — the path the mission follows from now, its speed,
        whether the team coordinates along it. Avoidance and coordination methods that keep the
        mission path override this; the default ignores it."""


class AvoidanceMethod(StageMethod):
    """A collision-avoidance method.

    It reads, per call: ``t`` [s]; ``nav`` the vessel's own
    :class:`~mjasc.core.navigation.OwnNavigation`; ``guidance`` its
    :class:`~mjasc.guidance.state.GuidanceState` (the path it follows now, γ, the mission speed);
    ``report`` its perception's :class:`~mjasc.core.estimates.PerceptionReport` (confirmed tracks of
    its own sensor, mapped static polygons); ``team`` the
    :class:`~mjasc.cooperation.messages.TeamPicture` its link delivered (None without a team).
    It returns an :class:`~mjasc.avoidance.request.AvoidanceRequest`, which the vessel applies: a
    speed override, a course override (the path follower steers that course over ground instead of
    its line-of-sight course; γ keeps following the path), a path switch, the mode.

    ``control`` runs at the control rate (10 Hz by default); ``predict`` at the prediction slot
    (every few seconds and on new tracks) — a method that needs no slow loop leaves it to the
    default (no request). Between the two, the method keeps whatever state it needs.
    """

    stage = "avoidance"
    #: The detour being followed (a :class:`~mjasc.avoidance.replanning.Detour`), for observers; None.
    detour: Any = None
    #: The decisions taken, newest last (dicts with ``time_s``, ``track_id``, ``decision``, ``static``), for the video.
    conflict_log: tuple = ()

    @abc.abstractmethod
    def control(self, t, nav, guidance, report, team=None):
        """Control tick → :class:`~mjasc.avoidance.request.AvoidanceRequest`."""

    def predict(self, t, nav, guidance, report, team=None):
        """Prediction slot → :class:`~mjasc.avoidance.request.AvoidanceRequest` (default: none)."""
        from mjasc.avoidance.request import AvoidanceRequest

        return AvoidanceRequest()

    @classmethod
    def predict_many(cls, calls) -> list:
        """The prediction slot of several vessels using this method, ``calls`` a list of
        ``(method, t, nav, guidance, report, team)``; returns their requests in order. A method
        that can batch across vessels overrides this (the methods share no state)."""
        return [c[0].predict(*c[1:]) for c in calls]

    @classmethod
    def control_many(cls, calls) -> list:
        """The control tick of several vessels using this method, ``calls`` a list of
        ``(method, t, nav, guidance, report, team)``; returns their requests in order. A method
        that can batch across vessels overrides this (the methods share no state)."""
        return [c[0].control(*c[1:]) for c in calls]

    @property
    def last_prediction(self):
        """The latest prediction for the threat panel (a
        :class:`~mjasc.avoidance.system.PredictionRecord`), or None."""
        return None

    def mission_gamma_m(self, guidance) -> float:
        """Progress along the mission path [m] (γ); a method that leaves the mission path maps back."""
        return float(guidance.gamma_m) if guidance is not None else 0.0

    def gives_way_to(self) -> tuple:
        """The team mates the vessel gives way to now (names; default: none). Broadcast by a
        coordination method that carries it (``takes_right_of_way``, the thesis coordination): a
        team mate named stands on toward this vessel instead of yielding to it in turn."""
        return ()

    def stands_on_to(self) -> tuple:
        """The team mates toward which the vessel stands on now (names; default: none), broadcast
        as :meth:`gives_way_to` is: of two team mates that both stand on, one gives way."""
        return ()

    def planned_trajectory(self, t, nav, guidance, horizon_s: float, step_s: float):
        """Where the vessel intends to be, ``(times (k,) [s], points (k, 2) [m])`` for the team's
        broadcast, or None (the coordination layer then samples the guidance's path)."""
        return None


class TrackingMethod(StageMethod):
    """A multi-target tracker of one vessel.

    ``update(t, nav, detections)`` is called at the tracking rate with the vessel's own
    :class:`~mjasc.core.navigation.OwnNavigation` and its own sensor's target detections of the
    latest scan (:class:`~mjasc.perception.detection.Detections`: centres (m, 2) world [m], radii,
    covariances; structures wider than a target have gone to the static map). ``tracks()`` returns
    the confirmed tracks as :class:`~mjasc.core.estimates.TrackEstimate` (world ENU, SI).
    """

    stage = "tracking"

    @abc.abstractmethod
    def update(self, t_s: float, nav, detections) -> None:
        """One tracking step with the latest scan's target detections."""

    @abc.abstractmethod
    def tracks(self) -> tuple:
        """The confirmed tracks now, a tuple of :class:`~mjasc.core.estimates.TrackEstimate`."""


class CoordinationMethod(StageMethod):
    """A coordination law of one vessel (cooperative path following over the team's link).

    Built with ``context.link`` (:class:`~mjasc.cooperation.link.LinkEndpoint`: broadcast its own
    messages, receive those delivered to it), ``context.mission_path`` and
    ``context.mission_speed_m_s``. At the comms slot ``exchange(t, nav, gamma_m, guidance, plan)``
    (``plan``: the vessel's intended ``(times, points)`` from its avoidance method, or None; ask for
    it with :meth:`plan_request`) receives and broadcasts; at the control slot
    ``speed_correction(t, nav, gamma_m)`` returns the factor on the mission speed (1: none).
    ``team_picture(t)`` hands what the link delivered to collision avoidance
    (:class:`~mjasc.cooperation.messages.TeamPicture`); ``team_positions()`` the team mates' latest
    broadcast positions ``{name: (t, (2,) position)}`` for perception to mark their tracks.
    """

    stage = "coordination"
    #: The latest factor on the mission speed (for the agent's guidance state).
    last_factor: float = 1.0
    #: True: :meth:`exchange` is also given ``gives_way_to=`` and ``stands_on_to=`` (the team mates the
    #: vessel's avoidance gives way to / stands on toward now, :meth:`AvoidanceMethod.gives_way_to`)
    #: to broadcast.
    takes_right_of_way: bool = False

    @abc.abstractmethod
    def exchange(self, t_s: float, nav, gamma_m: float, guidance=None, plan=None) -> None:
        """The comms slot: receive what was delivered, broadcast the vessel's message."""

    @abc.abstractmethod
    def speed_correction(self, t_s: float, nav, gamma_m: float) -> float:
        """The control slot: the factor on the mission speed."""

    @abc.abstractmethod
    def team_picture(self, t_s: float):
        """What the link delivered, for collision avoidance (:class:`~mjasc.cooperation.messages.TeamPicture`)."""

    def team_positions(self) -> dict:
        """Team mates' latest broadcast positions ``{name: (t [s], (2,) [m])}`` (default: none)."""
        return {}

    def plan_request(self):
        """``(horizon_s, step_s)`` of the plan to broadcast, or None (default: no plan)."""
        return None

    def track_sharing(self):
        """Team-shared perception: the fusion settings
        (:class:`~mjasc.perception.track_fusion.FusionSettings`) when the method shares tracks —
        then :meth:`exchange` is also given ``tracks=`` (the own confirmed tracks to broadcast) —
        else None (default)."""
        return None

    def team_tracks(self) -> dict:
        """The team mates' shared tracks, name → (sent time [s], tuple of
        :class:`~mjasc.core.estimates.SharedTrack`) (default: none)."""
        return {}


class ControlMethod(StageMethod):
    """A path-following controller of one vessel: from the guidance reference to propeller commands.

    The method holds the path it follows (``path``, replaced by :meth:`set_path` when avoidance
    splices in a detour or returns to the mission) and its progress ``gamma_m`` γ along it [m]. At
    each control tick :meth:`steer` gets the vessel's own
    :class:`~mjasc.core.navigation.OwnNavigation`, its :class:`~mjasc.guidance.state.GuidanceState`
    (that path, γ, the mission speed), the speed to track [m/s] (the mission speed × the
    coordination factor, or avoidance's override) and a course to steer [rad, world course over
    ground, ENU, CCW from east] when avoidance overrides the course (None: follow the path). It
    returns the normalized propeller commands (port, starboard) in [−1, 1] and a
    :class:`~mjasc.guidance.path_following.PathFollowingStatus` whose ``gamma_m`` is the new γ.
    ``context`` gives the hull's datasheet (``vessel``), its mass matrix ``total_mass`` (3, 3)
    (rigid body + added mass) and its propellers' lateral arm ``propeller_lateral_m`` [m].
    """

    stage = "control"

    def __init__(self, context: StageContext, options: Any = None):
        super().__init__(context, options)
        self.path = context.mission_path
        self.gamma_m = 0.0

    def set_path(self, path, gamma0_m: float = 0.0) -> None:
        """Follow ``path`` from γ = ``gamma0_m`` [m] on."""
        self.path, self.gamma_m = path, float(gamma0_m)

    @abc.abstractmethod
    def steer(self, nav, guidance, speed_ref_m_s: float, course_ref_rad: float | None, dt_s: float):
        """One control tick → ``(commands (2,), PathFollowingStatus)``; updates ``gamma_m``."""
