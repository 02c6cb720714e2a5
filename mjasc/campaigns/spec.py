"""A campaign file (TOML) → :class:`CampaignSpec`: its families and, deterministically, its runs.

A campaign is a list of **families**; each family generates runs, and every run is a complete
scenario (:class:`RunSpec`: its TOML text replays it with ``mjasc run``)::

    name = "encounters"                   # default: the file name
    description = "…"
    base_seed = 0                         # default 0
    [outputs]
    recordings = false                    # keep each run's recording.rrd + summary.json
    [evaluation]
    mission_cost = true                   # also run each run with traffic without it: path-length and time cost
    gospa_cutoff_m = 10.0                 # the tracking score's GOSPA cut-off [m] and order (the defaults)
    gospa_order = 2.0
    [colreg]                              # optional: the numeric reading of rules 13–14 (mjasc.evaluation.colreg.ColregConfig)
    head_on_bearing_deg = 15.0

    [[families]]
    kind = "head_on"                      # an encounter family (encounters.py), "imazu", or "perturbation"
    name = "head_on"                      # default: the kind; unique in the file
    runs_per_point = 50                   # runs per grid point (default 1)
    [families.parameters]                 # laws (distributions.py); a parameter not given keeps its default
    dcpa_m = { uniform = [-20.0, 20.0] }

The family kinds and their parameters: :mod:`mjasc.campaigns.encounters` (head_on,
crossing_give_way, crossing_stand_on, overtaking, overtaken, multi_target, team_vs_traffic,
bottleneck), :mod:`mjasc.campaigns.imazu` (the 22 Imazu cases) and
:mod:`mjasc.campaigns.perturbation` (an existing scenario perturbed). A file in the first
campaign format (top-level ``scenario``, ``runs``, ``[randomize]``, ``duration_s``) is one family
of kind ``perturbation`` named ``perturbation``; its runs are exactly the runs of before.

**Run order.** Families in file order; run ``index`` (0-based over the campaign) is run
``k = index − (runs of the families before)`` of its family. For encounter families run k lies at
grid point ``k // runs_per_point`` and draws from ``default_rng([base_seed, family_index, k,
0xC0FFEE])`` (:mod:`mjasc.campaigns.distributions`). The scenario seed of run ``index`` is
``base_seed + index`` unless the family draws a ``seed`` parameter. A family that rejects a draw
(wrong COLREG role, impossible geometry) draws again from the same generator, at most
:data:`mjasc.campaigns.encounters.MAX_ATTEMPTS` times; a run for which no draw is accepted is a
:class:`CampaignError` naming the family, the run and the last reason.

**Methods.** A top-level ``methods = ["thesis", "velocity_obstacle"]`` (entries may be tables
with options and a label, :mod:`mjasc.campaigns.methods`) runs every generated run once per method:
run ``(index, label)``, same seed and scenario text except the ``[vessels.avoidance]`` tables.
Without ``methods`` a run is ``(index, "")`` and its text is the family's, exactly as before.

**Digest.** ``sha256`` of the canonical JSON (sorted keys) of the file's parsed content, the
content of every scenario file a family reads, and :data:`SPEC_FORMAT`: an edited file (or an edited
referenced scenario) is a new campaign; comments and layout do not count.
"""

from __future__ import annotations

import hashlib
import json
import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Iterator

from mjasc.evaluation.colreg import ColregConfig
from mjasc.campaigns.campaign_tables import CampaignEvaluation, CampaignOutputs
from mjasc.campaigns.methods import COMPARED_STAGES, STAGE, apply_method, parse_methods
from mjasc.campaigns.perturbation import CampaignError
from mjasc.campaigns.perturbation_family import parse_perturbation_family
from mjasc.campaigns.scenario_text import load_run_scenario, scenario_toml, write_scenario
from mjasc.core.config_tables import (
    check_keys,
    dataclass_from_table,
    errors_as,
    integer,
    load_toml,
    number,
    show,
    string,
    table,
)
from mjasc.core.resources import resolve_bundled
from mjasc.runs.plausibility import file_name
from mjasc.runs.scenario import ScenarioError

