"""How a manoeuvring trial's numbers are read off its track (:mod:`mjasc.physics.trials`): a level's
first crossing interpolated linearly between physics steps, a least-squares circle through the
steady turn, coordinates along and across the approach course, a sailed path's length. World ENU,
SI units."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["crossing_time", "row_at_level", "fit_circle", "course_frame", "path_length"]


def crossing_time(times: np.ndarray, values: np.ndarray, level: float):
    """First time ``values`` reaches ``level`` from below (linear between samples); None if never."""
    above = np.flatnonzero(values >= level)
    if above.size == 0:
        return None
    i = int(above[0])
    if i == 0:
        return float(times[0])
    v0, v1 = values[i - 1], values[i]
    f = (level - v0) / (v1 - v0) if v1 != v0 else 1.0
    return float(times[i - 1] + f * (times[i] - times[i - 1]))


def row_at_level(rows: np.ndarray, column: int, level: float):
    """Row (all columns) interpolated where ``rows[:, column]`` first reaches ``level``; None if never."""
    values = rows[:, column]
    above = np.flatnonzero(values >= level)
    if above.size == 0:
        return None
    i = int(above[0])
    if i == 0:
        return rows[0]
    v0, v1 = values[i - 1], values[i]
    f = (level - v0) / (v1 - v0) if v1 != v0 else 1.0
    return rows[i - 1] + f * (rows[i] - rows[i - 1])


def fit_circle(points: np.ndarray) -> tuple[np.ndarray, float]:
    """Least-squares circle (Kåsa): centre (2,), radius [m] of points (n, 2)."""
    x, y = points[:, 0], points[:, 1]
    a = np.column_stack([2.0 * x, 2.0 * y, np.ones_like(x)])
    sol, *_ = np.linalg.lstsq(a, x * x + y * y, rcond=None)
    centre = sol[:2]
    return centre, float(np.sqrt(sol[2] + centre @ centre))


def course_frame(psi0: float, origin: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Along- and across-course coordinates [m] of world points (n, 2) relative to ``origin``
    on the approach course ψ0 (across positive to port)."""
    d = np.asarray(points, dtype=float) - origin
    c, s = math.cos(psi0), math.sin(psi0)
    return d[..., 0] * c + d[..., 1] * s, -d[..., 0] * s + d[..., 1] * c


def path_length(xy: np.ndarray) -> float:
    """Length [m] of the polyline through the points (n, 2)."""
    return float(np.sum(np.hypot(np.diff(xy[:, 0]), np.diff(xy[:, 1]))))
