"""Water current fields: the velocity of the water over ground, in the world frame.

The hydrodynamics evaluates the current at every vessel's position at every physics step and
forms the relative velocity ``ν_r = ν − ν_c`` (docs/architecture.md; the thesis's environment
"adds water current", digest §1). Every field maps world-frame points ``(n, 2)`` [m] (ENU: x east,
y north) and a simulation time ``t_s`` [s] to world-frame current velocities ``(n, 2)`` [m/s], and
gives the material derivative seen by a body moving over ground with velocity ``ṗ``::

    a_c = dV/dt along the body's path = ∂V/∂t + (∇V)·ṗ          (n, 2) [m/s²]

which the hydrodynamics needs for the current's added-mass (Froude–Krylov) term.

Contract of every field (``CurrentField``):

* ``velocity(points_m, t_s)`` returns a new ``(n, 2)`` array that the caller owns (it may be
  written in place); ``points_m`` must be shaped ``(n, 2)``.
* ``acceleration(points_m, velocities_m_s, t_s)``: analytic where the field allows, otherwise one
  central finite difference *along the body's path*,
  ``[V(p + h·ṗ, t + h) − V(p − h·ṗ, t − h)] / (2h)`` with ``h = FD_STEP_S = 1e-3 s``
  (spatial step ``h·|ṗ|``, i.e. 5 mm at 5 m/s; truncation error O(h²), round-off ~1e-13 m/s²).
  At a kink of a piecewise field (grid cell edges, a Rankine core edge) it returns the average of
  the two one-sided derivatives.
* ``is_steady`` (no time dependence) and ``is_uniform`` (no space dependence) let callers skip
  work; ``describe()`` returns the parameters as a plain dict that is also a valid config table
  (``current_from_config(f.describe())`` rebuilds the field).
* Fields add: ``f + g`` (and ``sum([f, g, h])``) is a :class:`SumCurrent`.

Direction convention: a current direction is the direction the water flows **toward** ("sets
toward", the oceanographic convention — the opposite of the meteorological "coming from"),
counter-clockwise from east in radians, like headings. A current "setting north" has direction π/2.

Fields
------
:class:`UniformCurrent`, :class:`LinearShear`, :class:`Vortex` (Lamb–Oseen or Rankine eddy,
optionally drifting), :class:`GriddedCurrent` (bilinear on a rectilinear grid, optional time
slices), :class:`TidalCurrent` (sinusoidal reversing tide on top of a base field),
:class:`GaussMarkovCurrent` (seeded, slowly varying uniform current, Fossen 2011 §8.3),
:class:`SumCurrent` (superposition).

TOML schema (``current_from_config``)
-------------------------------------
A scenario's ``[current]`` table; ``type`` selects the field. Numbers may be integers or floats
and must be finite; unknown keys are rejected. Errors are ``ValueError`` naming the field path,
e.g. ``current.components[1].core_radius_m: must be > 0, got -2``.

uniform — constant everywhere; give ``velocity_m_s`` *or* ``speed_m_s`` + ``direction_rad``::

    [current]
    type = "uniform"
    velocity_m_s = [0.3, 0.0]          # east, north [m/s]
    # or: speed_m_s = 0.3  and  direction_rad = 1.5708   (flowing toward north)

shear — ``V(p) = V0 + G·(p − p0)``, ``G[i][j] = ∂V_i/∂x_j`` [1/s] (unbounded: keep the domain
small enough that the speeds stay sensible)::

    [current]
    type = "shear"
    base_velocity_m_s = [0.5, 0.0]     # V0 at origin_m
    gradient_per_s = [[0.0, -0.01], [0.0, 0.0]]   # eastward flow slowing by 1 cm/s per m north
    origin_m = [0.0, 0.0]              # optional, default [0, 0]

vortex — an eddy, tangential speed CCW positive (negative ``max_speed_m_s`` turns clockwise)::

    [current]
    type = "vortex"
    centre_m = [50.0, -20.0]
    core_radius_m = 15.0               # Lamb–Oseen r_c (Gaussian width) / Rankine core radius
    max_speed_m_s = 0.4                # peak tangential speed (at 1.1209 r_c for Lamb–Oseen)
    profile = "lamb_oseen"             # optional: "lamb_oseen" (default) | "rankine"
    drift_m_s = [0.05, 0.0]            # optional: the centre moves as centre_m + drift_m_s·t

grid — bilinear interpolation on a rectilinear grid; ``u_m_s[i][j]`` is the east component at
``(x_m[i], y_m[j])`` (``indexing="ij"``, shape ``(nx, ny)``); with ``times_s`` the arrays gain a
leading time axis ``(nt, nx, ny)`` and are interpolated linearly in time. Outside the grid (and
outside ``times_s``) the field is clamped to the edge value::

    [current]
    type = "grid"
    x_m = [0.0, 100.0, 200.0]
    y_m = [0.0, 100.0]
    u_m_s = [[0.1, 0.2], [0.3, 0.4], [0.5, 0.6]]
    v_m_s = [[0.0, 0.0], [0.0, 0.1], [0.0, 0.2]]
    # times_s = [0.0, 600.0]  with u_m_s, v_m_s shaped [2][3][2]

tidal — ``V(p, t) = V_base(p, t) + A·sin(2πt/T + φ)``, a reversing tide along the axis of ``A``.
The base is either a nested field table ``base`` or a uniform ``mean_velocity_m_s``::

    [current]
    type = "tidal"
    amplitude_m_s = [0.0, 0.5]         # flood toward north at peak, ebb toward south
    period_s = 44714.0                 # M2 tide, 12.42 h
    phase_rad = 0.0                    # optional, default 0
    mean_velocity_m_s = [0.1, 0.0]     # or a nested table:
    # [current.base]
    # type = "shear"  ...

gauss_markov — uniform current ``V(t) = V_mean + x(t)``, each of x's two components an
independent stationary first-order Gauss–Markov process with time constant τ and standard
deviation σ; a deterministic function of (t, seed)::

    [current]
    type = "gauss_markov"
    mean_velocity_m_s = [0.3, 0.1]
    time_constant_s = 300.0            # τ > 0
    sigma_m_s = 0.05                   # σ ≥ 0, per component
    seed = 7                           # int ≥ 0; optional if the scenario has a seed
    step_s = 1.0                       # optional: sample grid Δ, default min(τ/50, 1 s)
    start = "stationary"               # optional: "stationary" (x(0) ~ N(0, σ²)) | "mean" (x(0) = 0)

sum — superposition of components, each a full field table::

    [current]
    type = "sum"
    [[current.components]]
    type = "uniform"
    velocity_m_s = [0.2, 0.0]
    [[current.components]]
    type = "vortex"
    centre_m = [0.0, 0.0]
    core_radius_m = 10.0
    max_speed_m_s = 0.3
"""

