"""The 22 Imazu encounter cases, scaled from ships to an Otter, as scenario tables.

Imazu (1987) proposed 22 standard encounters for testing ship collision avoidance: cases 1–4
have one target (1 head-on, 2 crossing where the own ship gives way, 3 overtaking, 4 crossing where
it stands on), 5–11 two targets and 12–22 three. :data:`IMAZU_CASES` holds them in the encoding of
the NTNU colav-simulator (``imazu01 … imazu22``): the own ship at the origin heading north at
10 m/s; each target as (ΔN [m], ΔE [m], course [° clockwise from north], speed [m/s]) relative to
the own ship, NED; and the TCPA [s] / DCPA [m] of the undisturbed straight-line motion.

**Why this encoding.** It gives absolute start states, so the relative geometry — DCPAs of
0–110 m for the threats, 250–730 m for background targets, and TCPAs spread over 300–1160 s so
that the targets of a multi-target case arrive one after the other — is kept as published. The
other public encoding (every target reaching one common point at one time, DCPA 0) makes every case
a simultaneous collision course; that is one of the encounter families' settings (multi_target
with dcpa_m = 0 and equal TCPAs), not Imazu's situations.

**Scaling** (case by case). Speeds scale by s = U_own / 10 m/s = 0.15 (an Otter at its 1.5 m/s
cruise; targets at 5, 9, 10 m/s become 0.75, 1.35, 1.5 m/s), which keeps every speed ratio and
every course. Distances scale by λ_c = 110 m / (the case's farthest target's start range), so the
farthest target starts 110 m away, just inside the 120 m sensor range; times scale by
τ_c = λ_c / s, which keeps every course, bearing and the shape of every relative track: DCPA' =
λ_c·DCPA, TCPA' = τ_c·TCPA. λ_c ranges from 0.0078 (case 5, a head-on target 14.1 km away) to 0.053
(case 3, the overtaken ship 2.06 km ahead); the scaled encounters pass within 0–15 m (0–7 Otter
lengths) and reach their CPAs after 25–150 s. A run lasts until 30 s after the last TCPA'.

**NED → ENU.** x = λ_c·ΔE, y = λ_c·ΔN, yaw = 90° − course (counter-clockwise from east); the own
Otter starts at the origin with yaw 90° (north) and follows a straight path north at 1.5 m/s with
the range sensor (120 m), the IMM tracker and collision avoidance of the encounter families.

``scripts/make_imazu_tasks.py`` writes ``tasks/imazu/imazu_01.toml … imazu_22.toml`` from
:func:`imazu_document` (each states the case, the published numbers and the scaling in its
header) and ``tasks/campaigns/imazu.toml``. A campaign family of kind ``imazu`` generates the same
scenarios with parameters ``case`` (1–22; default: a grid over all 22), ``current_m_s``,
``current_direction_deg``, ``sensor_range_noise_m``, ``sensor_dropout`` and ``seed`` (as
:class:`mjasc.campaigns.encounter_parameters.Conditions` declares them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from mjasc.evaluation.colreg import role_from_geometry, wrap_deg
from mjasc.campaigns.cpa import bearing_deg, cpa
from mjasc.campaigns.distributions import Grid, ParameterSpace, family_rng
from mjasc.campaigns.encounter_parameters import Conditions
from mjasc.campaigns.encounters import own_vessel_table
from mjasc.campaigns.perturbation import CampaignError
from mjasc.core.config_tables import (
    check_keys,
    check_params,
    errors_as,
    integer,
    number,
    param,
    read_field,
    string,
    table,
)

__all__ = ["IMAZU_CASES", "SHIP_SPEED_M_S", "OWN_SPEED_M_S", "START_RANGE_M", "TARGET_RADIUS_M", "AFTER_CPA_S",
           "ImazuCase", "ScaledCase", "scale_case", "imazu_document", "imazu_header", "ImazuFamily", "parse_family"]

SHIP_SPEED_M_S = 10.0   # the own ship's speed in the published cases
OWN_SPEED_M_S = 1.5     # the Otter's cruise speed
START_RANGE_M = 110.0   # the farthest target's start range after scaling (sensor range 120 m)
TARGET_RADIUS_M = 2.0   # scaled ships: a bounding circle of an Otter-sized hull and its wake
AFTER_CPA_S = 30.0

# case: (type, [(ΔN m, ΔE m, course °, speed m/s)], [(TCPA s, DCPA m)])
IMAZU_CASES: dict[int, tuple[str, list[tuple[float, float, float, float]], list[tuple[float, float]]]] = {
    1: ("head-on", [(13060, 0, 180, 10)], [(653, 0)]),
    2: ("crossing, own ship gives way", [(7060, 7000, 270, 10)], [(703, 42)]),
    3: ("overtaking", [(2060, 0, 0, 5)], [(412, 0)]),
    4: ("crossing, own ship stands on", [(2560, -5500, 40, 10)], [(884, 525)]),
    5: ("multi", [(7060, 7000, 270, 10), (14120, 0, 180, 10)], [(703, 42), (706, 0)]),
    6: ("multi", [(2560, 5000, 320, 10), (860, 2700, 342, 10)], [(815, 696), (895, 427)]),
    7: ("multi", [(2560, 5000, 320, 9), (2060, 0, 0, 5)], [(855, 109), (412, 0)]),
    8: ("multi", [(7060, -7000, 90, 10), (14120, 0, 180, 10)], [(703, 42), (706, 0)]),
    9: ("multi", [(7060, 7000, 270, 10), (810, 2950, 345, 10)], [(703, 42), (1161, 418)]),
    10: ("multi", [(7060, 7000, 270, 10), (710, -2750, 45, 10)], [(703, 42), (367, 396)]),
    11: ("multi", [(7060, -7000, 90, 10), (810, 2950, 345, 10)], [(703, 42), (1161, 418)]),
    12: ("multi", [(2560, 5000, 320, 9), (710, -2750, 45, 10), (14120, 0, 180, 10)],
         [(855, 109), (367, 396), (706, 0)]),
    13: ("multi", [(2560, -5500, 40, 10), (710, -2750, 45, 10), (14120, 0, 180, 10)],
         [(884, 525), (367, 396), (706, 0)]),
    14: ("multi", [(2200, 5000, 320, 10), (500, 2700, 342, 10), (5700, 6400, 270, 10)],
         [(797, 357), (877, 71), (605, 495)]),
    15: ("multi", [(2200, 5000, 320, 10), (1700, 0, 0, 5), (5700, 6400, 270, 10)], [(797, 357), (340, 0), (605, 495)]),
    16: ("multi", [(7060, -7000, 90, 10), (710, -2750, 45, 10), (7060, 7000, 270, 10)],
         [(703, 42), (367, 396), (703, 42)]),
    17: ("multi", [(2200, 5000, 320, 10), (1700, 0, 0, 5), (350, -2750, 45, 10)], [(797, 357), (340, 0), (349, 729)]),
    18: ("multi", [(2200, 5000, 320, 10), (500, 2700, 342, 10), (10200, 4500, 225, 10)],
         [(797, 357), (877, 71), (603, 254)]),
    19: ("multi", [(350, -2450, 45, 10), (500, 2700, 342, 10), (10200, 4500, 225, 10)],
         [(313, 614), (877, 71), (603, 254)]),
    20: ("multi", [(500, 2700, 342, 10), (1700, 0, 0, 5), (5700, 6400, 270, 10)], [(877, 71), (340, 0), (605, 495)]),
    21: ("multi", [(350, -2450, 45, 10), (500, 2700, 342, 10), (5700, 6400, 270, 10)],
         [(313, 614), (877, 71), (605, 495)]),
    22: ("multi", [(2200, 5000, 320, 10), (1700, 0, 0, 5), (5700, 6400, 270, 10)], [(797, 357), (340, 0), (605, 495)]),
}
"""The published cases (colav-simulator encoding); the TCPA/DCPA columns are recomputed with
straight-line motion and rounded to whole seconds and metres."""


@dataclass(frozen=True)
class ScaledCase:
    """One case after scaling (ENU, the own vessel at the origin heading north)."""

    case: int
    kind: str
    length_scale: float            # λ_c
    speed_scale: float             # s
    time_scale: float              # τ_c = λ_c / s
    positions_m: np.ndarray        # (n, 2) target starts, ENU
    yaws_deg: np.ndarray           # (n,) target yaw, counter-clockwise from east
    speeds_m_s: np.ndarray         # (n,)
    tcpa_s: np.ndarray             # (n,) of the scaled undisturbed motion
    dcpa_m: np.ndarray             # (n,)
    roles: tuple[str, ...]         # the own vessel's COLREG role against each target (evaluation.colreg.role_from_geometry)
    duration_s: float


def scale_case(case: int, own_speed_m_s: float = OWN_SPEED_M_S, start_range_m: float = START_RANGE_M) -> ScaledCase:
    """Case ``case`` (1–22) scaled as the module docstring states."""
    if case not in IMAZU_CASES:
        raise ValueError(f"case: must be 1 … 22, got {case}")
    kind, targets, _ = IMAZU_CASES[case]
    s = own_speed_m_s / SHIP_SPEED_M_S
    north_east = np.array([[t[0], t[1]] for t in targets], dtype=float)
    lam = start_range_m / float(np.max(np.hypot(north_east[:, 0], north_east[:, 1])))
    pos = lam * north_east[:, ::-1]  # (x, y) = λ (ΔE, ΔN)
    course = np.array([t[2] for t in targets], dtype=float)
    yaw = np.array([wrap_deg(90.0 - c) for c in course])
    speed = s * np.array([t[3] for t in targets], dtype=float)
    own_v = np.array([0.0, own_speed_m_s])
    tc, dc, roles = [], [], []
    for p, y, v, c in zip(pos, yaw, speed, course):
        vel = v * np.array([math.cos(math.radians(y)), math.sin(math.radians(y))])
        t, d = cpa(p, vel - own_v)
        tc.append(t)
        dc.append(d)
        # Bow frame of a vessel heading north: forward = +y, port = −x.
        roles.append(role_from_geometry(float(bearing_deg(p[1], -p[0])), wrap_deg(c)))
    return ScaledCase(case, kind, lam, s, lam / s, pos, yaw, speed, np.array(tc), np.array(dc), tuple(roles),
                      float(np.ceil(max(tc) + AFTER_CPA_S)))


def imazu_document(case: int, sensor: dict | None = None, current_m_s: tuple[float, float] = (0.0, 0.0)) -> dict:
    """The scenario document of case ``case`` (what ``tasks/imazu/imazu_NN.toml`` holds)."""
    sc = scale_case(case)
    length = OWN_SPEED_M_S * (sc.duration_s + 30.0) + 20.0
    doc = {"name": f"imazu_{case:02d}",
           "description": f"Imazu case {case} ({sc.kind}), scaled to an Otter at 1.5 m/s (λ = {sc.length_scale:.5f})",
           "duration_s": sc.duration_s, "seed": 0,
           "current": {"type": "uniform", "velocity_m_s": [float(current_m_s[0]), float(current_m_s[1])]},
           "vessels": [own_vessel_table("own", "otter", (0.0, 0.0), 90.0, OWN_SPEED_M_S, length, sensor or {}, {})],
           "moving_obstacles": [
               {"name": f"target_{j + 1}", "radius_m": TARGET_RADIUS_M,
                "position_m": [round(float(p[0]), 3) + 0.0, round(float(p[1]), 3) + 0.0],
                "heading_deg": float(y), "speed_m_s": round(float(v), 6)}
               for j, (p, y, v) in enumerate(zip(sc.positions_m, sc.yaws_deg, sc.speeds_m_s))]}
    return doc


def imazu_header(case: int) -> str:
    """The header comment of a task file: the case, the published numbers, the scaling."""
    sc = scale_case(case)
    kind, targets, table_cpa = IMAZU_CASES[case]
    lines = [f"Imazu case {case}: {kind}, {len(targets)} target(s). Written by scripts/make_imazu_tasks.py from",
             "mjasc/campaigns/imazu.py (edit that, not this file). Published (colav-simulator encoding, NED): own ship",
             "at the origin, course 0° (north), 10 m/s; targets (ΔN m, ΔE m, course °, speed m/s) → TCPA s / DCPA m:"]
    for j, (t, (tc, dc)) in enumerate(zip(targets, table_cpa)):
        lines.append(f"  target_{j + 1}: ({t[0]:g}, {t[1]:g}, {t[2]:g}, {t[3]:g}) → {tc:g} / {dc:g}")
    lines += [f"Scaling: speeds × s = {sc.speed_scale:g} (own 1.5 m/s, every speed ratio kept), distances × λ = "
              f"{sc.length_scale:.6f} (the farthest",
              f"target starts {START_RANGE_M:g} m away, inside the 120 m sensor range), times × τ = λ/s = "
              f"{sc.time_scale:.6f}; courses kept.",
              "NED → ENU: x = λ·ΔE, y = λ·ΔN, heading_deg = 90 − course. Scaled, undisturbed (nobody manoeuvres):"]
    for j in range(len(targets)):
        lines.append(f"  target_{j + 1}: TCPA {sc.tcpa_s[j]:.2f} s, DCPA {sc.dcpa_m[j]:.2f} m, "
                     f"speed {sc.speeds_m_s[j]:g} m/s, own role: {sc.roles[j]}")
    lines.append(f"Duration: the last TCPA + {AFTER_CPA_S:g} s, rounded up.")
    return "\n".join(lines)


# ---------------------------------------------------------------------- as a campaign family
@dataclass(frozen=True)
class ImazuCase:
    case: int = param(1, minimum=1, maximum=22, doc="the Imazu case, 1–22")

    def __post_init__(self):
        check_params(self, "parameters")


_SHARED = ("current_m_s", "current_direction_deg", "sensor_range_noise_m", "sensor_dropout", "seed")


@dataclass(frozen=True)
class ImazuFamily:
    name: str
    index: int
    space: ParameterSpace
    duration_s: float | None = None   # default: the case's (its last TCPA + 30 s)
    kind = "imazu"

    @property
    def runs(self) -> int:
        return self.space.runs

    def generate(self, k: int, base_seed: int, index: int) -> tuple[dict, dict, int, str]:
        v = self.space.draw(k, family_rng(base_seed, self.index, k))
        c = int(v["case"])
        cond = {f.name: f.default for f in fields(Conditions)}
        cond.update({n: v[n] for n in _SHARED})
        cond = Conditions(**cond)
        h = math.radians(90.0 - cond.current_direction_deg)
        current = (round(cond.current_m_s * math.cos(h), 6) + 0.0, round(cond.current_m_s * math.sin(h), 6) + 0.0)
        doc = imazu_document(c, {"range_noise_std_m": cond.sensor_range_noise_m,
                                 "dropout_probability": cond.sensor_dropout}, current)
        sc = scale_case(c)
        params = {n: val for n, val in v.items() if val is not None}
        for j in range(len(sc.roles)):
            params.update({f"t{j + 1}.role": sc.roles[j], f"t{j + 1}.tcpa_s": float(sc.tcpa_s[j]),
                           f"t{j + 1}.dcpa_m": float(sc.dcpa_m[j])})
        seed = cond.seed if cond.seed is not None else base_seed + index
        doc.pop("name")
        if self.duration_s is not None:
            doc["duration_s"] = self.duration_s
        params["duration_s"] = float(doc["duration_s"])  # (as an encounter run's: ended_before_cpa reads it)
        return params, doc, int(seed), imazu_header(c)


def parse_family(t: dict, where: str, index: int, base_dir: str | Path, thresholds=None) -> ImazuFamily:
    """A ``[[families]]`` table of kind ``imazu`` (``name``, ``runs_per_point``, ``duration_s``,
    ``[parameters]``)."""
    with errors_as(CampaignError):
        check_keys(t, {"name", "kind", "runs_per_point", "duration_s", "parameters"}, where)
        name = string(t.get("name", "imazu"), f"{where}.name")
        runs = integer(t.get("runs_per_point", 1), f"{where}.runs_per_point", minimum=1)
        duration = number(t["duration_s"], f"{where}.duration_s", positive=True) if "duration_s" in t else None
        given = dict(table(t.get("parameters", {}), f"{where}.parameters"))
        declared = {"case": 1, **{n: next(f.default for f in fields(Conditions) if f.name == n) for n in _SHARED}}

        def check(pname, value, w):
            if value is None:
                return None
            parent, _, key = w.rpartition(".")
            return read_field(ImazuCase if pname == "case" else Conditions, pname, {key: value}, parent, key=key)

        space = ParameterSpace.build(declared, given, f"{where}.parameters", check, runs)
        if "case" not in given:  # default: every case
            space = ParameterSpace(tuple((n, Grid(tuple(range(1, 23))) if n == "case" else law)
                                         for n, law in space.laws), runs)
    return ImazuFamily(name, index, space, duration)


# ---------------------------------------------------------------------- the shipped files
CAMPAIGN_SEEDS = 10
"""Runs (seeds) per case in ``tasks/campaigns/imazu.toml``."""


def task_files() -> dict[str, str]:
    """Path under ``tasks/`` → text, for every file scripts/make_imazu_tasks.py writes."""
    from mjasc.campaigns.scenario_text import scenario_toml

    files = {}
    for case in IMAZU_CASES:
        doc = imazu_document(case)
        doc["seed"] = case
        files[f"imazu/imazu_{case:02d}.toml"] = scenario_toml(doc, header=imazu_header(case))
    cases = ", ".join(str(c) for c in IMAZU_CASES)
    files["campaigns/imazu.toml"] = f"""\
# The 22 Imazu encounter cases (tasks/imazu/imazu_01.toml … imazu_22.toml: the case, the published
# numbers and the scaling to an Otter are in each file's header), {CAMPAIGN_SEEDS} seeds each: run k has seed
# base_seed + k (sensor noise, dropout and clutter differ; the geometry is the case's). Written by
# scripts/make_imazu_tasks.py. Run: `mjasc campaign imazu` (format: docs/campaigns.md).
name = "imazu"
description = "The 22 Imazu cases scaled to an Otter at 1.5 m/s, {CAMPAIGN_SEEDS} seeds each"
base_seed = 0

[[families]]
kind = "imazu"
name = "imazu"
runs_per_point = {CAMPAIGN_SEEDS}                     # seeds per case
[families.parameters]
case = {{ grid = [{cases}] }}
"""
    return files
