"""A path from waypoints: straight legs, each interior corner rounded by a circular arc tangent to
both legs (a fillet of the turn radius), as :meth:`mjasc.guidance.paths.Path.from_waypoints` builds it.

World frame ENU, metres. A corner turning by Δ (CCW positive) takes R·tan(|Δ|/2) off each adjacent
leg and adds an arc of radius R and angle Δ; an L-shaped path with legs a, b and a 90° corner has
length a + b − 2R + πR/2. Errors name the waypoint: a repeated point, a 180° reversal, a radius too
large for a leg's two corners.
"""

from __future__ import annotations

import numpy as np

from mjasc.core.frames import wrap_angle
from mjasc.guidance.path_segments import (CONTINUITY_TOLERANCE_M, DUPLICATE_TOLERANCE_M, ArcSegment, LineSegment,
                                         Segment)

__all__ = ["waypoint_segments"]


def waypoint_segments(waypoints, turn_radius_m: float = 0.0) -> list[Segment]:
    """The segments of straight legs between ``waypoints`` (n ≥ 2, 2) [m], each interior corner
    rounded by an arc of ``turn_radius_m`` [m] (0 = sharp corners; collinear corners need no arc)."""
    w = np.asarray(waypoints, dtype=float)
    if w.ndim != 2 or w.shape[1] != 2 or w.shape[0] < 2:
        raise ValueError(f"waypoints: expected shape (n ≥ 2, 2), got {w.shape}")
    for i in range(w.shape[0]):
        if not np.all(np.isfinite(w[i])):
            raise ValueError(f"waypoints[{i}]: must be finite, got {w[i].tolist()}")
    r = float(turn_radius_m)
    if not np.isfinite(r) or r < 0.0:
        raise ValueError(f"turn_radius_m: must be finite and ≥ 0, got {turn_radius_m}")
    legs = np.diff(w, axis=0)
    leg_len = np.hypot(legs[:, 0], legs[:, 1])
    for i in range(legs.shape[0]):
        if leg_len[i] <= DUPLICATE_TOLERANCE_M:
            raise ValueError(f"waypoints[{i + 1}]: repeats the previous point")
    courses = np.arctan2(legs[:, 1], legs[:, 0])
    n_corners = w.shape[0] - 2
    turns = np.array([wrap_angle(courses[i + 1] - courses[i]) for i in range(n_corners)])
    if r == 0.0 or n_corners == 0:
        return [LineSegment(w[i], w[i + 1]) for i in range(w.shape[0] - 1)]
    cut = np.zeros(n_corners)  # tangent length R tan(|Δ|/2) taken off each adjacent leg
    for i, turn in enumerate(turns):
        if abs(turn) >= np.pi - 1e-9:
            raise ValueError(
                f"waypoints[{i + 1}]: the path reverses (180° turn) here; cannot round the corner"
            )
        cut[i] = r * np.tan(abs(turn) / 2.0)
    for j in range(legs.shape[0]):
        need = (cut[j - 1] if j >= 1 else 0.0) + (cut[j] if j < n_corners else 0.0)
        if need > leg_len[j] + CONTINUITY_TOLERANCE_M:
            corner = j + 1 if j < n_corners and cut[j] > 0 else j
            raise ValueError(
                f"turn_radius_m: {r:g} m is too large for the corner at waypoints[{corner}] "
                f"(the leg waypoints[{j}]→waypoints[{j + 1}] is {leg_len[j]:.6g} m long, "
                f"its corners need {need:.6g} m)"
            )
    segments: list[Segment] = []
    cursor = w[0]
    for i in range(n_corners):
        corner = w[i + 1]
        d_in = legs[i] / leg_len[i]
        d_out = legs[i + 1] / leg_len[i + 1]
        turn = turns[i]
        if abs(turn) < 1e-12:  # collinear: no arc needed
            continue
        a = corner - cut[i] * d_in
        b = corner + cut[i] * d_out
        if np.hypot(*(a - cursor)) > DUPLICATE_TOLERANCE_M:
            segments.append(LineSegment(cursor, a))
        left = np.array([-d_in[1], d_in[0]])
        centre = a + np.sign(turn) * r * left
        start_angle = float(np.arctan2(a[1] - centre[1], a[0] - centre[0]))
        segments.append(ArcSegment(centre, r, start_angle, float(turn)))
        cursor = b
    if np.hypot(*(w[-1] - cursor)) > DUPLICATE_TOLERANCE_M:
        segments.append(LineSegment(cursor, w[-1]))
    return segments
