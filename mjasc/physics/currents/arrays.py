"""Readers of the currents' array parameters: vectors, 2×2 gradients, grid axes and grid values.

Each is a :mod:`mjasc.core.config_tables` converter ``reader(value, where) -> array``: it accepts
nested lists (a TOML array) or a numpy array of finite reals (no bools), returns a new float array
and otherwise raises :class:`~mjasc.core.config_tables.ConfigError` naming ``where``, the reason
and the value (``current.drift_m_s: must be 2 numbers [x, y], got [0, 0, 0]``). The current fields
declare them as the ``reader`` of their :func:`~mjasc.core.config_tables.param` fields.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, Callable

import numpy as np

from mjasc.core.config_tables import ConfigError, show

__all__ = ["float_array", "vector2", "matrix2", "increasing", "grid_values"]


def _has_bool(value: Any) -> bool:
    if isinstance(value, (bool, np.bool_)):
        return True
    if isinstance(value, (list, tuple)):
        return any(_has_bool(item) for item in value)
    return False


def float_array(value: Any, where: str, shape_text: str, ndim: int) -> np.ndarray:
    """A finite float array with ``ndim`` dimensions (from nested lists or an array); the error
    says it ``must be <shape_text>``."""
    if isinstance(value, (str, bytes, Mapping)) or _has_bool(value):
        raise ConfigError(f"{where}: must be {shape_text}, got {show(value)}")
    try:
        raw = np.asarray(value)
    except ValueError:  # ragged nested lists
        raise ConfigError(f"{where}: must be {shape_text}, got a ragged array") from None
    if raw.dtype.kind not in "iuf":
        raise ConfigError(f"{where}: must be {shape_text}, got {show(value)}")
    if raw.ndim != ndim:
        shown = show(value) if raw.size <= 4 else f"an array of shape {list(raw.shape)}"
        raise ConfigError(f"{where}: must be {shape_text}, got {shown}")
    array = raw.astype(float)
    if not np.all(np.isfinite(array)):
        raise ConfigError(f"{where}: must be finite, got {show(value)}")
    return array


def vector2(value: Any, where: str) -> np.ndarray:
    """A planar vector ``[x, y]`` → (2,) float array."""
    vector = float_array(value, where, "2 numbers [x, y]", 1)
    if vector.shape != (2,):
        raise ConfigError(f"{where}: must be 2 numbers [x, y], got {show(value)}")
    return vector


def matrix2(value: Any, where: str) -> np.ndarray:
    """A 2×2 matrix ``[[a, b], [c, d]]`` → (2, 2) float array."""
    matrix = float_array(value, where, "a 2x2 matrix [[a, b], [c, d]]", 2)
    if matrix.shape != (2, 2):
        raise ConfigError(f"{where}: must be a 2x2 matrix [[a, b], [c, d]], got {show(value)}")
    return matrix


def increasing(min_length: int) -> Callable[[Any, str], np.ndarray]:
    """Reader of a grid axis: at least ``min_length`` strictly increasing numbers → (n,) array."""

    def read(value: Any, where: str) -> np.ndarray:
        axis = float_array(value, where, f"a list of at least {min_length} increasing numbers", 1)
        if axis.size < min_length or np.any(np.diff(axis) <= 0.0):
            raise ConfigError(
                f"{where}: must be at least {min_length} strictly increasing numbers, got {show(value)}"
            )
        return axis

    return read


def grid_values(value: Any, where: str, shape: tuple[int, ...]) -> np.ndarray:
    """Values sampled on a grid: a float array of exactly ``shape`` (known once the axes are read)."""
    array = float_array(value, where, f"an array of shape {list(shape)}", len(shape))
    if array.shape != shape:
        raise ConfigError(f"{where}: must have shape {list(shape)}, got {list(array.shape)}")
    return array
