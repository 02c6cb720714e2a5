"""Monte Carlo campaigns: many randomized runs of one scenario, scaled out on Dask distributed.

A campaign (``mjasc.campaigns.perturbation``: the file format and the per-run draws) is ``runs`` independent
tasks. :func:`run_campaign` submits one task per run to a Dask client — a ``LocalCluster`` of
single-threaded worker processes on this machine, or any existing Dask cluster given by its
scheduler address (the same code) — or runs them one after the other in this process
(``scheduler="synchronous"`` or ``workers=0``: for debugging and tests). Each task builds run k's
scenario (:func:`mjasc.campaigns.perturbation.randomized_scenario`), runs it with
:func:`mjasc.runs.runner.run_scenario` and returns one small row (status, the draws, the run summary).
A run that fails (``RunFailed`` after a physics divergence, or any exception) becomes a failed
row; the other runs go on. Rows are gathered as they complete (``as_completed``) and sorted by k,
so the results do not depend on the number of workers or the completion order.

Outputs in ``out_dir``::

    campaign.json   the campaign, aggregate statistics and every run's row (sorted by k)
    runs.csv        one line per run: status, metrics per run and per vessel, the draws
    runs/<k>/       with ``[outputs] recordings = true``: recording.rrd + summary.json of run k
                    (written by the worker: on a remote cluster, out_dir must be a shared path)

Aggregate statistics (over completed runs): collision rate with its Wilson 95 % score interval,
quantiles of the run's minimum clearance (min over vessels of ``min_clearance_to_any_m``),
distributions of the run's mean and max cross-track error (mean of the vessels' means, max of their
maxima), per-vessel collision counts and clearance quantiles, wall time and throughput (runs/hour).
"""

from __future__ import annotations

import csv
import json
import math
import os
import sys
import time
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any, Callable

import numpy as np

from mjasc.campaigns.perturbation import Campaign, Randomization, draw_perturbations, randomized_scenario
from mjasc.core.config_tables import integer
from mjasc.runs.scenario import Scenario

__all__ = ["CampaignResult", "run_campaign", "run_one", "wilson_interval", "aggregate_rows",
           "format_aggregate", "TIMING_KEYS", "is_timing_key", "without_timing"]

#: z for a two-sided 95 % interval.
Z95 = 1.959963984540054
#: Fields of a row (and of its run summary) that depend on the machine, not on the run; besides
#: these, every key ending in ``_us`` (components report their wall-clock cost in microseconds).
TIMING_KEYS = frozenset({"wall_time_s", "cpu_time_s", "real_time_factor", "worker", "run_wall_time_s",
                         "run_cpu_time_s", "throughput_runs_per_hour", "startup_s", "timing_s"})
QUANTILES = (0.0, 0.05, 0.25, 0.5, 0.75, 0.95, 1.0)
#: How long a campaign waits for the first worker of a cluster [s].
WORKER_WAIT_S = 120.0


@dataclass
class CampaignResult:
    out_dir: Path
    rows: list[dict]  # one per run, sorted by k
    aggregate: dict
    files: dict = field(default_factory=dict)
    info: dict = field(default_factory=dict)  # scheduler, address, workers, startup_s


# ---------------------------------------------------------------------- one run (a task)
def _plain(obj: Any) -> Any:
    """JSON-ready copy: numpy scalars → Python numbers, non-finite floats → None."""
    if isinstance(obj, dict):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _plain(obj.tolist())
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def run_one(scenario: Scenario, randomize: Randomization, base_seed: int, k: int, run_dir: str | None = None,
            run_fn: Callable | None = None) -> dict:
    """Run k of a campaign (the Dask task). Never raises for a failed run: returns its row.

    ``run_dir`` None: no files (recording off); otherwise recording.rrd + summary.json there.
    ``run_fn`` replaces :func:`mjasc.runs.runner.run_scenario` (same signature) — a test hook."""
    if run_fn is None:
        from mjasc.runs.runner import run_scenario as run_fn
    t0, c0 = time.perf_counter(), time.thread_time()
    row: dict[str, Any] = {"k": int(k), "seed": base_seed + int(k), "status": "completed", "error": None}
    try:
        sc = randomized_scenario(scenario, randomize, k, base_seed=base_seed)
        row["draws"] = draw_perturbations(scenario, randomize, base_seed, k).as_dict(scenario)
        sc = replace(sc, outputs=replace(sc.outputs, recording=run_dir is not None, video=False))
        result = run_fn(sc, run_dir, progress=False)
        row["summary"] = _plain(result.summary)
    except Exception as exc:  # noqa: BLE001 — one failed run must not stop the campaign
        from mjasc.runs.runner import RunFailed

        row["status"] = "diverged" if isinstance(exc, RunFailed) else "failed"
        row["error"] = f"{type(exc).__name__}: {exc}"
        row["summary"] = None
    row["wall_time_s"] = round(time.perf_counter() - t0, 3)
    row["cpu_time_s"] = round(time.thread_time() - c0, 3)  # this thread's CPU time: wall minus waiting for a core
    row["worker"] = f"{os.uname().nodename}:{os.getpid()}"
    return row


