"""Run a campaign: every run of a campaign file, resumable, on Dask or in this process.

The driver (:func:`run_campaign`) opens the campaign's store in the output folder
(:mod:`mjasc.campaigns.store`: SQLite, one row per run keyed by the file's digest, the run's
index and its method label — a campaign comparing avoidance methods runs each index once per method,
:mod:`mjasc.campaigns.methods`), asks it which runs are already done, and runs only the others. Each run's result is written
the moment it arrives, so a campaign killed at any moment and started again with the same command
loses, duplicates and recomputes nothing.

Where runs execute (on Dask: :mod:`mjasc.campaigns.dask_runs`):

* a Dask ``LocalCluster`` of ``workers`` single-threaded workers (default: one per core) — threads
  of this process when runs are isolated (each worker only hands its runs to its own child process,
  below; the children start before Dask and import while it starts), processes otherwise — or an
  existing cluster by its scheduler address (``tcp://host:8786``; see docs/campaigns.md for SLURM/PBS
  via dask-jobqueue), or a ``distributed.Client``;
* this process (``workers = 0`` or ``scheduler = "synchronous"``, and by default for campaigns of at
  most :data:`IN_PROCESS_MAX_RUNS` runs to do, where Dask's start-up would dominate).

A vessel folder the runs sail (an own hull) is read once by the driver and shipped with the runs
(once per worker on a Dask cluster): each worker writes it into a temporary folder of its own and
sails it from there, so workers need not have the folder (:mod:`mjasc.campaigns.hull_shipping`);
the store records each family's hulls for the report (:mod:`mjasc.campaigns.hull_records`).

Either way each run executes in a child process of its worker (:mod:`mjasc.campaigns.executor`):
a run that raises, diverges, hangs past ``time_limit_s`` or kills its process is recorded with its
error and retried up to ``max_attempts`` times (a divergence is deterministic and is a result, not
retried); it never stops the campaign. The LocalCluster runs with ``worker-saturation = 1.0``, so a
worker holds one task at a time and a dying worker takes no queued runs with it. ``startup_s`` (in
the returned info) ends when a worker is up and, on an own LocalCluster, the first worker's child has
imported what runs need (the others import while it runs); in this process, when the runs' child has
(``isolate``).

Outputs in ``out_dir``: ``campaign.sqlite`` (the store), ``runs.csv`` and ``runs.parquet`` (exports),
``campaign.json`` (the campaign and its aggregate statistics, :mod:`mjasc.campaigns.statistics`),
and with ``[outputs] recordings = true`` ``runs/<k>/`` (recording.rrd + summary.json of run k,
``runs/<label>/<k>/`` with methods; written by the worker: on a remote cluster ``out_dir`` must be a
shared path).
"""

from __future__ import annotations

import json
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mjasc.campaigns.cluster import WORKER_WAIT_S, scheduler_problem, workers_problem
from mjasc.campaigns.dask_runs import run_on_dask
from mjasc.campaigns.executor import IsolatedExecutor, execute_in_process, take_prestarted
from mjasc.campaigns.hull_records import family_hulls
from mjasc.campaigns.hull_shipping import hold_hull_root, localise, pack_hulls, release_hull_root
from mjasc.campaigns.run_request import request_of
from mjasc.campaigns.statistics import aggregate, format_aggregate, wilson_interval
from mjasc.campaigns.store import RETRY_STATUSES, STORE_FILE, CampaignStore, record_result
from mjasc.runs.outputs import lock_folder, unlock_folder
from mjasc.campaigns.timing_fields import TIMING_KEYS, is_timing_key, without_timing
from mjasc.core.config_tables import integer, number
from mjasc.runs.interrupts import raise_pending

__all__ = ["CampaignResult", "run_campaign", "execute_runs", "wilson_interval", "format_aggregate", "TIMING_KEYS", "is_timing_key",
           "without_timing", "IN_PROCESS_MAX_RUNS"]

#: Campaigns with at most this many runs to do run in this process unless asked otherwise.
IN_PROCESS_MAX_RUNS = 4
#: Default per-run time limit [s] (a run that takes longer is killed and recorded as a timeout).
DEFAULT_TIME_LIMIT_S = 3600.0


