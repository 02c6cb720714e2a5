"""Campaign engine throughput: runs/s and runs/hour, parallel efficiency on 1 vs 2 workers, and the
engine's overhead per run against the same runs executed directly in this process.

Workloads (rows): the demo Monte Carlo campaign (tasks/campaigns/demo_monte_carlo.toml: three
Otters and a ferry, perturbed) and the Imazu encounter campaign (tasks/campaigns/imazu.toml: one
run per case), both with a shortened simulated duration and no recordings.

Configurations, measured interleaved in this one process (a burst of load elsewhere on the shared
machine hits all alike), best of ``--repeats`` per configuration:

* **direct** — each run's scenario text parsed and run here by :class:`mjasc.runs.runner.Runner`
  with the :class:`~mjasc.evaluation.run_evaluation.RunEvaluator` observing it (exactly the run's
  own compute in a campaign), one after the other: no engine at all.
* **engine, no Dask** — :func:`mjasc.campaigns.engine.run_campaign` with ``workers = 0``: the runs in
  one persistent child process (:mod:`mjasc.campaigns.executor`), results into the SQLite store.
* **1 worker / 2 workers** — ``run_campaign`` on its own Dask LocalCluster of that many workers
  (threads of this process), each with its own child process.

Every ``run_campaign`` goes into a fresh folder (nothing resumed); its wall time is taken around
the call (store, exports and campaign.json included); ``start-up`` is the engine's own
``info["startup_s"]`` (cluster up, the first worker's child process has imported what runs need;
the others import while it runs).

Definitions (N runs of T simulated seconds):

* throughput = N / wall;  **efficiency** = throughput(2 workers) / (2 · throughput(1 worker));
  target ≥ 90 %. Two workers need two idle cores: the table header gives ``os.cpu_count()``, the
  cores this process may use, the 1-minute load average before and after, and the machine's own
  2-process efficiency before and after (two CPU-bound spin loops vs one: the ceiling).
* **overhead per run** = (wall / N − direct / N) / (direct / N): the campaign's wall beyond the
  runs' own compute, per run, as a share of it (1 worker and no-Dask). Target ≤ 5 %. Shown with
  the start-up amortized over the N runs, and without it (the per-run part a long campaign sees).
* **projection to the full demo campaign** (runs of 240 s; the previous engine: 150 runs/hour,
  issue 9), two ways: *per sim-second* — runs/hour = 3600 · N · T / (wall · 240), every cost
  scaled with the duration (a lower bound: fixed costs are scaled too); *loop scaled* — the wall
  plus N · loop · (240 − T) / p, where loop is the direct runs' main-loop wall per simulated second
  and p the parallelism (1; for 2 workers 2 × the measured efficiency, start-up excluded). The full
  mode also runs demo run 0 at 240 s directly: the per-run cost the projection assumes.

Targets are printed with a verdict, never asserted (the machine is shared and noisy). Per-run
results are checked to be identical in every configuration and repetition, direct included.

    .venv/bin/python benchmarks/bench_campaign.py            # full mode (~9 min on 2 cores)
    .venv/bin/python benchmarks/bench_campaign.py --quick    # 2 runs of 2 s of the demo, once (~30 s)
    .venv/bin/python benchmarks/bench_campaign.py --workloads demo --runs 12 --duration 30 --repeats 3
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
#: Workload → (campaign file, runs, simulated seconds per run) of the full mode.
WORKLOADS = {"demo": ("demo_monte_carlo.toml", 12, 30.0), "imazu": ("imazu.toml", 22, 12.0)}
QUICK = {"workloads": ["demo"], "runs": 2, "duration": 2.0, "repeats": 1}
#: The full demo campaign (tasks/campaigns/demo_monte_carlo.toml) and the previous engine on it.
FULL_DEMO_RUNS, FULL_DEMO_DURATION_S, PREVIOUS_RUNS_PER_HOUR = 20, 240.0, 150.0
EFFICIENCY_TARGET, OVERHEAD_TARGET = 0.90, 0.05
CONFIGS = (("direct", None), ("engine, no Dask", 0), ("1 worker", 1), ("2 workers", 2))


@dataclass
class Measure:
    wall_s: float                  # the whole configuration (run_campaign call, or the direct loop)
    startup_s: float = 0.0         # engine start-up (cluster, the first worker's imports)
    child_run_s: float = 0.0       # Σ of the runs' own wall as timed in the child (engine only)
    loop_s: float = 0.0            # Σ of the Runner main loops (direct only)
    results: dict = field(default_factory=dict, repr=False)  # index → (status, metrics w/o timing)


def _campaign(name: str, runs: int, duration_s: float):
    from mjasc.campaigns.spec import load_campaign_spec

    spec = load_campaign_spec(ROOT / "tasks" / "campaigns" / WORKLOADS[name][0])
    if name == "imazu":  # one seed per case: the runs go through the cases
        spec = spec.with_overrides(runs_per_point=1, duration_s=duration_s, runs=runs)
    else:
        spec = spec.with_overrides(duration_s=duration_s, runs=runs)
    # The engine is measured against the same work done directly: without the mission-cost
    # reference run ([evaluation] mission_cost), which is a second simulation by design.
    return replace(spec, evaluation=replace(spec.evaluation, mission_cost=False))


def direct(runs: list) -> Measure:
    """The runs one after the other in this process: parse, Runner, RunEvaluator — what the
    executor's child does for a run (no recording, no video), without child, Dask or store."""
    from mjasc.campaigns.engine import without_timing
    from mjasc.campaigns.run_request import plain as _plain
    from mjasc.evaluation.run_evaluation import RunEvaluator
    from mjasc.runs.runner import RunFailed, Runner
    from mjasc.runs.scenario import parse_scenario

    out = Measure(0.0)
    t0 = time.perf_counter()
    for run in runs:
        sc = parse_scenario(tomllib.loads(run.scenario_toml), f"<run {run.index}>")
        sc = replace(sc, outputs=replace(sc.outputs, recording=False, video=False))
        runner = Runner(sc, None, progress=False)
        evaluator = RunEvaluator(runner)
        runner.observe("record", evaluator)
        status = "completed"
        try:
            summary = runner.run().summary
        except RunFailed as exc:
            status, summary = "diverged", exc.summary
        summary["evaluation"] = evaluator.summary()
        out.loop_s += summary.get("wall_time_s") or 0.0
        out.results[run.index] = (status, without_timing(json.loads(json.dumps(_plain(summary)))))
    out.wall_s = time.perf_counter() - t0
    return out


