"""The pieces of a :class:`~mjasc.guidance.paths.Path`: straight :class:`LineSegment` and circular
:class:`ArcSegment` (world frame ENU, metres; angles CCW from east [rad]; a segment is a piece of
constant curvature, left turns positive), with the checks of the points they are built from.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mjasc.core.frames import wrap_angle

__all__ = ["LineSegment", "ArcSegment", "Segment", "DUPLICATE_TOLERANCE_M", "CONTINUITY_TOLERANCE_M", "as_point", "xy_of"]

#: Consecutive points closer than this are treated as one point [m].
DUPLICATE_TOLERANCE_M = 1e-9
#: Two segment ends closer than this are the same point [m].
CONTINUITY_TOLERANCE_M = 1e-6


def xy_of(value, name: str) -> tuple[float, float]:
    """(x, y) floats of a point of shape (2,), or ValueError naming ``name``."""
    if isinstance(value, np.ndarray) and value.shape == (2,) or isinstance(value, (tuple, list)) and len(value) == 2:
        try:
            x, y = float(value[0]), float(value[1])
        except (TypeError, ValueError):
            x = y = math.nan
        if math.isfinite(x) and math.isfinite(y):
            return x, y
    p = as_point(value, name)
    return float(p[0]), float(p[1])


def as_point(value, name: str) -> np.ndarray:
    p = np.asarray(value, dtype=float)
    if p.shape != (2,):
        raise ValueError(f"{name}: expected a point of shape (2,), got shape {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ValueError(f"{name}: must be finite, got {p.tolist()}")
    p = p.copy()
    p.flags.writeable = False
    return p


@dataclass(frozen=True, eq=False)
class LineSegment:
    """Straight segment from ``start`` (2,) to ``end`` (2,) [m], world frame."""

    start: np.ndarray
    end: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "start", as_point(self.start, "LineSegment.start"))
        object.__setattr__(self, "end", as_point(self.end, "LineSegment.end"))
        if np.hypot(*(self.end - self.start)) <= DUPLICATE_TOLERANCE_M:
            raise ValueError("LineSegment.end: equals start (zero-length segment)")

    @property
    def length(self) -> float:
        return float(np.hypot(*(self.end - self.start)))

    @property
    def start_course(self) -> float:
        d = self.end - self.start
        return float(np.arctan2(d[1], d[0]))

    @property
    def curvature(self) -> float:
        return 0.0

    @property
    def end_point(self) -> np.ndarray:
        return self.end

    @property
    def start_point(self) -> np.ndarray:
        return self.start

    def sub(self, s_a: float, s_b: float) -> "LineSegment":
        """The piece between local arc lengths s_a < s_b."""
        d = (self.end - self.start) / self.length
        return LineSegment(self.start + s_a * d, self.start + s_b * d)


@dataclass(frozen=True, eq=False)
class ArcSegment:
    """Circular arc: ``centre`` (2,) [m], ``radius`` [m] > 0, ``start_angle`` [rad] = direction of the
    radius vector from the centre to the arc's start point (CCW from east), ``sweep`` [rad] signed,
    CCW (left turn) > 0, 0 < |sweep| ≤ 2π. The path's course at the start is
    ``start_angle + sign(sweep)·π/2``."""

    centre: np.ndarray
    radius: float
    start_angle: float
    sweep: float

    def __post_init__(self):
        object.__setattr__(self, "centre", as_point(self.centre, "ArcSegment.centre"))
        r, a, sw = float(self.radius), float(self.start_angle), float(self.sweep)
        if not np.isfinite(r) or r <= 0.0:
            raise ValueError(f"ArcSegment.radius: must be finite and > 0, got {self.radius}")
        if not np.isfinite(a):
            raise ValueError(f"ArcSegment.start_angle: must be finite, got {self.start_angle}")
        if not np.isfinite(sw) or sw == 0.0 or abs(sw) > 2.0 * np.pi + 1e-12:
            raise ValueError(f"ArcSegment.sweep: must be nonzero with |sweep| ≤ 2π, got {self.sweep}")
        object.__setattr__(self, "radius", r)
        object.__setattr__(self, "start_angle", a)
        object.__setattr__(self, "sweep", sw)

    @property
    def length(self) -> float:
        return self.radius * abs(self.sweep)

    @property
    def start_course(self) -> float:
        return float(wrap_angle(self.start_angle + np.sign(self.sweep) * np.pi / 2.0))

    @property
    def curvature(self) -> float:
        return float(np.sign(self.sweep) / self.radius)

    def _at_angle(self, angle: float) -> np.ndarray:
        return self.centre + self.radius * np.array([np.cos(angle), np.sin(angle)])

    @property
    def start_point(self) -> np.ndarray:
        return self._at_angle(self.start_angle)

    @property
    def end_point(self) -> np.ndarray:
        return self._at_angle(self.start_angle + self.sweep)

    def sub(self, s_a: float, s_b: float) -> "ArcSegment":
        """The piece between local arc lengths s_a < s_b."""
        sgn = np.sign(self.sweep)
        return ArcSegment(
            self.centre,
            self.radius,
            self.start_angle + sgn * s_a / self.radius,
            sgn * (s_b - s_a) / self.radius,
        )


Segment = LineSegment | ArcSegment