from __future__ import annotations

import abc
import math
import zlib
from collections.abc import Callable, Iterable, Mapping
from typing import Any

import numpy as np

from mjasc.core.config_tables import number, show as _show, table as as_table

__all__ = [
    "FD_STEP_S",
    "LAMB_OSEEN_PEAK_RATIO",
    "CurrentField",
    "UniformCurrent",
    "LinearShear",
    "Vortex",
    "GriddedCurrent",
    "TidalCurrent",
    "GaussMarkovCurrent",
    "SumCurrent",
    "current_from_config",
]

FD_STEP_S = 1e-3
"""Step h [s] of the default central finite difference along the body's path (see module doc)."""

_LAMB_OSEEN_ALPHA = 1.2564312086261696
"""(r_peak / r_c)² of the Lamb–Oseen vortex: the root of e^α = 1 + 2α."""

LAMB_OSEEN_PEAK_RATIO = math.sqrt(_LAMB_OSEEN_ALPHA)
"""r_peak / r_c ≈ 1.1209: where a Lamb–Oseen vortex's tangential speed peaks."""

_VORTEX_PROFILES = ("lamb_oseen", "rankine")
_GAUSS_MARKOV_STARTS = ("stationary", "mean")


# ---------------------------------------------------------------------------------------------
# validation helpers (``name`` is a parameter name or a config path); scalars and value display
# come from config_tables; this module keeps its published ASCII ">=" phrasing.


def _finite(value: Any, name: str) -> float:
    return number(value, name)


def _positive(value: Any, name: str) -> float:
    return number(value, name, positive=True)


def _non_negative(value: Any, name: str) -> float:
    v = number(value, name)
    if v < 0.0:
        raise ValueError(f"{name}: must be >= 0, got {_show(value)}")
    return v


def _has_bool(value: Any) -> bool:
    if isinstance(value, (bool, np.bool_)):
        return True
    if isinstance(value, (list, tuple)):
        return any(_has_bool(item) for item in value)
    return False


def _float_array(value: Any, name: str, shape_text: str, ndim: int) -> np.ndarray:
    """A finite float array with ``ndim`` dimensions (from nested lists or an array)."""
    if isinstance(value, (str, bytes, Mapping)) or _has_bool(value):
        raise ValueError(f"{name}: must be {shape_text}, got {_show(value)}")
    try:
        raw = np.asarray(value)
    except ValueError:  # ragged nested lists
        raise ValueError(f"{name}: must be {shape_text}, got a ragged array") from None
    if raw.dtype.kind not in "iuf":
        raise ValueError(f"{name}: must be {shape_text}, got {_show(value)}")
    if raw.ndim != ndim:
        shown = _show(value) if raw.size <= 4 else f"an array of shape {list(raw.shape)}"
        raise ValueError(f"{name}: must be {shape_text}, got {shown}")
    array = raw.astype(float)
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name}: must be finite, got {_show(value)}")
    return array


