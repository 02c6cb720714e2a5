"""Stage methods by name: the built-in ones, those registered in code, and those installed packages
declare through Python entry points.

A scenario selects a method by name in the stage's table (``[vessels.avoidance] method =
"velocity_obstacle"``); the rest of the table is the method's options, validated from its
``Options`` dataclass like every other table. Lookup order: methods registered in this process
(:func:`register`), the built-ins, then the entry points of installed packages in the stage's group:

===========  ====================  =======================
stage        entry-point group     default method
===========  ====================  =======================
avoidance    ``mjasc.avoidance``   ``thesis``
tracking     ``mjasc.tracking``    ``imm``
control      ``mjasc.control``     ``path_following`` (``[vessels.controller] type``)
coordination ``mjasc.coordination`` ``thesis`` (the ``[vessels.comms]`` table)
===========  ====================  =======================

A package adds a method without touching mjasc by declaring, in its ``pyproject.toml``::

    [project.entry-points."mjasc.avoidance"]
    my_method = "my_package.module:MyMethod"

The class must subclass the stage's interface (:mod:`mjasc.plugins.stages`); a wrong name, a class
that does not, or a package that fails to import is a one-line error naming the scenario field.
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
from dataclasses import dataclass
from importlib import metadata
from typing import Any

from mjasc.core.config_tables import ConfigError, dataclass_from_table, show, string, table
from mjasc.plugins.context import StageContext
from mjasc.plugins.stages import AvoidanceMethod, ControlMethod, CoordinationMethod, StageMethod, TrackingMethod
from mjasc.runs.plausibility import check_name

__all__ = ["STAGES", "MethodChoice", "register", "unregister", "available", "method_class", "parse_method_table",
           "entry_point_group", "parse_avoidance_table", "parse_coordination_table", "parse_tracking_table",
           "builtin_method", "registered_in_code"]

#: stage → (interface, default method name).
STAGES: dict[str, tuple[type, str]] = {
    "avoidance": (AvoidanceMethod, "thesis"),
    "tracking": (TrackingMethod, "imm"),
    "control": (ControlMethod, "path_following"),
    "coordination": (CoordinationMethod, "thesis"),
}

#: The built-in methods: stage → {name: "module:Class"} (imported on first use).
BUILTIN: dict[str, dict[str, str]] = {
    "avoidance": {"thesis": "mjasc.avoidance.system:CollisionAvoidance",
                  "velocity_obstacle": "mjasc.avoidance.velocity_obstacles.method:VelocityObstacleAvoidance"},
    "tracking": {"imm": "mjasc.perception.tracking.method:IMMMethod",
                 "filterpy_imm": "mjasc.perception.tracking.filterpy_tracker:FilterpyIMMMethod"},
    "control": {"path_following": "mjasc.guidance.path_following:PathFollower"},
    "coordination": {"thesis": "mjasc.cooperation.coordination:Coordination"},
}

_registered: dict[str, dict[str, type]] = {stage: {} for stage in STAGES}


def entry_point_group(stage: str) -> str:
    """The entry-point group of a stage (``mjasc.<stage>``)."""
    _check_stage(stage)
    return f"mjasc.{stage}"


def _check_stage(stage: str) -> None:
    if stage not in STAGES:
        raise ValueError(f"stage: unknown stage {stage!r} (known: {', '.join(STAGES)})")


def _entry_points(stage: str) -> dict[str, Any]:
    return {ep.name: ep for ep in metadata.entry_points(group=entry_point_group(stage))}


def register(stage: str, cls: type, name: str | None = None, replace: bool = False) -> type:
    """Register ``cls`` as a method of ``stage`` under ``name`` (default ``cls.method``) for this
    process (a notebook, a test); usable as a decorator via ``functools.partial``. Returns ``cls``.
    The name follows the rule of scenario names (letters, digits, ``_``, ``-``); a built-in
    method's name is refused, and another class already registered under the name, or an
    installed package's entry point of that name, too unless ``replace`` (the same class again is
    fine)."""
    _check_stage(stage)
    _check_class(stage, cls, f"register({show(name if name is not None else cls)})")
    name = name or cls.method
    if not name:
        raise ConfigError("register: the method needs a name (cls.method or name=)")
    if not isinstance(name, str):
        raise ConfigError(f"register: the method's name must be a string, got {show(name)}")
    check_name(name, "register: the method's name", vessel=False)
    if name in BUILTIN[stage]:
        raise ConfigError(f"register({name!r}): {name!r} is a built-in {stage} method; give yours another name")
    held = _registered[stage].get(name)
    if held is not None and held is not cls and not replace:
        raise ConfigError(f"register({name!r}): another {stage} method ({held.__module__}.{held.__qualname__}) is "
                          f"registered under {name!r}; unregister it first or pass replace=True")
    if held is None and not replace:  # (an installed package's method of that name would be shadowed unsaid)
        group = metadata.entry_points(group=entry_point_group(stage))
        installed = sorted({ep.value for ep in group if ep.name == name})
        if installed and installed != [f"{cls.__module__}:{cls.__qualname__}"]:
            raise ConfigError(f"register({name!r}): an installed package declares the {stage} method {name!r} "
                              f"({', '.join(installed)}); give yours another name or pass replace=True")
    _registered[stage][name] = cls
    return cls


def builtin_method(cls: type) -> bool:
    """Is ``cls`` one of mjasc's own methods (defined in the mjasc package), not a plugin's? Its
    answers are not checked and it has no hooks of its own beyond the stage's."""
    return cls.__module__.startswith("mjasc.")