@dataclass
class CampaignResult:
    """What :func:`run_campaign` did: the output folder, the stored runs (sorted by index), the
    aggregate statistics, the files written and how it ran (scheduler, workers, runs done now)."""

    out_dir: Path
    runs: list
    aggregate: dict
    files: dict = field(default_factory=dict)
    info: dict = field(default_factory=dict)


def run_campaign(campaign, out_dir: str | Path, scheduler=None, workers: int | None = None, progress: bool = True,
                 *, max_attempts: int = 2, time_limit_s: float | None = DEFAULT_TIME_LIMIT_S, isolate: bool = True,
                 limit: int | None = None) -> CampaignResult:
    """Run every run of ``campaign`` (a :class:`~mjasc.campaigns.spec.CampaignSpec`) not yet done in
    ``out_dir``'s store, and write the exports and ``campaign.json``.

    scheduler: None or "local" — a LocalCluster of ``workers`` processes (default: CPU count; in this
    process when at most :data:`IN_PROCESS_MAX_RUNS` runs are to do and ``workers`` is None); an
    address ("tcp://host:8786") — an existing Dask cluster (workers need mjasc installed); a
    ``distributed.Client`` — used as is (not closed); "synchronous" (or ``workers = 0``) — this process.
    max_attempts: tries per run for errors, timeouts and crashes. time_limit_s: per-run limit [s]
    (None: none). isolate: run each run in a child process (the default; False runs it in the
    worker itself: no protection from crashes or hangs). limit: only runs 0 … limit − 1 (with
    ``methods``: each with every method).

    A method registered only in this process (:func:`mjasc.plugins.register`) that the campaign
    compares, or that a run's scenario selects in any stage, reaches the runs' processes by its
    import path; one that has none is a ValueError unless the runs execute here unisolated
    (:mod:`mjasc.campaigns.methods`).
    """
    if workers is not None:
        workers = integer(workers, "workers", minimum=0)
    if problem := scheduler_problem(scheduler):  # (before the store is made)
        raise ValueError(f"scheduler: {problem}")
    if problem := workers_problem(scheduler, workers):
        raise ValueError(f"workers: {problem}")
    max_attempts = integer(max_attempts, "max_attempts", minimum=1)
    if time_limit_s is not None:
        time_limit_s = number(time_limit_s, "time_limit_s", positive=True)
    per_method = getattr(campaign, "runs_per_method", campaign.runs_defined)
    n_runs = per_method if limit is None else min(integer(limit, "limit", minimum=1), per_method)
    labels = tuple(getattr(campaign, "method_labels", ("",)))
    plugins = None
    if getattr(campaign, "methods", ()):
        from mjasc.campaigns.methods import plugin_sources

        stage = getattr(campaign, "compare_stage", "avoidance")
        plugins = {stage: plugin_sources((m.name for m in campaign.methods), stage)}
    out_dir = Path(out_dir).resolve()
    # One command at a time into a folder (a second one would do every run again): held from before
    # the store is read until the exports are written.
    made = not out_dir.is_dir()  # (this command makes the folder)
    lock = None if made else lock_folder(out_dir)
    try:
        # The runs to do are drawn before anything is written: a campaign whose draws fail (a grid
        # point no draw can make: CampaignError) leaves the folder as it was.
        todo = _runs_to_do(campaign, out_dir, labels, n_runs, max_attempts)
        plugins = with_scenario_plugins(plugins, todo)
        packs = pack_hulls(todo)  # (the own hulls read once, before anything is written: shipped to the workers)
        hulls = family_hulls(campaign, packs) if hasattr(campaign, "families") else None  # (for the report)
        if made:
            out_dir.mkdir(parents=True, exist_ok=True)
            lock = lock_folder(out_dir)
            if (out_dir / STORE_FILE).is_file():  # (another command began in the new folder meanwhile)
                todo = _runs_to_do(campaign, out_dir, labels, n_runs, max_attempts)
        fresh = not (out_dir / STORE_FILE).exists()  # (a command that stores no run leaves no new store)
        store = CampaignStore(out_dir, campaign.digest, name=campaign.name, source=str(campaign.source),
                              file_text=json.dumps(getattr(campaign, "data", {}), sort_keys=True, default=str),
                              runs_defined=campaign.runs_defined, hulls=hulls)
        try:
            recordings = bool(getattr(getattr(campaign, "outputs", None), "recordings", False))
            reference = bool(getattr(getattr(campaign, "evaluation", None), "mission_cost", True))
            info = execute_runs(todo, store, out_dir, scheduler=scheduler, workers=workers, progress=progress,
                                max_attempts=max_attempts, time_limit_s=time_limit_s, isolate=isolate,
                                recordings=recordings, reference=reference, label=campaign.name, plugins=plugins,
                                hulls=packs, colreg=getattr(campaign, "colreg_request", None),
                                gospa=getattr(campaign, "gospa_request", None))
            info["already_done"] = n_runs * len(labels) - len(todo)
            runs = store.runs()
            defined = store.info().get("runs_defined", campaign.runs_defined)  # (the largest extent asked so far)
            agg = aggregate(runs, defined, methods=[label for label in labels if label] or None)
            if todo and info["wall_time_s"] > 0:
                agg["throughput_runs_per_hour"] = round(3600.0 * len(todo) / info["wall_time_s"], 1)
            files = store.export()
            files["campaign"] = out_dir / "campaign.json"
            doc = {"campaign": {"name": campaign.name, "description": getattr(campaign, "description", ""),
                                "source": str(campaign.source), "digest": campaign.digest,
                                "runs_defined": defined, "hulls": hulls, **info},
                   "aggregate": agg}
            tmp = files["campaign"].with_suffix(".json.tmp")
            tmp.write_text(json.dumps(doc, indent=1, default=str))
            tmp.replace(files["campaign"])
            files["store"] = store.path
            return CampaignResult(out_dir, runs, agg, files, info)
        except BaseException:  # (no scheduler at the address, no worker, Ctrl-C before the first result)
            if fresh and todo and not store.runs():
                store.close()
                _remove_store(out_dir, made)
            raise
        finally:
            store.close()
    finally:
        unlock_folder(lock)


