"""Comparing methods: a campaign's ``methods`` list, and a run's scenario with a method set.

A campaign file may list the methods of one onboard stage it compares (top level, before the
tables); the stage is ``compare_stage``, ``"avoidance"`` by default, or ``"tracking"`` or
``"coordination"``::

    methods = ["thesis", "velocity_obstacle"]
    # or entries with options and a label (the label names the method in the store and the report;
    # default: the name; labels are unique, letters, digits, "_", "-", ".")
    methods = [{ name = "thesis", label = "thesis_k05", gain_k = 0.5 }, "thesis", "velocity_obstacle"]
    # trackers on the same runs:
    compare_stage = "tracking"
    methods = ["imm", "filterpy_imm"]

Every generated run (family × draw × seed) is then run once per entry, on the same scenario text
except every vessel's table of that stage present (``[vessels.avoidance]``, ``[vessels.tracking]``,
``[vessels.comms]``; a vessel without one is untouched): that table becomes ``method = <name>``,
then those of its keys the method declares in its ``Options`` (the family's own settings, such as
``safety_distance_m``, for a method that has them; the others are another method's options and are
dropped), then the entry's options. Names are checked against
:func:`mjasc.plugins.available` and options against the method's ``Options`` when the file is read
(one-line errors naming ``methods[i]``). A campaign without ``methods`` runs each scenario as
written, as before (same runs, same digest).

**Where a method is found.** Runs execute in child processes (:mod:`mjasc.campaigns.executor`) and on
Dask workers, which know the built-in methods and the installed packages' entry points
(``mjasc.<stage>``). A method registered in code (:func:`mjasc.plugins.register`) that the campaign
compares, or that a run's scenario selects in any stage (:func:`scenario_plugins`: a tracking method
in ``[vessels.tracking]``, …), is carried to them by its import path (``module:QualifiedName``,
imported and registered there before the run), which works for a class defined at the top level
of an importable module. A class that cannot be imported by name (defined in ``__main__``, in a
function) runs only in this process, unisolated (``run_campaign(…, workers=0, isolate=False)``);
anything else is a one-line error before any run
starts (:func:`plugin_sources`).
"""

from __future__ import annotations

import copy
import functools
import importlib
import json
import re
from dataclasses import dataclass, field
from importlib import metadata
from typing import Any

from mjasc.core.config_tables import ConfigError, show, string, table

__all__ = ["MethodEntry", "parse_methods", "apply_method", "plugin_sources", "scenario_plugins", "register_plugins",
           "check_plugins_reach"]

STAGE = "avoidance"
#: Where a scenario's vessel names each stage's method: stage → (table, key).
_METHOD_KEYS = {"avoidance": ("avoidance", "method"), "tracking": ("tracking", "method"),
                "control": ("controller", "type"), "coordination": ("comms", "method")}
#: The stages a campaign can compare (``compare_stage``) → the vessel's table that names the method:
#: those whose table names it by ``method`` (a controller's ``type`` table is the path's too).
COMPARED_STAGES = {stage: tbl for stage, (tbl, key) in _METHOD_KEYS.items() if key == "method"}
_LABEL = re.compile(r"^[A-Za-z0-9_.-]{1,64}$")


@dataclass(frozen=True)
class MethodEntry:
    """One compared method: its ``label`` (in the store, the report, file names), its registered
    ``name`` and its options (the TOML values, validated against the method's ``Options``)."""

    label: str
    name: str
    options: dict = field(default_factory=dict)


def parse_methods(value: Any, where: str = "methods", stage: str = STAGE) -> tuple[MethodEntry, ...]:
    """The campaign's ``methods`` list of ``stage`` methods → entries (ConfigError naming ``methods[i]``)."""
    from mjasc.plugins import available, parse_method_table

    if not isinstance(value, list) or not value:
        raise ConfigError(f"{where}: must be a non-empty list of {stage} method names or tables "
                          f"({{ name = …, label = …, options… }}), got {show(value)}")
    known = available(stage)
    entries: list[MethodEntry] = []
    for i, item in enumerate(value):
        at = f"{where}[{i}]"
        if isinstance(item, str):
            item = {"name": item}
        tbl = dict(table(item, at))
        if "name" not in tbl:
            raise ConfigError(f"{at}.name: missing (the {stage} method's name; available: {', '.join(known)})")
        name = tbl.pop("name")
        name_at = at if isinstance(value[i], str) else f"{at}.name"
        name = string(name, name_at)
        if name not in known:
            raise ConfigError(f"{name_at}: unknown {stage} method {name!r} (available: {', '.join(known)})")
        label = string(tbl.pop("label", name), f"{at}.label")
        if not _LABEL.match(label):
            raise ConfigError(f"{at}.label: must be 1–64 letters, digits, '_', '-' or '.' (it names files), "
                              f"got {show(label)}")
        if "method" in tbl:
            raise ConfigError(f"{at}.method: unknown field (the method is given by name)")
        parse_method_table(stage, {"method": name, **tbl}, at)  # the options, checked from the method's Options
        if any(e.label == label for e in entries):
            raise ConfigError(f"{at}.label: duplicate label {label!r} (give entries of the same method a label)")
        entries.append(MethodEntry(label, name, tbl))
    return tuple(entries)


@functools.lru_cache(maxsize=None)
def _declares(stage: str, cls: type, key: str, value_json: str) -> bool:
    """Whether ``stage`` method class ``cls`` takes option ``key`` (its table would not call it unknown)."""
    from mjasc.plugins import parse_method_table
    from mjasc.plugins.registry import register, unregister

    name = f"_probe_{id(cls)}"
    register(stage, cls, name)
    try:
        parse_method_table(stage, {"method": name, key: json.loads(value_json)}, "probe")
    except ConfigError as exc:
        return not str(exc).startswith(f"probe.{key}: unknown field")
    finally:
        unregister(stage, name)
    return True