__all__ = ["SPEC_FORMAT", "CampaignError", "RunSpec", "CampaignOutputs", "CampaignEvaluation", "CampaignSpec",
           "parse_campaign_spec", "load_campaign_spec", "write_scenario"]

#: Version of the run generation: bump when the same campaign file would generate different runs.
SPEC_FORMAT = 1


@dataclass(frozen=True)
class RunSpec:
    index: int            # run k of the campaign: 0-based, stable for a given campaign file
    family: str           # the family's name in the campaign file
    parameters: dict      # the drawn encounter parameters (name → float | str), for reports and maps
    scenario_toml: str    # the complete scenario as TOML text: `mjasc run` on it replays the run exactly
    seed: int             # the scenario's seed (also inside scenario_toml)
    method: str = ""      # the compared method's label (campaigns with `methods`); "" otherwise

    def scenario(self):
        """The parsed :class:`~mjasc.runs.scenario.Scenario` (what the engine runs)."""
        return load_run_scenario(self.scenario_toml, f"<run {self.index}>")


@dataclass(frozen=True)
class CampaignSpec:
    name: str
    description: str
    base_seed: int
    families: tuple
    outputs: CampaignOutputs
    digest: str
    source: str = ""
    data: dict = field(default_factory=dict, repr=False)  # the file's parsed content
    base_dir: str = "."
    limit: int | None = None  # only the first `limit` runs (the same campaign: same digest, same runs)
    evaluation: CampaignEvaluation = field(default_factory=CampaignEvaluation)
    methods: tuple = ()  # the compared methods (mjasc.campaigns.methods.MethodEntry); () = as written
    compare_stage: str = STAGE  # the stage whose methods ``methods`` compares
    # digests an earlier mjasc gave this campaign (its hull's meshes not yet covered): a store holding
    # it under one of them is the same campaign (CampaignStore.adopt_earlier)
    earlier_digests: tuple = ()
    colreg: ColregConfig = field(default_factory=ColregConfig)  # the [colreg] table: roles drawn and runs judged

    @property
    def colreg_request(self) -> dict | None:
        """The ``[colreg]`` thresholds that differ from the defaults, for the runs' evaluation (None: all default)."""
        default = ColregConfig()
        changed = {k: getattr(self.colreg, k) for k in default.__dataclass_fields__
                   if getattr(self.colreg, k) != getattr(default, k)}
        return changed or None

    @property
    def gospa_request(self) -> dict | None:
        """The ``[evaluation]`` GOSPA settings that differ from the defaults, for the runs' tracking
        score (None: c = 10 m, p = 2)."""
        ev = getattr(self, "evaluation", None) or CampaignEvaluation()
        default = CampaignEvaluation()
        changed = {k: getattr(ev, k) for k in ("gospa_cutoff_m", "gospa_order")
                   if getattr(ev, k) != getattr(default, k)}
        return changed or None

    @property
    def method_labels(self) -> tuple[str, ...]:
        """The labels runs are stored under: the compared methods' labels, or ``("",)`` without ``methods``."""
        return tuple(m.label for m in self.methods) or ("",)

    @property
    def runs_per_method(self) -> int:
        """How many runs the families generate (the sum over them; at most ``limit``): the run
        indices; with ``methods`` each index runs once per method."""
        total = sum(f.runs for f in self.families)
        return total if self.limit is None else min(total, self.limit)

    @property
    def runs_defined(self) -> int:
        """How many runs the campaign makes: :attr:`runs_per_method` × the number of methods (1
        without ``methods``)."""
        return self.runs_per_method * len(self.method_labels)

    def _locate(self, index: int):
        if not 0 <= index < self.runs_per_method:
            raise IndexError(f"run {index}: the campaign defines {self.runs_per_method} run(s)")
        k = index
        for fam in self.families:
            if k < fam.runs:
                return fam, k
            k -= fam.runs
        raise AssertionError("unreachable")

    def run(self, index: int, method: str | None = None) -> RunSpec:
        """Run ``index`` of the campaign (module docstring): the same RunSpec on every call. With
        ``methods``, ``method`` (a label) says which method's run; the runs of one index differ
        only in their tables of the compared stage (:mod:`mjasc.campaigns.methods`)."""
        entry = self._method(method)
        fam, k = self._locate(int(index))
        params, doc, seed, header = fam.generate(k, self.base_seed, index)  # CampaignError: no draw accepted
        doc = {"name": doc.get("name", f"{fam.name}_{index}"), **doc, "seed": int(seed)}
        which = ""
        if entry is not None:
            doc, _ = apply_method(doc, entry, self.compare_stage)
            options = ", ".join(f"{k} = {_short(v)}" for k, v in entry.options.items())
            which = (f"{self.compare_stage.capitalize()} method: {entry.label} "
                     f"({entry.name}{': ' + options if options else ''}).\n")
        shown = ", ".join(f"{k} = {_short(v)}" for k, v in params.items())
        text = scenario_toml(doc, header=(
            f"Campaign {self.name} (digest {self.digest[:12]}), family {fam.name} ({fam.kind}), run {index} "
            f"(run {k} of the family), seed {seed}.\n{which}{header}\nParameters: {shown}\n"
            f"Replay: mjasc run <this file>"))
        return RunSpec(int(index), fam.name, params, text, int(seed), entry.label if entry is not None else "")

    def _method(self, method: str | None):
        if not self.methods:
            if method not in (None, ""):
                raise ValueError(f"method: the campaign {self.name} compares no methods, got {method!r}")
            return None
        if method is None:
            raise ValueError(f"method: the campaign {self.name} compares methods ({', '.join(self.method_labels)}): "
                             f"say which run (method=…)")
        for m in self.methods:
            if m.label == method:
                return m
        raise ValueError(f"method: no method labelled {method!r} in {self.name} (have: {', '.join(self.method_labels)})")

    def runs(self) -> Iterator[RunSpec]:
        """Every run, in index order (with ``methods``: each index once per method, in file order)."""
        for index in range(self.runs_per_method):
            for label in self.method_labels:
                yield self.run(index, label or None)

    def with_overrides(self, base_seed: int | None = None, runs_per_point: int | None = None,
                       duration_s: float | None = None, runs: int | None = None) -> "CampaignSpec":
        """The campaign with ``base_seed``, every family's ``runs_per_point`` or ``duration_s``
        replaced (a new campaign: a new digest), or with only its first ``runs`` runs (the same
        campaign cut short: its digest and its runs are unchanged, so a store keeps them)."""
        if runs is not None:
            with errors_as(CampaignError):
                runs = integer(runs, "runs", minimum=1)
            if base_seed is None and runs_per_point is None and duration_s is None:
                return replace(self, limit=runs)
            return replace(self.with_overrides(base_seed, runs_per_point, duration_s), limit=runs)
        with errors_as(CampaignError):
            data = {k: v for k, v in self.data.items()}
            if base_seed is not None:
                data["base_seed"] = integer(base_seed, "base_seed", minimum=0)
            fams = [dict(f) for f in _family_tables(data)]
            for f in fams:
                if runs_per_point is not None:
                    f["runs_per_point"] = integer(runs_per_point, "runs_per_point", minimum=1)
                if duration_s is not None:
                    f["duration_s"] = number(duration_s, "duration_s", positive=True)
        data = {k: v for k, v in data.items() if k not in _LEGACY}
        data["families"] = fams
        return parse_campaign_spec(data, self.source, self.base_dir)


