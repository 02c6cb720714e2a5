"""A reversing tide: ``V(p, t) = V_base(p, t) + A·sin(2πt/T + φ)`` on top of any base field.

The tide flows along the axis of the amplitude ``A`` (flood toward ``A`` at the peak, ebb the
opposite way) with period ``T`` (the M2 tide: 44 714 s, 12.42 h). The base is any current field,
or a uniform mean current. The material derivative is the base's plus ``A·(2π/T)·cos(2πt/T + φ)``
(exact). World frame ENU, SI units.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from mjasc.core.config_tables import ConfigError, check_params, param
from mjasc.physics.currents.analytic import UniformConfig, UniformCurrent
from mjasc.physics.currents.arrays import vector2
from mjasc.physics.currents.base import CurrentField, read_parameters

__all__ = ["TidalConfig", "TidalCurrent"]


def _uniform(velocity_m_s: Any, where: str) -> UniformCurrent:
    return UniformCurrent.from_config(UniformConfig(velocity_m_s=vector2(velocity_m_s, where)))


def _field_or_velocity(value: Any, where: str) -> CurrentField:
    """Reader of the base given in Python: a current field as is, or a (2,) velocity [m/s] → a
    uniform current. (In a table, ``base`` is a nested ``[current.base]`` field table.)"""
    return value if isinstance(value, CurrentField) else _uniform(value, where)


@dataclass(frozen=True)
class TidalConfig:
    """The parameters of a :class:`TidalCurrent` (``[current]`` of ``type = "tidal"``); the base
    is ``base`` or a uniform ``mean_velocity_m_s`` (default none: [0, 0])."""

    amplitude_m_s: np.ndarray = param(reader=vector2, unit="m/s",
                                      doc="A, the peak flood velocity; the tide flows along its axis")
    period_s: float = param(minimum=60.0, unit="s",
                            doc="T, the tide's period (M2: 44714 s; ≥ 60 s: a tide's or a seiche's, not a wave's "
                                "orbital flow, which this model does not describe — 0.001 s accelerated the water "
                                "by thousands of m/s²)")
    phase_rad: float | None = param(None, unit="rad", doc="φ, the phase at t = 0 (default 0; or phase_deg)")
    phase_deg: float | None = param(None, unit="deg",
                                    doc="φ in degrees (instead of phase_rad; as every other angle of a scenario)")
    base: CurrentField | None = param(None, reader=_field_or_velocity,
                                      doc="the field the tide adds to: a nested [current.base] table")
    mean_velocity_m_s: np.ndarray | None = param(None, reader=vector2, unit="m/s",
                                                 doc="a uniform base instead of base (default [0, 0])")

    def __post_init__(self):
        check_params(self, "TidalCurrent")
        self.check(self, "TidalCurrent")

    @staticmethod
    def check(config: TidalConfig, where: str) -> None:
        """One base at most; the phase in radians or in degrees, not both."""
        if config.base is not None and config.mean_velocity_m_s is not None:
            raise ConfigError(f"{where}.mean_velocity_m_s: give either base or mean_velocity_m_s")
        if config.phase_rad is not None and config.phase_deg is not None:
            raise ConfigError(f"{where}.phase_deg: give phase_deg or phase_rad, not both")


class TidalCurrent(CurrentField):
    """A reversing tide: ``V(p, t) = V_base(p, t) + A·sin(2πt/T + φ)``.

    base: any field, or a (2,) velocity [m/s] for a uniform mean current.
    amplitude_m_s: (2,) A [m/s], the peak flood velocity (its axis is the tide's axis; the ebb
    flows the opposite way). period_s: T ≥ 60 s (M2: 44 714 s). phase_rad: φ [rad] (or
    phase_deg: φ [deg], the scenario file's unit for angles).
    Acceleration: base's + ``A·(2π/T)·cos(2πt/T + φ)`` (exact)."""

    is_steady = False

    def __init__(
        self, base: CurrentField | Any, amplitude_m_s: Any, period_s: float, phase_rad: float | None = None,
        phase_deg: float | None = None,
    ) -> None:
        self._setup(read_parameters(TidalConfig, "TidalCurrent", base=base, amplitude_m_s=amplitude_m_s,
                                    period_s=period_s, phase_rad=phase_rad, phase_deg=phase_deg))

    def _setup(self, config: TidalConfig) -> None:
        if config.base is not None:
            self._base = config.base
        else:
            mean = config.mean_velocity_m_s
            self._base = _uniform((0.0, 0.0) if mean is None else mean, "mean_velocity_m_s")
        self._amplitude = np.array(config.amplitude_m_s, dtype=float)
        self._period = config.period_s
        self._phase = (config.phase_rad if config.phase_rad is not None else
                       math.radians(config.phase_deg) if config.phase_deg is not None else 0.0)
        self._omega = 2.0 * math.pi / self._period
        self.is_uniform = self._base.is_uniform

    @property
    def base(self) -> CurrentField:
        return self._base

    def tide_m_s(self, t_s: float) -> np.ndarray:
        """(2,) tidal part A·sin(2πt/T + φ) [m/s] at time ``t_s``."""
        return self._amplitude * math.sin(self._omega * t_s + self._phase)

    def velocity(self, points_m: np.ndarray, t_s: float) -> np.ndarray:
        out = self._base.velocity(points_m, t_s)
        out += self._amplitude * math.sin(self._omega * t_s + self._phase)
        return out

    def acceleration(self, points_m, velocities_m_s, t_s) -> np.ndarray:
        out = self._base.acceleration(points_m, velocities_m_s, t_s)
        out += self._amplitude * (self._omega * math.cos(self._omega * t_s + self._phase))
        return out

    def describe(self) -> dict[str, Any]:
        return {
            "type": "tidal",
            "base": self._base.describe(),
            "amplitude_m_s": self._amplitude.tolist(),
            "period_s": self._period,
            "phase_rad": self._phase,
        }
