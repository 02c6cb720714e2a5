"""Monte Carlo campaign files (TOML) and the per-run randomization of a scenario.

A campaign file names a scenario, how many runs to make and what to perturb in each run::

    name = "demo_monte_carlo"           # default: the file name
    description = "…"
    scenario = "../demo.toml"           # relative to the campaign file
    runs = 100
    base_seed = 0                       # run k uses seed base_seed + k (sensor noise, comms, …)
    # duration_s = 60.0                 # optional: override the scenario's duration [s]
    [randomize]                         # every sigma optional, default 0 (no perturbation)
    vessel_position_sigma_m = 2.0       # per vessel: isotropic Gaussian on the start position [m]
    vessel_heading_sigma_deg = 5.0      # per vessel: Gaussian on the start heading [deg]
    current_velocity_sigma_m_s = 0.05   # isotropic Gaussian added to the current's velocity [m/s]
    traffic_heading_sigma_deg = 10.0    # per moving obstacle on CV/CT motion: heading [deg]
    traffic_speed_sigma_m_s = 0.1       # per moving obstacle: speed [m/s] (clipped at 0)
    [outputs]
    recordings = false                  # keep each run's recording.rrd + summary.json in runs/<k>/

Randomization of run ``k`` (:func:`randomized_scenario`) is a pure function of the scenario,
the campaign's sigmas, ``base_seed`` and ``k``: the draws come from
``numpy.random.default_rng([base_seed, k, 0xC0FFEE])`` — a stream distinct from every stream the
run itself derives from its seed (``[seed]``, ``[seed, vessel, component]``, docs/architecture.md).
All standard-normal variates are drawn in one fixed order and count, whatever the sigmas, so
changing one sigma never changes another quantity's draw::

    z_pos   (n_vessels, 2)   Δp_i   = σ_p · z_pos[i]            world ENU [m]
    z_head  (n_vessels,)     Δψ_i   = σ_ψ · z_head[i]           [rad], wrapped
    z_cur   (2,)             ΔV_c   = σ_c · z_cur               world ENU [m/s]
    z_thead (n_traffic,)     Δψ_o   = σ_ψo · z_thead[o]         CV/CT traffic only (a path fixes the heading)
    z_tspd  (n_traffic,)     v_o    = max(0, v_o + σ_vo · z_tspd[o])

The current perturbation is a uniform field: a uniform current's velocity becomes ``V + ΔV_c``;
any other field ``F`` becomes the sum ``F + Uniform(ΔV_c)``. The scenario's seed becomes
``base_seed + k`` and a seeded current (``gauss_markov`` without its own seed) is rebuilt from its
table with that seed, exactly as if the scenario file said ``seed = base_seed + k``. With every
sigma 0, run k *is* that scenario (the same objects, nothing redrawn).

**Rejected draws.** Traffic is scripted and avoids nothing, so a heading or speed draw that takes
a moving obstacle's disc into a static obstacle during the run (the demo's ferry sailing through
the pontoon; :func:`mjasc.runs.plausibility.traffic_through_structure`) describes an impossible
encounter: the run draws its whole set again, the next variates of the same generator in the same
order, at most :data:`MAX_DRAWS` times. A run whose first set is accepted is unchanged.

Only :func:`dataclasses.replace` is used on the scenario's dataclasses (no edits to scenario.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from mjasc.core.config_tables import (
    boolean,
    check_keys,
    check_params,
    dataclass_from_table,
    errors_as,
    integer,
    load_toml,
    path_problem,
    show_path,
    number,
    param,
    show,
    table,
)
from mjasc.core.frames import wrap_angle
from mjasc.core.resources import resolve_bundled
from mjasc.physics.currents import SumCurrent, UniformCurrent, current_from_config
from mjasc.runs.plausibility import file_name, traffic_through_structure
from mjasc.runs.scenario import Scenario, ScenarioError, load_scenario

__all__ = ["CampaignError", "Randomization", "Campaign", "RunDraws", "load_campaign", "parse_campaign",
           "draw_perturbations", "randomized_scenario", "RANDOMIZATION_STREAM", "MAX_DRAWS"]

#: Third entry of the per-run seed sequence ``[base_seed, k, RANDOMIZATION_STREAM]``.
RANDOMIZATION_STREAM = 0xC0FFEE
#: Draws tried per run before a run whose traffic always meets a static obstacle is an error.
MAX_DRAWS = 100


class CampaignError(ValueError):
    """A campaign file is invalid; the message names the field and the reason."""


@dataclass(frozen=True)
class Randomization:
    """Standard deviations of the per-run perturbations (0: that quantity is not perturbed)."""

    vessel_position_sigma_m: float = param(0.0, nonneg=True, unit="m",
                                           doc="per vessel: isotropic Gaussian on the start position")
    vessel_heading_sigma_deg: float = param(0.0, nonneg=True, unit="deg", doc="per vessel: Gaussian on the start heading")
    current_velocity_sigma_m_s: float = param(0.0, nonneg=True, unit="m/s",
                                              doc="isotropic Gaussian added to the current's velocity")
    traffic_heading_sigma_deg: float = param(0.0, nonneg=True, unit="deg",
                                             doc="per moving obstacle on CV/CT motion: Gaussian on its heading")
    traffic_speed_sigma_m_s: float = param(0.0, nonneg=True, unit="m/s",
                                           doc="per moving obstacle: Gaussian on its speed (clipped at 0)")

    def __post_init__(self):
        check_params(self, "randomize")

    @property
    def is_zero(self) -> bool:
        return all(getattr(self, f) == 0.0 for f in self.__dataclass_fields__)


@dataclass(frozen=True)
class Campaign:
    """A validated campaign: the base scenario (already loaded and validated), runs, seeds, sigmas."""

    name: str
    description: str
    scenario: Scenario
    scenario_path: str
    runs: int
    base_seed: int = 0
    randomize: Randomization = field(default_factory=Randomization)
    recordings: bool = False
    source: str = ""

    def with_overrides(self, runs: int | None = None, base_seed: int | None = None,
                       duration_s: float | None = None) -> "Campaign":
        c = self
        with errors_as(CampaignError):
            if runs is not None:
                c = replace(c, runs=integer(runs, "runs", minimum=1))
            if base_seed is not None:
                c = replace(c, base_seed=integer(base_seed, "base_seed", minimum=0))
            if duration_s is not None:
                c = replace(c, scenario=c.scenario.with_overrides(
                    duration_s=number(duration_s, "duration_s", positive=True)))
        return c

    def seed(self, k: int) -> int:
        """The scenario seed of run k."""
        return self.base_seed + k


@dataclass(frozen=True)
class RunDraws:
    """The perturbations applied to one run (world ENU; angles in degrees for people to read)."""

    vessel_offset_m: np.ndarray  # (n_vessels, 2)
    vessel_heading_offset_deg: np.ndarray  # (n_vessels,)
    current_offset_m_s: np.ndarray  # (2,)
    traffic_heading_offset_deg: np.ndarray  # (n_traffic,); 0 for traffic on a path
    traffic_speed_offset_m_s: np.ndarray  # (n_traffic,); after clipping the speed at 0

    def as_dict(self, scenario: Scenario) -> dict:
        """Plain JSON-ready dict keyed by vessel / obstacle name."""
        return {
            "vessels": {v.name: {"dx_m": round(float(d[0]), 6) + 0.0, "dy_m": round(float(d[1]), 6) + 0.0,
                                 "dheading_deg": round(float(h), 6) + 0.0}
                        for v, d, h in zip(scenario.vessels, self.vessel_offset_m, self.vessel_heading_offset_deg)},
            "current": {"dvx_m_s": round(float(self.current_offset_m_s[0]), 6) + 0.0,
                        "dvy_m_s": round(float(self.current_offset_m_s[1]), 6) + 0.0},
            "traffic": {o.name: {"dheading_deg": round(float(h), 6) + 0.0, "dspeed_m_s": round(float(s), 6) + 0.0}
                        for o, h, s in zip(scenario.moving_obstacles, self.traffic_heading_offset_deg,
                                           self.traffic_speed_offset_m_s)},
        }


# ---------------------------------------------------------------------- parsing
_TOP = {"name", "description", "scenario", "runs", "base_seed", "duration_s", "randomize", "outputs"}
_OUTPUTS = {"recordings"}


def parse_campaign(data: dict, source: str = "<dict>", base_dir: str | Path = ".") -> Campaign:
    """Validate a parsed campaign TOML document. ``scenario`` is resolved against ``base_dir`` (the
    campaign file's folder) and loaded and validated too. Raises :class:`CampaignError`."""
    with errors_as(CampaignError):
        data = table(data, "campaign")
        if "families" in data:
            raise CampaignError("families: a campaign of encounter families (or Imazu cases) is read by "
                                "mjasc.campaigns.spec.load_campaign_spec; load_campaign reads one perturbed scenario")
        check_keys(data, _TOP, "campaign")
        name = file_name(data, source)
        description = data.get("description", "")
        if not isinstance(description, str):
            raise CampaignError(f"description: must be a string, got {show(description)}")
        if "runs" not in data:
            raise CampaignError("runs: missing (how many runs the campaign makes)")
        runs = integer(data["runs"], "runs", minimum=1)
        base_seed = integer(data.get("base_seed", 0), "base_seed", minimum=0)
        randomize = dataclass_from_table(Randomization, data.get("randomize", {}), "randomize")
        out_table = table(data.get("outputs", {}), "outputs")
        check_keys(out_table, _OUTPUTS, "outputs")
        recordings = boolean(out_table.get("recordings", False), "outputs.recordings")
        duration = number(data["duration_s"], "duration_s", positive=True) if "duration_s" in data else None
        if "scenario" not in data:
            raise CampaignError("scenario: missing (path of the scenario file, relative to the campaign file)")
        rel = data["scenario"]
        if not isinstance(rel, str) or not rel:
            raise CampaignError(f"scenario: must be a path string, got {show(rel)}")
        if path_problem(rel):
            raise CampaignError(f"scenario: not a usable file name ({path_problem(rel)}), got {show_path(rel)}")
    path = (Path(base_dir) / rel).resolve()
    try:
        scenario = load_scenario(path)
    except ScenarioError as exc:
        raise CampaignError(f"scenario: {exc}") from None
    if duration is not None:
        scenario = scenario.with_overrides(duration_s=duration)
    return Campaign(name, description, scenario, str(path), runs, base_seed, randomize, recordings, source)


def load_campaign(path: str | Path) -> Campaign:
    """Read and validate a campaign file and its scenario; nothing runs on a bad file.
    Raises :class:`CampaignError` naming the file and the field. ``path`` is a file path
    (relative to the current folder) or a bundled campaign's name (``demo_monte_carlo``)."""
    path = resolve_bundled(path, "campaign")
    data = load_toml(path, CampaignError, "campaign")
    try:
        return parse_campaign(data, str(path), path.parent)
    except CampaignError as exc:
        raise CampaignError(f"{path}: {exc}") from None


# ---------------------------------------------------------------------- randomization
def draw_perturbations(scenario: Scenario, randomize: Randomization, base_seed: int, k: int) -> RunDraws:
    """Draws of run k (module docstring): deterministic in (base_seed, k), fixed draw order. A draw
    that sends traffic into a static obstacle is drawn again from the same generator (module
    docstring, "Rejected draws"); CampaignError when none of :data:`MAX_DRAWS` keeps it clear."""
    if k < 0 or base_seed < 0:
        raise ValueError(f"k, base_seed: must be ≥ 0, got k={k}, base_seed={base_seed}")
    rng = np.random.default_rng([base_seed, k, RANDOMIZATION_STREAM])
    reason = ""
    for _ in range(MAX_DRAWS):
        draws = _one_draw(scenario, randomize, rng)
        reason = traffic_through_structure(_moved_traffic(scenario, draws), scenario.static_obstacles,
                                           scenario.duration_s)
        if reason is None:
            return draws
    raise CampaignError(f"run {k}: no draw in {MAX_DRAWS} keeps the traffic clear of the static obstacles; last: "
                        f"{reason}")


def _one_draw(scenario: Scenario, randomize: Randomization, rng: np.random.Generator) -> RunDraws:
    n, m = len(scenario.vessels), len(scenario.moving_obstacles)
    z_pos = rng.standard_normal((n, 2))
    z_head = rng.standard_normal(n)
    z_cur = rng.standard_normal(2)
    z_thead = rng.standard_normal(m)
    z_tspd = rng.standard_normal(m)
    r = randomize
    on_path = np.array([o.path is not None for o in scenario.moving_obstacles], dtype=bool)
    speeds = np.array([o.speed_m_s for o in scenario.moving_obstacles], dtype=float)
    dspeed = np.maximum(0.0, speeds + r.traffic_speed_sigma_m_s * z_tspd) - speeds
    return RunDraws(
        vessel_offset_m=r.vessel_position_sigma_m * z_pos,
        vessel_heading_offset_deg=r.vessel_heading_sigma_deg * z_head,
        current_offset_m_s=r.current_velocity_sigma_m_s * z_cur,
        traffic_heading_offset_deg=np.where(on_path, 0.0, r.traffic_heading_sigma_deg * z_thead),
        traffic_speed_offset_m_s=dspeed,
    )


def _moved_traffic(scenario: Scenario, d: RunDraws) -> tuple:
    """The scenario's moving obstacles with the draws' heading and speed offsets applied."""
    return tuple(replace(o, heading_rad=o.heading_rad if o.path is not None else
                         float(wrap_angle(o.heading_rad + math.radians(d.traffic_heading_offset_deg[j]))),
                         speed_m_s=float(o.speed_m_s + d.traffic_speed_offset_m_s[j]))
                 for j, o in enumerate(scenario.moving_obstacles))


def _reseeded_current(scenario: Scenario, seed: int):
    """The scenario's current as the file would build it with ``seed`` (matters for seeded fields)."""
    if isinstance(scenario.current, UniformCurrent) or not scenario.current_config:
        return scenario.current
    return current_from_config(scenario.current_config, seed=seed)


def randomized_scenario(scenario: Scenario, config: Campaign | Randomization, k: int,
                        base_seed: int | None = None) -> Scenario:
    """Scenario of run k: seed ``base_seed + k`` and the draws of :func:`draw_perturbations` applied.

    ``config`` is a :class:`Campaign` (its sigmas and base_seed) or a :class:`Randomization` with
    ``base_seed`` given. Returns a new Scenario (``dataclasses.replace``); ``scenario`` is untouched.
    """
    if isinstance(config, Campaign):
        randomize, base_seed = config.randomize, config.base_seed if base_seed is None else base_seed
    else:
        randomize, base_seed = config, 0 if base_seed is None else base_seed
    k = int(k)
    seed = base_seed + k
    current = _reseeded_current(scenario, seed)
    sc = replace(scenario, seed=seed, current=current, raw={**scenario.raw, "seed": seed})
    if randomize.is_zero:
        return sc
    d = draw_perturbations(scenario, randomize, base_seed, k)
    sc = replace(sc, raw={**sc.raw, "randomization": {"base_seed": base_seed, "run": k, **d.as_dict(scenario)}})
    if randomize.vessel_position_sigma_m > 0 or randomize.vessel_heading_sigma_deg > 0:
        sc = replace(sc, vessels=tuple(
            replace(v, position_m=v.position_m + d.vessel_offset_m[i],
                    heading_rad=float(wrap_angle(v.heading_rad + math.radians(d.vessel_heading_offset_deg[i]))))
            for i, v in enumerate(sc.vessels)))
    if randomize.current_velocity_sigma_m_s > 0:
        if isinstance(current, UniformCurrent):
            new = UniformCurrent(current.velocity_m_s + d.current_offset_m_s)
        else:
            new = SumCurrent([current, UniformCurrent(d.current_offset_m_s)])
        sc = replace(sc, current=new, current_config=new.describe())
    if randomize.traffic_heading_sigma_deg > 0 or randomize.traffic_speed_sigma_m_s > 0:
        sc = replace(sc, moving_obstacles=_moved_traffic(sc, d))
    return sc


# ---------------------------------------------------------------------- as a campaign family (spec.py)
def _exact_degrees(angle_rad: float) -> float:
    """A heading in degrees that a scenario file turns back into exactly ``angle_rad``
    (``math.radians`` of it): ``math.degrees`` is off by an ulp now and then, so the neighbours are
    tried; the nearest value is returned when none is exact."""
    d = math.degrees(angle_rad)
    for _ in range(8):
        r = math.radians(d)
        if r == angle_rad:
            return d
        d = math.nextafter(d, math.inf if r < angle_rad else -math.inf)
    return math.degrees(angle_rad)


def perturbed_document(data: dict, scenario: Scenario, randomize: Randomization, base_seed: int, k: int,
                       draws: RunDraws | None = None) -> dict:
    """The scenario *file* of run k: ``data`` (the base scenario's TOML document) with the seed
    ``base_seed + k`` and the draws of :func:`draw_perturbations` written in (``draws``: those
    draws, when the caller has them already), so that ``parse_scenario(document)`` is
    :func:`randomized_scenario`'s scenario of run k (same numbers; a seeded current keeps its
    derived seed written out when a perturbation wraps it in a sum)."""
    doc = {key: value for key, value in data.items()}
    seed = base_seed + int(k)
    doc["seed"] = seed
    if randomize.is_zero:
        return doc
    d = draws if draws is not None else draw_perturbations(scenario, randomize, base_seed, k)
    if randomize.vessel_position_sigma_m > 0 or randomize.vessel_heading_sigma_deg > 0:
        vessels = []
        for i, (table_i, v) in enumerate(zip(data["vessels"], scenario.vessels)):
            heading = float(wrap_angle(v.heading_rad + math.radians(d.vessel_heading_offset_deg[i])))
            vessels.append({**table_i, "position_m": [float(x) for x in v.position_m + d.vessel_offset_m[i]],
                            "heading_deg": _exact_degrees(heading)})
        doc["vessels"] = vessels
    if randomize.current_velocity_sigma_m_s > 0:
        current = _reseeded_current(scenario, seed)
        if isinstance(current, UniformCurrent):
            doc["current"] = {"type": "uniform",
                              "velocity_m_s": [float(x) for x in current.velocity_m_s + d.current_offset_m_s]}
        else:
            doc["current"] = {"type": "sum", "components": [
                current.describe(), {"type": "uniform", "velocity_m_s": [float(x) for x in d.current_offset_m_s]}]}
    if (randomize.traffic_heading_sigma_deg > 0 or randomize.traffic_speed_sigma_m_s > 0) and scenario.moving_obstacles:
        traffic = []
        for j, (table_j, o) in enumerate(zip(data["moving_obstacles"], scenario.moving_obstacles)):
            t = {**table_j, "speed_m_s": float(o.speed_m_s + d.traffic_speed_offset_m_s[j])}
            if o.path is None:
                t["heading_deg"] = _exact_degrees(
                    float(wrap_angle(o.heading_rad + math.radians(d.traffic_heading_offset_deg[j]))))
            traffic.append(t)
        doc["moving_obstacles"] = traffic
    return doc
