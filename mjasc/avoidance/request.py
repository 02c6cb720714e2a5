"""What collision avoidance hands back to the vessel each time it runs: a request, never an action.

The avoidance stage does not hold the path follower; it returns an :class:`AvoidanceRequest` that
the vessel's agent applies: a speed override for the path follower (a velocity correction's
virtual-target law), a course override (a course over ground the path follower steers instead of
its line-of-sight course, e.g. the velocity obstacles' choice) and/or a :class:`PathSwitch` (onto a re-planned detour, or back onto the
mission path at the matching γ). The request also carries the mode (for the recording and the
summary) and the conflicts this call predicted.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mjasc.guidance.paths import Path

__all__ = ["AvoidanceRequest", "PathSwitch", "MODES"]

#: Mode strings and their codes (the recording shows the mode as a state lane, ``modes/<vessel>``).
MODES = {"mission": 0, "avoidance:yield": 1, "avoidance:pass": 2, "avoidance:detour": 3, "avoidance:steer": 4}


@dataclass(frozen=True, eq=False)
class PathSwitch:
    """Follow ``path`` from γ = ``gamma_m`` [m] on (a detour spliced into the mission, or the
    mission path again). ``reason``: "detour" or "mission"."""

    path: Path
    gamma_m: float
    reason: str


@dataclass(frozen=True, eq=False)
class AvoidanceRequest:
    """The avoidance stage's output for one call.

    mode: one of :data:`MODES`; speed_override_m_s: the speed the path follower must track instead
    of the mission speed [m/s] (None: the mission speed); course_override_rad: the course over
    ground the path follower steers instead of its line-of-sight course [rad, world ENU, CCW from
    east] (None: the LOS course; γ keeps following the path meanwhile, so the vessel returns to it
    afterwards); path_switch: the path to follow from now on (None: keep the current one);
    conflicts: the conflicts this call predicted with a collision (:class:`~mjasc.avoidance.prediction.PredictedConflict` and
    :class:`~mjasc.avoidance.static_conflicts.StaticConflict`; empty when it did not predict)."""

    mode: str = "mission"
    speed_override_m_s: float | None = None
    path_switch: PathSwitch | None = None
    conflicts: tuple = ()
    course_override_rad: float | None = None

    def __post_init__(self):
        """A request made with the constructor (a plugin's) checked: a known mode, a finite speed
        ≥ 0 and a finite course or None, a PathSwitch or None (the built-in methods use :meth:`of`)."""
        if self.mode not in MODES:
            raise ValueError(f"AvoidanceRequest.mode: must be one of {', '.join(MODES)}, got {self.mode!r}")
        v = self.speed_override_m_s
        if v is not None and not (isinstance(v, (int, float, np.floating, np.integer)) and math.isfinite(v) and v >= 0):
            raise ValueError(f"AvoidanceRequest.speed_override_m_s: must be None or a finite speed ≥ 0 [m/s], "
                             f"got {v!r}")
        c = self.course_override_rad
        if c is not None and not (isinstance(c, (int, float, np.floating, np.integer)) and math.isfinite(c)):
            raise ValueError(f"AvoidanceRequest.course_override_rad: must be None or a finite angle [rad], got {c!r}")
        if self.path_switch is not None and not isinstance(self.path_switch, PathSwitch):
            raise ValueError(f"AvoidanceRequest.path_switch: must be None or a PathSwitch, got "
                             f"{type(self.path_switch).__name__}")

    @classmethod
    def of(cls, mode: str, speed_override_m_s, path_switch, conflicts: tuple, course_override_rad) -> "AvoidanceRequest":
        """The same value as ``AvoidanceRequest(mode, speed_override_m_s, path_switch, conflicts,
        course_override_rad)``, without the frozen dataclass's ``__init__`` (one per vessel and
        control tick); values taken as given."""
        request = object.__new__(cls)
        request.__dict__.update(mode=mode, speed_override_m_s=speed_override_m_s, path_switch=path_switch,
                                conflicts=conflicts, course_override_rad=course_override_rad)
        return request
