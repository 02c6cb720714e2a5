"""Steady analytic currents: the uniform current and the linear shear ``V0 + G·(p − p0)``.

World frame ENU, SI units. Directions are where the water flows **toward**, counter-clockwise
from east (the oceanographic convention, like headings). Both fields' material derivatives are
exact: zero for the uniform current, ``G·ṗ`` for the shear.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from mjasc.core.config_tables import ConfigError, check_params, param
from mjasc.physics.currents.arrays import matrix2, vector2
from mjasc.physics.currents.base import CurrentField, as_points, points_and_velocities, read_parameters

__all__ = ["UniformConfig", "UniformCurrent", "ShearConfig", "LinearShear"]


@dataclass(frozen=True)
class UniformConfig:
    """The parameters of a :class:`UniformCurrent` (``[current]`` of ``type = "uniform"``):
    ``velocity_m_s``, or ``speed_m_s`` with ``direction_deg`` or ``direction_rad``."""

    velocity_m_s: np.ndarray | None = param(None, reader=vector2, unit="m/s",
                                            doc="velocity (east, north); or give speed_m_s and direction_deg")
    speed_m_s: float | None = param(None, nonneg=True, phrase="must be >= 0", unit="m/s",
                                    doc="speed, with direction_deg or direction_rad (instead of velocity_m_s)")
    direction_deg: float | None = param(None, unit="deg",
                                        doc="direction the water flows toward, CCW from east (with speed_m_s; "
                                            "in degrees, as every other angle of a scenario)")
    direction_rad: float | None = param(None, unit="rad",
                                        doc="the same direction in radians (instead of direction_deg)")

    def __post_init__(self):
        check_params(self, "UniformCurrent")
        self.check(self, "UniformCurrent")

    @staticmethod
    def check(config: UniformConfig, where: str) -> None:
        """Either the velocity, or the speed and the direction."""
        if config.velocity_m_s is not None:
            for other in ("speed_m_s", "direction_deg", "direction_rad"):
                if getattr(config, other) is not None:
                    raise ConfigError(f"{where}.{other}: give either velocity_m_s or speed_m_s + direction_deg, "
                                      "not both")
        elif config.speed_m_s is None:
            raise ConfigError(f"{where}.velocity_m_s: missing (or give speed_m_s and direction_deg)")
        elif config.direction_deg is None and config.direction_rad is None:
            raise ConfigError(f"{where}.direction_deg: missing (required with speed_m_s; or direction_rad)")
        elif config.direction_deg is not None and config.direction_rad is not None:
            raise ConfigError(f"{where}.direction_rad: give direction_deg or direction_rad, not both")


class UniformCurrent(CurrentField):
    """The same velocity everywhere, always: the hot common case (one fill per call).

    Give ``velocity_m_s = (vx, vy)`` [m/s], or ``speed_m_s`` [m/s] with ``direction_deg`` (or
    ``direction_rad``), the direction the water flows toward, CCW from east (oceanographic
    convention)."""

    is_steady = True
    is_uniform = True

    def __init__(
        self,
        velocity_m_s: Any = None,
        *,
        speed_m_s: float | None = None,
        direction_deg: float | None = None,
        direction_rad: float | None = None,
    ) -> None:
        self._setup(read_parameters(UniformConfig, "UniformCurrent", velocity_m_s=velocity_m_s,
                                    speed_m_s=speed_m_s, direction_deg=direction_deg, direction_rad=direction_rad))

    def _setup(self, config: UniformConfig) -> None:
        if config.velocity_m_s is not None:
            self._velocity = np.array(config.velocity_m_s, dtype=float)
        else:
            direction = config.direction_rad if config.direction_rad is not None else math.radians(config.direction_deg)
            self._velocity = config.speed_m_s * np.array([math.cos(direction), math.sin(direction)])
        self._velocity.setflags(write=False)

    @property
    def velocity_m_s(self) -> np.ndarray:
        """(2,) world-frame velocity [m/s] (read-only)."""
        return self._velocity

    @property
    def speed_m_s(self) -> float:
        return float(math.hypot(*self._velocity))

    @property
    def direction_rad(self) -> float:
        """Direction the water flows toward, CCW from east, in (−π, π]."""
        return float(math.atan2(self._velocity[1], self._velocity[0]))

    def velocity(self, points_m: np.ndarray, t_s: float) -> np.ndarray:
        points = np.asarray(points_m, dtype=float)
        if points.ndim != 2 or points.shape[1] != 2:
            raise ValueError(f"points_m: must have shape (n, 2), got shape {points.shape}")
        out = np.empty(points.shape)
        out[:] = self._velocity
        return out

    def acceleration(self, points_m, velocities_m_s, t_s) -> np.ndarray:
        points, _ = points_and_velocities(points_m, velocities_m_s)
        return np.zeros(points.shape)

    def describe(self) -> dict[str, Any]:
        return {"type": "uniform", "velocity_m_s": self._velocity.tolist()}


@dataclass(frozen=True)
class ShearConfig:
    """The parameters of a :class:`LinearShear` (``[current]`` of ``type = "shear"``)."""

    base_velocity_m_s: np.ndarray = param(reader=vector2, unit="m/s", doc="V0, the velocity at origin_m")
    gradient_per_s: np.ndarray = param(reader=matrix2, unit="1/s",
                                       doc="G, G[i][j] = ∂V_i/∂x_j ([[0, -0.01], [0, 0]]: eastward flow "
                                           "losing 1 cm/s per metre north)")
    origin_m: np.ndarray = param((0.0, 0.0), reader=vector2, unit="m", doc="p0, where the velocity is V0")

    def __post_init__(self):
        check_params(self, "LinearShear")


class LinearShear(CurrentField):
    """``V(p) = V0 + G·(p − p0)``: a steady linear profile, e.g. a river's speed varying across it.

    base_velocity_m_s: (2,) V0 [m/s] at ``origin_m`` p0 (2,) [m].
    gradient_per_s: (2, 2) G with ``G[i, j] = ∂V_i/∂x_j`` [1/s]; e.g. ``[[0, -0.01], [0, 0]]``
    is an eastward flow losing 1 cm/s per metre north. Acceleration: ``G·ṗ`` (exact).
    Unbounded: speeds grow linearly away from p0."""

    is_steady = True
    is_uniform = False

    def __init__(self, base_velocity_m_s: Any, gradient_per_s: Any, origin_m: Any = (0.0, 0.0)):
        self._setup(read_parameters(ShearConfig, "LinearShear", base_velocity_m_s=base_velocity_m_s,
                                    gradient_per_s=gradient_per_s, origin_m=origin_m))

    def _setup(self, config: ShearConfig) -> None:
        self._base = np.array(config.base_velocity_m_s, dtype=float)
        self._gradient = np.array(config.gradient_per_s, dtype=float)
        self._origin = np.array(config.origin_m, dtype=float)
        self._gradient_t = self._gradient.T.copy()
        self.is_uniform = not np.any(self._gradient)

    def velocity(self, points_m: np.ndarray, t_s: float) -> np.ndarray:
        points = as_points(points_m, "points_m")
        out = (points - self._origin) @ self._gradient_t
        out += self._base
        return out

    def acceleration(self, points_m, velocities_m_s, t_s) -> np.ndarray:
        _, velocities = points_and_velocities(points_m, velocities_m_s)
        return velocities @ self._gradient_t

    def describe(self) -> dict[str, Any]:
        return {
            "type": "shear",
            "base_velocity_m_s": self._base.tolist(),
            "gradient_per_s": self._gradient.tolist(),
            "origin_m": self._origin.tolist(),
        }
