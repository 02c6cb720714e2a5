"""The demo campaign against an earlier version of mjasc, in one call: runs/hour of this checkout
and of the baseline commit, each the real ``mjasc campaign`` command on the same 2 workers,
alternated (this, baseline, this, …) so a machine whose speed drifts hits both alike.

The speed issue's campaign target is a ratio of runs/hour against the engine of its day (commit
7aeb968, before the layout issue; it measured "150 runs/hour" then). A figure quoted from another
day is not a measurement in one run: this script builds the baseline's tree from git
(``git archive REV``) in a temporary folder and runs both on the same demo campaign:

* the campaign is ``tasks/campaigns/demo_monte_carlo.toml``'s perturbation of ``tasks/demo.toml``
  (the same scenario text then and now), written as a campaign file in the first format (which
  both versions read), with the full 240-s runs and no recordings;
* this checkout's evaluation has the mission-cost reference off (``[evaluation] mission_cost =
  false``): the baseline had no reference run, so both simulate each run once;
* runs/hour = runs / the command's wall time (process start to exit: imports, start-up, every run,
  the store and exports), quoted per command and as the ratio of this checkout's mean over its
  runs around each baseline run;
* "runs alone": the rate of a long campaign (the issue's 1,000 runs), whose start-up and exit are
  spread over its runs: workers × 3600 / the mean wall seconds of one run as its worker timed it
  (both versions write that mean to ``campaign.json``), with the same ratio. A 20-run command
  spends ~2.5 s of its ~28 s starting and ending; the old engine's 10-run command a few of ~140 s;
* before the first timed command, one untimed 3-s run of this checkout fills its compiled-kernel
  cache (numba compiles each kernel once per machine and checkout; the baseline has none).

    .venv/bin/python benchmarks/bench_campaign_baseline.py             # 20 runs vs 10, ~7 min on 2 cores
    .venv/bin/python benchmarks/bench_campaign_baseline.py --quick     # 1 run of 3 s each, in-process (~30 s)
    .venv/bin/python benchmarks/bench_campaign_baseline.py --baseline-runs 20 --pairs 2

Needs the git history (a clone, not an exported tree) for the baseline's files.
"""

from __future__ import annotations

import argparse
import io
import json
import os
import subprocess
import sys
import tarfile
import tempfile
import time
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
#: The engine when the speed issue was filed (the parent of the layout issue's first commit).
BASELINE = "7aeb968"
CAMPAIGN = ROOT / "tasks" / "campaigns" / "demo_monte_carlo.toml"
SCENARIO = ROOT / "tasks" / "demo.toml"


def baseline_tree(rev: str, folder: Path) -> Path:
    """The files of commit ``rev`` under ``folder`` (``git archive``); a clear error without git."""
    try:
        tar = subprocess.run(["git", "-C", str(ROOT), "archive", "--format=tar", rev], check=True,
                             capture_output=True).stdout
    except (OSError, subprocess.CalledProcessError) as e:
        err = getattr(e, "stderr", b"") or b""
        raise SystemExit(f"bench_campaign_baseline: cannot read commit {rev!r} from {ROOT}'s git history "
                         f"({err.decode(errors='replace').strip() or e}); run it in a clone") from None
    with tarfile.open(fileobj=io.BytesIO(tar)) as t:
        # (the "data" filter where this Python has it: 3.11.4 and later; the archive is our own history)
        t.extractall(folder, **({"filter": "data"} if hasattr(tarfile, "data_filter") else {}))
    return folder


def campaign_files(folder: Path, duration_s: float | None) -> tuple[Path, Path]:
    """(this checkout's campaign file, the baseline's): the demo campaign in the first format,
    pointing at a copy of the demo scenario (``duration_s`` overrides its length when given)."""
    spec = tomllib.loads(CAMPAIGN.read_text())
    text = SCENARIO.read_text()
    if duration_s is not None:
        lines = [f"duration_s = {duration_s!r}" if ln.startswith("duration_s") else ln for ln in text.splitlines()]
        text = "\n".join(lines) + "\n"
    (folder / "demo.toml").write_text(text)
    rand = "\n".join(f"{k} = {v!r}" for k, v in spec["randomize"].items())
    common = (f'name = "demo_monte_carlo"\ndescription = {spec.get("description", "demo")!r}\nscenario = "demo.toml"\nruns = {spec["runs"]}\n'
              f'base_seed = {spec.get("base_seed", 0)}\n\n[randomize]\n{rand}\n\n[outputs]\nrecordings = false\n')
    ours, theirs = folder / "campaign_now.toml", folder / "campaign_baseline.toml"
    ours.write_text(common + "\n[evaluation]\nmission_cost = false\n")
    theirs.write_text(common)
    return ours, theirs


def compile_tree(tree: Path) -> None:
    """Byte-compile ``tree``'s mjasc, as an install does (and as ``make`` does for this checkout):
    both engines then start from .pyc files even where the environment forbids writing them."""
    subprocess.run([sys.executable, "-m", "compileall", "-q", str(tree / "mjasc")], check=True, capture_output=True)


