"""Reading one config value: the checked readers every TOML table of a scenario goes through.

Each reader takes the raw value and ``where``, the value's path in the scenario file
(``vessels[1].sensor.beams``), and returns the checked value or raises :class:`ConfigError` (a
ValueError) whose message names the path and the reason, then shows the value::

    vessels[1].sensor.beams: must be an integer, got 3.5

numpy scalars count as numbers and integers (arrays do not), so the same readers also check values
a program passes to a config class directly. Whole tables and declared parameters are
:mod:`mjasc.core.config_tables`, which re-exports everything here.
"""

from __future__ import annotations

import math
import typing
from contextlib import contextmanager
from typing import Any, Callable, Iterable, Iterator, Mapping

import numpy as np

__all__ = ["Converter", "ConfigError", "show", "table", "check_keys", "number", "integer", "boolean", "string",
           "point", "points", "within", "errors_as"]

Converter = Callable[[Any, str], Any]
"""A reader of one value: ``converter(value, where) -> checked value`` (raises ConfigError)."""


class ConfigError(ValueError):
    """A config value is invalid; the message is ``"<where>: <reason>, got <value>"``."""


def show(value: Any) -> str:
    """A value as an error message shows it: numbers plainly (numpy scalars too), arrays by shape,
    anything else by ``repr`` cut to 80 characters."""
    if isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_)):
        return str(value)
    if isinstance(value, np.ndarray):
        return f"an array of shape {list(value.shape)}"
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


def _fail(where: str, reason: str, value: Any) -> typing.NoReturn:
    raise ConfigError(f"{where}: {reason}, got {show(value)}")


# ---------------------------------------------------------------------------------------------- tables
def table(value: Any, where: str) -> dict:
    """``value`` itself if it is a table (a mapping), else ConfigError ``"<where>: must be a table"``."""
    if not isinstance(value, Mapping):
        _fail(where, "must be a table", value)
    return value


def check_keys(tbl: Mapping, allowed: Iterable[str], where: str) -> None:
    """Reject the first (alphabetically) key of ``tbl`` not in ``allowed``:
    ``"<where>.<key>: unknown field (allowed: a, b, c)"``."""
    allowed = set(allowed)
    unknown = sorted(set(tbl) - allowed)
    if unknown:
        raise ConfigError(f"{where}.{unknown[0]}: unknown field (allowed: {', '.join(sorted(allowed))})")


# ---------------------------------------------------------------------------------------------- scalars
def _is_real(value: Any) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))


def number(value: Any, where: str, *, positive: bool = False, nonneg: bool = False,
           minimum: float | None = None, maximum: float | None = None) -> float:
    """A finite real number as a float. Bounds: ``positive`` → > 0, ``nonneg`` → ≥ 0,
    ``minimum`` → ≥ minimum, ``maximum`` → ≤ maximum (checked in that order)."""
    if not _is_real(value):
        _fail(where, "must be a number", value)
    v = float(value)
    if not math.isfinite(v):
        _fail(where, "must be finite", value)
    if positive and not v > 0:
        _fail(where, "must be > 0", value)
    if nonneg and v < 0:
        _fail(where, "must be ≥ 0", value)
    if minimum is not None and v < minimum:
        _fail(where, f"must be ≥ {minimum}", value)
    if maximum is not None and v > maximum:
        _fail(where, f"must be ≤ {maximum}", value)
    return v


def integer(value: Any, where: str, *, minimum: int | None = None, maximum: int | None = None) -> int:
    """An integer (an int or numpy integer; not a bool, not a float such as 3.0) as an int."""
    if not isinstance(value, (int, np.integer)) or isinstance(value, (bool, np.bool_)):
        _fail(where, "must be an integer", value)
    if minimum is not None and value < minimum:
        _fail(where, f"must be ≥ {minimum}", value)
    if maximum is not None and value > maximum:
        _fail(where, f"must be ≤ {maximum}", value)
    return int(value)


def boolean(value: Any, where: str) -> bool:
    """``true`` or ``false`` (a bool; 0 and 1 are not accepted)."""
    if not isinstance(value, (bool, np.bool_)):
        _fail(where, "must be true or false", value)
    return bool(value)


def string(value: Any, where: str, *, choices: Iterable[str] | None = None) -> str:
    """A non-empty string; with ``choices``, one of them (``"must be one of a, b"``, sorted)."""
    if not isinstance(value, str) or not value:
        _fail(where, "must be a non-empty string", value)
    if choices is not None:
        choices = set(choices)
        if value not in choices:
            _fail(where, f"must be one of {', '.join(sorted(choices))}", value)
    return value


# ---------------------------------------------------------------------------------------------- geometry
def point(value: Any, where: str) -> np.ndarray:
    """A point ``[x, y]`` [m] → (2,) float array; each coordinate read by :func:`number`."""
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        _fail(where, "must be a point [x, y] in metres", value)
    return np.array([number(value[0], f"{where}[0]"), number(value[1], f"{where}[1]")])


def points(value: Any, where: str, minimum: int, limit: float | None = None) -> np.ndarray:
    """A list of at least ``minimum`` points ``[[x, y], ...]`` → (n, 2) float array; point k's
    errors name ``where[k]``; with ``limit``, every coordinate within ±limit (:func:`within`)."""
    if not isinstance(value, list) or len(value) < minimum:
        _fail(where, f"must be a list of at least {minimum} points [x, y]", value)
    out = np.array([point(p, f"{where}[{i}]") for i, p in enumerate(value)]).reshape(-1, 2)
    if limit is not None:
        for i, p in enumerate(out):
            within(p, f"{where}[{i}]", -limit, limit)
    return out


def within(values: np.ndarray, where: str, minimum: float | None, maximum: float | None) -> np.ndarray:
    """Every element of an array within [minimum, maximum]; the error names the element,
    ``"<where>[k]: must be ≤ 1000000.0, got 1e+300"``."""
    for k, v in enumerate(np.ravel(values)):
        if minimum is not None and v < minimum:
            _fail(f"{where}[{k}]", f"must be ≥ {minimum}", float(v))
        if maximum is not None and v > maximum:
            _fail(f"{where}[{k}]", f"must be ≤ {maximum}", float(v))
    return values


# ---------------------------------------------------------------------------------------------- boundaries
@contextmanager
def errors_as(error: type[ValueError]) -> Iterator[None]:
    """Inside the block, a :class:`ConfigError` that is not already an ``error`` is re-raised as
    ``error(same message)`` (a module's own exception type at its public boundary)."""
    try:
        yield
    except ConfigError as exc:
        if isinstance(exc, error):
            raise
        raise error(str(exc)) from None