def engine(campaign, workers: int, folder: Path) -> Measure:
    from mjasc.campaigns.engine import run_campaign, without_timing

    t0 = time.perf_counter()
    res = run_campaign(campaign, folder, workers=workers, progress=False)
    wall = time.perf_counter() - t0
    return Measure(wall, float(res.info.get("startup_s") or 0.0),
                   sum(r.wall_time_s or 0.0 for r in res.runs), 0.0,
                   {r.index: (r.status, without_timing(r.metrics)) for r in res.runs})


def measure(name: str, runs: int, duration_s: float, repeats: int, tmp: Path) -> tuple[dict, bool, int]:
    """Best (least wall) Measure per configuration over interleaved repetitions; whether every
    configuration and repetition gave the same per-run results; runs that did not complete."""
    campaign = _campaign(name, runs, duration_s)
    specs = list(campaign.runs())
    direct([_campaign(name, 1, 1.0).run(0)])  # warm-up: the first Runner in a process pays lazy imports
    best: dict[str, Measure] = {}
    reference, same = None, True
    for rep in range(repeats):
        for label, workers in CONFIGS:
            m = direct(specs) if workers is None else engine(campaign, workers, tmp / f"{name}_{rep}_{workers}")
            reference = m.results if reference is None else reference
            same &= m.results == reference
            if label not in best or m.wall_s < best[label].wall_s:
                best[label] = m
    failed = sum(1 for status, _ in reference.values() if status != "completed")
    return best, same, failed


_SPIN = ("import time\nt0 = time.perf_counter(); n = 0\nwhile time.perf_counter() - t0 < {s}:\n"
         "    for _ in range(10000): pass\n    n += 1\nprint(n)")


def machine_ceiling(seconds: float) -> float:
    """The machine's own 2-process efficiency now: the work two concurrent CPU-bound processes do in
    ``seconds`` over twice what one does alone (pure-Python spin loops). On two idle cores ≈ 1; the
    engine's 2-worker efficiency cannot exceed it."""
    import subprocess
    import sys

    def spin(k: int) -> int:
        procs = [subprocess.Popen([sys.executable, "-c", _SPIN.format(s=seconds)], stdout=subprocess.PIPE, text=True)
                 for _ in range(k)]
        return sum(int(p.communicate()[0]) for p in procs)

    return spin(2) / (2 * spin(1))