def is_timing_key(key: str) -> bool:
    """True for a machine-dependent field: one of :data:`TIMING_KEYS` or a ``*_us`` wall-clock cost."""
    return key in TIMING_KEYS or key.endswith("_us")


def without_timing(obj: Any) -> Any:
    """A row (or any nested dict) without its machine-dependent fields (:func:`is_timing_key`):
    what must be identical whatever the workers, their number and the completion order."""
    if isinstance(obj, dict):
        return {k: without_timing(v) for k, v in obj.items() if not is_timing_key(k)}
    if isinstance(obj, list):
        return [without_timing(v) for v in obj]
    return obj


# ---------------------------------------------------------------------- statistics
def wilson_interval(successes: int, n: int, z: float = Z95) -> tuple[float, float] | None:
    """Wilson score interval for a binomial proportion (Wilson 1927):
    ``(p̂ + z²/2n ± z·√(p̂(1−p̂)/n + z²/4n²)) / (1 + z²/n)``; None for n = 0."""
    if n <= 0:
        return None
    if not 0 <= successes <= n:
        raise ValueError(f"successes: must be in [0, n={n}], got {successes}")
    p = successes / n
    denom = 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    lo = 0.0 if successes == 0 else max(0.0, centre - half)  # exact 0 and 1 at the ends (no round-off)
    hi = 1.0 if successes == n else min(1.0, centre + half)
    return lo, hi


def _quantiles(values) -> dict | None:
    x = np.asarray([v for v in values if v is not None], dtype=float)
    if x.size == 0:
        return None
    q = np.quantile(x, QUANTILES)
    out = {f"p{round(100 * p)}": round(float(v), 4) for p, v in zip(QUANTILES, q)}
    out.update(mean=round(float(x.mean()), 4), std=round(float(x.std(ddof=1)), 4) if x.size > 1 else 0.0, n=int(x.size))
    return out


def _run_metrics(row: dict) -> dict:
    """Per-run scalars from a completed row's summary (None where the run has no value)."""
    s = row.get("summary") or {}
    vessels = s.get("vessels", {})
    clear = [v["min_clearance_to_any_m"] for v in vessels.values() if v.get("min_clearance_to_any_m") is not None]
    means = [v["mean_cross_track_m"] for v in vessels.values() if v.get("mean_cross_track_m") is not None]
    maxes = [v["max_cross_track_m"] for v in vessels.values() if v.get("max_cross_track_m") is not None]
    return {
        "any_collision": s.get("any_collision"),
        "collisions": len(s["collisions"]) if "collisions" in s else None,
        "min_clearance_m": min(clear) if clear else None,
        "mean_cross_track_m": round(float(np.mean(means)), 4) if means else None,
        "max_cross_track_m": max(maxes) if maxes else None,
        "sim_time_s": s.get("sim_time_s"),
    }


