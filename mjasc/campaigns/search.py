"""Searching for failures: spend runs where the collision avoidance fails or nearly fails.

Uniform Monte Carlo spends most runs where nothing happens. :func:`search_failures` runs the
**cross-entropy method** (Rubinstein & Kroese, *The Cross-Entropy Method*, 2004; as used for
rare-event search in autonomous-vehicle validation by O'Kelly et al., NeurIPS 2018) over one
encounter family's continuous parameters, minimising the run's minimum separation:

1. The parameters are searched at their quantiles u ∈ [0, 1]^d of the family's declared laws (so
   a uniform law over [lo, hi] maps linearly, a normal one through its inverse CDF).
2. Iteration i samples ``batch`` points from independent normals N(μ, σ²) clipped to [0, 1]
   (iteration 0: μ = 0.5, σ = ``initial_std``, close to uniform over the box), runs them on the
   campaign engine (isolated child processes, Dask or this process, every result stored), and keeps
   the ``elite_fraction`` with the lowest minimum separation.
3. μ, σ ← the elite's mean and standard deviation, smoothed: θ ← α θ_elite + (1 − α) θ
   (``smoothing`` α), σ ≥ ``min_std``.

``method = "uniform"`` draws every point uniformly over the box instead (the baseline at the same
budget). Every run whose separation falls below ``failure_separation_m`` (default 0: overlapping
hull circles) or that collides is a failure; each is written to ``failures/run_<k>.toml``, a
scenario file ``mjasc run`` replays exactly. Points the family rejects (not its encounter) are
redrawn and cost no run.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mjasc.campaigns.engine import with_scenario_plugins, execute_runs
from mjasc.campaigns.hull_records import family_hulls
from mjasc.campaigns.hull_shipping import pack_hulls
from mjasc.campaigns.scenario_text import scenario_toml, write_scenario
from mjasc.campaigns.spec import CampaignError, RunSpec
from mjasc.campaigns.statistics import run_outcome
from mjasc.campaigns.store import CampaignStore
from mjasc.core.config_tables import check_params, param

__all__ = ["SearchConfig", "SearchResult", "CrossEntropySampler", "search_failures", "searchable_family"]


@dataclass(frozen=True)
class SearchConfig:
    """Settings of a failure search."""

    method: str = param("cross_entropy", choices=("cross_entropy", "uniform"), doc="search method")
    budget: int = param(48, minimum=2, doc="runs in all")
    batch: int = param(12, minimum=2, doc="runs per iteration")
    elite_fraction: float = param(0.25, positive=True, maximum=1.0, doc="share of a batch that refits the sampler")
    initial_std: float = param(0.35, positive=True, doc="σ of the first batch, in quantile units")
    min_std: float = param(0.03, positive=True, doc="σ never falls below this (keeps exploring)")
    smoothing: float = param(0.7, positive=True, maximum=1.0, doc="α: θ ← α θ_elite + (1 − α) θ")
    failure_separation_m: float = param(0.0, doc="a run with a smaller minimum separation is a failure [m]")
    seed: int = param(0, minimum=0, doc="seed of the sampler")

    def __post_init__(self):
        check_params(self, "search")


@dataclass
class SearchResult:
    """Per run: (index, the parameters' quantiles u, parameters, minimum separation [m] or None,
    collision); the failures' replayable scenario files; the best (lowest) separation found."""

    runs: list = field(default_factory=list)
    failures: list = field(default_factory=list)
    min_separation_m: float | None = None

    def table(self) -> dict:
        seps = [r["min_separation_m"] for r in self.runs if r["min_separation_m"] is not None]
        return {"runs": len(self.runs), "failures": len(self.failures),
                "min_separation_m": None if not seps else round(min(seps), 3),
                "median_separation_m": None if not seps else round(float(np.median(seps)), 3)}


class CrossEntropySampler:
    """The sampler of the search in the unit box [0, 1]^d: ``ask()`` a point, ``tell(points, scores)``
    after a batch (lower is worse for the CAS, i.e. better for the search). ``uniform``: never adapts."""

    def __init__(self, d: int, config: SearchConfig):
        self.config = config
        self.rng = np.random.default_rng([config.seed, 0x5EA2C4])
        self.mu, self.sd = np.full(d, 0.5), np.full(d, config.initial_std)

    def ask(self) -> np.ndarray:
        if self.config.method == "uniform":
            return self.rng.random(self.mu.size)
        return np.clip(self.rng.normal(self.mu, self.sd), 0.0, 1.0)

    def tell(self, points: np.ndarray, scores) -> None:
        if self.config.method == "uniform":
            return
        points, scores = np.asarray(points, dtype=float), np.asarray(scores, dtype=float)
        n_elite = max(2, int(round(self.config.elite_fraction * len(points))))
        elite = points[np.argsort(scores, kind="stable")[:n_elite]]
        a = self.config.smoothing
        self.mu = a * elite.mean(axis=0) + (1 - a) * self.mu
        self.sd = np.maximum(a * elite.std(axis=0) + (1 - a) * self.sd, self.config.min_std)


