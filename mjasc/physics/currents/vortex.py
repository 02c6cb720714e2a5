"""An eddy: the Lamb–Oseen or Rankine vortex, purely tangential flow, optionally drifting.

With ``r`` the distance to the centre, ``r_c`` the core radius and ``v_max`` the signed peak
tangential speed (CCW positive; negative turns clockwise), the tangential speed is

* Lamb–Oseen (default): ``v_θ(r) = Γ/(2πr)·(1 − exp(−r²/r_c²))``, peaking at
  ``r* = 1.1209 r_c`` (:data:`LAMB_OSEEN_PEAK_RATIO`) with ``Γ = 2π r* v_max / (1 − e^{−α})``,
  ``α = (r*/r_c)² = 1.25643``, the root of ``e^α = 1 + 2α``;
* Rankine: solid-body ``v_max·r/r_c`` inside the core, ``v_max·r_c/r`` outside.

The field is divergence-free; its material derivative is analytic. World frame ENU, SI units.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from mjasc.core.config_tables import check_params, param
from mjasc.physics.currents.arrays import vector2
from mjasc.physics.currents.base import CurrentField, as_points, points_and_velocities, read_parameters

__all__ = ["LAMB_OSEEN_PEAK_RATIO", "VORTEX_PROFILES", "VortexConfig", "Vortex"]

_LAMB_OSEEN_ALPHA = 1.2564312086261696
"""(r_peak / r_c)² of the Lamb–Oseen vortex: the root of e^α = 1 + 2α."""

LAMB_OSEEN_PEAK_RATIO = math.sqrt(_LAMB_OSEEN_ALPHA)
"""r_peak / r_c ≈ 1.1209: where a Lamb–Oseen vortex's tangential speed peaks."""

VORTEX_PROFILES = ("lamb_oseen", "rankine")
"""The vortex profiles, the default first."""


@dataclass(frozen=True)
class VortexConfig:
    """The parameters of a :class:`Vortex` (``[current]`` of ``type = "vortex"``)."""

    centre_m: np.ndarray = param(reader=vector2, unit="m", doc="the centre at t = 0")
    core_radius_m: float = param(minimum=0.01, unit="m",
                                 doc="r_c: Lamb–Oseen Gaussian width / Rankine core radius (≥ 1 cm)")
    max_speed_m_s: float = param(unit="m/s", doc="peak tangential speed v_max, CCW positive (< 0: clockwise)")
    profile: str = param("lamb_oseen", choices=VORTEX_PROFILES, phrase="must be one of 'lamb_oseen', 'rankine'",
                         doc="tangential speed profile")
    drift_m_s: np.ndarray = param((0.0, 0.0), reader=vector2, unit="m/s",
                                  doc="velocity of the centre: it moves as centre_m + drift_m_s·t")

    def __post_init__(self):
        check_params(self, "Vortex")


