"""Validated config tables: the one way mjasc turns a scenario's TOML tables into checked, typed values.

Every reader takes the raw value and ``where``, the value's path in the scenario file
(``vessels[1].sensor.beams``), and returns the checked value or raises :class:`ConfigError` (a
ValueError) whose message names the path and the reason, then shows the value::

    vessels[1].sensor.beams: must be an integer, got 3.5

Readers (``where`` is always the second argument; the readers of one value are
:mod:`mjasc.core.config_values`, re-exported here):

* :func:`load_toml` — a TOML file → its top-level table (a missing, unreadable, non-UTF-8 or badly
  named file, or bad TOML, is one error naming the file: :mod:`mjasc.core.input_files`);
* :func:`table` — a TOML table (a dict); :func:`check_keys` — no key outside ``allowed``;
* :func:`number` — a finite real (bools are not numbers; ints become floats), with optional
  bounds ``positive`` (> 0), ``nonneg`` (≥ 0), ``minimum`` (≥), ``maximum`` (≤);
* :func:`integer` — an int (not a bool, not 3.0), optional ``minimum`` / ``maximum``;
* :func:`boolean` — ``true`` / ``false`` only; :func:`string` — a non-empty string, optional ``choices``;
* :func:`point` — ``[x, y]`` → (2,) float array [m]; :func:`points` — ``[[x, y], ...]`` → (n, 2);
  :func:`within` — every element of an array within bounds (an array field's ``minimum`` / ``maximum``);
* :func:`dataclass_from_table` — a whole table → a frozen dataclass, each key read by the reader
  of its field's type (float, int, bool, str, ``X | None``, ``tuple[X, ...]``) or a given converter,
  unknown keys rejected, missing keys left at the dataclass's defaults;
* :func:`read_field` — one key of a table read as one declared field of a dataclass (for tables
  whose keys map onto several objects, or are spelled differently from the field).

**Parameters are declared once.** A config dataclass declares each field with :func:`param`: its
default, its bounds (``positive``, ``nonneg``, ``minimum``, ``maximum``, ``choices``), its unit and
its doc, in the field's metadata. From that one declaration :func:`check_params` validates an
instance (the class's ``__post_init__`` calls it), :func:`dataclass_from_table` reads a TOML table
(the same bounds, the error naming the table path) and :func:`describe_params` lists the
parameters for the docs. A field whose type is itself a config dataclass nests it: its own table,
or with ``flatten=True`` its fields read from the parent table (``[vessels.avoidance]`` holds the
prediction fields too)::

    @dataclass(frozen=True)
    class Example:
        gain: float = param(0.3, positive=True, unit="1/s", doc="virtual-target gain k")

        def __post_init__(self):
            check_params(self, "example")

numpy scalars count as numbers and integers (arrays do not), so the same readers also check
values a program passes to a config class directly (``__post_init__`` validators).

:class:`ConfigError` is what the readers raise; :func:`errors_as` re-raises it as a caller's own
ValueError subclass at a module boundary (``scenario.ScenarioError``).
"""

from __future__ import annotations

import dataclasses
import functools
import types
import typing
from typing import Any, Callable, Iterable, Mapping

import numpy as np

from mjasc.core.config_values import (  # noqa: F401 - the readers are re-exported
    ConfigError, Converter, _fail, _is_real, boolean, check_keys, errors_as, integer, number, point, points, show,
    string, table, within)
from mjasc.core.input_files import load_toml, one_line, path_problem, show_path

__all__ = ["ConfigError", "show", "load_toml", "path_problem", "show_path", "one_line", "table", "check_keys",
           "number", "integer", "boolean", "string", "point",
           "points", "within", "dataclass_from_table", "read_field", "errors_as", "Param", "param", "check_params",
           "describe_params"]

