"""Closest point of approach of straight-line motion, and placing a target to meet a requested CPA.

The own vessel moves at speed U along its heading; a target moves at speed r·U (r: the speed
ratio) on a course c relative to the own course (clockwise, degrees: :mod:`mjasc.evaluation.colreg`).
Everything is in the own vessel's body frame FLU at t = 0 (x forward, y to port, metres), where
the target's heading is −c (counter-clockwise) and the relative velocity is

    w = v_target − v_own = U (r cos c − 1, −r sin c).

**CPA.** With d(t) = d₀ + w t the target's position relative to the own vessel,
``TCPA = −(d₀·w) / |w|²`` and ``DCPA = |d₀ + w·TCPA|`` (:func:`cpa`; any frame).

**Placement** (:func:`place_target`). Given (c, r) and the requested signed DCPA D and TCPA T > 0,
the target starts at

    d₀ = D · Jŵ − w T,          Jŵ = (ŵ_y, −ŵ_x)   (ŵ turned 90° clockwise),

so that d(T) = D·Jŵ ⟂ w: the CPA is at T exactly, at distance |D|. The start range is
R₀ = √(D² + |w|² T²) and the relative bearing at t = 0 is β₀ = −atan2(d₀_y, d₀_x).

**The sign of D.** cross(d, ḋ) = cross(D·Jŵ, w) = D·|w|: for D > 0 the target's bearing draws left
(counter-clockwise) all through the encounter. That is the passing the rules ask of an undisturbed
encounter: port to port head-on; a target crossing from starboard passes ahead of the own vessel
(the own vessel, giving way, ends up astern of it); a target crossing from port passes astern of
the own vessel; an overtaken slower target stays on the own port side; a faster target overtaking
the own vessel passes it on the own starboard side. D < 0 is the other side; D = 0 a collision course.

**Bearing instead of course** (:func:`course_for_bearing`). Position (2 unknowns), course and
speed of the target give 4 degrees of freedom; DCPA and TCPA fix 2, so only two of (bearing,
course, speed ratio) can be chosen. When the bearing at t = 0 and r are given, c is the root of
β₀(c) = β (β₀ from the closed form above), found on a 0.25° scan of c and refined by Brent's
method; of several roots the caller's ``accept`` filter keeps those with the right role and the one
nearest ``nominal_course_deg`` wins.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.optimize import brentq

from mjasc.evaluation.colreg import wrap_deg

__all__ = ["cpa", "relative_velocity", "Placement", "place_target", "course_for_bearing", "bearing_deg"]


def cpa(rel_position_m, rel_velocity_m_s) -> tuple[float, float]:
    """(TCPA [s], DCPA [m]) of straight-line relative motion d(t) = d₀ + w t (TCPA may be < 0:
    the CPA is past). w = 0 (no relative motion): (0, |d₀|)."""
    d = np.asarray(rel_position_m, dtype=float)
    w = np.asarray(rel_velocity_m_s, dtype=float)
    ww = float(w @ w)
    if ww == 0.0:
        return 0.0, float(np.hypot(*d))
    t = -float(d @ w) / ww
    return t, float(np.hypot(*(d + w * t)))


def bearing_deg(x_forward, y_port):
    """Relative bearing, clockwise from the bow, degrees in (−180, 180] (arrays too)."""
    b = -np.degrees(np.arctan2(y_port, x_forward))
    return np.where(b == -180.0, 180.0, b) + 0.0


def relative_velocity(speed_m_s: float, relative_course_deg, speed_ratio: float) -> np.ndarray:
    """w = U (r cos c − 1, −r sin c) in the own body frame (x forward, y port) [m/s]; c may be an array."""
    c = np.radians(relative_course_deg)
    return speed_m_s * np.stack([speed_ratio * np.cos(c) - 1.0, -speed_ratio * np.sin(c)], axis=-1)


@dataclass(frozen=True)
class Placement:
    """A target's start relative to the own vessel (body frame FLU at t = 0)."""

    position_body_m: np.ndarray      # d₀ (2,) [m]
    velocity_body_m_s: np.ndarray    # the target's own velocity (2,) [m/s]
    relative_velocity_m_s: np.ndarray  # w (2,) [m/s]
    relative_course_deg: float       # c, clockwise
    bearing_deg: float               # β₀ at t = 0, clockwise from the bow
    range_m: float                   # R₀ = |d₀|


