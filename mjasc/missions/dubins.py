"""Shortest paths for a hull with a minimum turn radius: Dubins curves (Dubins 1957).

Between two poses (position, course) the shortest path whose curvature never exceeds 1/R is one
of six words of at most three pieces — an arc (L: left, counter-clockwise; R: right) or a straight
(S): LSL, RSR, LSR, RSL, LRL, RLR (Dubins, "On curves of minimal length with a constraint on
average curvature…", Amer. J. Math. 79(3), 1957). Each word is built here geometrically:

* turning circles of radius R beside the start and the goal pose, centres
  ``c = p + s R n(θ)`` with ``n(θ) = (−sin θ, cos θ)`` the left normal and s = +1 (L) or −1 (R);
* CSC words: the straight leaves circle 1 and meets circle 2 on their common tangent. With
  d = |c₂ − c₁| and α its direction, same-side words (LSL, RSR) have the straight's course α and
  length d; opposite-side words (LSR, RSL) need d ≥ 2R and have length ℓ = √(d² − 4R²) and course
  α ± atan2(2R, ℓ) (+ for LSR);
* CCC words (d < 4R): a third circle of radius R touching both, centre at distance 2R from each.

Courses are CCW from east (ENU), lengths in metres. :func:`dubins_path` returns the shortest word
as a :class:`~mjasc.guidance.paths.Path` of arcs and lines (pieces shorter than a micrometre
dropped); :func:`dubins_length` only its length, from the same geometry in plain floats (no
segments made: ~30–40× faster, for searches over many poses). The mission layer uses them to
plan a vessel's transit to its formation pose (:mod:`mjasc.missions.go_to_formation`).
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.guidance.paths import ArcSegment, LineSegment, Path

__all__ = ["dubins_path", "dubins_words", "dubins_length"]

_TWO_PI = 2.0 * math.pi
_TINY = 1e-6


def _normal(course: float) -> np.ndarray:
    return np.array([-math.sin(course), math.cos(course)])


def _sweep(side: int, course_from: float, course_to: float) -> float:
    """Signed turn [rad] from one course to another turning to ``side`` (+1 left/CCW, −1 right)."""
    s = (side * (course_to - course_from)) % _TWO_PI
    if s > _TWO_PI - 1e-12:
        s = 0.0
    return side * s


def _arc(centre: np.ndarray, radius: float, side: int, course_from: float, sweep: float) -> ArcSegment | None:
    if abs(sweep) * radius < _TINY:
        return None
    # The radius vector points from the centre to the vessel: −s R n(θ).
    start_angle = course_from - side * math.pi / 2.0
    return ArcSegment(centre, radius, start_angle, sweep)


def _csc(p0, th0, p1, th1, r, s1, s2):
    c1 = p0 + s1 * r * _normal(th0)
    c2 = p1 + s2 * r * _normal(th1)
    d_vec = c2 - c1
    d = float(math.hypot(*d_vec))
    alpha = math.atan2(d_vec[1], d_vec[0])
    if s1 == s2:
        ell, phi = d, alpha
    else:
        if d < 2.0 * r:
            return None
        ell = math.sqrt(max(d * d - 4.0 * r * r, 0.0))
        phi = alpha + s1 * math.atan2(2.0 * r, ell)
    t1 = c1 - s1 * r * _normal(phi)
    t2 = c2 - s2 * r * _normal(phi)
    pieces = [_arc(c1, r, s1, th0, _sweep(s1, th0, phi))]
    if ell > _TINY:
        pieces.append(LineSegment(t1, t2))
    pieces.append(_arc(c2, r, s2, phi, _sweep(s2, phi, th1)))
    return [p for p in pieces if p is not None]


def _ccc(p0, th0, p1, th1, r, s):
    """LRL (s = +1) or RLR (s = −1): both choices of the middle circle."""
    c1 = p0 + s * r * _normal(th0)
    c2 = p1 + s * r * _normal(th1)
    d_vec = c2 - c1
    d = float(math.hypot(*d_vec))
    if d >= 4.0 * r or d < _TINY:
        return []
    mid = 0.5 * (c1 + c2)
    h = math.sqrt(4.0 * r * r - 0.25 * d * d)
    perp = np.array([-d_vec[1], d_vec[0]]) / d
    words = []
    for sign in (1.0, -1.0):
        c3 = mid + sign * h * perp
        ta, tb = 0.5 * (c1 + c3), 0.5 * (c3 + c2)
        # course at a point of a circle turning to side s: radius angle + s π/2
        phi_a = math.atan2(ta[1] - c1[1], ta[0] - c1[0]) + s * math.pi / 2.0
        phi_b = math.atan2(tb[1] - c3[1], tb[0] - c3[0]) - s * math.pi / 2.0
        pieces = [_arc(c1, r, s, th0, _sweep(s, th0, phi_a)), _arc(c3, r, -s, phi_a, _sweep(-s, phi_a, phi_b)),
                  _arc(c2, r, s, phi_b, _sweep(s, phi_b, th1))]
        words.append([p for p in pieces if p is not None])
    return words


def dubins_words(start_m, start_course_rad: float, goal_m, goal_course_rad: float, turn_radius_m: float) -> dict:
    """Every feasible Dubins word between the poses: name → list of segments (lines, arcs)."""
    p0 = np.asarray(start_m, dtype=float)[:2]
    p1 = np.asarray(goal_m, dtype=float)[:2]
    r = float(turn_radius_m)
    if not (math.isfinite(r) and r > 0.0):
        raise ValueError(f"turn_radius_m: must be finite and > 0, got {turn_radius_m}")
    th0, th1 = float(start_course_rad), float(goal_course_rad)
    words = {}
    for name, s1, s2 in (("LSL", 1, 1), ("RSR", -1, -1), ("LSR", 1, -1), ("RSL", -1, 1)):
        w = _csc(p0, th0, p1, th1, r, s1, s2)
        if w:
            words[name] = w
    for name, s in (("LRL", 1), ("RLR", -1)):
        for k, w in enumerate(_ccc(p0, th0, p1, th1, r, s)):
            if w:
                words[f"{name}{k}"] = w
    return words


def dubins_path(start_m, start_course_rad: float, goal_m, goal_course_rad: float, turn_radius_m: float) -> Path:
    """The shortest path from ``start_m`` (2,) on course ``start_course_rad`` to ``goal_m`` (2,) on
    ``goal_course_rad`` whose turns are arcs of ``turn_radius_m`` [m] (ValueError when the poses
    coincide)."""
    words = dubins_words(start_m, start_course_rad, goal_m, goal_course_rad, turn_radius_m)
    best = min((w for w in words.values() if w), key=lambda w: sum(s.length for s in w), default=None)
    if best is None:
        raise ValueError("goal_m: equals the start pose (no path to plan)")
    return Path.from_segments(best)


def _sweep_len(side: int, course_from: float, course_to: float) -> float:
    """|:func:`_sweep`| [rad]."""
    return abs(_sweep(side, course_from, course_to))


def dubins_length(start_m, start_course_rad: float, goal_m, goal_course_rad: float, turn_radius_m: float) -> float:
    """The length [m] of :func:`dubins_path` between the poses (the same words and geometry,
    nothing built; tests/test_missions.py compares the two); ``inf`` when no word has a length (the
    poses coincide); ValueError for a turn radius :func:`dubins_path` refuses (not finite and > 0)."""
    x0, y0 = float(start_m[0]), float(start_m[1])
    x1, y1 = float(goal_m[0]), float(goal_m[1])
    r, th0, th1 = float(turn_radius_m), float(start_course_rad), float(goal_course_rad)
    if not (math.isfinite(r) and r > 0.0):  # (NaN gave inf — "poses coincide" —, 0 a straight line's length)
        raise ValueError(f"turn_radius_m: must be finite and > 0, got {turn_radius_m}")
    n0x, n0y, n1x, n1y = -math.sin(th0), math.cos(th0), -math.sin(th1), math.cos(th1)
    best = math.inf
    for s1, s2 in ((1, 1), (-1, -1), (1, -1), (-1, 1)):  # CSC
        c1x, c1y = x0 + s1 * r * n0x, y0 + s1 * r * n0y
        dx, dy = x1 + s2 * r * n1x - c1x, y1 + s2 * r * n1y - c1y
        d = math.hypot(dx, dy)
        alpha = math.atan2(dy, dx)
        if s1 == s2:
            ell, phi = d, alpha
        elif d < 2.0 * r:
            continue
        else:
            ell = math.sqrt(max(d * d - 4.0 * r * r, 0.0))
            phi = alpha + s1 * math.atan2(2.0 * r, ell)
        length = r * (_sweep_len(s1, th0, phi) + _sweep_len(s2, phi, th1)) + ell
        if 0.0 < length < best:
            best = length
    for s in (1, -1):  # CCC, both middle circles
        c1x, c1y = x0 + s * r * n0x, y0 + s * r * n0y
        c2x, c2y = x1 + s * r * n1x, y1 + s * r * n1y
        dx, dy = c2x - c1x, c2y - c1y
        d = math.hypot(dx, dy)
        if d >= 4.0 * r or d < _TINY:
            continue
        mx, my = 0.5 * (c1x + c2x), 0.5 * (c1y + c2y)
        h = math.sqrt(4.0 * r * r - 0.25 * d * d)
        px, py = -dy / d, dx / d
        for sign in (1.0, -1.0):
            c3x, c3y = mx + sign * h * px, my + sign * h * py
            phi_a = math.atan2(0.5 * (c3y - c1y), 0.5 * (c3x - c1x)) + s * math.pi / 2.0
            phi_b = math.atan2(0.5 * (c2y - c3y), 0.5 * (c2x - c3x)) - s * math.pi / 2.0
            length = r * (_sweep_len(s, th0, phi_a) + _sweep_len(-s, phi_a, phi_b) + _sweep_len(s, phi_b, th1))
            if 0.0 < length < best:
                best = length
    return best