def unregister(stage: str, name: str) -> None:
    """Forget a method registered with :func:`register` (no error if it was not)."""
    _check_stage(stage)
    _registered[stage].pop(name, None)


def registered_in_code(stage: str) -> dict[str, type]:
    """The methods of ``stage`` registered in this process with :func:`register` (name → class)."""
    _check_stage(stage)
    return dict(_registered[stage])


def available(stage: str) -> list[str]:
    """Every method name of ``stage`` this process can use, sorted."""
    _check_stage(stage)
    return sorted(set(_registered[stage]) | set(BUILTIN[stage]) | set(_entry_points(stage)))


def _check_class(stage: str, cls: Any, where: str) -> None:
    interface = STAGES[stage][0]
    if not (isinstance(cls, type) and issubclass(cls, interface)):
        raise ConfigError(f"{where}: {show(cls)} is not {_article(interface.__name__)} {interface.__name__} "
                          f"({_article(stage)} {stage} method must subclass mjasc.plugins.{interface.__name__})")


def _article(word: str) -> str:
    """'an' before a vowel ("an AvoidanceMethod", "an avoidance method"), else 'a'."""
    return "an" if word[:1].lower() in "aeiou" else "a"


def method_class(stage: str, name: str, where: str = "method") -> type:
    """The class of method ``name`` of ``stage``; ConfigError naming ``where`` when there is none or
    it cannot be loaded."""
    _check_stage(stage)
    if name in _registered[stage]:
        return _registered[stage][name]
    if name in BUILTIN[stage]:
        module, attr = BUILTIN[stage][name].split(":")
        return getattr(importlib.import_module(module), attr)
    found = [ep for ep in metadata.entry_points(group=entry_point_group(stage)) if ep.name == name]
    if not found:
        raise ConfigError(f"{where}: unknown {stage} method {name!r} (available: {', '.join(available(stage))})")
    targets = sorted({ep.value for ep in found})
    if len(targets) > 1:  # (two installed packages declare the name: which would load depends on the path)
        raise ConfigError(f"{where}: {stage} method {name!r} is declared by more than one installed package "
                          f"({', '.join(targets)}); uninstall one or rename its entry point")
    ep = found[0]
    try:
        cls = ep.load()
    except Exception as exc:  # a broken plugin package: say which, do not crash the loader
        raise ConfigError(f"{where}: {stage} method {name!r} from entry point {ep.value!r} failed to load: "
                          f"{type(exc).__name__}: {exc}") from None
    _check_class(stage, cls, where)
    return cls


