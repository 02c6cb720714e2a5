"""One vessel's onboard pipeline, run by the runner at each slot of the schedule.

Data flows one way through a control tick::

    own navigation ─► (sensing ─► tracking ─► collision prediction ─► avoidance) ─► speed/path refs
                     (comms ─► coordination) ────────────────────────────────────► speed correction
                                                                                  ─► path following ─► propellers

A vessel knows its own state (its navigation system) and nothing else of the simulator's truth:
other bodies reach it only through its sensor and its comms link.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .path_following import PathFollower, PathFollowingConfig, PathFollowingStatus
from .scenario import VesselConfig
from .vessels import VesselType

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
    """Mission control of one vessel. Later layers (tracking, avoidance, coordination) plug in
    by setting :attr:`speed_override_m_s` / replacing the follower's path between ticks."""

    def __init__(self, config: VesselConfig, vessel: VesselType, total_mass: np.ndarray, lateral_offset_m: float):
        self.name = config.name
        self.config = config
        self.vessel = vessel
        self.mission_speed_m_s = config.cruise_speed_m_s
        self.speed_override_m_s: float | None = None
        self.mode = "mission"
        self.follower = None
        if config.controller == "path_following":
            cfg = PathFollowingConfig(lookahead_m=config.options.get("lookahead_m"))
            self.follower = PathFollower(config.path, vessel, total_mass, lateral_offset_m, cfg)
            self.follower.gamma_m = config.path.project(config.position_m)

    def control(self, nav: OwnNavigation, dt_s: float) -> ControlOutput:
        if self.follower is None:
            return ControlOutput(np.asarray(self.config.commands, dtype=float), None, 0.0, "open_loop")
        speed = self.speed_override_m_s if self.speed_override_m_s is not None else self.mission_speed_m_s
        cmd, status = self.follower.command(nav.position_m, nav.heading_rad, nav.velocity_m_s, nav.body_velocity,
                                            speed, dt_s)
        return ControlOutput(cmd, status, status.speed_ref_m_s, self.mode)
