"""The current-field interface: :class:`CurrentField`, the sum of fields, and the call checks.

A field maps world-frame points ``(n, 2)`` [m] (ENU) and a time ``t_s`` [s] to world-frame current
velocities ``(n, 2)`` [m/s] and gives the material derivative ``a_c = ∂V/∂t + (∇V)·ṗ`` [m/s²] seen
by bodies moving over ground with ``ṗ`` (the contract is in :mod:`mjasc.physics.currents`). The
default derivative is one central finite difference along the body's path with step
:data:`FD_STEP_S`; fields with a closed form override it.

:class:`SumCurrent` is the superposition ``V = Σ V_i`` that ``f + g`` and ``sum([f, g])`` build.
:func:`read_parameters` reads a field constructor's arguments through its parameter dataclass (the
same declaration that reads the ``[current]`` table), so both name the bad parameter the same way.
"""

from __future__ import annotations

import abc
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from mjasc.core.config_tables import ConfigError, dataclass_from_table, param, show

__all__ = ["FD_STEP_S", "CurrentField", "SumCurrent", "SumConfig", "as_points", "points_and_velocities",
           "read_parameters"]

FD_STEP_S = 1e-3
"""Step h [s] of the default central finite difference along the body's path (see module doc)."""


def as_points(points: Any, name: str) -> np.ndarray:
    """``points`` as a float array of shape (n, 2), else ValueError naming ``name``."""
    array = np.asarray(points, dtype=float)
    if array.ndim != 2 or array.shape[1] != 2:
        raise ValueError(f"{name}: must have shape (n, 2), got shape {array.shape}")
    return array


def points_and_velocities(points_m: Any, velocities_m_s: Any) -> tuple[np.ndarray, np.ndarray]:
    """Both arguments of :meth:`CurrentField.acceleration` as (n, 2) float arrays of one shape."""
    points = as_points(points_m, "points_m")
    velocities = as_points(velocities_m_s, "velocities_m_s")
    if velocities.shape != points.shape:
        raise ValueError(
            f"velocities_m_s: must match points_m's shape {points.shape}, got {velocities.shape}"
        )
    return points, velocities


def read_parameters(config_type: type, where: str, **values: Any) -> Any:
    """A field constructor's arguments read into its parameter dataclass ``config_type``, exactly
    as the ``[current]`` table is read (:func:`~mjasc.core.config_tables.dataclass_from_table`);
    an argument given as None is "not given" (its declared default). Errors name ``where.<name>``."""
    check = getattr(config_type, "check", None)
    return dataclass_from_table(config_type, {k: v for k, v in values.items() if v is not None}, where,
                                check=check)


class CurrentField(abc.ABC):
    """A water current over ground, world frame ENU, SI units (see the package docstring)."""

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
        points, velocities = points_and_velocities(points_m, velocities_m_s)
        h = FD_STEP_S
        ahead = self.velocity(points + h * velocities, t_s + h)
        ahead -= self.velocity(points - h * velocities, t_s - h)
        ahead *= 1.0 / (2.0 * h)
        return ahead

    @classmethod
    def from_config(cls, config: Any) -> CurrentField:
        """The field of a parameter dataclass already read (what ``current_from_config`` builds)."""
        field = cls.__new__(cls)
        field._setup(config)
        return field

    def _setup(self, config: Any) -> None:
        """Set the field up from its read parameter dataclass (the constructors' common part)."""
        raise NotImplementedError

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


@dataclass(frozen=True)
class SumConfig:
    """The ``[current]`` table of ``type = "sum"``: the fields it adds."""

    components: tuple = param(doc="the fields added up, each a full [current] table ([[current.components]])")


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
                raise ConfigError(f"fields[{i}]: must be a CurrentField, got {show(field)}")
        if not flat:
            raise ConfigError("fields: must contain at least one field")
        self._fields = tuple(flat)
        self.is_steady = all(f.is_steady for f in flat)
        self.is_uniform = all(f.is_uniform for f in flat)

    @classmethod
    def from_config(cls, config: SumConfig) -> SumCurrent:
        return cls(config.components)

    @property
    def fields(self) -> tuple[CurrentField, ...]:
        return self._fields

    def velocity(self, points_m: np.ndarray, t_s: float) -> np.ndarray:
        points = as_points(points_m, "points_m")
        out = self._fields[0].velocity(points, t_s)
        for field in self._fields[1:]:
            out += field.velocity(points, t_s)
        return out

    def acceleration(self, points_m, velocities_m_s, t_s) -> np.ndarray:
        points, velocities = points_and_velocities(points_m, velocities_m_s)
        out = self._fields[0].acceleration(points, velocities, t_s)
        for field in self._fields[1:]:
            out += field.acceleration(points, velocities, t_s)
        return out

    def describe(self) -> dict[str, Any]:
        return {"type": "sum", "components": [f.describe() for f in self._fields]}
