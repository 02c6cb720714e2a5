"""Campaign throughput: runs/hour in this process and on a LocalCluster of 1 and 2 worker processes.

The campaign is tasks/campaigns/demo_monte_carlo.toml shortened (``--duration``, default 30 s of
the demo: three Otters, a ferry, no recording). Throughput counts from the first submission to the
last result; the cluster's start-up (processes, imports of MuJoCo and mjasc on every worker) is
shown apart. Speed-up is relative to one worker. The machine's core count bounds the speed-up
(the numbers in docs/campaigns.md are from a shared 2-core machine). Per-run results are checked
to be the same in every configuration.

    .venv/bin/python benchmarks/bench_campaign.py [--runs 16] [--duration 30] [--workers 1 2]
    .venv/bin/python benchmarks/bench_campaign.py --quick   # 2 runs of 2 s, in-process and 1 worker, once
"""

from __future__ import annotations

import argparse
import os
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=16)
    ap.add_argument("--duration", type=float, default=30.0, help="simulated seconds per run")
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--repeat", type=int, default=2, help="interleaved repetitions; the best of each is shown")
    ap.add_argument("--quick", action="store_true", help="2 runs of 2 s, in-process and 1 worker, once (a smoke test)")
    args = ap.parse_args()
    if args.quick:
        args.runs, args.duration, args.workers, args.repeat = 2, 2.0, [1], 1

    import mjasc  # noqa: F401
    from mjasc.campaigns.engine import run_campaign, without_timing
    from mjasc.campaigns.perturbation import load_campaign

    campaign = load_campaign(ROOT / "tasks" / "campaigns" / "demo_monte_carlo.toml").with_overrides(
        runs=args.runs, duration_s=args.duration)
    configs = [("in-process", dict(scheduler="synchronous"))] + \
              [(f"LocalCluster, {n} worker{'s' if n > 1 else ''}", dict(workers=n)) for n in args.workers]
    best: dict[str, tuple] = {}
    reference, same = None, True
    with tempfile.TemporaryDirectory() as tmp:
        for rep in range(args.repeat):  # interleaved, so a burst of load elsewhere hits every configuration
            for label, kw in configs:
                res = run_campaign(campaign, Path(tmp) / f"{rep}_{label.replace(' ', '_')}", progress=False, **kw)
                rows = without_timing(res.rows)
                reference = rows if reference is None else reference
                same &= rows == reference
                if label not in best or res.aggregate["wall_time_s"] < best[label][2].aggregate["wall_time_s"]:
                    best[label] = (label, kw.get("workers", 0), res)
    results = [best[label] for label, _ in configs]
    one = next((r.aggregate["throughput_runs_per_hour"] for _, n, r in results if n == 1), None)

    print(f"Campaign throughput: {args.runs} runs of {args.duration:g} s of the demo (3 Otters + ferry, no recording), "
          f"{os.cpu_count()} CPU core(s) on this machine\n")
    print("| configuration | start-up s | wall s (submit → last result) | CPU s per run | runs/hour "
          "| sim-time × real time | speed-up vs 1 worker |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for label, n, res in results:
        a = res.aggregate
        speed = f"{a['throughput_runs_per_hour'] / one:.2f}×" if one and n > 0 else "—"
        startup = res.info["startup_s"]
        print(f"| {label} | {startup:.1f} | {a['wall_time_s']:.1f} | {a['run_cpu_time_s']['mean']:.2f} | "
              f"{a['throughput_runs_per_hour']:,.0f} | "
              f"{a['real_time_factor']:.0f} | {speed} |")
    print(f"\nbest of {args.repeat} interleaved repetitions; per-run results identical in every configuration and "
          f"repetition: {'yes' if same else 'NO'}")


if __name__ == "__main__":  # required: Dask's worker processes are spawned and re-import __main__
    main()