def _short(v: Any) -> str:
    return f"{v:.6g}" if isinstance(v, float) else str(v)


# ---------------------------------------------------------------------- parsing
_TOP = {"name", "description", "base_seed", "outputs", "evaluation", "colreg", "families", "methods", "compare_stage"}
_LEGACY = {"scenario", "runs", "duration_s", "randomize"}


def _family_tables(data: dict) -> list[dict]:
    """The ``[[families]]`` tables; a file in the first format is one perturbation family."""
    if "families" in data:
        fams = data["families"]
        if not isinstance(fams, list) or not fams:
            raise CampaignError(f"families: need at least one [[families]] table, got {show(fams)}")
        return [table(f, f"families[{i}]") for i, f in enumerate(fams)]
    if "scenario" not in data:
        raise CampaignError("families: missing (a campaign is a list of [[families]] tables; or, in the first "
                            "format, a scenario = path with runs and [randomize])")
    if "runs" not in data:
        raise CampaignError("runs: missing (how many runs the campaign makes)")
    legacy = {"kind": "perturbation", "name": "perturbation", "scenario": data["scenario"],
              "runs_per_point": integer(data["runs"], "runs", minimum=1)}
    for key in ("duration_s", "randomize"):
        if key in data:
            legacy[key] = data[key]
    return [legacy]