class Vortex(CurrentField):
    """An eddy: purely tangential flow around a centre, CCW positive, divergence-free.

    With ``r`` the distance to the centre, ``r_c`` = ``core_radius_m``, ``v_max`` =
    ``max_speed_m_s`` (signed: < 0 turns clockwise), the tangential speed is

    * Lamb–Oseen (default): ``v_θ(r) = Γ/(2πr)·(1 − exp(−r²/r_c²))``, peaking at
      ``r* = 1.1209 r_c`` (``LAMB_OSEEN_PEAK_RATIO``) with ``Γ = 2π r* v_max / (1 − e^{−α})``,
      ``α = (r*/r_c)² = 1.25643``; smooth everywhere, circulation inside R:
      ``Γ·(1 − exp(−R²/r_c²))``.
    * Rankine: solid-body ``v_max·r/r_c`` inside the core, ``v_max·r_c/r`` outside; circulation
      ``2π v_max R²/r_c`` inside, ``2π v_max r_c`` outside.

    The centre drifts as ``centre_m + drift_m_s·t``. Acceleration is analytic:
    ``a = J(q)·(ṗ − d)`` with ``q = p − c(t)`` and ``J`` the velocity gradient."""

    is_uniform = False

    def __init__(
        self,
        centre_m: Any,
        core_radius_m: float,
        max_speed_m_s: float,
        profile: str = "lamb_oseen",
        drift_m_s: Any = (0.0, 0.0),
    ) -> None:
        self._setup(read_parameters(VortexConfig, "Vortex", centre_m=centre_m, core_radius_m=core_radius_m,
                                    max_speed_m_s=max_speed_m_s, profile=profile, drift_m_s=drift_m_s))

    def _setup(self, config: VortexConfig) -> None:
        self._centre = np.array(config.centre_m, dtype=float)
        self._core = config.core_radius_m
        self._vmax = config.max_speed_m_s
        self._profile = config.profile
        self._drift = np.array(config.drift_m_s, dtype=float)
        self.is_steady = not np.any(self._drift)
        self._core2 = self._core**2
        if self._profile == "lamb_oseen":
            peak = LAMB_OSEEN_PEAK_RATIO * self._core
            self._circulation = 2.0 * math.pi * peak * self._vmax / -math.expm1(-_LAMB_OSEEN_ALPHA)
        else:
            self._circulation = 2.0 * math.pi * self._core * self._vmax

    @property
    def circulation_m2_s(self) -> float:
        """Total circulation Γ [m²/s] (the limit as R → ∞), CCW positive."""
        return self._circulation

    def centre_at(self, t_s: float) -> np.ndarray:
        """(2,) world position [m] of the centre at time ``t_s``."""
        return self._centre + self._drift * t_s

    def tangential_speed_m_s(self, radius_m: Any) -> np.ndarray:
        """v_θ(r) [m/s], CCW positive, for distances ``radius_m`` ≥ 0 (any shape)."""
        r = np.abs(np.asarray(radius_m, dtype=float))
        return self._f(r * r) * r

    def circulation_within_m2_s(self, radius_m: Any) -> np.ndarray:
        """Closed-form circulation ∮ V·dl [m²/s] around the circle of radius R about the centre."""
        r = np.abs(np.asarray(radius_m, dtype=float))
        if self._profile == "lamb_oseen":
            return self._circulation * -np.expm1(-(r * r) / self._core2)
        return 2.0 * math.pi * r * self.tangential_speed_m_s(r)

    def _f(self, r2: np.ndarray) -> np.ndarray:
        """f(r) = v_θ(r)/r [1/s] as a function of r² (finite at the centre)."""
        if self._profile == "lamb_oseen":
            x = r2 * (1.0 / self._core2)
            x_safe = np.where(x > 0.0, x, 1.0)
            h = np.where(x > 0.0, -np.expm1(-x_safe) / x_safe, 1.0)  # (1 − e^{−x})/x
            return h * (self._circulation / (2.0 * math.pi * self._core2))
        inside = r2 <= self._core2
        r2_safe = np.where(inside, 1.0, r2)
        return np.where(inside, self._vmax / self._core, self._vmax * self._core / r2_safe)

    def _g(self, r2: np.ndarray) -> np.ndarray:
        """g(r) = (1/r)·df/dr = 2·df/d(r²) [1/(m² s)] as a function of r²."""
        if self._profile == "lamb_oseen":
            # h'(x) = (x e^{−x} − (1 − e^{−x}))/x²; its Taylor series below x = 1e-2, where the
            # direct form cancels (series truncation < 1e-13 there)
            x = r2 * (1.0 / self._core2)
            small = x < 1e-2
            x_big = np.where(small, 1.0, x)
            dh_direct = (x_big * np.exp(-x_big) + np.expm1(-x_big)) / (x_big * x_big)
            dh_series = -1 / 2 + x * (1 / 3 + x * (-1 / 8 + x * (1 / 30 + x * (-1 / 144))))
            dh = np.where(small, dh_series, dh_direct)
            return dh * (2.0 * self._circulation / (2.0 * math.pi * self._core2**2))
        inside = r2 <= self._core2
        r2_safe = np.where(inside, 1.0, r2)
        return np.where(inside, 0.0, -2.0 * self._vmax * self._core / (r2_safe * r2_safe))

    def velocity(self, points_m: np.ndarray, t_s: float) -> np.ndarray:
        q = as_points(points_m, "points_m") - self.centre_at(t_s)
        f = self._f(np.einsum("ij,ij->i", q, q))
        out = np.empty(q.shape)
        out[:, 0] = -f * q[:, 1]
        out[:, 1] = f * q[:, 0]
        return out

    def acceleration(self, points_m, velocities_m_s, t_s) -> np.ndarray:
        points, velocities = points_and_velocities(points_m, velocities_m_s)
        q = points - self.centre_at(t_s)
        u = velocities - self._drift
        r2 = np.einsum("ij,ij->i", q, q)
        f, g = self._f(r2), self._g(r2)
        gqu = g * np.einsum("ij,ij->i", q, u)
        out = np.empty(q.shape)
        out[:, 0] = -f * u[:, 1] - gqu * q[:, 1]
        out[:, 1] = f * u[:, 0] + gqu * q[:, 0]
        return out

    def describe(self) -> dict[str, Any]:
        return {
            "type": "vortex",
            "centre_m": self._centre.tolist(),
            "core_radius_m": self._core,
            "max_speed_m_s": self._vmax,
            "profile": self._profile,
            "drift_m_s": self._drift.tolist(),
        }
