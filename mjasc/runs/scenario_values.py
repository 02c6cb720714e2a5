"""The typed scenario: what a run contains once its file is read (:mod:`mjasc.runs.scenario` reads
and validates the TOML; everything here is re-exported there).

:class:`Scenario` (duration, seed, rates, outputs, current, vessels, obstacles, comms, mission),
:class:`VesselConfig` (one vessel: hull type, start pose, path, component tables), :class:`Rates`
(the multi-rate schedule) and :class:`Outputs` (recording, video, summary), each field declared
once with its bounds, unit and doc. Angles here are radians; scenario files write degrees.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np

from mjasc.core.config_tables import ConfigError, check_params, errors_as, param, point, read_field
from mjasc.core.frames import WORLD_LIMIT_M
from mjasc.guidance.paths import Path
from mjasc.physics.currents import CurrentField, current_from_config
from mjasc.physics.obstacles import MovingObstacle
from mjasc.runs.plausibility import check_duration

__all__ = ["ScenarioError", "Scenario", "VesselConfig", "Rates", "Outputs", "RECORDING_DETAILS", "MAX_DURATION_S",
           "camera_problem", "check_camera_vessel"]



#: The largest seed (a scenario's ``seed``, ``mjasc run --seed``, ``mjasc search``/``render --seed``):
#: 2**32 − 1, what numpy's legacy and dm_control's generators take — declared once, here.
MAX_SEED = 2**32 - 1

class ScenarioError(ConfigError):
    """A scenario file is invalid; the message names the field and the reason (a ValueError).

    The field readers are :mod:`mjasc.core.config_tables`'s; their :class:`ConfigError` leaves the
    public functions here as a ScenarioError."""


# ---------------------------------------------------------------------- typed scenario
@dataclass(frozen=True)
class Rates:
    """Multi-rate schedule (the ``[rates]`` table). Control, sensing, tracking, comms and recording
    run every ``round(physics_hz / rate)`` physics steps; prediction every ``prediction_period_s``."""

    physics_hz: float = param(50.0, minimum=10.0, maximum=1000.0, unit="Hz",
                              doc="physics steps per second (timestep 1/rate: 1 to 100 ms)")
    control_hz: float = param(10.0, positive=True, unit="Hz", doc="guidance and control ticks per second")
    sensing_hz: float = param(5.0, positive=True, unit="Hz", doc="range scans per second")
    tracking_hz: float = param(5.0, positive=True, unit="Hz", doc="tracker updates per second")
    comms_hz: float = param(1.0, positive=True, unit="Hz", doc="coordination messages per second")
    record_hz: float = param(10.0, positive=True, unit="Hz", doc="recorded samples per second")
    prediction_period_s: float = param(5.0, positive=True, unit="s", doc="period of the collision prediction")

    def __post_init__(self):
        check_params(self, "rates")
        self.check(self, "rates")

    @staticmethod
    def check(rates: "Rates", where: str) -> None:
        """No slot runs faster than the physics."""
        for f in fields(rates):
            if f.name.endswith("_hz") and getattr(rates, f.name) > rates.physics_hz:
                raise ScenarioError(f"{where}.{f.name}: must not exceed {where}.physics_hz ({rates.physics_hz}), "
                                    f"got {getattr(rates, f.name)}")


MAX_DURATION_S = 86400.0
"""Longest run [s]: one day of simulated time."""

_CAMERAS = ("top_down", "overview", "split")
"""The fixed cameras (``split``: overview and the first vessel's chase camera side by side);
``chase:<vessel>`` follows a vessel, ``split:<vessel>`` shows the overview beside its chase camera."""
_CAMERA_HELP = "top_down, overview, chase:<vessel>, split or split:<vessel>"


def camera_problem(camera: str) -> str | None:
    """Why ``camera`` is not a video camera name (``must be …``), or None when it is one."""
    if camera in _CAMERAS or camera.startswith(("chase:", "split:")):
        return None
    return f"must be {_CAMERA_HELP}, got {camera!r}"

RECORDING_DETAILS = ("standard", "full")
"""What the recording holds (``[outputs] recording_detail``; :mod:`mjasc.runs.recording`)."""


@dataclass(frozen=True)
class Outputs:
    """What a run writes (the ``[outputs]`` table)."""

    recording: bool = param(True, doc="write the Rerun recording")
    recording_detail: str = param("standard", choices=RECORDING_DETAILS,
                                  doc="standard: hulls, trails, paths, plots, tracks as labelled points, conflicts, "
                                      "detours, events; full: also sensor returns, detections, track ellipses and "
                                      "discs, one plot per track, every predicted track, the detour's flow field")
    video: bool = param(False, doc="write an MP4 video")
    video_camera: str = param("top_down", doc="top_down, overview, chase:<vessel> (its chase camera), split or "
                                               "split:<vessel> (overview left, the vessel's chase camera right; "
                                               "split: the first vessel)")
    video_fps: float = param(20.0, positive=True, maximum=120, unit="1/s",
                             doc="video frames per second, rounded to a whole number of physics steps a frame (20 at "
                                 "50 Hz physics: 25) so that the video plays in real time")
    video_width: int = param(640, minimum=16, maximum=1280, unit="px",
                             doc="frame width: within the scene's offscreen buffer (1280×720), even (H.264)")
    video_height: int = param(480, minimum=16, maximum=720, unit="px",
                              doc="frame height: within the scene's offscreen buffer (1280×720), even (H.264)")

    def __post_init__(self):
        check_params(self, "outputs")
        self.check(self, "outputs")

    @staticmethod
    def check(outputs: "Outputs", where: str) -> None:
        """Even frame sizes (H.264) and a camera mjasc has."""
        for name in ("video_width", "video_height"):
            if getattr(outputs, name) % 2:
                raise ScenarioError(f"{where}.{name}: must be even (H.264), got {getattr(outputs, name)}")
        camera = outputs.video_camera
        if camera_problem(camera):
            raise ScenarioError(f"{where}.video_camera: {camera_problem(camera)}")


def check_camera_vessel(outputs: Outputs, names) -> None:
    """``chase:<vessel>`` and ``split:<vessel>`` name one of the scenario's vessels."""
    camera = outputs.video_camera
    for kind in ("chase:", "split:"):
        if camera.startswith(kind) and camera[len(kind):] not in names:
            raise ScenarioError(f"outputs.video_camera: no vessel named {camera[len(kind):]!r} "
                                f"(vessels: {', '.join(names)})")


@dataclass(frozen=True)
class VesselConfig:
    """One vessel: its type, start pose, controller and mission path (world ENU, SI)."""

    name: str = param(doc="the vessel's name: unique, no '/', not starting with 'obstacle'")
    type: str = param(doc="vessel type: a folder of assets/vessels")
    position_m: np.ndarray = param(reader=point, minimum=-WORLD_LIMIT_M, maximum=WORLD_LIMIT_M, unit="m",
                                   doc="start position [x, y]")
    heading_rad: float = param(unit="rad", doc="start heading, CCW from east (heading_deg in the file)")
    speed_m_s: float = param(nonneg=True, unit="m/s", doc="start surge speed (≤ 1.5 × the type's top speed)")
    controller: str = param(doc="a control method (path_following, or any of 'mjasc list'), or none (constant "
                                "commands)")
    path: Path | None = param(doc="the mission path (path_following)")
    cruise_speed_m_s: float = param(positive=True, unit="m/s",
                                    doc="path-following speed (≤ the type's top speed; speed_m_s in the file)")
    commands: tuple[float, float] = param((0.0, 0.0), doc="constant propeller commands for controller = none")
    options: dict = field(default_factory=dict)  # sub-tables later layers read (sensor, tracking, avoidance)

    def __post_init__(self):
        check_params(self, self.name)


@dataclass(frozen=True)
class Scenario:
    name: str
    description: str
    duration_s: float = param(positive=True, maximum=MAX_DURATION_S, unit="s",
                              doc="how long the run lasts (at least one control period)")
    seed: int = param(nonneg=True, maximum=MAX_SEED, doc="the run's seed: sensor noise, packet loss, seeded currents")
    rates: Rates
    outputs: Outputs
    current: CurrentField
    current_config: dict
    vessels: tuple[VesselConfig, ...]
    static_obstacles: tuple
    moving_obstacles: tuple[MovingObstacle, ...]
    source: str = ""
    raw: dict = field(default_factory=dict)
    comms: Any = None  # network config (comms.parse_network_options) or None
    mission: Any = None  # the chained mission (mjasc.missions.config.MissionConfig) or None: path following

    def with_overrides(self, seed: int | None = None, video: bool | None = None, duration_s: float | None = None,
                       video_camera: str | None = None) -> "Scenario":
        """The scenario with these fields replaced (None: kept), each checked as when read from a file."""
        from dataclasses import replace

        s = self
        with errors_as(ScenarioError):
            if seed is not None:
                new_seed = read_field(Scenario, "seed", {"seed": seed}, "")
                # A seeded current (Gauss–Markov without its own seed) draws from the scenario seed:
                # rebuild it so that --seed changes the current too.
                s = replace(s, seed=new_seed, current=current_from_config(dict(s.current_config), seed=new_seed))
            if video is not None:
                s = replace(s, outputs=replace(s.outputs, video=bool(video)))
            if video_camera is not None:
                s = replace(s, outputs=replace(s.outputs, video_camera=str(video_camera)))
                check_camera_vessel(s.outputs, [v.name for v in s.vessels])
            if duration_s is not None:
                s = replace(s, duration_s=read_field(Scenario, "duration_s", {"duration_s": duration_s}, ""))
                check_duration(s)
            if seed is not None or duration_s is not None:  # (the checks a file with these values gets: a
                # seeded current over the bound, traffic that reaches a structure within the new duration)
                from mjasc.physics.vessels import load_vessel_type
                from mjasc.runs.plausibility import check_plausible

                check_plausible(s, {v.type: load_vessel_type(v.type) for v in s.vessels})
        return s