# ---------------------------------------------------------------------------------------------- dataclasses
@dataclasses.dataclass(frozen=True)
class Param:
    """The declaration of one config parameter (stored in its dataclass field's metadata).

    doc: what it is; unit: SI unit ("" for none); positive (> 0), nonneg (≥ 0), minimum (≥),
    maximum (≤): bounds of a number (``X | None`` fields accept None as "not set"); choices: the
    allowed strings; reader: a converter for the TOML value when the type's reader does not fit
    (e.g. ``"dynamic"`` → None); flatten: a nested config dataclass read from the parent table;
    phrase: the wording of a bound violation, when it must differ from the default
    (``"must be finite and > 0"``).
    """

    doc: str
    unit: str = ""
    positive: bool = False
    nonneg: bool = False
    minimum: float | None = None
    maximum: float | None = None
    choices: tuple[str, ...] | None = None
    reader: Converter | None = None
    flatten: bool = False
    phrase: str | None = None

    def bounds_text(self) -> str:
        """The bounds as the docs show them (``> 0``, ``≥ 0, ≤ 1``, ``one of a, b``)."""
        parts = []
        if self.positive:
            parts.append("> 0")
        if self.nonneg:
            parts.append("≥ 0")
        if self.minimum is not None:
            parts.append(f"≥ {self.minimum}")
        if self.maximum is not None:
            parts.append(f"≤ {self.maximum}")
        if self.choices:
            parts.append("one of " + ", ".join(self.choices))
        return ", ".join(parts)


def param(default: Any = dataclasses.MISSING, *, doc: str, unit: str = "", positive: bool = False,
          nonneg: bool = False, minimum: float | None = None, maximum: float | None = None,
          choices: Iterable[str] | None = None, reader: Converter | None = None, flatten: bool = False,
          phrase: str | None = None, default_factory: Any = dataclasses.MISSING) -> Any:
    """A dataclass field declared with its :class:`Param` (bounds, unit, doc) in its metadata."""
    meta = {"param": Param(doc, unit, positive, nonneg, minimum, maximum,
                           tuple(sorted(choices)) if choices is not None else None, reader, flatten, phrase)}
    if default_factory is not dataclasses.MISSING:
        return dataclasses.field(default_factory=default_factory, metadata=meta)
    return dataclasses.field(default=default, metadata=meta)


@functools.lru_cache(maxsize=None)
def _type_hints(cls: type) -> dict:
    """``typing.get_type_hints(cls)``, once per class (it evaluates every annotation: ~50 µs a call)."""
    return typing.get_type_hints(cls)


@functools.lru_cache(maxsize=None)
def _fields(cls: type) -> tuple:
    """``dataclasses.fields(cls)``, once per class."""
    return dataclasses.fields(cls)


def _param_of(f: dataclasses.Field) -> Param | None:
    return f.metadata.get("param") if f.metadata else None


def _check_value(value: Any, tp: Any, p: Param, where: str) -> Any:
    """Check one value against its declared type and bounds; returns the value (converted)."""
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        rest = [a for a in args if a is not type(None)]
        tp = rest[0] if len(rest) == 1 else tp
    if dataclasses.is_dataclass(tp):
        if not isinstance(value, tp):
            _fail(where, f"must be a {tp.__name__}", value)
        return value
    if isinstance(value, np.ndarray) and (p.minimum is not None or p.maximum is not None):
        return within(value, where, p.minimum, p.maximum)  # bounds of an array: element by element
    try:
        if tp is bool:
            return boolean(value, where)
        if tp is int:
            v = integer(value, where, minimum=None if p.minimum is None else int(p.minimum),
                        maximum=None if p.maximum is None else int(p.maximum))
            if (p.positive and v <= 0) or (p.nonneg and v < 0):
                _fail(where, f"must be {'> 0' if p.positive else '≥ 0'}", value)
            return v
        if tp is float:
            return number(value, where, positive=p.positive, nonneg=p.nonneg, minimum=p.minimum, maximum=p.maximum)
        if tp is str:
            return string(value, where, choices=p.choices)
    except ConfigError:
        if p.phrase is None:
            raise
        raise ConfigError(f"{where}: {p.phrase}, got {show(value)}") from None
    return value


