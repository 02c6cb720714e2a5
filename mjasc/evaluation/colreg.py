"""Rule-of-the-road roles of an encounter (COLREG rules 13–15) and whether the own vessel acted as
its role asks (rules 16–17).

Geometry from the own vessel's point of view, world frame ENU, headings CCW from east [rad]:

* relative bearing β of the target: the angle from the own bow to the line of sight, measured
  **clockwise** (as on a ship's compass), in [0°, 360°): β = wrap(ψ_own − atan2(Δy, Δx)) — a target
  dead ahead is 0°, on the starboard beam 90°, astern 180°, on the port beam 270°;
* the relative course c: the target's course minus the own course, clockwise, in (−180°, 180°]
  (c = 180: reciprocal; c = −90: the target heads to the own port side, i.e. crosses from starboard);
* the own vessel's bearing seen from the target, β_t = β + 180° − c (wrapped).

Roles (own vessel's view; :func:`role_from_geometry`, with β and β_t wrapped to (−180°, 180°]),
checked in this order (rule 13 applies "whatever else applies"):

1. **overtaking** (rule 13): the own vessel comes up from more than 22.5° abaft the target's beam,
   |β_t| > ``abaft_beam_deg`` (112.5°) → the own vessel keeps out of the way;
2. **overtaken**: the target comes up from more than 22.5° abaft the own beam, |β| > 112.5° → the own
   vessel stands on;
3. **head-on** (rule 14): |β| ≤ ``head_on_bearing_deg`` and the courses reciprocal within
   ``head_on_course_deg`` → both give way, altering to starboard;
4. **crossing** (rule 15): the target on the own starboard side, 0 ≤ β < 112.5° → the own vessel
   gives way (``crossing_give_way``); on the port side → it stands on (``crossing_stand_on``).

A role holds where there is risk of collision (rule 7: the bearing does not change appreciably, i.e.
the vessels would pass close): :func:`classify`, from positions and velocities, returns ``none``
when the range is opening, or when both holding course and speed would pass farther apart than
``risk_cpa_m`` (the distance at the straight-line CPA, centre to centre). Campaign families check
the role at t = 0 from the geometry alone (they place the targets at a chosen CPA distance).

Compliance (rules 16–17) is judged from the own vessel's track over the encounter
(:func:`judge_compliance`): a give-way vessel must act **early** (its first substantial change of
course or speed comes while the range is still above ``early_range_m`` or the time to CPA above
``early_tcpa_s``), **to starboard** when it alters course (its first course change beyond
``action_course_deg`` is clockwise, i.e. negative in ENU) and **must not cross ahead** of the target (it
passes astern: at CPA the target is ahead of it along the target's course, relative position · target
velocity < 0 … measured as the own vessel crossing the target's track behind it); a stand-on vessel
must keep course and speed (no substantial change) until action is required — until the range falls
below ``stand_on_range_m`` or the time to CPA below ``stand_on_tcpa_s`` (rule 17 (b)). A course is the
course over ground (as the role's), not the heading: in a cross current a vessel holding its track
crabs, and one that slows down turns its bow further into the current without altering course; while
the vessel is not making way (``making_way_fraction`` of its onset speed) its last course holds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mjasc.core.config_tables import check_params, param

__all__ = ["ROLES", "GEOMETRIC_ROLES", "ColregConfig", "wrap_deg", "own_bearing_from_target_deg", "role_from_geometry",
           "relative_bearing_deg", "classify", "judge_compliance", "Compliance"]

#: Roles of the own vessel, and what each asks of it.
ROLES = {
    "head_on": "give way: alter course to starboard",
    "crossing_give_way": "give way: act early, to starboard, do not cross ahead",
    "crossing_stand_on": "stand on: keep course and speed until action is required",
    "overtaking": "give way: keep out of the way of the overtaken vessel",
    "overtaken": "stand on: keep course and speed until action is required",
    "none": "no rule applies (no risk of collision or abaft the beam)",
}
#: The roles of an encounter with risk of collision (what :func:`role_from_geometry` returns).
GEOMETRIC_ROLES = ("head_on", "crossing_give_way", "crossing_stand_on", "overtaking", "overtaken")
GIVE_WAY = frozenset({"head_on", "crossing_give_way", "overtaking"})
STAND_ON = frozenset({"crossing_stand_on", "overtaken"})


@dataclass(frozen=True)
class ColregConfig:
    """Thresholds of the role classification and the compliance judgement."""

    abaft_beam_deg: float = param(112.5, minimum=90.0, maximum=180.0, unit="deg",
                                  doc="rule 13: overtaking from more than 22.5° abaft the beam (|β| > 112.5°)")
    risk_cpa_m: float = param(20.0, positive=True, unit="m",
                              doc="rule 7: risk of collision only while holding course and speed would "
                                  "pass closer than this (straight-line CPA, centre to centre)")
    head_on_bearing_deg: float = param(15.0, positive=True, maximum=45.0, unit="deg",
                                       doc="rule 14: the target within this angle of the own bow")
    head_on_course_deg: float = param(15.0, positive=True, maximum=45.0, unit="deg",
                                      doc="rule 14: the courses within this angle of reciprocal")
    action_course_deg: float = param(10.0, positive=True, unit="deg",
                                     doc="a course change beyond this is a substantial action (rule 16: readily apparent)")
    action_speed_fraction: float = param(0.25, positive=True, maximum=1.0,
                                         doc="a speed change beyond this fraction of the initial speed is a substantial action")
    early_range_m: float = param(30.0, nonneg=True, unit="m",
                                 doc="a give-way vessel acts early when it first acts at a range above this")
    early_tcpa_s: float = param(15.0, nonneg=True, unit="s",
                                doc="... or at a time to CPA above this")
    stand_on_range_m: float = param(10.0, nonneg=True, unit="m",
                                    doc="a stand-on vessel may act once the range is below this (rule 17 (b))")
    stand_on_tcpa_s: float = param(8.0, nonneg=True, unit="s", doc="... or the time to CPA below this")
    making_way_fraction: float = param(0.5, nonneg=True, maximum=1.0,
                                       doc="a course is the course over ground while the speed over ground is at "
                                           "least this fraction of the onset speed (and 0.1 m/s); slower, the "
                                           "vessel's drift is not a course: the last one holds")

    def __post_init__(self):
        check_params(self, "colreg")


def relative_bearing_deg(own_position_m, own_heading_rad: float, target_position_m) -> float:
    """β in [0, 360): clockwise from the own bow to the target (module docstring)."""
    d = np.asarray(target_position_m, dtype=float) - np.asarray(own_position_m, dtype=float)
    los = math.atan2(d[1], d[0])
    return math.degrees(own_heading_rad - los) % 360.0


def wrap_deg(angle_deg: float) -> float:
    """An angle in degrees wrapped to (−180, 180]."""
    a = (angle_deg + 180.0) % 360.0 - 180.0
    return 180.0 if a == -180.0 else a + 0.0


def own_bearing_from_target_deg(bearing_deg: float, relative_course_deg: float) -> float:
    """β_t: the own vessel's relative bearing seen from the target (clockwise from the target's bow)."""
    return wrap_deg(bearing_deg + 180.0 - relative_course_deg)


def role_from_geometry(bearing_deg: float, relative_course_deg: float, config: ColregConfig = ColregConfig()) -> str:
    """The own vessel's role (module docstring) for a target at relative bearing ``bearing_deg``
    whose course differs from the own by ``relative_course_deg`` (both clockwise, degrees), assuming
    risk of collision."""
    b, c = wrap_deg(bearing_deg), wrap_deg(relative_course_deg)
    if abs(own_bearing_from_target_deg(b, c)) > config.abaft_beam_deg:
        return "overtaking"
    if abs(b) > config.abaft_beam_deg:
        return "overtaken"
    if abs(b) <= config.head_on_bearing_deg and abs(180.0 - abs(c)) <= config.head_on_course_deg:
        return "head_on"
    return "crossing_give_way" if b >= 0.0 else "crossing_stand_on"


def classify(own_position_m, own_course_rad: float, own_speed_m_s: float, target_position_m,
             target_course_rad: float, target_speed_m_s: float, config: ColregConfig = ColregConfig()) -> str:
    """The own vessel's role towards the target (one of :data:`ROLES`), from both positions (2,) [m],
    courses over ground [rad, CCW from east] and speeds [m/s]: ``none`` when the range is opening or
    the straight-line CPA lies farther than ``config.risk_cpa_m`` (no risk of collision), else
    :func:`role_from_geometry`."""
    los = np.asarray(target_position_m, dtype=float) - np.asarray(own_position_m, dtype=float)
    v_own = own_speed_m_s * np.array([math.cos(own_course_rad), math.sin(own_course_rad)])
    v_tgt = target_speed_m_s * np.array([math.cos(target_course_rad), math.sin(target_course_rad)])
    w = v_tgt - v_own
    closing = float(np.dot(w, los))
    if closing >= 0.0:  # the range is not decreasing: no risk of collision
        return "none"
    at_cpa = los - (closing / float(np.dot(w, w))) * w  # (closing < 0: w ≠ 0)
    if math.hypot(at_cpa[0], at_cpa[1]) > config.risk_cpa_m:  # a wide pass: the bearing changes
        return "none"
    beta = relative_bearing_deg(own_position_m, own_course_rad, target_position_m)
    rel_course = -math.degrees(target_course_rad - own_course_rad)  # clockwise
    return role_from_geometry(beta, rel_course, config)


@dataclass(frozen=True)
class Compliance:
    """The judgement of one encounter: ``role``; ``acted`` (a substantial change of course or speed
    happened before CPA) and when (``action_time_s``, ``action_range_m``, ``action_tcpa_s``); for a
    give-way role ``early``, ``to_starboard`` (None when it only changed speed) and
    ``crossed_ahead``; for a stand-on role ``kept_course_and_speed`` (no substantial action while
    it was not yet required). ``compliant`` sums it up; ``reasons`` lists what failed."""

    role: str
    acted: bool
    action_time_s: float | None
    action_range_m: float | None
    action_tcpa_s: float | None
    early: bool | None
    to_starboard: bool | None
    crossed_ahead: bool | None
    kept_course_and_speed: bool | None
    compliant: bool
    reasons: tuple[str, ...]


def _tcpa(rel_p: np.ndarray, rel_v: np.ndarray) -> np.ndarray:
    """Time to the closest point of approach under straight motion, per row [s] (≥ 0)."""
    vv = np.sum(rel_v * rel_v, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(vv > 1e-12, -np.sum(rel_p * rel_v, axis=-1) / vv, 0.0)
    return np.maximum(t, 0.0)


def _course_while_making_way(heading_rad: np.ndarray, velocity_m_s: np.ndarray, speed_m_s: np.ndarray,
                             config: ColregConfig) -> np.ndarray:
    """The own course over ground [rad] per sample, held at its last value while the vessel is not making
    way (speed over ground below ``making_way_fraction`` of the onset speed, or below 0.1 m/s): a vessel
    that has taken off most of its way made a speed action, and its course over ground is then the
    current's drift. Before any sample making way, the onset's course (its heading when it lay still).
    The heading is not the course: in a cross current a vessel holding its track crabs, and slowing down
    turns its bow into the current without altering its course."""
    gate = max(0.1, config.making_way_fraction * float(speed_m_s[0]))
    way = speed_m_s >= gate
    cog = np.arctan2(velocity_m_s[:, 1], velocity_m_s[:, 0])
    last = np.maximum.accumulate(np.where(way, np.arange(way.size), -1))  # last sample making way, −1: none yet
    start = cog[0] if speed_m_s[0] > 0.1 else heading_rad[0]
    return np.where(last >= 0, cog[np.maximum(last, 0)], start)


def judge_compliance(role: str, times_s, own_position_m, own_heading_rad, own_velocity_m_s, target_position_m,
                     target_velocity_m_s, config: ColregConfig = ColregConfig()) -> Compliance:
    """Judge the own vessel's conduct in one encounter from time series over the encounter, from its
    onset to past its CPA: times (n,), own positions (n, 2), headings (n,), velocities (n, 2), target
    positions (n, 2) and velocities (n, 2) (world ENU, SI)."""
    t = np.asarray(times_s, dtype=float)
    p, h, v = (np.asarray(own_position_m, dtype=float), np.asarray(own_heading_rad, dtype=float),
               np.asarray(own_velocity_m_s, dtype=float))
    q, w = np.asarray(target_position_m, dtype=float), np.asarray(target_velocity_m_s, dtype=float)
    rel = q - p
    rng = np.hypot(rel[:, 0], rel[:, 1])
    k_cpa = int(np.argmin(rng))
    tcpa = _tcpa(rel, w - v)
    speed = np.hypot(v[:, 0], v[:, 1])
    v0 = max(float(speed[0]), 1e-6)
    course = _course_while_making_way(h, v, speed, config)
    dh = np.degrees(np.angle(np.exp(1j * (course - course[0]))))  # course change from the onset, CCW positive [deg]
    substantial = (np.abs(dh) > config.action_course_deg) | (np.abs(speed - speed[0]) > config.action_speed_fraction * v0)
    substantial[k_cpa + 1:] = False
    idx = np.flatnonzero(substantial)
    acted = idx.size > 0
    a = int(idx[0]) if acted else None
    action_time = float(t[a]) if acted else None
    action_range = float(rng[a]) if acted else None
    action_tcpa = float(tcpa[a]) if acted else None
    reasons: list[str] = []
    early = to_starboard = crossed_ahead = kept = None
    if role in GIVE_WAY:
        early = acted and (action_range > config.early_range_m or action_tcpa > config.early_tcpa_s)
        if not acted:
            reasons.append("did not act")
        elif not early:
            reasons.append(f"acted late (range {action_range:.1f} m, TCPA {action_tcpa:.1f} s)")
        turned = np.abs(dh[: k_cpa + 1]) > config.action_course_deg
        if turned.any():
            first = int(np.flatnonzero(turned)[0])
            to_starboard = bool(dh[first] < 0.0)
            if not to_starboard and role in ("head_on", "crossing_give_way"):
                reasons.append("altered course to port")
        # Crossing ahead: the own vessel passes the target's track ahead of the target, i.e. when the
        # own vessel crosses the line of the target's motion, it is on the target's bow side.
        w_n = np.hypot(w[:, 0], w[:, 1])
        along = np.sum((p - q) * w, axis=1) / np.maximum(w_n, 1e-9)  # > 0: the own vessel ahead of the target
        side = w[:, 0] * (p - q)[:, 1] - w[:, 1] * (p - q)[:, 0]  # sign of the own vessel's side of the target's track
        flips = np.flatnonzero(np.sign(side[1:]) != np.sign(side[:-1]))
        moving = w_n > 1e-3
        crossed_ahead = bool(any(moving[k] and along[k] > 0.0 for k in flips))
        if crossed_ahead and role == "crossing_give_way":
            reasons.append("crossed ahead of the stand-on vessel")
    elif role in STAND_ON:
        required = (rng <= config.stand_on_range_m) | (tcpa <= config.stand_on_tcpa_s)
        early_moves = substantial & ~np.maximum.accumulate(required)
        kept = not bool(early_moves.any())
        if not kept:
            reasons.append("changed course or speed before action was required")
    compliant = not reasons
    return Compliance(role, acted, action_time, action_range, action_tcpa, early, to_starboard, crossed_ahead, kept,
                      compliant, tuple(reasons))
