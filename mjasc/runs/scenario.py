"""Scenario files (TOML): what a run contains, validated completely before anything runs.

The format is documented with a complete example in ``tasks/README.md``. Every error names the
field path and the reason (``vessels[1].controller.speed_m_s: must be > 0, got -1.0``), and
:func:`load_scenario` raises before any model is built or any file is written.

Angles in scenario files are in degrees (``heading_deg``, ``turn_rate_deg_s``) because people
write them; everything inside mjasc is radians (docs/architecture.md). The typed values a file
becomes (:class:`Scenario`, :class:`VesselConfig`, :class:`Rates`, :class:`Outputs`) are
:mod:`mjasc.runs.scenario_values`, re-exported here.
"""

from __future__ import annotations

import math
import re
from pathlib import Path as FilePath
from typing import Any

import numpy as np

from mjasc.core.config_tables import (
    check_keys,
    dataclass_from_table,
    errors_as,
    load_toml,
    number,
    points,
    read_field,
    show,
    string,
    table,
)
from mjasc.core.frames import WORLD_LIMIT_M
from mjasc.core.resources import resolve_bundled
from mjasc.guidance.paths import Path
from mjasc.physics.currents import UniformCurrent, current_from_config
from mjasc.physics.obstacles import CircleObstacle, MovingObstacle, PolygonObstacle
from mjasc.physics.vessels import available_vessels, load_vessel_type, resolve_vessel_type
from mjasc.runs.plausibility import check_name, check_plausible, check_team_link, file_name
from mjasc.runs.scenario_values import (MAX_DURATION_S, RECORDING_DETAILS, Outputs, Rates, Scenario,  # noqa: F401
                                       ScenarioError, VesselConfig, camera_problem, check_camera_vessel)

__all__ = ["ScenarioError", "Scenario", "VesselConfig", "Rates", "Outputs", "RECORDING_DETAILS", "load_scenario",
           "parse_scenario"]



# ---------------------------------------------------------------------- scenario-specific readers
def _heading(t: dict, where: str) -> float:
    return math.radians(number(t.get("heading_deg", 0.0), f"{where}.heading_deg", minimum=-3600.0, maximum=3600.0))


def _path(t: dict, where: str) -> Path:
    wps = points(t.get("waypoints"), f"{where}.waypoints", 2, limit=WORLD_LIMIT_M)
    radius = number(t.get("turn_radius_m", 0.0), f"{where}.turn_radius_m", nonneg=True)
    try:
        return Path.from_waypoints(wps, turn_radius_m=radius)
    except ValueError as exc:
        raise ScenarioError(_readdress(str(exc), where, ("waypoints", "turn_radius_m"), "waypoints")) from None


def _readdress(msg: str, where: str, fields: tuple[str, ...], default: str, prefix: str = "") -> str:
    """A builder's error (``"waypoints[1]: repeats …"``, ``"pier.vertices: …"``) named by the
    scenario's field path (``"vessels[0].controller.waypoints[1]: repeats …"``): a message that
    starts with one of ``fields`` (after ``prefix``, the object's own name) is put under ``where``,
    any other goes under ``where.default`` — the field is named once, not twice."""
    body = msg[len(prefix):] if prefix and msg.startswith(prefix) else msg
    for f in fields:
        if body.startswith(f) and body[len(f):len(f) + 1] in (":", "["):
            return f"{where}.{body}"
    return f"{where}.{default}: {body}"


# ---------------------------------------------------------------------- sections
_TOP = {"name", "description", "duration_s", "seed", "rates", "outputs", "current", "vessels",
        "static_obstacles", "moving_obstacles", "comms", "mission"}

#: Optional per-vessel components: scenario table → (module, parser). Each parser takes
#: (table, where) and returns a typed config, raising ValueError that names ``where.<key>``.
COMPONENT_PARSERS = {
    "sensor": ("mjasc.perception.range_sensor", "parse_sensor_options"),
    "tracking": ("mjasc.plugins.registry", "parse_tracking_table"),
    "avoidance": ("mjasc.plugins.registry", "parse_avoidance_table"),
    "comms": ("mjasc.plugins.registry", "parse_coordination_table"),
    "mission": ("mjasc.missions.config", "parse_vessel_mission"),
}


def _parse_component(kind: str, value: Any, where: str):
    import importlib

    module_name, func = COMPONENT_PARSERS[kind]
    try:
        parser = getattr(importlib.import_module(module_name), func)
    except (ImportError, AttributeError):
        raise ScenarioError(f"{where}: component {kind!r} is not available in this version of mjasc") from None
    try:
        return parser(table(value, where), where)
    except ScenarioError:
        raise
    except ValueError as exc:
        msg = str(exc)
        raise ScenarioError(msg if msg.startswith(where) else f"{where}: {msg}") from None
