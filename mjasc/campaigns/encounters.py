"""Encounter families: parameters of an encounter → a scenario table (an own vessel or a team, and
targets on straight lines).

Kinds: ``head_on``, ``crossing_give_way``, ``crossing_stand_on``, ``overtaking``, ``overtaken``
(one target with that COLREG role, :mod:`mjasc.evaluation.colreg`), ``multi_target`` (one target
per entry of ``roles``), ``team_vs_traffic`` (a team in line abreast, with comms, against the
targets of ``roles``), ``bottleneck`` (the own vessel passes a gap between two islands where the
targets of ``roles`` meet it). A family table::

    [[families]]
    kind = "multi_target"
    name = "three_ships"                  # default: the kind
    runs_per_point = 20
    roles = ["head_on", "crossing_give_way", "crossing_stand_on"]   # multi_target, team_vs_traffic, bottleneck
    duration_s = 90.0                     # default: the last TCPA + after_cpa_s
    own = { avoidance = { window_s = 30.0 } }   # merged into every own vessel's table (type, sensor,
                                          # tracking, avoidance, comms)
    rates = { prediction_period_s = 2.0 } # the scenario's [rates]
    [families.parameters]                 # laws (distributions.py); shared by all targets …
    dcpa_m = { uniform = [-10.0, 10.0] }
    t2.tcpa_s = 60.0                      # … or for target 2 only (several targets: t1, t2, …)

**The geometry** (:mod:`mjasc.campaigns.cpa`). The own vessel (or the team's centre) starts at the
origin with yaw ``own_heading_deg`` (ENU, counter-clockwise from east; default 90 = north) and
follows a straight mission path at ``own_speed_m_s``. Each target moves on a straight line at
``speed_ratio`` × the own speed (a kinematic moving obstacle, over ground), placed so that the
undisturbed motion (nobody manoeuvres) has exactly the signed ``dcpa_m`` at ``tcpa_s``.
``relative_course_deg`` (the aspect: target course − own course, **clockwise**, 180 = reciprocal)
is given and the relative bearing at t = 0 follows — or ``relative_bearing_deg`` (clockwise from
the own bow, at t = 0) is given and the course follows (give one, not both: with the speed ratio,
DCPA and TCPA they would over-determine the target). DCPA > 0 is the side the rules ask for (port
to port head-on, a crossing target from starboard passes ahead of the own vessel); < 0 the other
side (cpa.py). In a uniform current (``current_m_s`` toward ``current_direction_deg``, clockwise
from the own course) the own speed loop holds the surge over ground, so the undisturbed own motion
stays on the path at the mission speed up to the crab angle (a factor 1/cos(crab) < 1.01 for
0.2 m/s across 1.5 m/s); the targets are not set by the current.

**Roles and resampling.** Each target's role at t = 0 (:func:`mjasc.evaluation.colreg.role_from_geometry`
with the campaign's ``[colreg]`` thresholds) must be the family's; a target must also start
:data:`START_MARGIN_M` clear of every own vessel, and in a bottleneck its track must clear the
islands. A draw that fails is drawn again from the same generator (the laws are truncated to the
role's region), at most :data:`MAX_ATTEMPTS` times per run.

**Defaults** (a parameter the file does not give is fixed at its default; declared in
:mod:`mjasc.campaigns.encounter_parameters`): ``Conditions``, ``Team``, ``Bottleneck``,
``TargetParameters``, and per role ``ROLE_DEFAULTS``
(chosen so that the target starts 80–110 m away, inside the 120 m sensor range):

    role                 relative course   speed ratio   TCPA    start range (DCPA 0, 1.5 m/s)
    head_on                  180°             1.0         35 s      105 m
    crossing_give_way        −90°             1.0         50 s      106 m
    crossing_stand_on        +90°             1.0         50 s      106 m
    overtaking                 0°             0.4         90 s       81 m
    overtaken                  0°             1.6         90 s       81 m

Every own vessel carries a 360-beam range sensor (120 m), the IMM tracker and collision avoidance
(window 40 s, safety distance 1.5 m), as the demo's Otters do; team vessels add coordination
(``[vessels.comms]``) on a radio link with ``comms_loss``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np

from mjasc.evaluation.colreg import GEOMETRIC_ROLES, ColregConfig, role_from_geometry, wrap_deg
from mjasc.campaigns.cpa import Placement, course_for_bearing, place_target
from mjasc.campaigns.distributions import ParameterSpace, family_rng
from mjasc.campaigns.encounter_parameters import ROLE_DEFAULTS, Bottleneck, Conditions, TargetParameters, Team
from mjasc.campaigns.perturbation import CampaignError
from mjasc.core.config_tables import (
    check_keys,
    errors_as,
    integer,
    number,
    read_field,
    string,
    table,
)
from mjasc.core.geometry import signed_distance_to_polygon
from mjasc.physics.vessels import load_vessel_type, resolve_vessel_type, vessel_files
from mjasc.runs.plausibility import check_name

__all__ = ["FAMILY_KINDS", "MAX_ATTEMPTS", "START_MARGIN_M", "EncounterFamily", "parse_family", "own_vessel_table"]

FAMILY_KINDS = (*GEOMETRIC_ROLES, "multi_target", "team_vs_traffic", "bottleneck")
MAX_ATTEMPTS = 1000
START_MARGIN_M = 5.0
"""Hull-to-hull distance [m] every target must keep from every own vessel at t = 0."""
ISLAND_MARGIN_M = 1.0
"""Distance [m] a target's track keeps from the bottleneck's islands (beyond its radius)."""


_GROUPS = {"team_vs_traffic": (Conditions, Team), "bottleneck": (Conditions, Bottleneck)}
_DEFAULT_ROLES = {"multi_target": ("head_on", "crossing_give_way", "crossing_stand_on"),
                  "team_vs_traffic": ("crossing_give_way",), "bottleneck": ("head_on",)}
_OWN_KEYS = {"type", "sensor", "tracking", "avoidance", "comms"}
SENSOR = {"beams": 360, "max_range_m": 120.0}
AVOIDANCE = {"window_s": 40.0, "safety_distance_m": 1.5}
COORDINATION = {"max_speed_correction": 0.4, "error_scale_m": 10.0}


class _Reject(Exception):
    """A draw whose encounter does not fit the family (the message says why)."""


def _names(cls) -> list[str]:
    return [f.name for f in fields(cls)]


def own_vessel_table(name: str, vessel_type: str, position_m, heading_deg: float, speed_m_s: float,
                     length_m: float, sensor: dict, overrides: dict) -> dict:
    """A ``[[vessels]]`` table: a straight mission path of ``length_m`` along the heading, the
    sensor, tracker and avoidance, and ``overrides`` merged in (tables updated key by key)."""
    h = math.radians(heading_deg)
    end = [position_m[0] + length_m * math.cos(h), position_m[1] + length_m * math.sin(h)]
    controller = {"type": "path_following", "waypoints": [_pt(position_m), _pt(end)], "speed_m_s": _r(speed_m_s)}
    t = {"name": name, "type": vessel_type, "position_m": _pt(position_m), "heading_deg": _r(heading_deg),
         "speed_m_s": _r(speed_m_s), "controller": controller, "sensor": {**SENSOR, **sensor}, "tracking": {},
         "avoidance": dict(AVOIDANCE)}
    for key, value in overrides.items():
        if key == "type":
            continue
        t[key] = {**t.get(key, {}), **value}
    return t


def _r(x: float) -> float:
    """Generated numbers are written to 1 µm / 1 µdeg: readable files, far below any tolerance."""
    return round(float(x), 6) + 0.0


def _pt(p) -> list[float]:
    return [_r(p[0]), _r(p[1])]


@dataclass(frozen=True)
class EncounterFamily:
    name: str
    kind: str
    index: int
    roles: tuple[str, ...]
    space: ParameterSpace
    bearing_given: tuple[bool, ...]   # per target: the bearing is given (the course follows)
    thresholds: ColregConfig
    duration_s: float | None = None
    own: dict | None = None
    rates: dict | None = None

    @property
    def runs(self) -> int:
        return self.space.runs

    def references(self) -> dict:
        """Files the runs depend on (their content goes into the campaign's digest): the files of
        the own vessels' vessel folder, when ``own.type`` is one (an edited hull, a new campaign)."""
        vtype = (self.own or {}).get("type", "")
        files = vessel_files(vtype) if vtype else {}
        return {f"families[{self.index}].own.type": files} if files else {}

    def _prefix(self, j: int) -> str:
        return f"t{j + 1}." if len(self.roles) > 1 else ""

    def generate(self, k: int, base_seed: int, index: int) -> tuple[dict, dict, int, str]:
        """(parameters, scenario document, seed, header) of family run k (campaign run ``index``)."""
        rng = family_rng(base_seed, self.index, k)
        last = ""
        for attempt in range(1, MAX_ATTEMPTS + 1):
            values = self.space.draw(k, rng)
            try:
                params, doc, header = self._build(values)
            except _Reject as exc:
                last = str(exc)
                continue
            seed = values["seed"] if values["seed"] is not None else base_seed + index
            params["draws"] = attempt  # (how many draws the family's encounter took: not the run's attempts)
            return params, doc, int(seed), header
        raise CampaignError(f"families[{self.index}] ({self.name}) run {k}: no draw in {MAX_ATTEMPTS} attempts "
                            f"gives the family's encounter; last: {last}")

    def searchable(self) -> list[str]:
        """The parameters a search may move: those drawn from a continuous law (not fixed, not a grid,
        not a choice)."""
        from mjasc.campaigns.distributions import Normal, Uniform

        return [n for n, law in self.space.laws if isinstance(law, (Uniform, Normal))]

    def from_unit(self, u: dict[str, float]) -> tuple[dict, dict, str]:
        """(parameters, scenario document, header) for the searchable parameters at the quantiles
        ``u`` ∈ [0, 1] of their laws (the others at their fixed values or grid point 0). Raises
        ValueError when the point does not give the family's encounter (its role, its clearances)."""
        values = {}
        for name, law in self.space.laws:
            if name in u:
                values[name] = law.value(float(min(max(u[name], 0.0), 1.0)))
            elif law.grid:
                values[name] = law.values[0]
            else:
                values[name] = law.value(0.5)
        try:
            return self._build(values)
        except _Reject as exc:
            raise ValueError(str(exc)) from None

    # ------------------------------------------------------------------ one draw → one scenario
    def _build(self, v: dict) -> tuple[dict, dict, str]:
        cond = Conditions(**{n: v[n] for n in _names(Conditions)})
        team = Team(**{n: v[n] for n in _names(Team)}) if self.kind == "team_vs_traffic" else None
        neck = Bottleneck(**{n: v[n] for n in _names(Bottleneck)}) if self.kind == "bottleneck" else None
        own = self.own or {}
        vtype = own.get("type", "otter")
        vt = load_vessel_type(vtype)
        speed = cond.own_speed_m_s or vt.cruise_speed_m_s
        psi = math.radians(cond.own_heading_deg)
        rot = np.array([[math.cos(psi), -math.sin(psi)], [math.sin(psi), math.cos(psi)]])
        n_own = team.team_size if team else 1
        lateral = [((n_own - 1) / 2 - i) * (team.team_spacing_m if team else 0.0) for i in range(n_own)]
        own_xy = [rot @ np.array([0.0, y]) for y in lateral]
        params = {n: v[n] for n in v if v[n] is not None}
        params["own_speed_m_s"] = speed
        targets, lines = [], []
        for j, role in enumerate(self.roles):
            pre = self._prefix(j)
            tp = TargetParameters(**{n: v[pre + n] for n in _names(TargetParameters)})
            p = self._place(role, tp, speed, j)
            start = rot @ p.position_body_m
            gap = min(np.hypot(*(start - o)) for o in own_xy) - tp.target_radius_m - vt.radius_m
            if gap < START_MARGIN_M:
                raise _Reject(f"target {j + 1} starts {gap:.1f} m from an own vessel (< {START_MARGIN_M} m)")
            heading = wrap_deg(cond.own_heading_deg - p.relative_course_deg)
            targets.append((tp, p, start, heading))
            derived = ("relative_course_deg", p.relative_course_deg) if self.bearing_given[j] else \
                ("relative_bearing_deg", p.bearing_deg)  # the other one is drawn
            params.update({f"{pre}{derived[0]}": derived[1], f"{pre}start_range_m": p.range_m, f"{pre}role": role})
            lines.append(f"target {j + 1}: {role}, bearing {p.bearing_deg:+.2f}°, relative course "
                         f"{p.relative_course_deg:+.2f}°, speed {tp.speed_ratio * speed:.3f} m/s (ratio "
                         f"{tp.speed_ratio:g}), DCPA {tp.dcpa_m:+.3f} m at TCPA {tp.tcpa_s:g} s, start range "
                         f"{p.range_m:.2f} m")
        duration = self.duration_s or max(t[0].tcpa_s for t in targets) + cond.after_cpa_s
        params["duration_s"] = duration
        doc: dict[str, Any] = {"description": f"{self.kind} encounter (campaign family {self.name})",
                               "duration_s": _r(duration)}
        if self.rates:
            doc["rates"] = dict(self.rates)
        cdir = psi - math.radians(cond.current_direction_deg)
        doc["current"] = {"type": "uniform", "velocity_m_s": [_r(cond.current_m_s * math.cos(cdir)),
                                                                _r(cond.current_m_s * math.sin(cdir))]}
        if team:
            doc["comms"] = {"preset": "radio", "range_m": 500.0, "loss_probability": team.comms_loss}
        sensor = {"range_noise_std_m": cond.sensor_range_noise_m, "dropout_probability": cond.sensor_dropout}
        length = speed * (duration + 30.0) + 20.0
        overrides = {key: value for key, value in own.items()}
        if team:
            overrides["comms"] = {**COORDINATION, **overrides.get("comms", {})}
        names = ["own"] if n_own == 1 else [f"own_{i + 1}" for i in range(n_own)]
        doc["vessels"] = [own_vessel_table(nm, vtype, xy, cond.own_heading_deg, speed, length, sensor, overrides)
                          for nm, xy in zip(names, own_xy)]
        if neck:
            islands = self._islands(neck, rot, speed * targets[0][0].tcpa_s)
            self._check_islands(islands, targets, speed, duration)
            doc["static_obstacles"] = [{"name": nm, "type": "polygon", "vertices": [_pt(q) for q in poly]}
                                       for nm, poly in zip(("port_island", "starboard_island"), islands)]
        doc["moving_obstacles"] = [
            {"name": "target" if len(targets) == 1 else f"target_{j + 1}", "radius_m": tp.target_radius_m,
             "position_m": _pt(start), "heading_deg": _r(heading), "speed_m_s": _r(tp.speed_ratio * speed)}
            for j, (tp, p, start, heading) in enumerate(targets)]
        return params, doc, "\n".join(lines)

    def _place(self, role: str, tp: TargetParameters, speed: float, j: int) -> Placement:
        th = self.thresholds
        if self.bearing_given[j]:
            p = course_for_bearing(speed, tp.relative_bearing_deg, tp.speed_ratio, tp.dcpa_m, tp.tcpa_s,
                                   accept=lambda q: role_from_geometry(q.bearing_deg, q.relative_course_deg, th) == role,
                                   nominal_course_deg=ROLE_DEFAULTS[role]["relative_course_deg"])
            if p is None:
                raise _Reject(f"target {j + 1}: no course gives bearing {tp.relative_bearing_deg:.2f}° as {role} "
                              f"(speed ratio {tp.speed_ratio:g}, DCPA {tp.dcpa_m:g} m, TCPA {tp.tcpa_s:g} s)")
            return p
        p = place_target(speed, tp.relative_course_deg, tp.speed_ratio, tp.dcpa_m, tp.tcpa_s)
        if p is None:
            raise _Reject(f"target {j + 1}: same course and speed as the own vessel: no encounter")
        got = role_from_geometry(p.bearing_deg, p.relative_course_deg, th)
        if got != role:
            raise _Reject(f"target {j + 1}: bearing {p.bearing_deg:.2f}°, relative course {p.relative_course_deg:.2f}° "
                          f"is {got}, not {role}")
        return p

    @staticmethod
    def _islands(b: Bottleneck, rot: np.ndarray, along_m: float) -> list[np.ndarray]:
        """The port and starboard islands (world, counter-clockwise) around the gap at ``along_m``."""
        x0, x1 = along_m - b.island_length_m / 2, along_m + b.island_length_m / 2
        g = b.gap_width_m / 2
        port = [(x0, g), (x1, g), (x1, g + b.island_width_m), (x0, g + b.island_width_m)]
        stbd = [(x0, -g - b.island_width_m), (x1, -g - b.island_width_m), (x1, -g), (x0, -g)]
        return [np.array([rot @ np.array(q) for q in poly]) for poly in (port, stbd)]

    @staticmethod
    def _check_islands(islands, targets, speed: float, duration: float) -> None:
        t = np.arange(0.0, duration + 0.25, 0.25)
        for j, (tp, p, start, heading) in enumerate(targets):
            h = math.radians(heading)
            track = start + np.outer(t * tp.speed_ratio * speed, [math.cos(h), math.sin(h)])
            for poly in islands:
                clear = float(signed_distance_to_polygon(track, poly).min())
                if clear < tp.target_radius_m + ISLAND_MARGIN_M:
                    raise _Reject(f"target {j + 1}'s track passes {clear:.1f} m from an island "
                                  f"(< radius + {ISLAND_MARGIN_M} m)")


# ---------------------------------------------------------------------- parsing
_FAMILY = {"name", "kind", "runs_per_point", "duration_s", "parameters", "roles", "own", "rates"}


def _checker(owners: dict[str, tuple[type, str]]):
    def check(name: str, value: Any, where: str) -> Any:
        cls, fname = owners[name]
        if value is None:
            return None
        parent, _, key = where.rpartition(".")
        return read_field(cls, fname, {key: value}, parent, key=key)

    return check


def parse_family(t: dict, where: str, index: int, base_dir: str | Path, thresholds: ColregConfig) -> EncounterFamily:
    """A ``[[families]]`` table of an encounter kind → :class:`EncounterFamily` (module docstring).
    Raises CampaignError naming the field."""
    with errors_as(CampaignError):
        check_keys(t, _FAMILY, where)
        kind = string(t.get("kind"), f"{where}.kind", choices=FAMILY_KINDS)
        name = check_name(string(t.get("name", kind), f"{where}.name"), f"{where}.name", vessel=False)
        runs = integer(t.get("runs_per_point", 1), f"{where}.runs_per_point", minimum=1)
        duration = number(t["duration_s"], f"{where}.duration_s", positive=True) if "duration_s" in t else None
        if kind in GEOMETRIC_ROLES:
            if "roles" in t:
                raise CampaignError(f"{where}.roles: only for multi_target, team_vs_traffic and bottleneck "
                                    f"(a {kind} family has one {kind} target)")
            roles: tuple[str, ...] = (kind,)
        else:
            raw = t.get("roles", list(_DEFAULT_ROLES[kind]))
            if not isinstance(raw, list) or not 1 <= len(raw) <= 6:
                raise CampaignError(f"{where}.roles: must be a list of 1 to 6 roles, got {raw!r}")
            roles = tuple(string(r, f"{where}.roles[{i}]", choices=GEOMETRIC_ROLES) for i, r in enumerate(raw))
        own = dict(table(t.get("own", {}), f"{where}.own"))
        check_keys(own, _OWN_KEYS, f"{where}.own")
        for key, value in own.items():
            if key == "type":  # (a vessel folder: its absolute path, relative to the campaign file's folder)
                written = string(value, f"{where}.own.type")
                try:
                    own[key] = resolve_vessel_type(written, base_dir)
                except ValueError as exc:
                    raise CampaignError(f"{where}.own.type: {exc}") from None
            else:
                own[key] = dict(table(value, f"{where}.own.{key}"))
        rates = dict(table(t["rates"], f"{where}.rates")) if "rates" in t else None
        declared: dict[str, Any] = {}
        owners: dict[str, tuple[type, str]] = {}
        for cls in _GROUPS.get(kind, (Conditions,)):
            for f in fields(cls):
                declared[f.name], owners[f.name] = f.default, (cls, f.name)
        given = dict(table(t.get("parameters", {}), f"{where}.parameters"))
        multi = len(roles) > 1
        per_target: dict[str, dict] = {}
        for key in list(given):  # t2 = { tcpa_s = … } (TOML's t2.tcpa_s = …) or a flat "t2.tcpa_s" key
            head, dot, rest = key.partition(".")
            if multi and head[:1] == "t" and head[1:].isdigit():
                value = given.pop(key)
                entries = {rest: value} if dot else dict(table(value, f"{where}.parameters.{key}"))
                per_target.setdefault(head, {}).update(entries)
        for key in per_target:
            if not 1 <= int(key[1:]) <= len(roles):
                raise CampaignError(f"{where}.parameters.{key}: there are targets t1 … t{len(roles)}")
        target_keys = set(_names(TargetParameters))
        shared_targets = {key: given.pop(key) for key in list(given) if key in target_keys}
        bearing_given = []
        for j, role in enumerate(roles):
            pre = f"t{j + 1}." if multi else ""
            own_table = dict(table(per_target.get(f"t{j + 1}", {}), f"{where}.parameters.t{j + 1}"))
            check_keys(own_table, target_keys, f"{where}.parameters.t{j + 1}")
            mine = {**shared_targets, **own_table}
            if "relative_bearing_deg" in mine and "relative_course_deg" in mine:
                raise CampaignError(f"{where}.parameters.{pre}relative_bearing_deg: give relative_bearing_deg or "
                                    "relative_course_deg, not both (with the speed ratio, DCPA and TCPA they "
                                    "over-determine the target)")
            bearing_given.append("relative_bearing_deg" in mine)
            defaults = {**{f.name: f.default for f in fields(TargetParameters)}, **ROLE_DEFAULTS[role]}
            if bearing_given[-1]:
                defaults["relative_course_deg"] = None
            for f in fields(TargetParameters):
                declared[pre + f.name], owners[pre + f.name] = defaults[f.name], (TargetParameters, f.name)
                if f.name in mine:
                    given[pre + f.name] = mine[f.name]
        space = ParameterSpace.build(declared, given, f"{where}.parameters", _checker(owners), runs)
    return EncounterFamily(name, kind, index, roles, space, tuple(bearing_given), thresholds, duration, own or None,
                           rates)