def check_params(obj: Any, where: str) -> None:
    """Validate every :func:`param` field of the dataclass instance ``obj`` against its declared
    type and bounds (ConfigError naming ``f"{where}.{field}"``, or the field alone when ``where``
    is ""); nested configs are checked by their own ``__post_init__`` when built, and re-addressed
    here under ``where``."""
    hints = _type_hints(type(obj))
    for f in _fields(type(obj)):
        p = _param_of(f)
        if p is None:
            continue
        value = getattr(obj, f.name)
        name = f"{where}.{f.name}" if where else f.name
        sub = name if not p.flatten else where
        if dataclasses.is_dataclass(value):
            check_params(value, sub)
        else:
            _check_value(value, hints[f.name], p, name)


def describe_params(cls: type, prefix: str = "") -> list[dict]:
    """One row per declared parameter of ``cls`` (nested configs expanded):
    ``{"name", "type", "default", "unit", "bounds", "doc"}``, for generated docs and ``--help``."""
    rows = []
    hints = _type_hints(cls)
    for f in _fields(cls):
        p = _param_of(f)
        if p is None:
            continue
        tp = hints[f.name]
        name = f"{prefix}{f.name}"
        if dataclasses.is_dataclass(tp):
            rows += describe_params(tp, "" if p.flatten else f"{name}.")
            continue
        default = f.default if f.default is not dataclasses.MISSING else (
            f.default_factory() if f.default_factory is not dataclasses.MISSING else None)
        rows.append({"name": name, "type": getattr(tp, "__name__", str(tp).replace("typing.", "")),
                     "default": default, "unit": p.unit, "bounds": p.bounds_text(), "doc": p.doc})
    return rows


def _sequence(element: Converter, length: int | None) -> Converter:
    """Reader of a list → tuple, each element read by ``element`` (naming ``where[k]``)."""
    def read(value: Any, where: str) -> tuple:
        if not isinstance(value, (list, tuple)) or (length is not None and len(value) != length):
            _fail(where, "must be a list" + (f" of {length} values" if length is not None else ""), value)
        return tuple(element(v, f"{where}[{k}]") for k, v in enumerate(value))

    return read


_SCALAR_READERS: dict[Any, Converter] = {bool: boolean, int: integer, float: number, str: string}


def _reader_for(tp: Any) -> Converter | None:
    """The reader of a field type: float, int, bool, str, ``X | None`` (X's reader: a TOML value is
    never None), ``tuple[X, ...]`` or ``tuple[X, Y]``; None when there is none."""
    if tp in _SCALAR_READERS:
        return _SCALAR_READERS[tp]
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if origin in (typing.Union, types.UnionType):
        rest = [a for a in args if a is not type(None)]
        return _reader_for(rest[0]) if len(rest) == 1 else None
    if origin is tuple and args:
        if len(args) == 2 and args[1] is Ellipsis:
            element = _reader_for(args[0])
            return _sequence(element, None) if element else None
        readers = [_reader_for(a) for a in args]
        if all(readers) and len(set(readers)) == 1:
            return _sequence(readers[0], len(args))
    return None


