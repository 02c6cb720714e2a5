"""The ``perturbation`` family of a campaign (``[[families]]`` with ``kind = "perturbation"``, and
every campaign file in the first format): run ``index`` is the base scenario perturbed by
:func:`~mjasc.campaigns.perturbation.randomized_scenario`'s draws of that run, written out as a
scenario document, optionally under fixed worse :class:`Conditions` (sensor dropout, link loss) and
on seeds of its own (``first_seed``). The draws themselves, their order and the rejected-draw rule
are in :mod:`mjasc.campaigns.perturbation`."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from mjasc.campaigns.perturbation import (
    CampaignError,
    Randomization,
    draw_perturbations,
    perturbed_document,
)
from mjasc.core.config_tables import (
    check_keys,
    check_params,
    dataclass_from_table,
    errors_as,
    integer,
    load_toml,
    number,
    param,
    path_problem,
    show,
    show_path,
    string,
)
from mjasc.physics.vessels import vessel_files
from mjasc.runs.scenario import Scenario, ScenarioError

__all__ = ["Conditions", "PerturbationFamily", "parse_perturbation_family"]


def _flat_draws(draws: dict) -> dict:
    """RunDraws.as_dict flattened to ``name.key`` (``alpha.dx_m``, ``current.dvx_m_s``, ``ferry.dspeed_m_s``)."""
    out = {f"current.{key}": v for key, v in draws["current"].items()}
    for group in ("vessels", "traffic"):
        for name, entries in draws[group].items():
            out.update({f"{name}.{key}": v for key, v in entries.items()})
    return out


@dataclass(frozen=True)
class Conditions:
    """Fixed conditions a perturbation family imposes on every run (unset: as the scenario says):
    a stress test of the same scenario under worse sensing and a worse link."""

    sensor_dropout: float | None = param(None, nonneg=True, maximum=0.95,
                                         doc="every vessel's range sensor loses each true return with this probability")
    comms_loss: float | None = param(None, nonneg=True, maximum=1.0,
                                     doc="the link's packet-loss probability near the sender ([comms] loss_probability)")

    def __post_init__(self):
        check_params(self, "conditions")

    def apply(self, doc: dict) -> dict:
        """``doc`` (a scenario document) with the conditions written in (a new dict)."""
        doc = dict(doc)
        if self.sensor_dropout is not None:
            doc["vessels"] = [{**v, "sensor": {**v["sensor"], "dropout_probability": self.sensor_dropout}}
                              if isinstance(v.get("sensor"), dict) else v for v in doc.get("vessels", [])]
        if self.comms_loss is not None and isinstance(doc.get("comms"), dict):
            doc["comms"] = {**doc["comms"], "loss_probability": self.comms_loss}
        return doc


@dataclass(frozen=True)
class PerturbationFamily:
    """Today's campaign as one family kind: run ``index`` of the campaign is
    :func:`randomized_scenario` of run ``index`` (seed ``base_seed + index``, draws from
    ``default_rng([base_seed, index, 0xC0FFEE])``), written out as a scenario document.
    ``first_seed`` set: family run k uses seed ``first_seed + k`` instead (the same seeds in every
    family: a scenario on its seeds 1–20 as shipped and stressed); ``conditions`` are imposed on
    every run (:class:`Conditions`)."""

    name: str
    index: int
    scenario_ref: str          # as the campaign file writes it (relative to the file)
    data: dict = field(repr=False)          # the base scenario's TOML document (duration override applied)
    scenario: Scenario = field(repr=False)  # its parsed form
    randomize: Randomization = field(default_factory=Randomization)
    runs_per_point: int = 1
    first_seed: int | None = None
    conditions: Conditions = field(default_factory=Conditions)
    kind = "perturbation"

    @property
    def runs(self) -> int:
        return self.runs_per_point

    def references(self) -> dict:
        """Files the runs depend on (their content goes into the campaign's digest): the scenario
        and the files of each vessel folder its vessels' ``type`` names (an edited hull, a new campaign)."""
        refs = {self.scenario_ref: self.data}
        for i, v in enumerate(self.scenario.vessels):
            files = vessel_files(v.type)
            if files:
                refs[f"{self.scenario_ref} vessels[{i}].type"] = files
        return refs

    def _resolved_types(self, doc: dict) -> dict:
        """``doc`` with each vessel folder's ``type`` as its absolute path (the scenario file wrote
        it relative to its own folder; a run's scenario text is read from nowhere)."""
        vessels = doc.get("vessels")
        pairs = list(zip(vessels, self.scenario.vessels)) if isinstance(vessels, list) else []
        if all(v.get("type") == sv.type for v, sv in pairs):
            return doc
        return {**doc, "vessels": [{**v, "type": sv.type} for v, sv in pairs]}

    def generate(self, k: int, base_seed: int, index: int) -> tuple[dict, dict, int, str]:
        """(parameters, scenario document, seed, header) of the campaign's run ``index`` (family run k)."""
        draws = None if self.randomize.is_zero else draw_perturbations(self.scenario, self.randomize, base_seed, index)
        doc = {"name": self.scenario.name, **perturbed_document(self.data, self.scenario, self.randomize, base_seed,
                                                                  index, draws)}
        seed = base_seed + index
        if self.first_seed is not None:
            seed = doc["seed"] = self.first_seed + k
        doc = self._resolved_types(self.conditions.apply(doc))
        params = {} if draws is None else _flat_draws(draws.as_dict(self.scenario))
        params.update({f"conditions.{key}": v for key, v in vars(self.conditions).items() if v is not None})
        header = f"perturbation of {self.scenario_ref} ({self.scenario.name}), draws of run {index}, seed {seed}"
        return params, doc, seed, header


_FAMILY = {"name", "kind", "scenario", "runs_per_point", "duration_s", "randomize", "first_seed", "conditions"}


def parse_perturbation_family(t: dict, where: str, index: int, base_dir: str | Path) -> PerturbationFamily:
    """A ``[[families]]`` table of kind ``perturbation`` (``scenario``, ``runs_per_point``, optional
    ``duration_s`` and ``[randomize]``) → its family. Raises CampaignError naming ``where.<key>``
    (the key alone when ``where`` is "": a file in the first format)."""
    def at(key: str) -> str:
        return f"{where}.{key}" if where else key

    with errors_as(CampaignError):
        check_keys(t, _FAMILY, where or "campaign")
        name = string(t.get("name", "perturbation"), at("name"))
        runs = integer(t.get("runs_per_point", 1), at("runs_per_point"), minimum=1)
        randomize = dataclass_from_table(Randomization, t.get("randomize", {}), at("randomize"))
        duration = number(t["duration_s"], at("duration_s"), positive=True) if "duration_s" in t else None
        first_seed = integer(t["first_seed"], at("first_seed"), minimum=0) if "first_seed" in t else None
        conditions = dataclass_from_table(Conditions, t.get("conditions", {}), at("conditions"))
        rel = t.get("scenario")
        if not isinstance(rel, str) or not rel:
            raise CampaignError(f"{at('scenario')}: must be the path of a scenario file (relative to the campaign "
                                f"file), got {show(rel)}")
        if path_problem(rel):
            raise CampaignError(f"{at('scenario')}: not a usable file name ({path_problem(rel)}), got {show_path(rel)}")
    path = (Path(base_dir) / rel).resolve()
    try:
        data = dict(load_toml(path, ScenarioError, "scenario"))  # (its errors name the file)
    except ScenarioError as exc:
        raise CampaignError(f"{at('scenario')}: {exc}") from None
    if duration is not None:
        data["duration_s"] = duration
    from mjasc.runs.scenario import parse_scenario

    try:
        scenario = parse_scenario(data, str(path))
    except ScenarioError as exc:  # (a field of the scenario file: name the file)
        raise CampaignError(f"{at('scenario')} {show_path(rel)}: {exc}") from None
    try:
        parse_scenario(conditions.apply(data), str(path))
    except ScenarioError as exc:
        raise CampaignError(f"{at('conditions')}: {exc}") from None
    return PerturbationFamily(name, index, rel, data, scenario, randomize, runs, first_seed, conditions)