def searchable_family(campaign, family: str):
    """``(family, its searchable parameter names)`` of ``campaign``'s family named ``family``, or a
    CampaignError saying why it cannot be searched (checked before anything is written)."""
    fam = next((f for f in campaign.families if f.name == family), None)
    searchable = [f.name for f in campaign.families if hasattr(f, "from_unit")]
    if fam is not None and not hasattr(fam, "from_unit"):  # (it said "no encounter family 'x' (have: x)")
        raise CampaignError(f"family: {family!r} is a family of kind {fam.kind!r}, which has no parameter laws to "
                            f"search; the search takes an encounter family (head_on, …, bottleneck: docs/campaigns.md"
                            f"{'; here: ' + ', '.join(searchable) if searchable else ''})")
    if fam is None:
        raise CampaignError(f"family: no encounter family {family!r} in {campaign.name} "
                            f"(have: {', '.join(f.name for f in campaign.families)})")
    names = fam.searchable()
    if not names:
        raise CampaignError(f"family {family!r}: no continuous parameter to search (declare uniform or normal "
                            f"laws)")
    return fam, names


def search_failures(campaign, family: str, out_dir: str | Path, config: SearchConfig = SearchConfig(), *,
                    scheduler=None, workers: int | None = None, progress: bool = False,
                    time_limit_s: float | None = 3600.0) -> SearchResult:
    """Search ``campaign``'s family ``family`` for failures (module docstring); results in
    ``out_dir/campaign.sqlite`` (resumable: a stored run is not run again) and ``out_dir/failures/``."""
    fam, names = searchable_family(campaign, family)
    out_dir = Path(out_dir).resolve()
    settings = json.dumps({k: getattr(config, k) for k in config.__dataclass_fields__}, sort_keys=True)
    digest, *earlier = (hashlib.sha256(f"{d}|{family}|{settings}".encode()).hexdigest()
                        for d in (campaign.digest, *getattr(campaign, "earlier_digests", ())))
    CampaignStore.adopt_earlier(out_dir, digest, earlier)  # (a search stored before meshes were in the digest)
    sampler = CrossEntropySampler(len(names), config)
    result = SearchResult()
    hulls = {family: family_hulls(campaign).get(family)}  # (the report names the hulls the search sailed)
    with CampaignStore(out_dir, digest, name=f"{campaign.name}:{family}:{config.method}", source=str(campaign.source),
                       file_text=settings, runs_defined=config.budget, hulls=hulls) as store:
        index, packs = 0, None
        while index < config.budget:
            batch: list[tuple[RunSpec, np.ndarray]] = []
            while len(batch) < min(config.batch, config.budget - index):
                for _ in range(1000):  # points outside the family's encounter are redrawn (no run)
                    u = sampler.ask()
                    try:
                        params, doc, header = fam.from_unit(dict(zip(names, u)))
                        break
                    except ValueError:
                        continue
                else:
                    raise RuntimeError(f"family {family!r}: 1000 points in a row are not its encounter")
                k = index + len(batch)
                seed = campaign.base_seed + k
                doc = {"name": f"{family}_search_{k}", **doc, "seed": seed}
                text = scenario_toml(doc, header=f"Failure search ({config.method}) over family {family} of campaign "
                                                 f"{campaign.name}, run {k}, seed {seed}.\n{header}")
                batch.append((RunSpec(k, family, {**params, **{f"u.{n}": float(x) for n, x in zip(names, u)}},
                                      text, seed), u))
            done = store.done(2)
            if packs is None:  # (the family's own hulls read once for the whole search, not with each batch)
                packs = pack_hulls([r for r, _ in batch])
            todo = [r for r, _ in batch if r.index not in done]
            execute_runs(todo, store, out_dir, scheduler=scheduler, workers=workers, progress=progress,
                         time_limit_s=time_limit_s, label=family, colreg=getattr(campaign, "colreg_request", None),
                         gospa=getattr(campaign, "gospa_request", None),
                         hulls=packs, plugins=with_scenario_plugins(None, todo))
            stored = {r.index: r for r in store.runs()}
            scores = []
            for run, u in batch:
                r = stored.get(run.index)
                o = run_outcome(r.metrics if r is not None and r.status == "completed" else None)
                sep = o["min_separation_m"]
                result.runs.append({"index": run.index, "u": u.tolist(), "parameters": run.parameters,
                                    "min_separation_m": sep, "collision": o["collision"]})
                if o["collision"] or (sep is not None and sep < config.failure_separation_m):
                    result.failures.append(write_scenario(run, out_dir / "failures" / f"run_{run.index}.toml"))
                scores.append(np.inf if sep is None else sep)
            index += len(batch)
            sampler.tell(np.array([u for _, u in batch]), scores)
    seps = [r["min_separation_m"] for r in result.runs if r["min_separation_m"] is not None]
    result.min_separation_m = min(seps) if seps else None
    return result