@dataclass(frozen=True, eq=False)
class MethodChoice:
    """A stage's method chosen in a scenario: its name and validated options (an instance of the
    method's ``Options``, or None)."""

    stage: str
    name: str
    options: Any = None

    @property
    def cls(self) -> type:
        return method_class(self.stage, self.name)

    def build(self, context: StageContext) -> StageMethod:
        """The method for one vessel; a method whose construction raises is a ConfigError naming
        the stage, the method and the vessel (before the run starts)."""
        cls = self.cls
        try:
            built = cls.from_context(context, self.options)
        except ConfigError:
            raise
        except Exception as exc:  # noqa: BLE001 — a plugin's constructor: its error, on one line
            text = " ".join(str(exc).split())
            raise ConfigError(f"{self.stage} method {self.name!r} ({cls.__module__}.{cls.__qualname__}) for vessel "
                              f"{context.vessel_name!r}: could not be built: {type(exc).__name__}: {text}") from None
        if getattr(built, "method", self.name) != self.name:  # (a class registered under another name: the
            try:  # summary names the method the scenario chose)
                built.method = self.name
            except AttributeError:
                pass
        return built


def parse_method_table(stage: str, tbl: Any, where: str, name_key: str = "method") -> MethodChoice:
    """A stage's scenario table → :class:`MethodChoice`: ``name_key`` (``method``; default: the
    stage's default method) picks the method, the other keys are its options, read and checked from
    its ``Options``."""
    tbl = dict(table({} if tbl is None else tbl, where))
    name = string(tbl.pop(name_key, STAGES[stage][1]), f"{where}.{name_key}")
    cls = method_class(stage, name, f"{where}.{name_key}")
    if inspect.isabstract(cls):  # (it would fail when the run builds it: say so now)
        missing = ", ".join(sorted(getattr(cls, "__abstractmethods__", ())))
        raise ConfigError(f"{where}.{name_key}: the {stage} method {name!r} ({cls.__module__}.{cls.__qualname__}) "
                          f"does not implement {missing}")
    if cls.Options is None:
        if tbl:
            raise ConfigError(f"{where}.{next(iter(tbl))}: unknown field (the {stage} method {name!r} takes no options)")
        return MethodChoice(stage, name, None)
    what = f"the {stage} method {name!r} ({cls.__module__}.{cls.__qualname__})"
    if not (isinstance(cls.Options, type) and dataclasses.is_dataclass(cls.Options)):
        raise ConfigError(f"{where}.{name_key}: {what}: its Options must be a dataclass class or None, got "
                          f"{show(cls.Options)}")
    check = cls.check_options if cls.check_options is not StageMethod.check_options else None
    try:
        return MethodChoice(stage, name, dataclass_from_table(cls.Options, tbl, where, check=check))
    except ValueError:  # (ConfigError included: already one line naming the field)
        raise
    except Exception as exc:  # noqa: BLE001 — the plugin's Options or check_options failed otherwise: on one line
        text = " ".join(str(exc).split())
        raise ConfigError(f"{where}: {what}: its options could not be checked: {type(exc).__name__}: {text} "
                          f"(check_options and the Options' own checks raise ValueError naming the field)") from None


def parse_avoidance_table(tbl: Any, where: str = "avoidance") -> MethodChoice:
    """A ``[vessels.avoidance]`` table → the chosen avoidance method and its options."""
    return parse_method_table("avoidance", tbl, where)


def parse_coordination_table(tbl: Any, where: str = "comms") -> MethodChoice:
    """A ``[vessels.comms]`` table → the chosen coordination method and its options."""
    return parse_method_table("coordination", tbl, where)


def parse_tracking_table(tbl: Any, where: str = "tracking") -> MethodChoice:
    """A ``[vessels.tracking]`` table → the chosen tracking method and its options (``imm``, the
    default: a :class:`~mjasc.perception.tracking.config.TrackingConfig`)."""
    return parse_method_table("tracking", tbl, where)
