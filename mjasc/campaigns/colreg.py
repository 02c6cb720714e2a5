"""COLREG roles of a two-vessel encounter (rules 13–15), from the own vessel's point of view.

Angles here are the mariner's: **clockwise**, in degrees, wrapped to (−180, 180].

* relative bearing β — the direction of the target seen from the own vessel, measured from the own
  bow (β > 0: to starboard; 90 = starboard beam; ±180 = dead astern);
* relative course c — the target's course minus the own course (c = 180: reciprocal courses;
  c = −90: the target heads to the own vessel's port side, i.e. it crosses from starboard).

In the project's ENU/FLU frames (yaw ψ counter-clockwise from east) a target at body-frame position
(x forward, y to port) has β = −atan2(y, x), and a target with yaw ψ_t has c = −(ψ_t − ψ_own).
The own vessel seen from the target has the bearing β_t = β + 180 − c.

Classification (checked in this order; rule 13 applies "whatever else applies"):

1. **overtaking** (rule 13, the own vessel overtakes and keeps out of the way): the own vessel comes
   up from more than 22.5° abaft the target's beam, |β_t| ≥ 112.5°;
2. **overtaken** (the target overtakes; the own vessel stands on): |β| ≥ 112.5°;
3. **head_on** (rule 14, both turn to starboard): |β| ≤ ``head_on_bearing_deg`` and the courses
   are within ``head_on_course_deg`` of reciprocal, |180 − |c|| ≤ ``head_on_course_deg``;
4. **crossing_give_way** (rule 15, the target is on the own starboard side): 0 ≤ β < 112.5°;
5. **crossing_stand_on** (rule 15, the target is on the own port side): −112.5° < β < 0.

The role holds for an encounter with risk of collision; the campaign families judge it at t = 0
(the start of the run, when the target is first in sensor range).
"""

from __future__ import annotations

from dataclasses import dataclass

from mjasc.core.config_tables import check_params, param

__all__ = ["ROLES", "RoleThresholds", "wrap_deg", "own_bearing_from_target_deg", "classify"]

ROLES = ("head_on", "crossing_give_way", "crossing_stand_on", "overtaking", "overtaken")
"""The roles :func:`classify` returns."""


@dataclass(frozen=True)
class RoleThresholds:
    """The numeric reading of rules 13–14 (the rules themselves give no numbers for rule 14)."""

    abaft_beam_deg: float = param(112.5, minimum=90.0, maximum=180.0, unit="deg",
                                  doc="rule 13: overtaking from more than 22.5° abaft the beam (|β| ≥ 112.5°)")
    head_on_bearing_deg: float = param(15.0, positive=True, maximum=45.0, unit="deg",
                                       doc="rule 14: the target within this angle of the own bow")
    head_on_course_deg: float = param(15.0, positive=True, maximum=45.0, unit="deg",
                                      doc="rule 14: the courses within this angle of reciprocal")

    def __post_init__(self):
        check_params(self, "roles")


def wrap_deg(angle_deg: float) -> float:
    """An angle in degrees wrapped to (−180, 180]."""
    a = (angle_deg + 180.0) % 360.0 - 180.0
    return 180.0 if a == -180.0 else a + 0.0


def own_bearing_from_target_deg(bearing_deg: float, relative_course_deg: float) -> float:
    """β_t: the own vessel's relative bearing seen from the target (clockwise from the target's bow)."""
    return wrap_deg(bearing_deg + 180.0 - relative_course_deg)


def classify(bearing_deg: float, relative_course_deg: float, thresholds: RoleThresholds = RoleThresholds()) -> str:
    """The own vessel's role (module docstring) for a target at relative bearing ``bearing_deg``
    whose course differs from the own by ``relative_course_deg`` (both clockwise, degrees)."""
    b, c = wrap_deg(bearing_deg), wrap_deg(relative_course_deg)
    if abs(own_bearing_from_target_deg(b, c)) >= thresholds.abaft_beam_deg:
        return "overtaking"
    if abs(b) >= thresholds.abaft_beam_deg:
        return "overtaken"
    if abs(b) <= thresholds.head_on_bearing_deg and abs(180.0 - abs(c)) <= thresholds.head_on_course_deg:
        return "head_on"
    return "crossing_give_way" if b >= 0.0 else "crossing_stand_on"