def _remove_store(out_dir: Path, made: bool) -> None:
    """Remove the store a failed command made and stored nothing in (and the folder, if ``made`` by
    the command and left empty): the folder is as it was."""
    for suffix in ("", "-wal", "-shm", "-journal"):
        try:
            (out_dir / (STORE_FILE + suffix)).unlink()
        except OSError:
            pass
    if made:
        try:
            out_dir.rmdir()
        except OSError:  # (not empty: a recording's folder, say)
            pass


def with_scenario_plugins(plugins: dict | None, runs: list) -> dict | None:
    """``plugins`` (the compared avoidance methods' sources, or None) with every method registered in
    this process that the runs' scenarios select in any stage (a tracking method in
    ``[vessels.tracking]``, …): the runs' processes import them by name as well."""
    from mjasc.campaigns.methods import scenario_plugins

    used = scenario_plugins(r.scenario_toml for r in runs)
    if not used:
        return plugins
    out = {stage: dict(sources) for stage, sources in (plugins or {}).items()}
    for stage, sources in used.items():
        out.setdefault(stage, {}).update(sources)
    return out


def _runs_to_do(campaign, out_dir: Path, labels: tuple, n_runs: int, max_attempts: int) -> list:
    """The runs of ``campaign`` (0 … n_runs − 1, each with every method label) without a result in
    ``out_dir``'s store."""
    done = {label: set() for label in labels}
    if (out_dir / STORE_FILE).is_file():
        CampaignStore.adopt_earlier(out_dir, campaign.digest, getattr(campaign, "earlier_digests", ()))
        with CampaignStore(out_dir, campaign.digest) as existing:  # (read only: no campaign row written)
            done = {label: existing.done(max_attempts, label) for label in labels}
    return [campaign.run(k, label) if label else campaign.run(k)
            for k in range(n_runs) for label in labels if k not in done[label]]