_VESSEL = {"name", "type", "position_m", "heading_deg", "speed_m_s", "controller", "sensor", "tracking",
           "avoidance", "comms", "mission"}
#: The vessel's keys that no sub-table has (one found in a sub-table was written after its header).
_VESSEL_ONLY = {"position_m", "heading_deg", "controller", "sensor", "tracking", "avoidance", "comms", "mission"}
#: The controller table's mission keys; its other keys are the control method's options.
_CONTROLLER = {"type", "waypoints", "turn_radius_m", "speed_m_s", "commands"}


def _rates(t: dict) -> Rates:
    return dataclass_from_table(Rates, t, "rates", check=Rates.check)


def _outputs(t: dict) -> Outputs:
    return dataclass_from_table(Outputs, t, "outputs", check=Outputs.check)


def _vessel(t: Any, i: int, path_optional: bool = False, base_dir: FilePath | None = None) -> VesselConfig:
    """One ``[[vessels]]`` table. ``path_optional``: the scenario's mission never follows the
    controller's path (target tracking only): without waypoints the vessel gets a 10 m line ahead
    of its start pose, which its first mission leg replaces. ``base_dir``: the scenario file's
    folder, against which a vessel folder's path (``type = "hulls/heron"``) is resolved."""
    where = f"vessels[{i}]"
    t = table(t, where)
    check_keys(t, _VESSEL, where)
    for sub in ("controller", *COMPONENT_PARSERS):  # (a vessel key that TOML put into a sub-table)
        misplaced = [k for k in t.get(sub, {}) if k in _VESSEL_ONLY] if isinstance(t.get(sub), dict) else []
        if misplaced:  # (parse_scenario adds why)
            raise ScenarioError(f"{where}.{sub}.{misplaced[0]}: unknown field")
    name = check_name(string(t.get("name", f"v{i}"), f"{where}.name"), f"{where}.name", vessel=True)
    if "type" not in t:
        raise ScenarioError(f"{where}.type: missing (the vessel type: one of {', '.join(sorted(available_vessels()))}, "
                            f"or a vessel folder's path)")
    vtype = string(t.get("type"), f"{where}.type")
    try:  # (a folder: its absolute path from here on, checked against the contract)
        vtype = resolve_vessel_type(vtype, base_dir)
    except ValueError as exc:
        raise ScenarioError(f"{where}.type: {exc}") from None
    pos = read_field(VesselConfig, "position_m", t, where, default=np.zeros(2))
    heading = _heading(t, where)
    vt = load_vessel_type(vtype)
    speed = number(read_field(VesselConfig, "speed_m_s", t, where, default=0.0), f"{where}.speed_m_s")
    if speed > 1.5 * vt.top_speed_m_s:  # (the start's speed: a push, at most 1.5 × what the hull sails)
        raise ScenarioError(f"{where}.speed_m_s: must be ≤ {1.5 * vt.top_speed_m_s:g} m/s (1.5 × the hull's top "
                            f"speed, {vt.top_speed_m_s:g} m/s), got {speed:g}")
    ctrl = table(t.get("controller", {"type": "none"}), f"{where}.controller")
    ctype = string(ctrl.get("type", "path_following"), f"{where}.controller.type")
    if ctype == "none":
        check_keys(ctrl, {"type", "commands"}, f"{where}.controller")  # (no path: open-loop commands only)
        if "avoidance" in t:  # (it would predict nothing and never act: a vessel that only looks protected)
            raise ScenarioError(f"{where}.avoidance: needs a path-following controller — an open-loop vessel "
                                f"(controller type \"none\", constant commands) has no speed or path to correct")
        if "mission" in t:  # (its legs would be handed to no follower: silently ignored)
            raise ScenarioError(f"{where}.mission: needs a path-following controller — an open-loop vessel "
                                f"(controller type \"none\", constant commands) sails no mission")
    path, commands = None, (0.0, 0.0)
    cruise = vt.cruise_speed_m_s
    options = {k: _parse_component(k, t[k], f"{where}.{k}") for k in COMPONENT_PARSERS if k in t}
    for needs in ("avoidance", "tracking"):  # (a tracker without one got a default sensor nobody asked for)
        if needs in options and "sensor" not in options:
            raise ScenarioError(f"{where}.{needs}: needs a [vessels.sensor] table — a vessel "
                                f"{'avoids' if needs == 'avoidance' else 'tracks'} only what its own sensor sees")
    if getattr(getattr(options.get("comms"), "options", None), "share_tracks", False) and "sensor" not in options:
        raise ScenarioError(f"{where}.comms.share_tracks: needs a [vessels.sensor] table — a vessel shares the "
                            f"tracks its own sensor sees (without one it would send none)")
    if ctype != "none":
        from mjasc.plugins.registry import parse_method_table

        method_table = {k: v for k, v in ctrl.items() if k not in _CONTROLLER}
        try:
            options["control"] = parse_method_table("control", {"type": ctype, **method_table},
                                                    f"{where}.controller", name_key="type")
        except ValueError as exc:  # (an unknown key: the table's own keys are allowed too, say so)
            m = re.match(rf"{re.escape(where)}\.controller\.(\w+): unknown field \(allowed: (.*)\)$", str(exc))
            if m is None:
                raise
            allowed = ", ".join(sorted(set(m[2].split(", ")) | _CONTROLLER))
            raise ScenarioError(f"{where}.controller.{m[1]}: unknown field (allowed: {allowed})") from None
        if "waypoints" in ctrl:
            path = _path(ctrl, f"{where}.controller")
        elif path_optional:
            ahead = pos + 10.0 * np.array([math.cos(heading), math.sin(heading)])
            path = Path.line(pos, ahead)
        else:
            raise ScenarioError(f"{where}.controller.waypoints: missing ({ctype} needs a path)")
        cruise = number(read_field(VesselConfig, "cruise_speed_m_s", ctrl, f"{where}.controller", key="speed_m_s",
                                   default=vt.cruise_speed_m_s), f"{where}.controller.speed_m_s")
        if cruise > vt.top_speed_m_s:
            raise ScenarioError(f"{where}.controller.speed_m_s: must be ≤ {vt.top_speed_m_s:g} m/s (the hull's top "
                                f"speed), got {cruise:g}")
    else:
        c = ctrl.get("commands", [0.0, 0.0])
        if not isinstance(c, list) or len(c) != 2:
            raise ScenarioError(f"{where}.controller.commands: must be [port, starboard] in [-1, 1], got {c!r}")
        commands = tuple(number(x, f"{where}.controller.commands[{k}]", minimum=-1, maximum=1) for k, x in enumerate(c))
    return VesselConfig(name, vtype, pos, heading, speed, ctype, path, cruise, commands, options)