def _keeps(stage: str, name: str, key: str, value: Any) -> bool:
    from mjasc.plugins import method_class

    try:
        value_json = json.dumps(value, sort_keys=True)
    except (TypeError, ValueError):
        return True  # not a TOML value: let the scenario's own validation name it
    return _declares(stage, method_class(stage, name), key, value_json)


def apply_method(doc: dict, entry: MethodEntry, stage: str = STAGE) -> tuple[dict, int]:
    """A copy of scenario document ``doc`` with ``entry`` (a ``stage`` method) set in every vessel's
    table of that stage (module docstring); returns ``(doc, number of tables set)``."""
    doc = copy.deepcopy(doc)
    key = COMPARED_STAGES[stage]
    n = 0
    for v in doc.get("vessels") or []:
        if not isinstance(v, dict) or not isinstance(v.get(key), dict):
            continue
        base = v[key]
        kept = {k: x for k, x in base.items() if k != "method" and _keeps(stage, entry.name, k, x)}
        v[key] = {"method": entry.name, **kept, **copy.deepcopy(entry.options)}
        n += 1
    return doc, n


# ---------------------------------------------------------------------- reaching child processes
def _importable(cls: type) -> str | None:
    """``module:QualifiedName`` when importing it gives ``cls`` back, else None."""
    mod, qual = getattr(cls, "__module__", ""), getattr(cls, "__qualname__", "")
    if not mod or mod in ("__main__", "__mp_main__") or "<locals>" in qual:
        return None
    try:
        obj: Any = importlib.import_module(mod)
        for part in qual.split("."):
            obj = getattr(obj, part)
    except Exception:  # noqa: BLE001 — not importable by name
        return None
    return f"{mod}:{qual}" if obj is cls else None


def plugin_sources(names, stage: str = STAGE) -> dict[str, str | None]:
    """For each ``stage`` method name that child processes would not find by themselves (neither
    built in nor an installed entry point: registered in this process), its import path, or None
    when its class cannot be imported by name."""
    from mjasc.plugins import method_class
    from mjasc.plugins.registry import BUILTIN, entry_point_group

    eps = {ep.name: ep for ep in metadata.entry_points(group=entry_point_group(stage))}
    out: dict[str, str | None] = {}
    for name in dict.fromkeys(names):
        cls = method_class(stage, name)
        if name in BUILTIN[stage]:
            mod, attr = BUILTIN[stage][name].split(":")
            if getattr(importlib.import_module(mod), attr) is cls:
                continue
        elif name in eps and name not in out:
            try:
                if eps[name].load() is cls:
                    continue
            except Exception:  # noqa: BLE001 — a broken entry point: carry the class that is used here
                pass
        out[name] = _importable(cls)
    return out




def scenario_plugins(texts) -> dict[str, dict[str, str | None]]:
    """The methods registered in this process (:func:`mjasc.plugins.register`) that the scenario
    texts ``texts`` (TOML) select in a vessel's table, any stage: ``{stage: {name: import path or
    None}}`` (:func:`plugin_sources`); empty when nothing is registered in code (no text is read)."""
    import tomllib

    from mjasc.plugins.registry import registered_in_code

    wanted = {stage: set(registered_in_code(stage)) for stage in _METHOD_KEYS}
    if not any(wanted.values()):
        return {}
    used: dict[str, set] = {stage: set() for stage in _METHOD_KEYS}
    for text in dict.fromkeys(texts):
        try:
            vessels = tomllib.loads(text).get("vessels") or []
        except (tomllib.TOMLDecodeError, AttributeError):
            continue  # (the run's own parse names the problem)
        for v in vessels if isinstance(vessels, list) else []:
            for stage, (key, name_key) in _METHOD_KEYS.items():
                tbl = v.get(key) if isinstance(v, dict) else None
                name = tbl.get(name_key) if isinstance(tbl, dict) else None
                if isinstance(name, str) and name in wanted[stage]:
                    used[stage].add(name)
    return {stage: plugin_sources(sorted(names), stage) for stage, names in used.items() if names}


def check_plugins_reach(sources: dict[str, str | None], in_this_process: bool, stage: str = STAGE) -> None:
    """ValueError (one line) when a ``stage`` method registered only in this process, not importable
    by name, would have to run in a child process or on a Dask worker."""
    local = [n for n, path in sources.items() if path is None]
    if local and not in_this_process:
        from mjasc.plugins import method_class

        cls = method_class(stage, local[0])
        raise ValueError(f"{stage} method {local[0]!r} is registered only in this process and its class "
                         f"{cls.__module__}.{cls.__qualname__} cannot be imported by name, so the runs' child "
                         f"processes and Dask workers cannot find it: define it at the top level of an importable "
                         f"module, install it as an entry point (group 'mjasc.{stage}'), or run the campaign in "
                         f"this process with workers=0, isolate=False")


def register_plugins(plugins: dict | None) -> None:
    """In a run's process: import and register the methods a request carries
    (``{stage: {name: "module:QualifiedName"}}``)."""
    if not plugins:
        return
    from mjasc.plugins import register

    for stage, entries in plugins.items():
        for name, path in entries.items():
            mod, qual = path.split(":", 1)
            obj: Any = importlib.import_module(mod)
            for part in qual.split("."):
                obj = getattr(obj, part)
            register(stage, obj, name)