def aggregate_rows(rows: list[dict], wall_time_s: float | None = None) -> dict:
    """Aggregate statistics of a campaign's rows (module docstring). ``wall_time_s``: the
    campaign's wall time from the first submission to the last result (for the throughput)."""
    done = [r for r in rows if r["status"] == "completed"]
    failed = [r for r in rows if r["status"] != "completed"]
    metrics = [_run_metrics(r) for r in done]
    n_coll = sum(bool(m["any_collision"]) for m in metrics)
    wilson = wilson_interval(n_coll, len(done))
    per_vessel: dict[str, dict] = {}
    for r in done:
        for name, v in r["summary"]["vessels"].items():
            pv = per_vessel.setdefault(name, {"collisions": 0, "_clear": [], "_xte": []})
            pv["collisions"] += bool(v.get("collisions"))
            pv["_clear"].append(v.get("min_clearance_to_any_m"))
            pv["_xte"].append(v.get("mean_cross_track_m"))
    for pv in per_vessel.values():
        pv["collision_rate"] = round(pv["collisions"] / len(done), 4) if done else None
        pv["min_clearance_m"] = _quantiles(pv.pop("_clear"))
        pv["mean_cross_track_m"] = _quantiles(pv.pop("_xte"))
    run_walls = [r["wall_time_s"] for r in rows if r.get("wall_time_s") is not None]
    run_cpus = [r["cpu_time_s"] for r in rows if r.get("cpu_time_s") is not None]
    sim_total = sum(m["sim_time_s"] or 0.0 for m in metrics)
    agg = {
        "runs": len(rows),
        "completed": len(done),
        "failed": len(failed),
        "failed_runs": [{"k": r["k"], "status": r["status"], "error": r["error"]} for r in failed],
        "collision": {"runs_with_collision": n_coll,
                      "rate": round(n_coll / len(done), 4) if done else None,
                      "wilson95": [round(wilson[0], 4), round(wilson[1], 4)] if wilson else None},
        "min_clearance_m": _quantiles(m["min_clearance_m"] for m in metrics),
        "mean_cross_track_m": _quantiles(m["mean_cross_track_m"] for m in metrics),
        "max_cross_track_m": _quantiles(m["max_cross_track_m"] for m in metrics),
        "per_vessel": per_vessel,
        "sim_time_s_total": round(sim_total, 3),
        "run_wall_time_s": {"sum": round(sum(run_walls), 3),
                            "mean": round(float(np.mean(run_walls)), 3) if run_walls else None,
                            "max": round(max(run_walls), 3) if run_walls else None},
        "run_cpu_time_s": {"sum": round(sum(run_cpus), 3),
                           "mean": round(float(np.mean(run_cpus)), 3) if run_cpus else None},
    }
    if wall_time_s is not None:
        agg["wall_time_s"] = round(wall_time_s, 3)
        agg["throughput_runs_per_hour"] = round(3600.0 * len(rows) / wall_time_s, 1) if wall_time_s > 0 else None
        agg["real_time_factor"] = round(sim_total / wall_time_s, 2) if wall_time_s > 0 else None
    return agg


# ---------------------------------------------------------------------- outputs
def _csv_rows(rows: list[dict]) -> tuple[list[str], list[dict]]:
    header = ["k", "seed", "status", "any_collision", "collisions", "min_clearance_m", "mean_cross_track_m",
              "max_cross_track_m", "sim_time_s", "wall_time_s", "cpu_time_s"]
    extra: list[str] = []
    lines = []
    for r in rows:
        line = {"k": r["k"], "seed": r["seed"], "status": r["status"], "wall_time_s": r.get("wall_time_s"),
                "cpu_time_s": r.get("cpu_time_s")}
        if r["status"] == "completed":
            line.update(_run_metrics(r))
            for name, v in r["summary"]["vessels"].items():
                for key in ("min_clearance_to_any_m", "mean_cross_track_m", "max_cross_track_m", "distance_m"):
                    line[f"{name}.{key}"] = v.get(key)
                line[f"{name}.collisions"] = len(v.get("collisions", []))
        for group, entries in (r.get("draws") or {}).items():
            if group == "current":
                for key, val in entries.items():
                    line[f"draw.current.{key}"] = val
            else:
                for name, d in entries.items():
                    for key, val in d.items():
                        line[f"draw.{name}.{key}"] = val
        line["error"] = r.get("error") or ""
        for key in line:
            if key not in header and key not in extra:
                extra.append(key)
        lines.append(line)
    extra = [k for k in extra if k != "error"]
    metric_cols = [k for k in extra if not k.startswith("draw.")]
    draw_cols = [k for k in extra if k.startswith("draw.")]
    return header + metric_cols + draw_cols + ["error"], lines