def _vector2(value: Any, name: str) -> np.ndarray:
    vector = _float_array(value, name, "2 numbers [x, y]", 1)
    if vector.shape != (2,):
        raise ValueError(f"{name}: must be 2 numbers [x, y], got {_show(value)}")
    return vector


def _matrix2(value: Any, name: str) -> np.ndarray:
    matrix = _float_array(value, name, "a 2x2 matrix [[a, b], [c, d]]", 2)
    if matrix.shape != (2, 2):
        raise ValueError(f"{name}: must be a 2x2 matrix [[a, b], [c, d]], got {_show(value)}")
    return matrix


def _increasing(value: Any, name: str, min_length: int) -> np.ndarray:
    axis = _float_array(value, name, f"a list of at least {min_length} increasing numbers", 1)
    if axis.size < min_length or np.any(np.diff(axis) <= 0.0):
        raise ValueError(
            f"{name}: must be at least {min_length} strictly increasing numbers, got {_show(value)}"
        )
    return axis


def _choice(value: Any, name: str, options: tuple[str, ...]) -> str:
    if not isinstance(value, str) or value not in options:
        raise ValueError(f"{name}: must be one of {', '.join(map(repr, options))}, got {_show(value)}")
    return value


def _seed(value: Any, name: str) -> int:
    if not isinstance(value, (int, np.integer)) or isinstance(value, (bool, np.bool_)) or value < 0:
        raise ValueError(f"{name}: must be an integer >= 0, got {_show(value)}")
    return int(value)


def _as_points(points: Any, name: str) -> np.ndarray:
    array = np.asarray(points, dtype=float)
    if array.ndim != 2 or array.shape[1] != 2:
        raise ValueError(f"{name}: must have shape (n, 2), got shape {array.shape}")
    return array


def _points_and_velocities(points_m: Any, velocities_m_s: Any) -> tuple[np.ndarray, np.ndarray]:
    points = _as_points(points_m, "points_m")
    velocities = _as_points(velocities_m_s, "velocities_m_s")
    if velocities.shape != points.shape:
        raise ValueError(
            f"velocities_m_s: must match points_m's shape {points.shape}, got {velocities.shape}"
        )
    return points, velocities


# ---------------------------------------------------------------------------------------------
# the interface


class CurrentField(abc.ABC):
    """A water current over ground, world frame ENU, SI units (see the module docstring)."""

    is_steady: bool
    """True when the field does not depend on time."""
    is_uniform: bool
    """True when the field does not depend on position."""

    @abc.abstractmethod
    def velocity(self, points_m: np.ndarray, t_s: float) -> np.ndarray:
        """Current velocity (n, 2) [m/s] at world points ``points_m`` (n, 2) [m] at time ``t_s``."""

    def acceleration(
        self, points_m: np.ndarray, velocities_m_s: np.ndarray, t_s: float
    ) -> np.ndarray:
        """Material derivative (n, 2) [m/s²] of the current seen by bodies at ``points_m`` moving
        over ground with ``velocities_m_s`` (n, 2): ``∂V/∂t + (∇V)·ṗ``.

        Default: one central finite difference along the path with step ``FD_STEP_S``."""
        points, velocities = _points_and_velocities(points_m, velocities_m_s)
        h = FD_STEP_S
        ahead = self.velocity(points + h * velocities, t_s + h)
        ahead -= self.velocity(points - h * velocities, t_s - h)
        ahead *= 1.0 / (2.0 * h)
        return ahead

    @abc.abstractmethod
    def describe(self) -> dict[str, Any]:
        """Parameters as plain Python values; a valid ``current_from_config`` table."""

    def __add__(self, other: object) -> CurrentField:
        if not isinstance(other, CurrentField):
            return NotImplemented
        return SumCurrent([self, other])

    def __radd__(self, other: object) -> CurrentField:
        if isinstance(other, int) and not isinstance(other, bool) and other == 0:
            return self  # lets sum([f, g]) work
        return NotImplemented

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.describe()})"


# ---------------------------------------------------------------------------------------------
# fields


