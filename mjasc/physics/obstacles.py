"""Obstacles of a scenario: static polygons and circles, and moving obstacles with known motion.

Static obstacles are geometry (docks, islands, buoys). Moving obstacles are kinematic bodies
(MuJoCo mocap) whose motion is the constant-velocity / constant-turn model of thesis eq. 3.2
without noise, or a path followed at constant speed. Vessels never read this truth: they see
obstacles through their own range sensor. World frame ENU, SI units.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mjasc.core.config_tables import check_params, param, point
from mjasc.core.frames import WORLD_LIMIT_M
from mjasc.core.geometry import circle_polygon, clean_polygon, polygon_signed_area
from mjasc.guidance.paths import Path

__all__ = ["PolygonObstacle", "CircleObstacle", "MovingObstacle", "MovingObstacleSet", "MAX_TRAFFIC_SPEED_M_S"]

MAX_TRAFFIC_SPEED_M_S = 30.0
"""Fastest moving obstacle [m/s] (58 kn: a fast ferry); faster traffic is a typo in a scenario."""


@dataclass(frozen=True)
class PolygonObstacle:
    """A static polygon (k, 2), stored counter-clockwise; height is only for drawing and sensing."""

    name: str = param(doc="the obstacle's name (unique among a scenario's obstacles)")
    vertices: np.ndarray = param(minimum=-WORLD_LIMIT_M, maximum=WORLD_LIMIT_M, unit="m",
                                 doc="corners [[x, y], ...], at least 3, either winding (stored CCW)")
    height_m: float = param(2.0, positive=True, unit="m", doc="height above the water, for drawing and sensing")

    def __post_init__(self):
        check_params(self, self.name)
        v = np.asarray(self.vertices, dtype=float)
        if v.ndim != 2 or v.shape[1] != 2 or v.shape[0] < 3:
            raise ValueError(f"{self.name}.vertices: need at least 3 [x, y] points, got shape {v.shape}")
        if not np.all(np.isfinite(v)):
            raise ValueError(f"{self.name}.vertices: must be finite")
        edge = np.hypot(*(np.roll(v, -1, axis=0) - v).T)
        if np.any(edge < 1e-9):  # a zero-length wall: MuJoCo cannot place a box along it
            k = int(np.argmax(edge < 1e-9))
            raise ValueError(f"{self.name}.vertices[{k}]: repeats the next vertex")
        # A boundary that crosses itself (vertices listed out of order) would be a wall drawn across
        # the obstacle and an inside that depends on the test: refused, as the planner refuses it
        # (clean_polygon; only checked here, the vertices are kept as given).
        clean_polygon(v, name=f"{self.name}.vertices")
        area = polygon_signed_area(v)
        if abs(area) < 1e-9:
            raise ValueError(f"{self.name}.vertices: polygon has zero area")
        if area < 0:
            v = v[::-1].copy()
        object.__setattr__(self, "vertices", v)

    @property
    def centre(self) -> np.ndarray:
        return self.vertices.mean(axis=0)


@dataclass(frozen=True)
class CircleObstacle:
    """A static disc (buoy, pillar, small islet)."""

    name: str = param(doc="the obstacle's name (unique among a scenario's obstacles)")
    centre: np.ndarray = param(reader=point, minimum=-WORLD_LIMIT_M, maximum=WORLD_LIMIT_M, unit="m",
                               doc="centre [x, y]")
    radius_m: float = param(positive=True, maximum=WORLD_LIMIT_M, unit="m", doc="radius")
    height_m: float = param(2.0, positive=True, unit="m", doc="height above the water, for drawing and sensing")

    def __post_init__(self):
        check_params(self, self.name)
        object.__setattr__(self, "centre", np.asarray(self.centre, dtype=float).reshape(2))

    def polygon(self, sides: int = 16) -> np.ndarray:
        """A circumscribed polygon (sides, 2), counter-clockwise."""
        return circle_polygon(self.centre, self.radius_m, sides)


@dataclass(frozen=True)
class MovingObstacle:
    """A kinematic obstacle bounded by a circle of ``radius_m``.

    Either constant-turn motion from (position, heading, speed, turn rate) at t = 0 (turn rate 0:
    constant velocity), or ``path`` followed at ``speed_m_s`` from arc length ``start_gamma_m``.
    """

    name: str = param(doc="the obstacle's name (unique among a scenario's obstacles)")
    radius_m: float = param(positive=True, maximum=WORLD_LIMIT_M, unit="m", doc="radius of the circle bounding it")
    position_m: np.ndarray = param(default_factory=lambda: np.zeros(2), reader=point, minimum=-WORLD_LIMIT_M,
                                   maximum=WORLD_LIMIT_M, unit="m",
                                   doc="position at t = 0 [x, y]")
    heading_rad: float = param(0.0, unit="rad", doc="heading at t = 0, CCW from east")
    speed_m_s: float = param(0.0, nonneg=True, maximum=MAX_TRAFFIC_SPEED_M_S, unit="m/s", doc="speed over ground")
    turn_rate_rad_s: float = param(0.0, unit="rad/s", doc="constant turn rate (0: constant velocity)")
    path: Path | None = param(None, doc="a path followed at speed_m_s instead of the constant-turn motion")
    start_gamma_m: float = param(0.0, nonneg=True, unit="m", doc="arc length along path at t = 0")

    def __post_init__(self):
        check_params(self, self.name)
        object.__setattr__(self, "position_m", np.asarray(self.position_m, dtype=float).reshape(2))


class MovingObstacleSet:
    """All moving obstacles of a run, evaluated together: ``state(t)`` → positions, headings, velocities.

    Constant-turn obstacles use the closed form of thesis eq. 3.2. Path-following obstacles are
    sampled once along their paths every :data:`PATH_SAMPLE_M` metres and interpolated linearly
    (a table lookup per obstacle at every physics step). The chord error on an arc of radius R is
    ds²/(8R) (< 1 mm for R ≥ 8 m).
    """

    PATH_SAMPLE_M = 0.25

    def __init__(self, obstacles: list[MovingObstacle]):
        self.obstacles = list(obstacles)
        self.names = [o.name for o in self.obstacles]
        self.radii_m = np.array([o.radius_m for o in self.obstacles])
        ct = [o for o in self.obstacles if o.path is None]
        self._ct_idx = np.array([i for i, o in enumerate(self.obstacles) if o.path is None], dtype=int)
        self._p0 = np.array([o.position_m for o in ct]).reshape(-1, 2)
        self._th0 = np.array([o.heading_rad for o in ct])
        self._v = np.array([o.speed_m_s for o in ct])
        self._w = np.array([o.turn_rate_rad_s for o in ct])
        # constant per obstacle, computed once (the same expressions as per call: the same bits)
        self._small = np.abs(self._w) < 1e-9
        w_safe = np.where(self._small, 1.0, self._w)
        self._vw, self._nvw = self._v / w_safe, -self._v / w_safe
        self._c0, self._s0 = np.cos(self._th0), np.sin(self._th0)
        self._last = (None, None)  # (t, state): the physics step and the record slot ask the same t
        paths = [o for o in self.obstacles if o.path is not None]
        self._path_idx = np.array([i for i, o in enumerate(self.obstacles) if o.path is not None], dtype=int)
        if paths:
            ds = self.PATH_SAMPLE_M
            counts = [int(np.ceil(o.path.length / ds)) + 1 for o in paths]
            k = max(counts)
            self._samples = np.zeros((len(paths), k, 2))
            self._sample_headings = np.zeros((len(paths), k))
            self._sample_g = np.zeros((len(paths), k))
            for j, o in enumerate(paths):
                g = np.minimum(np.arange(k) * ds, o.path.length)  # padded rows repeat the end point
                self._sample_g[j] = g
                self._samples[j] = o.path.point(g)
                self._sample_headings[j] = o.path.tangent_angle(g)
            self._g0 = np.array([o.start_gamma_m for o in paths])
            self._pv = np.array([o.speed_m_s for o in paths])
            self._plen = np.array([o.path.length for o in paths])
        # per obstacle, in order: the constants of its closed form as plain floats (see rows())
        self._plain = []
        ct_k = {int(i): k for k, i in enumerate(self._ct_idx)}
        path_k = {int(i): k for k, i in enumerate(self._path_idx)}
        for i in range(len(self.obstacles)):
            if i in ct_k:
                k = ct_k[i]
                self._plain.append((0, (float(self._p0[k, 0]), float(self._p0[k, 1]), float(self._th0[k]),
                                        float(self._v[k]), float(self._w[k]), bool(self._small[k]),
                                        float(self._vw[k]), float(self._nvw[k]), float(self._c0[k]),
                                        float(self._s0[k]))))
            else:
                k = path_k[i]
                self._plain.append((1, (float(self._g0[k]), float(self._pv[k]), float(self._plen[k]),
                                        self._sample_g[k].tolist(), [tuple(r) for r in self._samples[k].tolist()],
                                        self._sample_headings[k].tolist(), self._samples.shape[1] - 2)))

    def __len__(self) -> int:
        return len(self.obstacles)

    def constants(self) -> list:
        """Per obstacle, in order, (kind, constants) as :meth:`rows` evaluates them: kind 0 a
        constant turn (x0, y0, θ0, v, ω, small ω, v/ω, −v/ω, cos θ0, sin θ0), kind 1 along a path
        (γ0, speed, length, sample γ, sample points, sample headings, last sample index)."""
        return self._plain

    def state(self, t_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(positions (M, 2) [m], headings (M,) [rad], velocities (M, 2) [m/s]) at time t."""
        rows = self.rows(t_s)
        if not rows:
            return np.zeros((0, 2)), np.zeros(0), np.zeros((0, 2))
        a = np.array(rows)
        return a[:, 0:2].copy(), a[:, 2].copy(), a[:, 3:5].copy()

    def rows(self, t_s: float) -> list[tuple[float, float, float, float, float]]:
        """(x, y, heading, vx, vy) of each obstacle at time t, as plain floats (the same bits as
        the arrays of :meth:`state`; shared, do not modify).

        Evaluated obstacle by obstacle with ``math``: with the few obstacles of a scenario this is
        ~10× cheaper than numpy's per-call overhead, and it runs at every physics step. ``math.sin``
        / ``cos`` and numpy's float64 ``sin`` / ``cos`` are the same C library functions here
        (tests/test_obstacles.py checks the bits against the array form)."""
        t_last, last = self._last
        if t_last == t_s:
            return last
        out = []
        ds = self.PATH_SAMPLE_M
        for kind, p in self._plain:
            if kind == 0:  # constant turn (thesis eq. 3.2)
                x0, y0, th0, v, w, small, vw, nvw, c0, s0 = p
                th = th0 + w * t_s
                c, s = math.cos(th), math.sin(th)
                if small:
                    vt = v * t_s
                    dx, dy = vt * c0, vt * s0
                else:
                    dx, dy = vw * (s - s0), nvw * (c - c0)
                out.append((x0 + dx, y0 + dy, th, v * c, v * s))
            else:  # a path at constant speed, interpolated in the sample table
                g0, pv, plen, g_row, xy_row, h_row, last_i = p
                g = min(g0 + pv * t_s, plen)
                i0 = min(int(g / ds), last_i)
                g_a = g_row[i0]
                span = g_row[i0 + 1] - g_a  # < ds on the last stretch, 0 in the padding
                f = (g - g_a) / span if span > 0 else 0.0
                (ax, ay), (bx, by) = xy_row[i0], xy_row[i0 + 1]
                h = h_row[i0]
                moving = pv if g < plen else 0.0
                out.append((ax + f * (bx - ax), ay + f * (by - ay), h, moving * math.cos(h), moving * math.sin(h)))
        self._last = (t_s, out)
        return out