def run_command(tree: Path, campaign: Path, runs: int, workers: int, out: Path) -> tuple[float, float | None]:
    """Wall seconds of ``python -m mjasc campaign`` from ``tree`` and the mean wall seconds of one
    of its runs (as its worker timed it: parse, run, evaluation; both versions write it to
    ``campaign.json``, ``aggregate.run_wall_time_s.mean``); raises with its output on failure."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    env.setdefault("MUJOCO_GL", "osmesa")
    cmd = [sys.executable, "-m", "mjasc", "campaign", str(campaign), "--workers", str(workers), "--runs", str(runs),
           "--out", str(out)]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, cwd=out.parent, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"bench_campaign_baseline: {' '.join(cmd)} (PYTHONPATH={tree}) failed "
                         f"with exit {proc.returncode}:\n{proc.stdout[-1500:]}\n{proc.stderr[-3000:]}")
    try:
        run_wall = json.loads((out / "campaign.json").read_text())["aggregate"]["run_wall_time_s"]["mean"]
    except (OSError, ValueError, KeyError, TypeError):
        run_wall = None
    return wall, run_wall


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="1 run of 3 s each, workers 0 (in-process): the path only")
    ap.add_argument("--baseline", default=BASELINE, help=f"the earlier commit (default {BASELINE})")
    ap.add_argument("--runs", type=int, default=20, help="runs of this checkout per command (default 20)")
    ap.add_argument("--baseline-runs", type=int, default=10, help="runs of the baseline per command (default 10)")
    ap.add_argument("--pairs", type=int, default=1, help="baseline commands; this checkout runs before and after each")
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args(argv)
    duration = 3.0 if args.quick else None
    runs, base_runs, workers = (1, 1, 0) if args.quick else (args.runs, args.baseline_runs, args.workers)
    sim_s = duration if duration is not None else tomllib.loads(SCENARIO.read_text())["duration_s"]
    t_start = time.perf_counter()
    load0 = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        old = baseline_tree(args.baseline, tmp / "baseline")
        for tree in (ROOT, old):
            compile_tree(tree)
        ours, theirs = campaign_files(tmp, duration)
        # (untimed: one short run fills this checkout's compiled-kernel cache, as `make demo` does on
        # a fresh machine; a cold cache would put numba's one-time compile, ~1 min, into the first row)
        warm = tmp / "warm"
        warm.mkdir()
        run_command(ROOT, campaign_files(warm, 3.0)[0], 1, 0, warm / "out")
        rows, k = [], 0
        for i in range(2 * args.pairs + 1):
            k += 1
            if i % 2 == 0:
                rows.append(("this checkout", runs, run_command(ROOT, ours, runs, workers, tmp / f"out{k}")))
            else:
                rows.append((f"baseline {args.baseline}", base_runs,
                             run_command(old, theirs, base_runs, workers, tmp / f"out{k}")))
    print(f"Demo campaign, this checkout against {args.baseline}: runs of {sim_s:g} simulated s, no recordings, "
          f"{workers} worker(s) (0: in-process); os.cpu_count() = {os.cpu_count()}; 1-min load average "
          f"{load0:.2f} before, {os.getloadavg()[0]:.2f} after; {time.perf_counter() - t_start:.0f} s in all. "
          f"Each row is one whole `mjasc campaign` command, in the order run.\n")
    print("| # | code | runs | wall s | runs/hour | ratio to the baseline | mean run s | runs/hour, runs alone "
          "| ratio, runs alone |")
    print("|---:|---|---:|---:|---:|---:|---:|---:|---:|")
    rph = [n / w * 3600.0 for _, n, (w, _) in rows]
    # A long campaign's rate: every worker busy with runs back to back (start-up and exit spread
    # over its thousands of runs): workers × 3600 / the mean run's wall seconds.
    alone = [max(workers, 1) * 3600.0 / rw if rw else None for _, _, (_, rw) in rows]

    def ratio(values: list, i: int) -> str:
        a, b, c = values[i - 1], values[i], values[i + 1]
        return f"{(a + c) / 2 / b:.2f}× (#{i}, #{i + 2})" if None not in (a, b, c) else "—"

    for i, ((label, n, (wall, run_wall)), r) in enumerate(zip(rows, rph)):
        odd = i % 2 == 1
        mean_run = f"{run_wall:.2f}" if run_wall else "—"
        rate_alone = f"{alone[i]:,.0f}" if alone[i] else "—"
        print(f"| {i + 1} | {label} | {n} | {wall:.1f} | {r:,.0f} | {ratio(rph, i) if odd else '—'} | {mean_run} | "
              f"{rate_alone} | {ratio(alone, i) if odd else '—'} |")
    ours_rph = [r for i, r in enumerate(rph) if i % 2 == 0]
    base_rph = [r for i, r in enumerate(rph) if i % 2 == 1]
    print(f"\nThis checkout {min(ours_rph):,.0f}–{max(ours_rph):,.0f} runs/hour, the baseline "
          f"{min(base_rph):,.0f}–{max(base_rph):,.0f}; the speed issue's target is 10× the baseline. "
          f"\"Runs alone\" is the rate of a long campaign, whose start-up and exit are spread over "
          f"its runs: {max(workers, 1)} worker(s) × 3600 s / the mean run's wall seconds.")


if __name__ == "__main__":
    main()
