"""One vessel's onboard pipeline, run by the runner at each slot of the schedule.

Data flows one way through a tick (slot order in ``schedule.SLOT_ORDER``)::

    sensing    perception.sense(t, nav)                 range scan → detections
    tracking   perception.update_tracks(t, nav)         detections → IMM tracks (TrackEstimate)
    comms      coordination.exchange(t, nav, γ)         broadcast own γ/pose; receive team mates'
    prediction avoidance.predict(t, nav, tracks, …)     tracks → conflicts → mode, detour, speed law
    control    avoidance.speed_override / detour path,
               coordination.speed_correction           → path following → propeller commands

A vessel knows its own state (its navigation system) and nothing else of the simulator's truth:
other bodies reach it only through its sensor and its comms link. Components are optional: a
vessel without a ``[vessels.sensor]`` table has no perception, and so on. Each component has the
small interface below (duck-typed) and logs itself to the recording with ``log(recorder, t, name)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mjasc.guidance.path_following import PathFollower, PathFollowingConfig, PathFollowingStatus
from mjasc.runs.scenario import VesselConfig
from mjasc.physics.vessels import VesselType

__all__ = ["OwnNavigation", "VesselAgent", "ControlOutput"]


@dataclass(frozen=True)
class OwnNavigation:
    """The vessel's own navigation solution (world ENU / body FLU, SI)."""

    time_s: float
    position_m: np.ndarray
    heading_rad: float
    velocity_m_s: np.ndarray
    body_velocity: np.ndarray


@dataclass(frozen=True)
class ControlOutput:
    commands: np.ndarray  # (2,) normalized port, starboard
    status: PathFollowingStatus | None
    speed_ref_m_s: float
    mode: str


class VesselAgent:
    """Mission control of one vessel with its optional perception, avoidance and coordination.

    Component interfaces (each optional, set by the runner from the scenario):

    ``perception``: ``sense(t, nav)``, ``update_tracks(t, nav)``, ``tracks() -> list[TrackEstimate]``,
    ``static_polygons() -> list[(k, 2) array]``, ``set_team_positions(dict[name, (t, position)])``,
    ``drain_events() -> list[(t, text)]``, ``log(recorder, t, vessel_name)``.

    ``avoidance``: ``predict(t, nav, tracks, static_polygons)``, ``control_refs(t, nav) ->
    (speed_override or None, mode str)`` (may switch ``agent.follower`` to a detour path and back),
    ``drain_events()``, ``log(recorder, t, vessel_name)``.

    ``coordination``: ``exchange(t, nav, gamma_m)``, ``speed_correction(t, nav, gamma_m) -> float``
    (multiplies the mission speed), ``team_positions() -> dict``, ``drain_events()``,
    ``log(recorder, t, vessel_name)``.
    """

    def __init__(self, config: VesselConfig, vessel: VesselType, total_mass: np.ndarray, lateral_offset_m: float):
        self.name = config.name
        self.config = config
        self.vessel = vessel
        self.mission_speed_m_s = config.cruise_speed_m_s
        self.mode = "mission"
        self.follower: PathFollower | None = None
        self.perception = None
        self.avoidance = None
        self.coordination = None
        if config.controller == "path_following":
            cfg = PathFollowingConfig(lookahead_m=config.options.get("lookahead_m"))
            self.follower = PathFollower(config.path, vessel, total_mass, lateral_offset_m, cfg)
            self.follower.gamma_m = config.path.project(config.position_m)

    # ---------------------------------------------------------------- slots
    def on_sensing(self, nav: OwnNavigation) -> None:
        if self.perception is not None:
            self.perception.sense(nav.time_s, nav)

    def on_tracking(self, nav: OwnNavigation) -> None:
        if self.perception is not None:
            self.perception.update_tracks(nav.time_s, nav)

    def on_comms(self, nav: OwnNavigation) -> None:
        if self.coordination is not None:
            self.coordination.exchange(nav.time_s, nav, self.mission_gamma_m())
            if self.perception is not None:
                self.perception.set_team_positions(self.coordination.team_positions())

    def on_prediction(self, nav: OwnNavigation) -> None:
        if self.avoidance is not None and self.perception is not None:
            self.avoidance.predict(nav.time_s, nav, self.perception.tracks(), self.perception.static_polygons())

    def mission_gamma_m(self) -> float:
        """Progress along the mission path [m] (the coordination variable γ)."""
        if self.follower is None:
            return 0.0
        if self.avoidance is not None and hasattr(self.avoidance, "mission_gamma_m"):
            return self.avoidance.mission_gamma_m(self.follower)
        return self.follower.gamma_m

    def control(self, nav: OwnNavigation, dt_s: float) -> ControlOutput:
        if self.follower is None:
            return ControlOutput(np.asarray(self.config.commands, dtype=float), None, 0.0, "open_loop")
        speed = self.mission_speed_m_s
        mode = "mission"
        if self.coordination is not None:
            speed *= self.coordination.speed_correction(nav.time_s, nav, self.mission_gamma_m())
        if self.avoidance is not None:
            override, mode = self.avoidance.control_refs(nav.time_s, nav)
            if override is not None:
                speed = override
        self.mode = mode
        cmd, status = self.follower.command(nav.position_m, nav.heading_rad, nav.velocity_m_s, nav.body_velocity,
                                            speed, dt_s)
        return ControlOutput(cmd, status, status.speed_ref_m_s, mode)

    # ---------------------------------------------------------------- recording
    def components(self) -> list:
        return [c for c in (self.perception, self.coordination, self.avoidance) if c is not None]

    def drain_events(self) -> list[tuple[float, str]]:
        events = []
        for c in self.components():
            events.extend(c.drain_events())
        return events

    def log(self, recorder, t_s: float) -> None:
        for c in self.components():
            c.log(recorder, t_s, self.name)