def _perturbation_parser(t, where, index, base_dir, thresholds):
    return parse_perturbation_family(t, where, index, base_dir)


def _family_parser(kind: Any, where: str):
    """The parser of a family ``kind``; the encounter and Imazu families' modules (with scipy's
    optimizer) are imported only for a campaign that has such a family."""
    if kind == "perturbation":
        return _perturbation_parser
    from mjasc.campaigns import encounters, imazu

    parsers = {"perturbation": _perturbation_parser, **{k: encounters.parse_family for k in encounters.FAMILY_KINDS},
               "imazu": imazu.parse_family}
    return parsers[string(kind, where, choices=parsers)]


def _canonical(obj: Any) -> str:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), ensure_ascii=False, default=str)


def _digest(data: dict, refs: dict) -> str:
    """A campaign's digest: its parsed file and the content of the files its runs depend on."""
    return hashlib.sha256(_canonical({"format": SPEC_FORMAT, "campaign": data, "files": refs}).encode()).hexdigest()


_FAMILY_KEYS = {"name", "kind", "runs_per_point", "duration_s", "own", "rates", "roles", "scenario", "first_seed"}
_SUBTABLE_KEY = re.compile(r"^(?P<family>families\[\d+\]\.)?(?P<table>[a-z_]+)\.(?P<key>[a-z_0-9]+): unknown")


def _misplaced_key_hint(msg: str) -> str:
    """TOML puts every key written after a ``[table]`` header into that table: a family's
    ``runs_per_point`` after its ``[families.parameters]`` header, or ``base_seed`` after
    ``[evaluation]``, is an unknown key of that table. Say so when the key belongs one level up."""
    m = _SUBTABLE_KEY.match(msg)
    if m is None:
        return ""
    if m["family"] and m["key"] in _FAMILY_KEYS:
        return (f"; '{m['key']}' is a key of the family, not of [families.{m['table']}]: in TOML every key after a "
                "[table] header belongs to that table, so write it before the family's first sub-table")
    if not m["family"] and m["table"] != "campaign" and m["key"] in _TOP:
        return (f"; '{m['key']}' is a top-level key, not one of [{m['table']}]: in TOML every key after a "
                "[table] header belongs to that table, so write it before the first [table]")
    return ""


def parse_campaign_spec(data: dict, source: str = "<dict>", base_dir: str | Path = ".") -> CampaignSpec:
    """Validate a parsed campaign file into a :class:`CampaignSpec` (scenario paths relative to
    ``base_dir``, the file's folder). Every family is checked (every law against its parameter's
    declaration, and its first run parsed as a scenario) before anything runs. Raises
    :class:`CampaignError`."""
    try:
        return _parse_campaign_spec(data, source, base_dir)
    except CampaignError as exc:
        hint = _misplaced_key_hint(str(exc))
        if hint:
            raise CampaignError(f"{exc}{hint}") from None
        raise