def dataclass_from_table(cls: type, tbl: Any, where: str, converters: Mapping[str, Converter] | None = None, *,
                         defaults: Any = None, check: Callable[[Any, str], None] | None = None):
    """Build the dataclass ``cls`` from a scenario table.

    tbl: the table; its keys must be ``cls``'s init fields (else ``"<where>.<key>: unknown field"``).
    Each value is read by ``converters[key]`` if given (``converter(value, f"{where}.{key}")``),
    else by the reader of the field's type (see the module docstring); a field of any other type
    needs a converter (TypeError otherwise: a programming error, not a bad table).
    Missing keys keep the dataclass's defaults, or ``defaults``'s values when an instance of ``cls``
    is given (e.g. a preset); a missing key without a default → ``"<where>.<key>: missing"``.
    check: the class's own validator ``check(config, where)`` (the one its ``__post_init__`` runs
    with a fixed name): run first on the assembled values (an instance made without ``__init__``) so
    that its errors name ``where``, not the class's default name. ``cls(**values)`` is then built as
    usual (``__post_init__`` included).
    """
    tbl = table(tbl, where)
    init_fields = [f for f in _fields(cls) if f.init]
    hints = _type_hints(cls)
    flat = {f.name: _flat_type(hints[f.name]) for f in init_fields
            if (_param_of(f) is not None and _param_of(f).flatten)}
    allowed = [f.name for f in init_fields if f.name not in flat]
    for sub in flat.values():
        allowed += [g.name for g in dataclasses.fields(sub) if g.init]
    check_keys(tbl, allowed, where)
    converters = converters or {}
    values: dict[str, Any] = {}
    for f in init_fields:
        key_where = f"{where}.{f.name}"
        p = _param_of(f)
        if f.name in flat:
            sub = flat[f.name]
            own = {g.name for g in dataclasses.fields(sub) if g.init}
            sub_defaults = getattr(defaults, f.name) if defaults is not None else None
            values[f.name] = dataclass_from_table(sub, {k: v for k, v in tbl.items() if k in own}, where,
                                                  converters, defaults=sub_defaults)
            continue
        if f.name in tbl:
            read = converters.get(f.name) or (p.reader if p is not None else None) or _reader_for(hints[f.name])
            if read is None and dataclasses.is_dataclass(_flat_type(hints[f.name])):
                sub = _flat_type(hints[f.name])
                read = lambda v, w, sub=sub: dataclass_from_table(sub, v, w)  # noqa: E731
            if read is None:
                raise TypeError(f"{cls.__name__}.{f.name}: no reader for type {hints[f.name]!r}; "
                                f"pass converters[{f.name!r}]")
            values[f.name] = read(tbl[f.name], key_where)
        elif defaults is not None:
            values[f.name] = getattr(defaults, f.name)
        elif f.default is not dataclasses.MISSING:
            values[f.name] = f.default
        elif f.default_factory is not dataclasses.MISSING:
            values[f.name] = f.default_factory()
        else:
            raise ConfigError(f"{key_where}: missing")
    candidate = object.__new__(cls)
    for name, value in values.items():
        object.__setattr__(candidate, name, value)
    check_params(candidate, where)
    if check is not None:
        check(candidate, where)
    return cls(**values)


def read_field(cls: type, name: str, tbl: Mapping, where: str, *, key: str | None = None,
               default: Any = dataclasses.MISSING) -> Any:
    """One key of the table ``tbl`` read as the field ``name`` of the config dataclass ``cls``
    declares it: by its reader (its param's own, else its type's) and against its declared bounds,
    errors naming ``f"{where}.{key}"`` (``key`` alone when ``where`` is "", the top-level table).
    For tables whose keys are not one dataclass's fields one to one (``moving_obstacles[i].radius_m``
    → ``MovingObstacle.radius_m``; ``key`` when the key is spelled differently from the field).
    A missing key gives ``default`` (not read), else the field's default, else ConfigError
    ``"<where>.<key>: missing"``."""
    key = name if key is None else key
    f = next(g for g in _fields(cls) if g.name == name)
    key_where = f"{where}.{key}" if where else key
    if key not in tbl:
        if default is not dataclasses.MISSING:
            return default
        if f.default is not dataclasses.MISSING:
            return f.default
        if f.default_factory is not dataclasses.MISSING:
            return f.default_factory()
        raise ConfigError(f"{key_where}: missing")
    p, tp = _param_of(f), _type_hints(cls)[name]
    read = (p.reader if p is not None else None) or _reader_for(tp)
    value = read(tbl[key], key_where) if read is not None else tbl[key]
    return _check_value(value, tp, p, key_where) if p is not None else value


def _flat_type(tp: Any) -> Any:
    """``X`` of ``X | None`` (else ``tp`` itself)."""
    if typing.get_origin(tp) in (typing.Union, types.UnionType):
        rest = [a for a in typing.get_args(tp) if a is not type(None)]
        if len(rest) == 1:
            return rest[0]
    return tp