class UniformCurrent(CurrentField):
    """The same velocity everywhere, always: the hot common case (one fill per call).

    Give ``velocity_m_s = (vx, vy)`` [m/s], or ``speed_m_s`` [m/s] with ``direction_rad``, the
    direction the water flows toward, CCW from east (oceanographic convention)."""

    is_steady = True
    is_uniform = True

    def __init__(
        self,
        velocity_m_s: Any = None,
        *,
        speed_m_s: float | None = None,
        direction_rad: float | None = None,
    ) -> None:
        if velocity_m_s is not None:
            if speed_m_s is not None or direction_rad is not None:
                raise ValueError(
                    "velocity_m_s: give either velocity_m_s or speed_m_s + direction_rad, not both"
                )
            self._velocity = _vector2(velocity_m_s, "velocity_m_s")
        else:
            if speed_m_s is None:
                raise ValueError("velocity_m_s: missing (or give speed_m_s and direction_rad)")
            if direction_rad is None:
                raise ValueError("direction_rad: missing (required with speed_m_s)")
            speed = _non_negative(speed_m_s, "speed_m_s")
            direction = _finite(direction_rad, "direction_rad")
            self._velocity = speed * np.array([math.cos(direction), math.sin(direction)])
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
        points, _ = _points_and_velocities(points_m, velocities_m_s)
        return np.zeros(points.shape)

    def describe(self) -> dict[str, Any]:
        return {"type": "uniform", "velocity_m_s": self._velocity.tolist()}


class LinearShear(CurrentField):
    """``V(p) = V0 + G·(p − p0)``: a steady linear profile, e.g. a river's speed varying across it.

    base_velocity_m_s: (2,) V0 [m/s] at ``origin_m`` p0 (2,) [m].
    gradient_per_s: (2, 2) G with ``G[i, j] = ∂V_i/∂x_j`` [1/s]; e.g. ``[[0, -0.01], [0, 0]]``
    is an eastward flow losing 1 cm/s per metre north. Acceleration: ``G·ṗ`` (exact).
    Unbounded: speeds grow linearly away from p0."""

    is_steady = True
    is_uniform = False

    def __init__(self, base_velocity_m_s: Any, gradient_per_s: Any, origin_m: Any = (0.0, 0.0)):
        self._base = _vector2(base_velocity_m_s, "base_velocity_m_s")
        self._gradient = _matrix2(gradient_per_s, "gradient_per_s")
        self._origin = _vector2(origin_m, "origin_m")
        self._gradient_t = self._gradient.T.copy()
        self.is_uniform = not np.any(self._gradient)

    def velocity(self, points_m: np.ndarray, t_s: float) -> np.ndarray:
        points = _as_points(points_m, "points_m")
        out = (points - self._origin) @ self._gradient_t
        out += self._base
        return out

    def acceleration(self, points_m, velocities_m_s, t_s) -> np.ndarray:
        _, velocities = _points_and_velocities(points_m, velocities_m_s)
        return velocities @ self._gradient_t

    def describe(self) -> dict[str, Any]:
        return {
            "type": "shear",
            "base_velocity_m_s": self._base.tolist(),
            "gradient_per_s": self._gradient.tolist(),
            "origin_m": self._origin.tolist(),
        }


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
        self._centre = _vector2(centre_m, "centre_m")
        self._core = _positive(core_radius_m, "core_radius_m")
        self._vmax = _finite(max_speed_m_s, "max_speed_m_s")
        self._profile = _choice(profile, "profile", _VORTEX_PROFILES)
        self._drift = _vector2(drift_m_s, "drift_m_s")
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
        q = _as_points(points_m, "points_m") - self.centre_at(t_s)
        f = self._f(np.einsum("ij,ij->i", q, q))
        out = np.empty(q.shape)
        out[:, 0] = -f * q[:, 1]
        out[:, 1] = f * q[:, 0]
        return out

    def acceleration(self, points_m, velocities_m_s, t_s) -> np.ndarray:
        points, velocities = _points_and_velocities(points_m, velocities_m_s)
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