def write_outputs(campaign: Campaign, rows: list[dict], aggregate: dict, out_dir: Path, info: dict) -> dict:
    out_dir.mkdir(parents=True, exist_ok=True)
    files = {"campaign": out_dir / "campaign.json", "runs_csv": out_dir / "runs.csv"}
    doc = {
        "campaign": {"name": campaign.name, "description": campaign.description, "source": campaign.source,
                     "scenario": campaign.scenario_path, "scenario_name": campaign.scenario.name,
                     "duration_s": campaign.scenario.duration_s, "runs": campaign.runs,
                     "base_seed": campaign.base_seed, "randomize": asdict(campaign.randomize),
                     "recordings": campaign.recordings, **info},
        "aggregate": aggregate,
        "runs": rows,
    }
    files["campaign"].write_text(json.dumps(_plain(doc), indent=1))
    header, lines = _csv_rows(rows)
    with open(files["runs_csv"], "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=header, restval="")
        w.writeheader()
        w.writerows(lines)
    return files


def format_aggregate(agg: dict, name: str = "") -> str:
    """A short plain-text table of the aggregate (what ``mjasc campaign`` prints)."""
    def q(d, unit):
        if not d:
            return "—"
        return (f"p5 {d['p5']:.2f} / median {d['p50']:.2f} / p95 {d['p95']:.2f} / "
                f"min {d['p0']:.2f} / max {d['p100']:.2f} {unit}")

    c = agg["collision"]
    lines = [f"{name}: {agg['runs']} run(s), {agg['completed']} completed, {agg['failed']} failed"]
    rate = "—" if c["rate"] is None else \
        f"{c['runs_with_collision']}/{agg['completed']} = {100 * c['rate']:.1f} % " \
        f"(Wilson 95 %: {100 * c['wilson95'][0]:.1f}–{100 * c['wilson95'][1]:.1f} %)"
    rows = [("collision rate", rate),
            ("min clearance", q(agg["min_clearance_m"], "m")),
            ("mean cross-track", q(agg["mean_cross_track_m"], "m")),
            ("max cross-track", q(agg["max_cross_track_m"], "m"))]
    if "wall_time_s" in agg:
        rows.append(("wall time", f"{agg['wall_time_s']:.1f} s, {agg['throughput_runs_per_hour']:.0f} runs/hour, "
                                  f"{agg['real_time_factor']}× real time overall"))
    for k in agg["failed_runs"][:5]:
        rows.append((f"run {k['k']} {k['status']}", k["error"][:100] if k["error"] else ""))
    width = max(len(r[0]) for r in rows)
    return "\n".join(lines + [f"  {a:<{width}}  {b}" for a, b in rows])


# ---------------------------------------------------------------------- scheduling
def _warm_up() -> str:
    """Run on every worker before the tasks: import mjasc (and MuJoCo) once, report the version."""
    import mjasc
    import mjasc.runs.runner  # noqa: F401

    return getattr(mjasc, "__version__", "unknown")


def _open_client(scheduler, workers: int | None):
    """(client, closers): a Client instance is used as is; None/"local" starts a LocalCluster of
    ``workers`` single-threaded processes; any other string is an existing scheduler's address."""
    from distributed import Client, LocalCluster

    if isinstance(scheduler, Client):
        return scheduler, []
    if scheduler in (None, "local"):
        import logging

        logging.getLogger("distributed").setLevel(logging.WARNING)  # no INFO chatter from the scheduler
        n = workers if workers is not None else (os.cpu_count() or 1)
        # dashboard_address ":0": the scheduler's HTTP server takes a free port (8787 may be in use).
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0")
        client = Client(cluster)
        return client, [client, cluster]
    if not isinstance(scheduler, str):
        raise ValueError(f"scheduler: must be None, 'local', 'synchronous', an address or a distributed.Client, "
                         f"got {scheduler!r}")
    if workers is not None:
        raise ValueError(f"workers: only for a local cluster; the cluster at {scheduler} has its own workers")
    client = Client(scheduler)
    return client, [client]


def run_campaign(campaign: Campaign, out_dir: str | Path, scheduler=None, workers: int | None = None,
                 progress: bool = True, run_fn: Callable | None = None) -> CampaignResult:
    """Run every run of ``campaign`` and write campaign.json + runs.csv into ``out_dir``.

    scheduler: None or "local" — a LocalCluster with ``workers`` processes (default: CPU count),
    one thread each; an address ("tcp://host:8786") — an existing Dask cluster (workers need mjasc
    installed); a ``distributed.Client`` — used as is (not closed); "synchronous" (or workers=0) —
    every run in this process, one after the other.
    run_fn: replaces :func:`mjasc.runs.runner.run_scenario` inside each task (a test hook; it must be
    picklable for a cluster).
    """
    if workers is not None:
        workers = integer(workers, "workers", minimum=0)
    out_dir = Path(out_dir).resolve()
    out_dir.mkdir(parents=True, exist_ok=True)
    sc, rnd, base = campaign.scenario, campaign.randomize, campaign.base_seed

    def run_dir(k: int) -> str | None:
        return str(out_dir / "runs" / str(k)) if campaign.recordings else None

    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=campaign.runs, unit="run", desc=campaign.name, file=sys.stderr)
    rows: list[dict] = []
    info: dict[str, Any] = {}
    in_process = scheduler == "synchronous" or workers == 0
    try:
        if in_process:
            info.update(scheduler="synchronous", workers=0, startup_s=0.0)
            t0 = time.perf_counter()
            for k in range(campaign.runs):
                rows.append(run_one(sc, rnd, base, k, run_dir(k), run_fn))
                if bar is not None:
                    bar.update(1)
        else:
            from distributed import as_completed

            t_start = time.perf_counter()
            client, closers = _open_client(scheduler, workers)
            try:
                try:
                    client.wait_for_workers(1, timeout=WORKER_WAIT_S)
                except TimeoutError:
                    raise RuntimeError(f"no Dask worker joined the scheduler at {client.scheduler.address} "
                                       f"within {WORKER_WAIT_S:.0f} s") from None
                try:
                    versions = client.run(_warm_up)
                except Exception as exc:  # noqa: BLE001
                    raise RuntimeError(f"the Dask workers cannot import mjasc ({type(exc).__name__}: {exc}); "
                                       f"install mjasc on every worker") from None
                kind = "local" if scheduler in (None, "local") else \
                    scheduler if isinstance(scheduler, str) else "client"
                info.update(scheduler=kind, address=client.scheduler.address, workers=len(versions),
                            startup_s=round(time.perf_counter() - t_start, 3))
                t0 = time.perf_counter()
                sc_future = client.scatter(sc, broadcast=True, hash=False)
                futures = {client.submit(run_one, sc_future, rnd, base, k, run_dir(k), run_fn, pure=False,
                                         key=f"mjasc-run-{campaign.name}-{k}-{os.getpid()}-{time.time_ns()}"): k
                           for k in range(campaign.runs)}
                for fut in as_completed(futures):
                    k = futures[fut]
                    try:
                        row = fut.result()
                    except Exception as exc:  # noqa: BLE001 — a lost worker, a task that could not run
                        row = {"k": k, "seed": base + k, "status": "failed", "error": f"{type(exc).__name__}: {exc}",
                               "summary": None, "wall_time_s": None, "worker": None}
                    rows.append(row)
                    fut.release()
                    if bar is not None:
                        bar.update(1)
                        bar.set_postfix(failed=sum(r["status"] != "completed" for r in rows))
            finally:
                import logging

                nanny_log = logging.getLogger("distributed.nanny")
                level = nanny_log.level
                if closers and scheduler in (None, "local"):  # our own workers: no shutdown chatter
                    nanny_log.setLevel(logging.ERROR)
                try:
                    for c in closers:
                        c.close()
                finally:
                    nanny_log.setLevel(level)
        wall = time.perf_counter() - t0
    finally:
        if bar is not None:
            bar.close()
    rows.sort(key=lambda r: r["k"])
    aggregate = aggregate_rows(rows, wall)
    files = write_outputs(campaign, rows, aggregate, out_dir, info)
    return CampaignResult(out_dir, rows, aggregate, files, info)