def _static(t: Any, i: int):
    where = f"static_obstacles[{i}]"
    t = table(t, where)
    if "type" not in t:
        raise ScenarioError(f"{where}.type: missing (one of circle, polygon)")
    kind = string(t.get("type"), f"{where}.type", choices={"polygon", "circle"})
    name = check_name(string(t.get("name", f"static{i}"), f"{where}.name"), f"{where}.name", vessel=False)
    if kind == "polygon":
        height = read_field(PolygonObstacle, "height_m", t, where)
        check_keys(t, {"type", "name", "vertices", "height_m"}, where)
        v = points(t.get("vertices"), f"{where}.vertices", 3, limit=WORLD_LIMIT_M)
        if len(v) > 3 and np.array_equal(v[0], v[-1]):
            v = v[:-1]  # written as a closed ring: the last vertex repeats the first
        try:
            return PolygonObstacle(name, v, height)
        except ValueError as exc:
            raise ScenarioError(_readdress(str(exc), where, ("vertices",), "vertices", f"{name}.")) from None
    height = read_field(CircleObstacle, "height_m", t, where)
    check_keys(t, {"type", "name", "centre_m", "radius_m", "height_m"}, where)
    return CircleObstacle(name, read_field(CircleObstacle, "centre", t, where, key="centre_m"),
                          read_field(CircleObstacle, "radius_m", t, where), height)


