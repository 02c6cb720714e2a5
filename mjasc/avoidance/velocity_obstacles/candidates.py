"""The velocities the velocity-obstacle method chooses among, and what each costs.

The **preferred velocity** is the path's: the line-of-sight course of the path being followed at
the mission speed (integral-free LOS, Fossen 2021 §12.4)::

    χ_pref = χ_p(γ) − atan(e / Δ),      v_pref = U (cos χ_pref, sin χ_pref)

with χ_p the path's course at the vessel's γ, e its cross-track error (positive left of the path),
Δ the lookahead and U the mission speed × the coordination factor (:class:`GuidanceState`). So
when the method lets go, the path follower's own LOS law takes over from the same course.

The **candidates** are a grid of courses χ_pref + δ_i, δ_i evenly over ±span (the preferred course
among them) × speeds U·j/(m−1), j = m−1 … 0, and m−1 more evenly above U up to the hull's top
speed (the option ``top_speed_m_s``, unset: the hull's) — the stop (speed 0) once; the preferred
velocity is row 0. U is the mission speed × the coordination factor, which a team's coordination
may have lowered to 0.6 of the cruise speed; capped at U, the grid had nothing faster for a
vessel to get clear with: a stand-on Otter in a team, 5 m off its lane at 0.95 m/s, found every
velocity of the grid colliding or to port (rule 17 (c)) while those at 1–3 m/s about its heading
were free, turned to port and was run into (docs/avoidance.md, "Known limits of the VO method").

The **cost** of a candidate v = s (cos χ, sin χ) (Kuwata et al. 2014 §III, in the spirit of their
weighted objective: deviation from the preferred velocity, hysteresis, collision penalty)::

    J(v) = w_χ |wrap(χ − χ_pref)| + w_u |s − U| / U + w_Δ ‖v − v_prev‖ / U
           + [v ∈ ∪VO^T] · w_c (1 + T / max(τ_c,min, τ_floor)) + [v forbidden by COLREG] · w_r

τ_c,min the earliest time to collision of v over all obstacles: sooner collisions cost more, so when
no candidate is collision-free the one that collides latest (most time to act) is taken and a
choice always exists. When some candidate is collision-free the cheapest collision-free one is
taken: the collision penalty (at least 2 w_c, as τ_c ≤ T) is above every deviation cost of a grid
capped at U (w_χ·span + w_u + w_Δ·2), but with speeds up to the top speed they reach
w_χ·span + w_u (top − U)/U + w_Δ·2·top/U, above 2 w_c at a low U (a Delfim at 0.6 m/s: 22 against
20), so the choice does not rest on the weights for that.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["preferred_velocity", "path_velocity", "candidate_grid", "Choice", "choose"]

#: τ_c below this counts as this in the collision penalty [s] (an overlap now is not infinitely worse).
TTC_FLOOR_S = 0.5


def preferred_velocity(position_m, path, gamma_m: float, speed_m_s: float, lookahead_m: float) -> tuple[float, float]:
    """(χ_pref [rad], U [m/s]): the path's LOS course at the vessel's position and γ, and the speed
    (module docstring)."""
    g = min(max(float(gamma_m), 0.0), path.length)
    qx, qy, chi, _ = path.at(g)
    x, y = float(position_m[0]), float(position_m[1])
    e = -(x - qx) * math.sin(chi) + (y - qy) * math.cos(chi)
    course = chi - math.atan2(e, float(lookahead_m))
    return math.atan2(math.sin(course), math.cos(course)), max(float(speed_m_s), 0.0)


def path_velocity(path, gamma_m: float, speed_m_s: float) -> tuple[np.ndarray, np.ndarray]:
    """(point (2,) [m], velocity (2,) [m/s]): the path's point at γ and its tangent at the mission
    speed — the motion the LOS course converges onto (the VO method's path conflict)."""
    g = min(max(float(gamma_m), 0.0), path.length)
    qx, qy, chi, _ = path.at(g)
    u = max(float(speed_m_s), 0.0)
    return np.array([qx, qy]), np.array([u * math.cos(chi), u * math.sin(chi)])


def candidate_grid(course_rad: float, speed_m_s: float, n_courses: int, span_rad: float, n_speeds: int,
                   stop_course_rad: float, top_speed_m_s: float | None = None
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(courses (c,) [rad], speeds (c,) [m/s], velocities (c, 2)): row 0 the preferred velocity,
    then every course × every nonzero speed, then the stop (course ``stop_course_rad``, the heading
    kept while stopping). The courses: ``n_courses`` evenly over ±``span_rad`` about
    ``course_rad``; the speeds: ``n_speeds`` − 1 evenly from ``top_speed_m_s`` (when given and
    above ``speed_m_s``) down to one step above ``speed_m_s``, then ``n_speeds`` − 1 from
    ``speed_m_s`` down to one step above 0 (module docstring)."""
    offsets = np.linspace(-span_rad, span_rad, int(n_courses))
    levels = speed_m_s * np.linspace(1.0, 0.0, int(n_speeds))[:-1]  # U … U/(m−1)
    if top_speed_m_s is not None and top_speed_m_s > speed_m_s:
        above = speed_m_s + (top_speed_m_s - speed_m_s) * np.linspace(0.0, 1.0, int(n_speeds))[1:]
        levels = np.concatenate([above[::-1], levels])  # top … above U, then U … U/(m−1)
    off, lev = np.meshgrid(offsets, levels, indexing="ij")
    courses = np.concatenate([[course_rad], course_rad + off.ravel(), [stop_course_rad]])
    courses = np.mod(courses + np.pi, 2 * np.pi) - np.pi
    speeds = np.concatenate([[speed_m_s], lev.ravel(), [0.0]])
    velocities = speeds[:, None] * np.stack([np.cos(courses), np.sin(courses)], axis=-1)
    return courses, speeds, velocities


@dataclass(frozen=True)
class Choice:
    """The chosen candidate: index, course [rad], speed [m/s], velocity (2,), cost, its earliest
    time to collision [s] (∞: none within the horizon), whether it was admissible (outside every VO
    and not forbidden) and whether COLREG forbade it."""

    index: int
    course_rad: float
    speed_m_s: float
    velocity_m_s: np.ndarray
    cost: float
    ttc_s: float
    admissible: bool
    forbidden: bool


def choose(courses, speeds, velocities, course_pref_rad: float, speed_pref_m_s: float, previous_velocity,
           ttc_min_s, horizon_s: float, forbidden, weights) -> tuple[Choice, np.ndarray]:
    """The cheapest candidate (module docstring) and every candidate's cost (c,).

    ttc_min_s (c,): each candidate's earliest time to collision over the obstacles (∞ none);
    forbidden (c,) bool: COLREG forbids it; previous_velocity (2,) or None; weights: an object with
    ``weight_course``, ``weight_speed``, ``weight_change``, ``weight_collision``, ``weight_colreg``."""
    u = max(float(speed_pref_m_s), 0.1)
    dchi = np.abs(np.mod(np.asarray(courses) - course_pref_rad + np.pi, 2 * np.pi) - np.pi)
    dchi = np.where(np.asarray(speeds) > 0.0, dchi, 0.0)  # stopping has no course
    cost = weights.weight_course * dchi + weights.weight_speed * np.abs(np.asarray(speeds) - speed_pref_m_s) / u
    if previous_velocity is not None:
        cost = cost + weights.weight_change * np.hypot(*(np.asarray(velocities) - previous_velocity).T) / u
    ttc = np.asarray(ttc_min_s, dtype=float)
    colliding = ttc <= float(horizon_s)
    cost = cost + np.where(colliding, weights.weight_collision * (1.0 + horizon_s / np.maximum(ttc, TTC_FLOOR_S)), 0.0)
    forbidden = np.asarray(forbidden, dtype=bool)
    cost = cost + np.where(forbidden, weights.weight_colreg, 0.0)
    k = int(np.argmin(np.where(colliding, np.inf, cost))) if not colliding.all() else int(np.argmin(cost))
    return Choice(k, float(courses[k]), float(speeds[k]), np.asarray(velocities[k], dtype=float), float(cost[k]),
                  float(ttc[k]), bool(not colliding[k] and not forbidden[k]), bool(forbidden[k])), cost