def direct_full_demo() -> float:
    """Wall [s] of demo run 0 at its full duration, run directly (the projection's check)."""
    spec = _campaign("demo", 1, FULL_DEMO_DURATION_S)
    return direct([spec.run(0)]).wall_s


# ---------------------------------------------------------------------- output
def _pct(x: float) -> str:
    return f"{100 * x:+.1f} %"


def _verdict(ok: bool) -> str:
    return "PASS" if ok else "short of target"


def report(results: list, duration: dict, runs: dict, repeats: int, loads: tuple, elapsed: float,
           full_check: float | None, ceiling: tuple) -> str:
    aff = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    lines = [f"Campaign engine: best of {repeats} interleaved repetition(s) per configuration; "
             f"os.cpu_count() = {os.cpu_count()}, {aff} usable by this process; 1-min load average "
             f"{loads[0]:.2f} before, {loads[1]:.2f} after; {elapsed:.0f} s in all. Efficiency on 2 workers "
             f"needs 2 idle cores: a load above {max(0, (os.cpu_count() or 1) - 2)} from other work lowers it. "
             f"The machine's own 2-process efficiency (two CPU-bound spin loops vs one, the ceiling of the "
             f"engine's): {100 * ceiling[0]:.0f} % before, {100 * ceiling[1]:.0f} % after.", "",
             "| workload | configuration | runs × sim s | wall s | start-up s | runs/s | runs/hour | wall s / run "
             "| run's own s / run | overhead / run | overhead / run, start-up excluded | speed-up vs direct |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    targets = []
    for name, best, same, failed in results:
        n, d = runs[name], best["direct"]
        per_direct = d.wall_s / n
        for label, _ in CONFIGS:
            m = best[label]
            own = d.wall_s if label == "direct" else m.child_run_s
            over = "—" if label in ("direct", "2 workers") else _pct((m.wall_s - d.wall_s) / d.wall_s)
            over_ss = "—" if label in ("direct", "2 workers") else _pct((m.wall_s - m.startup_s - d.wall_s) / d.wall_s)
            lines.append(f"| {name} | {label} | {n} × {duration[name]:g} | {m.wall_s:.1f} | {m.startup_s:.1f} | "
                         f"{n / m.wall_s:.3f} | {3600 * n / m.wall_s:,.0f} | {m.wall_s / n:.2f} | {own / n:.2f} | "
                         f"{over} | {over_ss} | {per_direct * n / m.wall_s:.2f}× |")
        one, two = best["1 worker"], best["2 workers"]
        eff = one.wall_s / (2 * two.wall_s)
        eff_ss = (one.wall_s - one.startup_s) / (2 * (two.wall_s - two.startup_s))
        over1 = (one.wall_s - d.wall_s) / d.wall_s
        over1_ss = (one.wall_s - one.startup_s - d.wall_s) / d.wall_s
        over0 = (best["engine, no Dask"].wall_s - d.wall_s) / d.wall_s
        targets += [(name, "efficiency 2 vs 1 workers", f"{100 * eff:.0f} %", "≥ 90 %", eff >= EFFICIENCY_TARGET),
                    (name, "efficiency 2 vs 1 workers, start-up excluded", f"{100 * eff_ss:.0f} %", "≥ 90 %",
                     eff_ss >= EFFICIENCY_TARGET),
                    (name, f"overhead / run, 1 worker ({n} runs, start-up amortized)", _pct(over1), "≤ 5 %",
                     over1 <= OVERHEAD_TARGET),
                    (name, "overhead / run, 1 worker, start-up excluded", _pct(over1_ss), "≤ 5 %",
                     over1_ss <= OVERHEAD_TARGET),
                    (name, "overhead / run, engine without Dask", _pct(over0), "≤ 5 %", over0 <= OVERHEAD_TARGET)]
    lines += ["", "| workload | target | measured | target | verdict |", "|---|---|---:|---:|---|"]
    lines += [f"| {w} | {what} | {val} | {tgt} | {_verdict(ok)} |" for w, what, val, tgt, ok in targets]
    for name, best, same, failed in results:
        if name != "demo":
            continue
        n, T, d = runs[name], duration[name], best["direct"]
        loop = d.loop_s / n / T                       # main loop [s] per simulated second
        fixed = max(0.0, (d.wall_s - d.loop_s) / n)   # per run: parse, build, evaluation summary
        one, two = best["1 worker"], best["2 workers"]
        eff_ss = min(1.0, (one.wall_s - one.startup_s) / (2 * (two.wall_s - two.startup_s)))
        lines += ["", f"Projection to the full demo campaign ({FULL_DEMO_RUNS} runs × {FULL_DEMO_DURATION_S:g} s; "
                      f"the previous engine: {PREVIOUS_RUNS_PER_HOUR:g} runs/hour). Direct: {fixed:.2f} s fixed + "
                      f"{loop:.3f} s per simulated second per run → {fixed + loop * FULL_DEMO_DURATION_S:.1f} s per "
                      f"full run" + (f" (measured directly at {FULL_DEMO_DURATION_S:g} s: {full_check:.1f} s)"
                                     if full_check else "") + ". *Per sim-second*: the measured wall per simulated "
                      "second times 240 s (every cost scales with the duration: a lower bound). *Loop scaled*: the "
                      f"measured wall plus the loop's extra {FULL_DEMO_DURATION_S - T:g} s per run at the direct "
                      f"rate, spread over the workers at the measured efficiency ({100 * eff_ss:.0f} % for 2, "
                      "start-up excluded).", "",
                  "| configuration | runs/hour, per sim-second | vs previous engine | runs/hour, loop scaled "
                  "| vs previous engine |", "|---|---:|---:|---:|---:|"]
        for label, workers in CONFIGS:
            m = best[label]
            rph_a = 3600 * n * T / (m.wall_s * FULL_DEMO_DURATION_S)
            par = 2 * eff_ss if workers == 2 else 1.0
            wall_b = m.wall_s + n * loop * (FULL_DEMO_DURATION_S - T) / par
            rph_b = 3600 * n / wall_b
            lines.append(f"| {label} | {rph_a:,.0f} | {rph_a / PREVIOUS_RUNS_PER_HOUR:.2f}× | {rph_b:,.0f} | "
                         f"{rph_b / PREVIOUS_RUNS_PER_HOUR:.2f}× |")
    lines.append("")
    for name, best, same, failed in results:
        lines.append(f"{name}: per-run results identical in every configuration and repetition (direct included): "
                     f"{'yes' if same else 'NO'}; runs not completed: {failed}.")
    return "\n".join(lines)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help=f"{QUICK['runs']} runs of {QUICK['duration']:g} s of the "
                                                          "demo, once (~30 s; a smoke test)")
    ap.add_argument("--workloads", nargs="+", choices=sorted(WORKLOADS), help="default: all (--quick: demo)")
    ap.add_argument("--runs", type=int, help="runs per workload (default: demo 12, imazu 22)")
    ap.add_argument("--duration", type=float, help="simulated seconds per run (default: demo 30, imazu 12)")
    ap.add_argument("--repeats", type=int, default=2, help="interleaved repetitions; the best of each is kept")
    ap.add_argument("--no-full-check", action="store_true", help="skip the direct demo run at full duration")
    a = ap.parse_args(argv)
    if a.quick:
        a.runs, a.duration, a.repeats, a.no_full_check = QUICK["runs"], QUICK["duration"], QUICK["repeats"], True
        a.workloads = a.workloads or QUICK["workloads"]
    a.workloads = a.workloads or list(WORKLOADS)
    import mjasc  # noqa: F401  (MUJOCO_GL before mujoco; the direct runs' imports paid before timing)
    import mjasc.evaluation.run_evaluation  # noqa: F401
    import mjasc.runs.runner  # noqa: F401

    runs = {w: a.runs or WORKLOADS[w][1] for w in a.workloads}
    duration = {w: a.duration or WORKLOADS[w][2] for w in a.workloads}
    for w in a.workloads:
        _campaign(w, runs[w], duration[w])  # validate (and import the generators) before timing
    spin_s = 0.5 if a.quick else 2.0
    load0, ceiling0 = os.getloadavg()[0], machine_ceiling(spin_s)
    t0 = time.perf_counter()
    results = []
    with tempfile.TemporaryDirectory() as tmp:
        for w in a.workloads:
            results.append((w, *measure(w, runs[w], duration[w], a.repeats, Path(tmp))))
    full = direct_full_demo() if "demo" in a.workloads and not a.no_full_check else None
    elapsed = time.perf_counter() - t0
    print(report(results, duration, runs, a.repeats, (load0, os.getloadavg()[0]), elapsed, full,
                 (ceiling0, machine_ceiling(spin_s))))


if __name__ == "__main__":  # required: Dask's worker processes are spawned and re-import __main__
    main()