def _moving(t: Any, i: int) -> MovingObstacle:
    where = f"moving_obstacles[{i}]"
    t = table(t, where)
    check_keys(t, {"name", "radius_m", "position_m", "heading_deg", "speed_m_s", "turn_rate_deg_s", "waypoints",
                   "turn_radius_m", "start_gamma_m"}, where)
    name = check_name(string(t.get("name", f"traffic{i}"), f"{where}.name"), f"{where}.name", vessel=False)
    radius = read_field(MovingObstacle, "radius_m", t, where, default=2.5)
    speed = read_field(MovingObstacle, "speed_m_s", t, where)
    if "waypoints" in t:
        for key in ("position_m", "heading_deg", "turn_rate_deg_s"):  # (the path gives them)
            if key in t:
                raise ScenarioError(f"{where}.{key}: not with waypoints (the obstacle starts on its path at "
                                    f"start_gamma_m and follows it)")
        path = _path(t, where)
        g0 = number(read_field(MovingObstacle, "start_gamma_m", t, where), f"{where}.start_gamma_m",
                    maximum=path.length)
        return MovingObstacle(name, radius, path.point(g0), float(path.tangent_angle(g0)), speed, 0.0, path, g0)
    for key in ("turn_radius_m", "start_gamma_m"):  # (keys of a path: they would be ignored)
        if key in t:
            raise ScenarioError(f"{where}.{key}: only with waypoints (without them the obstacle sails from "
                                f"position_m at heading_deg and turn_rate_deg_s)")
    if "position_m" not in t:
        raise ScenarioError(f"{where}.position_m: missing (or give waypoints)")
    pos = read_field(MovingObstacle, "position_m", t, where)
    turn = math.radians(number(t.get("turn_rate_deg_s", 0.0), f"{where}.turn_rate_deg_s"))
    return MovingObstacle(name, radius, pos, _heading(t, where), speed, turn)


def parse_scenario(data: dict, source: str = "<dict>") -> Scenario:
    """Validate a parsed TOML document into a :class:`Scenario` (raises :class:`ScenarioError`)."""
    try:
        with errors_as(ScenarioError):
            return _parse_scenario(data, source)
    except ScenarioError as exc:
        hint = _misplaced_key_hint(str(exc))
        if hint:
            raise ScenarioError(f"{exc}{hint}") from None
        raise


_SUBTABLE_KEY = re.compile(r"^(?:(?P<vessel>vessels\[\d+\])\.)?(?P<table>[a-z_]+(?:\[\d+\])?(?:\.[a-z_]+(?:\[\d+\])?)*)"
                           r"\.(?P<key>[a-z_0-9]+): unknown (?:field|key)")  # (nested: mission.go_to_formation)


def _misplaced_key_hint(msg: str) -> str:
    """TOML puts every key written after a ``[table]`` header into that table: a vessel's
    ``sensor = {…}`` after its ``[vessels.controller]`` header, or ``seed = 1`` after ``[outputs]``,
    is an unknown field of that table. Say so when the key belongs one level up."""
    m = _SUBTABLE_KEY.match(msg)
    if m is None or m["table"] == "scenario":
        return ""
    if m["vessel"] is not None and m["key"] in _VESSEL_ONLY:
        return (f"; '{m['key']}' is a key of the vessel, not of [vessels.{m['table']}]: in TOML every key after "
                f"a [table] header belongs to that table, so write it before the vessel's first sub-table")
    if m["vessel"] is None and m["key"] in _TOP:
        header = re.sub(r"\[\d+\]", "", m["table"])
        header = f"[[{header}]]" if header != m["table"] else f"[{header}]"  # ([[current.components]]: an array)
        return (f"; '{m['key']}' is a top-level key, not one of {header}: in TOML every key after a "
                f"[table] header belongs to that table, so write it before the first [table]")
    return ""