def _start(w: np.ndarray, dcpa_m: float, tcpa_s: float) -> np.ndarray:
    """d₀ = D·Jŵ − w T for arrays of w (…, 2)."""
    n = np.linalg.norm(w, axis=-1, keepdims=True)
    w_hat = w / n
    j = np.stack([w_hat[..., 1], -w_hat[..., 0]], axis=-1)
    return dcpa_m * j - w * tcpa_s


def place_target(speed_m_s: float, relative_course_deg: float, speed_ratio: float, dcpa_m: float,
                 tcpa_s: float) -> Placement | None:
    """The start that gives exactly (dcpa_m, tcpa_s) (module docstring); None when the target has
    no motion relative to the own vessel (same course and speed)."""
    if not speed_m_s > 0 or not tcpa_s > 0 or not speed_ratio >= 0:
        raise ValueError(f"speed, TCPA must be > 0 and the speed ratio ≥ 0, got {speed_m_s}, {tcpa_s}, {speed_ratio}")
    w = relative_velocity(speed_m_s, relative_course_deg, speed_ratio)
    if np.hypot(*w) < 1e-9 * speed_m_s:
        return None
    d0 = _start(w, dcpa_m, tcpa_s)
    c = math.radians(relative_course_deg)
    v = speed_ratio * speed_m_s * np.array([math.cos(c), -math.sin(c)])
    return Placement(d0, v, w, wrap_deg(relative_course_deg), float(bearing_deg(d0[0], d0[1])),
                     float(np.hypot(*d0)))


_SCAN_DEG = np.arange(-180.0, 180.0, 0.25)


def course_for_bearing(speed_m_s: float, bearing: float, speed_ratio: float, dcpa_m: float, tcpa_s: float,
                       accept: Callable[[Placement], bool] = lambda p: True,
                       nominal_course_deg: float = 180.0) -> Placement | None:
    """The placement whose bearing at t = 0 is ``bearing`` (clockwise, degrees), given the speed
    ratio, DCPA and TCPA (module docstring); None when no course gives it (or none is accepted)."""
    w = relative_velocity(speed_m_s, _SCAN_DEG, speed_ratio)
    ok = np.linalg.norm(w, axis=-1) > 1e-6 * speed_m_s
    d0 = _start(np.where(ok[:, None], w, 1.0), dcpa_m, tcpa_s)
    f = (bearing_deg(d0[:, 0], d0[:, 1]) - bearing + 180.0) % 360.0 - 180.0  # wrapped residual
    f = np.where(ok, f, np.nan)

    def residual(c: float) -> float:
        p = place_target(speed_m_s, c, speed_ratio, dcpa_m, tcpa_s)
        return float("nan") if p is None else wrap_deg(p.bearing_deg - bearing)

    g = np.roll(f, -1)  # the next scan point's residual (the scan wraps around)
    bracket = np.isfinite(f) & np.isfinite(g) & (np.abs(f) <= 90) & (np.abs(g) <= 90) & ((f == 0) | (f * g < 0))
    roots = []
    for i in np.flatnonzero(bracket):  # no bracket across a wrap jump or the singular point
        ca = float(_SCAN_DEG[i])
        if f[i] == 0.0:
            roots.append(ca)
            continue
        try:
            roots.append(brentq(residual, ca, ca + 0.25, xtol=1e-12, rtol=1e-14))
        except ValueError:
            continue
    found = []
    for c in roots:
        p = place_target(speed_m_s, wrap_deg(c), speed_ratio, dcpa_m, tcpa_s)
        if p is not None and abs(wrap_deg(p.bearing_deg - bearing)) < 1e-7 and accept(p):
            found.append(p)
    if not found:
        return None
    return min(found, key=lambda p: (abs(wrap_deg(p.relative_course_deg - nominal_course_deg)), p.range_m))