def _locate(axis: np.ndarray, coords: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cell index i (so that axis[i] ≤ c ≤ axis[i+1]) and weight w ∈ [0, 1], clamped at the ends."""
    clamped = np.clip(coords, axis[0], axis[-1])
    index = np.searchsorted(axis, clamped, side="right") - 1
    np.clip(index, 0, axis.size - 2, out=index)
    left = axis[index]
    weight = (clamped - left) / (axis[index + 1] - left)
    return index, weight


class GriddedCurrent(CurrentField):
    """Bilinear interpolation of a current sampled on a rectilinear grid, optional time slices.

    x_m (nx,), y_m (ny,): strictly increasing grid lines [m], nx, ny ≥ 2.
    u_m_s, v_m_s: east and north components [m/s], ``u_m_s[i, j]`` at ``(x_m[i], y_m[j])``
    (shape (nx, ny), ``np.meshgrid(x, y, indexing="ij")`` order), or (nt, nx, ny) with
    ``times_s`` (nt,) strictly increasing [s]: linear in time between slices.
    Outside the grid the point is clamped onto it (the edge value continues outward, zero normal
    gradient); before the first / after the last time slice the field holds that slice.
    Exact at the nodes; reproduces any field of the form a + b·x + c·y + d·x·y exactly.
    Acceleration by the default finite difference."""

    is_uniform = False

    def __init__(self, x_m: Any, y_m: Any, u_m_s: Any, v_m_s: Any, times_s: Any = None):
        self._x = _increasing(x_m, "x_m", 2)
        self._y = _increasing(y_m, "y_m", 2)
        if times_s is None:
            self._times = None
            shape: tuple[int, ...] = (self._x.size, self._y.size)
        else:
            self._times = _increasing(times_s, "times_s", 1)
            shape = (self._times.size, self._x.size, self._y.size)
        components = []
        for name, value in (("u_m_s", u_m_s), ("v_m_s", v_m_s)):
            array = _float_array(value, name, f"an array of shape {list(shape)}", len(shape))
            if array.shape != shape:
                raise ValueError(f"{name}: must have shape {list(shape)}, got {list(array.shape)}")
            components.append(array if self._times is not None else array[None])
        self._field = np.stack(components, axis=-1)  # (nt, nx, ny, 2)
        self.is_steady = self._field.shape[0] == 1

    def _bilinear(self, slice_index: int, ix, iy, wx, wy) -> np.ndarray:
        # (1 − w)·a + w·b form: exact at w = 0 and w = 1, hence exact at every node
        grid = self._field[slice_index]
        wx = wx[:, None]
        wy = wy[:, None]
        low = (1.0 - wx) * grid[ix, iy] + wx * grid[ix + 1, iy]
        high = (1.0 - wx) * grid[ix, iy + 1] + wx * grid[ix + 1, iy + 1]
        return (1.0 - wy) * low + wy * high

    def velocity(self, points_m: np.ndarray, t_s: float) -> np.ndarray:
        points = _as_points(points_m, "points_m")
        ix, wx = _locate(self._x, points[:, 0])
        iy, wy = _locate(self._y, points[:, 1])
        if self._field.shape[0] == 1:
            return self._bilinear(0, ix, iy, wx, wy)
        (k,), (wt,) = _locate(self._times, np.array([float(t_s)]))
        out = self._bilinear(k, ix, iy, wx, wy)
        if wt > 0.0:
            out *= 1.0 - wt
            out += wt * self._bilinear(k + 1, ix, iy, wx, wy)
        return out

    def describe(self) -> dict[str, Any]:
        table: dict[str, Any] = {
            "type": "grid",
            "x_m": self._x.tolist(),
            "y_m": self._y.tolist(),
        }
        field = self._field if self._times is not None else self._field[0]
        table["u_m_s"] = field[..., 0].tolist()
        table["v_m_s"] = field[..., 1].tolist()
        if self._times is not None:
            table["times_s"] = self._times.tolist()
        return table


class TidalCurrent(CurrentField):
    """A reversing tide: ``V(p, t) = V_base(p, t) + A·sin(2πt/T + φ)``.

    base: any field, or a (2,) velocity [m/s] for a uniform mean current.
    amplitude_m_s: (2,) A [m/s], the peak flood velocity (its axis is the tide's axis; the ebb
    flows the opposite way). period_s: T > 0 [s] (M2: 44 714 s). phase_rad: φ [rad].
    Acceleration: base's + ``A·(2π/T)·cos(2πt/T + φ)`` (exact)."""

    is_steady = False

    def __init__(
        self, base: CurrentField | Any, amplitude_m_s: Any, period_s: float, phase_rad: float = 0.0
    ) -> None:
        self._base = base if isinstance(base, CurrentField) else UniformCurrent(base)
        self._amplitude = _vector2(amplitude_m_s, "amplitude_m_s")
        self._period = _positive(period_s, "period_s")
        self._phase = _finite(phase_rad, "phase_rad")
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


class GaussMarkovCurrent(CurrentField):
    """A slowly varying uniform current: ``V(t) = V_mean + x(t)`` (Fossen 2011, §8.3: the
    first-order Gauss–Markov model ``ẋ + x/τ = w`` of current speed, here for both components).

    Each component of x is an independent stationary Gauss–Markov (Ornstein–Uhlenbeck) process
    with time constant τ [s] and standard deviation σ [m/s] (autocorrelation σ²·e^{−|Δt|/τ}). It
    is sampled on the fixed grid t_k = k·Δ by the exact discretization
    ``x_{k+1} = e^{−Δ/τ} x_k + σ·√(1 − e^{−2Δ/τ}) w_k``, w_k ~ N(0, 1) drawn from
    ``numpy.random.default_rng(seed)`` in fixed blocks of ``BLOCK_STEPS`` steps, extended lazily
    as later times are asked for, and interpolated linearly between samples. So V is a pure
    function of (t, seed, parameters): the same whatever was queried before or in which order.
    The realisation depends on (seed, Δ): ``describe()`` records both. Linear interpolation
    lowers the variance between samples by at most (1 − e^{−Δ/τ})/2 (1 % at the default
    Δ = min(τ/50, 1 s)). Times before 0 hold x(0).

    start: "stationary" draws x(0) ~ N(0, σ²) (default); "mean" starts at x(0) = 0.
    Acceleration: the slope of the interpolant (exact for it; uniform, so no spatial term)."""

    is_steady = False
    is_uniform = True
    BLOCK_STEPS = 1024

    def __init__(
        self,
        mean_velocity_m_s: Any,
        time_constant_s: float,
        sigma_m_s: float,
        seed: int,
        step_s: float | None = None,
        start: str = "stationary",
    ) -> None:
        self._mean = _vector2(mean_velocity_m_s, "mean_velocity_m_s")
        self._tau = _positive(time_constant_s, "time_constant_s")
        self._sigma = _non_negative(sigma_m_s, "sigma_m_s")
        self._seed = _seed(seed, "seed")
        self._step = (
            min(self._tau / 50.0, 1.0) if step_s is None else _positive(step_s, "step_s")
        )
        self._start = _choice(start, "start", _GAUSS_MARKOV_STARTS)
        self._a = math.exp(-self._step / self._tau)
        self._b = self._sigma * math.sqrt(-math.expm1(-2.0 * self._step / self._tau))
        self._rng = np.random.default_rng(self._seed)
        first = self._rng.standard_normal(2)
        self._samples = np.empty((self.BLOCK_STEPS + 1, 2))
        self._samples[0] = first * (self._sigma if self._start == "stationary" else 0.0)
        self._count = 1
        self._cached_t = math.nan
        self._cached_v = self._mean.copy()

    def _ensure(self, index: int) -> None:
        """Make sure samples x_0 … x_index exist (block by block, same stream whatever index)."""
        from scipy.signal import lfilter  # lazy: scipy.signal takes ~0.6 s to import

        while self._count <= index:
            noise = self._rng.standard_normal((self.BLOCK_STEPS, 2))
            previous = self._samples[self._count - 1]
            block, _ = lfilter(
                [self._b], [1.0, -self._a], noise, axis=0, zi=(self._a * previous)[None, :]
            )
            end = self._count + self.BLOCK_STEPS
            if end > len(self._samples):
                grown = np.empty((max(end, 2 * len(self._samples)), 2))
                grown[: self._count] = self._samples[: self._count]
                self._samples = grown
            self._samples[self._count : end] = block
            self._count = end

    def _segment(self, t_s: float) -> tuple[int, float]:
        if not t_s > 0.0:  # also catches NaN → hold x(0)
            self._ensure(1)
            return 0, 0.0
        u = t_s / self._step
        k = int(u)
        self._ensure(k + 1)
        return k, u - k

    def _value(self, t_s: float) -> np.ndarray:
        if t_s != self._cached_t:
            k, w = self._segment(t_s)
            x0 = self._samples[k]
            self._cached_v = self._mean + x0 + w * (self._samples[k + 1] - x0)
            self._cached_t = t_s
        return self._cached_v

    def velocity_at_times(self, times_s: Any) -> np.ndarray:
        """(m, 2) current velocities [m/s] at times ``times_s`` (m,) — for plots and analysis."""
        times = np.atleast_1d(np.asarray(times_s, dtype=float))
        u = np.where(times > 0.0, times, 0.0) / self._step
        k = np.floor(u).astype(np.int64)
        if k.size:
            self._ensure(int(k.max()) + 1)
        w = (u - k)[:, None]
        x0 = self._samples[k]
        return self._mean + x0 + w * (self._samples[k + 1] - x0)

    def velocity(self, points_m: np.ndarray, t_s: float) -> np.ndarray:
        points = np.asarray(points_m, dtype=float)
        if points.ndim != 2 or points.shape[1] != 2:
            raise ValueError(f"points_m: must have shape (n, 2), got shape {points.shape}")
        out = np.empty(points.shape)
        out[:] = self._value(float(t_s))
        return out

    def acceleration(self, points_m, velocities_m_s, t_s) -> np.ndarray:
        points, _ = _points_and_velocities(points_m, velocities_m_s)
        out = np.empty(points.shape)
        if not t_s >= 0.0:  # before the start x(t) is held: no rate
            out[:] = 0.0
            return out
        k, _ = self._segment(float(t_s))  # at a sample time: the slope of the segment after it
        out[:] = (self._samples[k + 1] - self._samples[k]) / self._step
        return out

    def describe(self) -> dict[str, Any]:
        return {
            "type": "gauss_markov",
            "mean_velocity_m_s": self._mean.tolist(),
            "time_constant_s": self._tau,
            "sigma_m_s": self._sigma,
            "seed": self._seed,
            "step_s": self._step,
            "start": self._start,
        }


class SumCurrent(CurrentField):
    """Superposition ``V = Σ V_i`` (and ``a = Σ a_i``) of fields; nested sums are flattened."""

    def __init__(self, fields: Iterable[CurrentField]) -> None:
        flat: list[CurrentField] = []
        for i, field in enumerate(fields):
            if isinstance(field, SumCurrent):
                flat.extend(field.fields)
            elif isinstance(field, CurrentField):
                flat.append(field)
            else:
                raise ValueError(f"fields[{i}]: must be a CurrentField, got {_show(field)}")
        if not flat:
            raise ValueError("fields: must contain at least one field")
        self._fields = tuple(flat)
        self.is_steady = all(f.is_steady for f in flat)
        self.is_uniform = all(f.is_uniform for f in flat)

    @property
    def fields(self) -> tuple[CurrentField, ...]:
        return self._fields

    def velocity(self, points_m: np.ndarray, t_s: float) -> np.ndarray:
        points = _as_points(points_m, "points_m")
        out = self._fields[0].velocity(points, t_s)
        for field in self._fields[1:]:
            out += field.velocity(points, t_s)
        return out

    def acceleration(self, points_m, velocities_m_s, t_s) -> np.ndarray:
        points, velocities = _points_and_velocities(points_m, velocities_m_s)
        out = self._fields[0].acceleration(points, velocities, t_s)
        for field in self._fields[1:]:
            out += field.acceleration(points, velocities, t_s)
        return out

    def describe(self) -> dict[str, Any]:
        return {"type": "sum", "components": [f.describe() for f in self._fields]}


# ---------------------------------------------------------------------------------------------
# configuration


class _Table:
    """A config table being read: typed getters whose errors name the full path."""

    def __init__(self, table: Mapping[str, Any], path: str) -> None:
        self.table = table
        self.path = path

    def name(self, key: str) -> str:
        return f"{self.path}.{key}"

    def has(self, key: str) -> bool:
        return key in self.table

    def get(self, key: str, convert: Callable[[Any, str], Any], default: Any = ...) -> Any:
        if key not in self.table:
            if default is ...:
                raise ValueError(f"{self.name(key)}: missing")
            return default
        return convert(self.table[key], self.name(key))


def _uniform_config(t: _Table, scenario_seed: int | None) -> CurrentField:
    if t.has("velocity_m_s"):
        for other in ("speed_m_s", "direction_rad"):
            if t.has(other):
                raise ValueError(
                    f"{t.name(other)}: give either velocity_m_s or speed_m_s + direction_rad"
                )
        return UniformCurrent(t.get("velocity_m_s", _vector2))
    if not t.has("speed_m_s"):
        raise ValueError(f"{t.name('velocity_m_s')}: missing (or give speed_m_s and direction_rad)")
    speed = t.get("speed_m_s", _non_negative)
    if not t.has("direction_rad"):
        raise ValueError(f"{t.name('direction_rad')}: missing (required with speed_m_s)")
    return UniformCurrent(speed_m_s=speed, direction_rad=t.get("direction_rad", _finite))


def _shear_config(t: _Table, scenario_seed: int | None) -> CurrentField:
    return LinearShear(
        t.get("base_velocity_m_s", _vector2),
        t.get("gradient_per_s", _matrix2),
        t.get("origin_m", _vector2, (0.0, 0.0)),
    )


def _vortex_config(t: _Table, scenario_seed: int | None) -> CurrentField:
    return Vortex(
        centre_m=t.get("centre_m", _vector2),
        core_radius_m=t.get("core_radius_m", _positive),
        max_speed_m_s=t.get("max_speed_m_s", _finite),
        profile=t.get("profile", lambda v, n: _choice(v, n, _VORTEX_PROFILES), "lamb_oseen"),
        drift_m_s=t.get("drift_m_s", _vector2, (0.0, 0.0)),
    )


def _grid_config(t: _Table, scenario_seed: int | None) -> CurrentField:
    x = t.get("x_m", lambda v, n: _increasing(v, n, 2))
    y = t.get("y_m", lambda v, n: _increasing(v, n, 2))
    times = t.get("times_s", lambda v, n: _increasing(v, n, 1), None)
    shape = (len(x), len(y)) if times is None else (len(times), len(x), len(y))

    def component(value: Any, name: str) -> np.ndarray:
        array = _float_array(value, name, f"an array of shape {list(shape)}", len(shape))
        if array.shape != shape:
            raise ValueError(f"{name}: must have shape {list(shape)}, got {list(array.shape)}")
        return array

    return GriddedCurrent(x, y, t.get("u_m_s", component), t.get("v_m_s", component), times)


def _tidal_config(t: _Table, scenario_seed: int | None) -> CurrentField:
    if t.has("base") and t.has("mean_velocity_m_s"):
        raise ValueError(f"{t.name('mean_velocity_m_s')}: give either base or mean_velocity_m_s")
    if t.has("base"):
        base = t.get("base", lambda v, n: current_from_config(v, path=n, seed=scenario_seed))
    else:
        base = UniformCurrent(t.get("mean_velocity_m_s", _vector2, (0.0, 0.0)))
    return TidalCurrent(
        base,
        t.get("amplitude_m_s", _vector2),
        t.get("period_s", _positive),
        t.get("phase_rad", _finite, 0.0),
    )


def _gauss_markov_config(t: _Table, scenario_seed: int | None) -> CurrentField:
    mean = t.get("mean_velocity_m_s", _vector2)
    tau = t.get("time_constant_s", _positive)
    sigma = t.get("sigma_m_s", _non_negative)
    if t.has("seed") or scenario_seed is None:
        seed = t.get("seed", _seed)
    else:  # distinct per table path, so two components never share one noise sequence
        _seed(scenario_seed, "seed")
        sequence = np.random.SeedSequence([scenario_seed, zlib.crc32(t.path.encode())])
        seed = int(sequence.generate_state(1, dtype=np.uint32)[0])
    return GaussMarkovCurrent(
        mean,
        tau,
        sigma,
        seed,
        t.get("step_s", _positive, None),
        t.get("start", lambda v, n: _choice(v, n, _GAUSS_MARKOV_STARTS), "stationary"),
    )


def _components(value: Any, name: str, scenario_seed: int | None) -> list[CurrentField]:
    if not isinstance(value, (list, tuple)):
        raise ValueError(f"{name}: must be a list of tables ([[...components]]), got {_show(value)}")
    if not value:
        raise ValueError(f"{name}: must contain at least one component")
    return [
        current_from_config(item, path=f"{name}[{i}]", seed=scenario_seed)
        for i, item in enumerate(value)
    ]


def _sum_config(t: _Table, scenario_seed: int | None) -> CurrentField:
    return SumCurrent(t.get("components", lambda v, n: _components(v, n, scenario_seed)))


_BUILDERS: dict[str, tuple[Callable[[_Table, int | None], CurrentField], tuple[str, ...]]] = {
    "uniform": (_uniform_config, ("velocity_m_s", "speed_m_s", "direction_rad")),
    "shear": (_shear_config, ("base_velocity_m_s", "gradient_per_s", "origin_m")),
    "vortex": (
        _vortex_config,
        ("centre_m", "core_radius_m", "max_speed_m_s", "profile", "drift_m_s"),
    ),
    "grid": (_grid_config, ("x_m", "y_m", "u_m_s", "v_m_s", "times_s")),
    "tidal": (
        _tidal_config,
        ("base", "mean_velocity_m_s", "amplitude_m_s", "period_s", "phase_rad"),
    ),
    "gauss_markov": (
        _gauss_markov_config,
        ("mean_velocity_m_s", "time_constant_s", "sigma_m_s", "seed", "step_s", "start"),
    ),
    "sum": (_sum_config, ("components",)),
}


def current_from_config(
    table: Mapping[str, Any], *, path: str = "current", seed: int | None = None
) -> CurrentField:
    """Build a field from a scenario's ``[current]`` TOML table (schema in the module docstring).

    path: the table's location, used in error messages (``current.components[1].core_radius_m``).
    seed: the scenario's seed. A ``gauss_markov`` table without its own ``seed`` gets one derived
    from (seed, its path) — reproducible, and distinct for each component; ``describe()`` shows
    it. Without ``seed``, such a table must give its own.
    Raises ValueError naming the offending field path and the reason; unknown keys are errors."""
    as_table(table, path)
    if "type" not in table:
        raise ValueError(f"{path}.type: missing (one of: {', '.join(_BUILDERS)})")
    kind = table["type"]
    if not isinstance(kind, str) or kind not in _BUILDERS:
        raise ValueError(
            f"{path}.type: unknown current type {_show(kind)} (one of: {', '.join(_BUILDERS)})"
        )
    build, keys = _BUILDERS[kind]
    for key in table:
        if key != "type" and key not in keys:
            raise ValueError(
                f"{path}.{key}: unknown key for type {kind!r} (expected: {', '.join(keys)})"
            )
    return build(_Table(table, path), seed)