def _parse_scenario(data: dict, source: str) -> Scenario:
    data = table(data, "scenario")
    check_keys(data, _TOP, "scenario")
    name = file_name(data, source)  # (it names the run's output folder: the rule of vessel names)
    if "duration_s" not in data:
        raise ScenarioError("duration_s: missing (how long the run lasts, in seconds)")
    duration = read_field(Scenario, "duration_s", data, "")
    seed = read_field(Scenario, "seed", data, "", default=0)
    rates = _rates(data.get("rates", {}))
    outputs = _outputs(data.get("outputs", {}))
    cur_cfg = data.get("current")
    if cur_cfg is None:
        current, cur_cfg = UniformCurrent((0.0, 0.0)), {"type": "uniform", "velocity_m_s": [0.0, 0.0]}
    else:
        try:
            current = current_from_config(table(cur_cfg, "current"), seed=seed)
        except ValueError as exc:
            msg = str(exc)
            raise ScenarioError(msg if msg.startswith("current") else f"current: {msg}") from None
    vessels_raw = data.get("vessels")
    if not isinstance(vessels_raw, list) or not vessels_raw:
        raise ScenarioError("vessels: need at least one [[vessels]] table")
    mission = None
    if "mission" in data:
        from mjasc.missions.config import check_mission, parse_mission

        mission = parse_mission(data["mission"], "mission")
    path_optional = mission is not None and not {"go_to_formation", "follow_path"} & set(mission.phases)
    base_dir = None if source.startswith("<") else FilePath(source).parent
    vessels = tuple(_vessel(v, i, path_optional, base_dir) for i, v in enumerate(vessels_raw))
    for i, v in enumerate(vessels):  # (a sensor scans at the sensing slots: a faster rate would be silently capped)
        sensor = v.options.get("sensor")
        if sensor is not None and sensor.rate_hz > rates.sensing_hz * (1.0 + 1e-12):
            raise ScenarioError(f"vessels[{i}].sensor.rate_hz: must be ≤ rates.sensing_hz = {rates.sensing_hz:g} Hz "
                                f"(a sensor scans at the sensing slots), got {sensor.rate_hz:g}")
    names = [v.name for v in vessels]
    for i, n in enumerate(names):
        if names.index(n) != i:
            raise ScenarioError(f"vessels[{i}].name: duplicate name {n!r}")
    statics = tuple(_static(o, i) for i, o in enumerate(_list(data.get("static_obstacles", []), "static_obstacles")))
    moving = tuple(_moving(o, i) for i, o in enumerate(_list(data.get("moving_obstacles", []), "moving_obstacles")))
    obstacle_names = [o.name for o in statics] + [o.name for o in moving]
    for i, n in enumerate(obstacle_names):
        if obstacle_names.index(n) != i:
            raise ScenarioError(f"obstacles: duplicate obstacle name {n!r}")
        if n in names:  # (the summary's clearances are keyed by name: one name, one body)
            raise ScenarioError(f"obstacles: {n!r} is also a vessel's name (names must be unique across "
                                f"vessels and obstacles)")
    check_camera_vessel(outputs, names)
    comms = None
    if "comms" in data:
        import importlib

        try:
            parse_network = importlib.import_module("mjasc.cooperation.comms").parse_network_options
        except (ImportError, AttributeError):
            raise ScenarioError("comms: the comms link is not available in this version of mjasc") from None
        try:
            comms = parse_network(table(data["comms"], "comms"), "comms")
            comms.hears(names)  # leader and links name team members
        except ValueError as exc:
            msg = str(exc)
            raise ScenarioError(msg if msg.startswith("comms") else f"comms: {msg}") from None
        if not any("comms" in v.options for v in vessels):  # (the link would carry nothing: a forgotten table?)
            raise ScenarioError("comms: no vessel takes part in the link (give the coordinated vessels a "
                                "[vessels.comms] table, or remove [comms])")
    if mission is not None:
        team_hears = comms.hears(names) if comms is not None else None  # (the runner's team: every vessel)
        check_mission(mission, vessels, [o.name for o in moving], team_hears, moving)
    else:
        for i, v in enumerate(vessels):
            if "mission" in v.options:
                raise ScenarioError(f"vessels[{i}].mission: the scenario has no [mission] table to take part in")
    check_team_link(vessels, rates)
    description = data.get("description", "")
    if not isinstance(description, str):
        raise ScenarioError(f"description: must be a string, got {show(description)}")
    scenario = Scenario(name, description, duration, seed, rates, outputs, current,
                        dict(cur_cfg), vessels, statics, moving, source, data, comms, mission)
    check_plausible(scenario, {v.type: load_vessel_type(v.type) for v in vessels})
    return scenario


def _list(value: Any, where: str) -> list:
    if not isinstance(value, list):
        raise ScenarioError(f"{where}: must be an array of tables ([[{where}]]), got {value!r}")
    return value


def load_scenario(path: str | FilePath, *, seed: Any = None, duration_s: Any = None) -> Scenario:
    """Read and validate a scenario file, given by its path (relative to the current folder) or by
    the name of a bundled scenario (``"demo"``, ``"thesis_6_2_dock"``: ``mjasc list`` shows them).
    ``seed`` / ``duration_s`` (not None): the file read as if it said so (``mjasc run --seed
    --duration``): every check sees those values and only those — a traffic path that reaches a
    structure after the new duration is fine, one that reaches it before is not.
    Raises :class:`ScenarioError` naming the file and the field."""
    path = resolve_bundled(path, "scenario")
    data = load_toml(path, ScenarioError, "scenario")
    if seed is not None or duration_s is not None:
        data = {**data, **{k: v for k, v in (("seed", seed), ("duration_s", duration_s)) if v is not None}}
    try:
        return parse_scenario(data, str(path))
    except ScenarioError as exc:
        raise ScenarioError(f"{path}: {exc}") from None