def execute_runs(runs: list, store: CampaignStore, out_dir: Path, *, scheduler=None, workers: int | None = None,
                 progress: bool = True, max_attempts: int = 2, time_limit_s: float | None = DEFAULT_TIME_LIMIT_S,
                 isolate: bool = True, recordings: bool = False, reference: bool = False,
                 label: str = "campaign", plugins: dict | None = None, hulls: dict | None = None,
                 colreg: dict | None = None, gospa: dict | None = None) -> dict:
    """Execute ``runs`` (:class:`~mjasc.campaigns.spec.RunSpec`) and write each result into ``store``
    as it arrives (module docstring: where they run, retries). ``reference``: follow each run with
    traffic by its run without traffic, for the mission cost (:mod:`mjasc.campaigns.executor`).
    ``plugins``: ``{stage: {name: "module:QualifiedName" or None}}``, methods registered in this
    process that the runs' processes import by name (None: not importable, only unisolated here).
    ``hulls``: the vessel folders the runs sail, packed (None: read from the runs now; CampaignError
    when one cannot be read), shipped to the runs' processes.
    ``colreg``: the campaign's ``[colreg]`` thresholds that differ from the defaults (the runs' judge);
    ``gospa``: its ``[evaluation]`` GOSPA cut-off and order that differ from them (the tracking score).
    Returns how it ran: scheduler, workers, start-up and wall time [s], runs_to_do."""
    if hulls is None:
        hulls = pack_hulls(runs)
    in_process = scheduler == "synchronous" or workers == 0 or (
        workers is None and scheduler is None and len(runs) <= IN_PROCESS_MAX_RUNS)
    if plugins and runs:
        from mjasc.campaigns.methods import check_plugins_reach

        for stage, sources in plugins.items():
            check_plugins_reach(sources, in_this_process=in_process and not isolate, stage=stage)
        plugins = {stage: {n: p for n, p in sources.items() if p} for stage, sources in plugins.items()}
        plugins = {stage: sources for stage, sources in plugins.items() if sources} or None
    info: dict[str, Any] = {"runs_to_do": len(runs)}
    if runs and not in_process and scheduler in (None, "local") and workers is not None and workers > len(runs):
        # (a worker per run to do at most: more would only start idle processes — --workers 1000 for
        # 2 runs started 1000 of them)
        info["workers_asked"] = workers
        workers = len(runs)
    bar = None
    if progress and runs:
        from tqdm import tqdm

        bar = tqdm(total=len(runs), unit="run", desc=label, file=sys.stderr)
    t0 = time.perf_counter()
    if hulls:
        hold_hull_root()  # (this process's copies stay while any campaign here runs)
    try:
        if not runs:
            info.update(scheduler="none")
        elif in_process:
            info.update(scheduler="synchronous", workers=0, startup_s=0.0)
            _run_here(runs, store, out_dir, max_attempts, time_limit_s, isolate, recordings, reference, bar, plugins,
                      info, hulls, colreg, gospa)
        else:
            run_on_dask(runs, store, out_dir, scheduler, workers, max_attempts, time_limit_s, isolate, recordings,
                        reference, bar, info, plugins, hulls, colreg, gospa)
    finally:
        if bar is not None:
            bar.close()
        if hulls:
            release_hull_root()  # (removed when no campaign in this process needs them any more)
    info["wall_time_s"] = round(time.perf_counter() - t0, 3)
    return info


def _run_here(runs, store, out_dir, max_attempts, time_limit_s, isolate, recordings, reference, bar,
              plugins=None, info: dict | None = None, hulls: dict | None = None,
              colreg: dict | None = None, gospa: dict | None = None) -> None:
    executor = ((take_prestarted(1) or [IsolatedExecutor()])[0]) if isolate else None
    try:
        if executor is not None:
            # The child's start-up (it imports what runs need, ~1.5–2 s) is the campaign's, as a
            # cluster's is; a child that fails to start is started again by the first run.
            t0 = time.perf_counter()
            executor.wait_ready(WORKER_WAIT_S)
            if info is not None:
                info["startup_s"] = round(time.perf_counter() - t0, 3)
        for run in runs:
            raise_pending()  # (an interrupt that arrived inside a finalizer: mjasc.runs.interrupts)
            request = request_of(run, out_dir, recordings, reference, plugins, colreg, gospa)
            if hulls:
                request = localise({**request, "hulls": hulls})
            while True:
                result = executor.run(request, time_limit_s) if executor else execute_in_process(request)
                attempts = record_result(store, run, result)
                if result["status"] not in RETRY_STATUSES or attempts >= max_attempts:
                    break
            if bar is not None:
                bar.update(1)
    finally:
        if executor is not None:
            executor.close()
