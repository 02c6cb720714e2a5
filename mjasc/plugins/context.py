"""What a stage method is given when it is built: the vessel's own particulars, never the world.

A method (a tracker, a collision-avoidance method, a controller, a coordination law) is built from
a :class:`StageContext` and its own validated options. The context holds what the vessel knows of
itself (its name, its hull's particulars, its mission path, the names of its team, its own
sensor's specification) and its random stream. It holds no MuJoCo model or data, no simulator and
no other vessel's state: a method cannot read the truth because nothing in its hands leads to it.
Everything else reaches the method each call as a typed value (its own navigation, its sensor's
detections, its perception's report, what its link delivered).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import math

import numpy as np

__all__ = ["StageContext"]


@dataclass(frozen=True, eq=False)
class StageContext:
    """The build-time context of one vessel's stage method.

    vessel_name: the vessel's name in the scenario; vessel: its own
    :class:`~mjasc.physics.vessels.VesselType` (radius_m, beam_m, length_m, top_speed_m_s,
    cruise_speed_m_s, hydrodynamic parameters — the hull's datasheet, not its state);
    mission_path: its mission :class:`~mjasc.guidance.paths.Path` (None without one);
    team_names: every team member's name, itself included (only its own without a team);
    sensor: its own range sensor's :class:`~mjasc.perception.range_sensor.SensorConfig` (None
    without a sensor); rng: the method's own random stream (seeded from the scenario seed, the
    vessel index and the stage, so the same seed gives the same run); mission_speed_m_s: its
    mission's cruise speed [m/s]; link: its end of the team's link
    (:class:`~mjasc.cooperation.link.LinkEndpoint`: send its own messages, receive those delivered
    to it; None without a link); total_mass: its (3, 3) mass matrix [kg, kg·m²] (rigid body + added
    mass, surge/sway/yaw); propeller_lateral_m: its propellers' distance from the centre line [m].
    """

    vessel_name: str
    vessel: Any
    mission_path: Any = None
    team_names: tuple[str, ...] = ()
    sensor: Any = None
    rng: np.random.Generator | None = None
    mission_speed_m_s: float = 0.0
    link: Any = None
    total_mass: Any = None
    propeller_lateral_m: float = 0.0

    @property
    def sensor_range_m(self) -> float:
        """Its own range sensor's maximum range [m] (infinite without a sensor)."""
        return float(self.sensor.max_range_m) if self.sensor is not None else math.inf