def _parse_campaign_spec(data: dict, source: str, base_dir: str | Path) -> CampaignSpec:
    """:func:`parse_campaign_spec` without the explanation of a misplaced key."""
    with errors_as(CampaignError):
        data = table(data, "campaign")
        legacy = "families" not in data
        check_keys(data, (_TOP | _LEGACY) - {"families", "colreg"} if legacy else _TOP, "campaign")
        name = file_name(data, source)
        description = data.get("description", "")
        if not isinstance(description, str):
            raise CampaignError(f"description: must be a string, got {show(description)}")
        base_seed = integer(data.get("base_seed", 0), "base_seed", minimum=0)
        outputs = dataclass_from_table(CampaignOutputs, data.get("outputs", {}), "outputs")
        evaluation = dataclass_from_table(CampaignEvaluation, data.get("evaluation", {}), "evaluation")
        thresholds = dataclass_from_table(ColregConfig, data.get("colreg", {}), "colreg")
        stage = string(data.get("compare_stage", STAGE), "compare_stage")
        if stage not in COMPARED_STAGES:
            raise CampaignError(f"compare_stage: must be one of {', '.join(COMPARED_STAGES)}, got {show(stage)}")
        if "compare_stage" in data and "methods" not in data:
            raise CampaignError("compare_stage: given without methods (the list of that stage's methods to compare)")
        methods = parse_methods(data["methods"], stage=stage) if "methods" in data else ()
        families = []
        for i, t in enumerate(_family_tables(data)):
            where = f"families[{i}]" if not legacy else ""
            fam = _family_parser(t.get("kind"), f"{where}.kind" if where else "kind")(t, where, i, base_dir, thresholds)
            if any(f.name == fam.name for f in families):
                raise CampaignError(f"{where}.name: duplicate family name {fam.name!r}")
            families.append(fam)
    refs = {}
    for fam in families:
        refs.update(getattr(fam, "references", dict)())
    digest = _digest(data, refs)
    earlier = _digest(data, {k: getattr(v, "core", v) for k, v in refs.items()})  # (vessel_files before meshes)
    spec = CampaignSpec(name, description, base_seed, tuple(families), outputs, digest, source, dict(data),
                        str(base_dir), evaluation=evaluation, methods=methods, compare_stage=stage, colreg=thresholds,
                        earlier_digests=(earlier,) if earlier != digest else ())
    first = 0
    for i, fam in enumerate(families):  # each family's first run must be a valid scenario (own overrides, rates)
        for label in spec.method_labels:
            run = spec.run(first, label or None)
            with_method = f" with method {label!r}" if label else ""
            try:
                sc = run.scenario()
            except ScenarioError as exc:
                own = _own_field(str(exc), getattr(fam, "own", None), f"families[{i}]")
                # a field the family's own table gave: named where the user wrote it (not a method's options)
                if own is not None and not (label and f".own.{COMPARED_STAGES[stage]}" in own):
                    raise CampaignError(own) from None
                raise CampaignError(f"families[{i}] ({fam.name}): its first run{with_method} is not a valid scenario: "
                                    f"{exc}") from None
            if label and not any(COMPARED_STAGES[stage] in v.options for v in sc.vessels):
                raise CampaignError(f"methods: family {fam.name!r} (families[{i}]) has no vessel with a "
                                    f"[vessels.{COMPARED_STAGES[stage]}] table: its runs would not differ "
                                    f"between methods")
        first += fam.runs
    return spec


def _own_field(error: str, own: dict | None, where: str) -> str | None:
    """``error`` (a generated scenario's, ``vessels[k].sensor.beams: …``) readdressed to the family's
    ``own`` table when the field is one that table gave (``families[i].own.sensor.beams: …``): an
    encounter family merges ``own`` into each own vessel's table, and the own vessels come first."""
    import re

    m = re.match(r"vessels\[\d+\]\.(\w+)", error)
    if not own or m is None or m.group(1) not in own:
        return None
    return f"{where}.own.{error[m.start(1):]}"


def load_campaign_spec(path: str | Path) -> CampaignSpec:
    """Read and validate a campaign file (a path, or a bundled campaign's name such as
    ``demo_monte_carlo`` or ``imazu``). Raises :class:`CampaignError` naming the file and the field."""
    path = resolve_bundled(path, "campaign")
    data = load_toml(path, CampaignError, "campaign")
    try:
        return parse_campaign_spec(data, str(path), path.parent)
    except CampaignError as exc:
        raise CampaignError(f"{path}: {exc}") from None
