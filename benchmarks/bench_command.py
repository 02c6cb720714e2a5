"""A scenario from the command line: what a user waits for, against what the run itself costs.

``mjasc run <scenario>`` starts a Python process, imports MuJoCo, numba, SciPy and Rerun, loads the
scenario, loads the compiled kernels from numba's cache, runs, writes the recording and the
summary and leaves. :mod:`benchmarks.bench_fullstack` times only the run, in a warm process; this
script times the whole command, in a fresh process each time, as a user runs it (recording on, no
video, the default outputs), and says where the rest goes.

For each row, in one call (the machine is shared: the same call's numbers only):

* **command** — wall time of ``python -m mjasc run <name> --out <tmp> --no-progress`` from start to
  exit, median of ``--repeats`` fresh processes.
* **run** — the same scenario's :meth:`mjasc.runs.runner.Runner.run` (recording on) in this warm
  process, best of ``--repeats``: what the command cannot do without.
* **fixed cost** — command − run, split by a probe process (the same command through
  :func:`mjasc.cli.main`, timed from inside): **start and imports** (the interpreter, then every
  module the command imports — the list an earlier probe of the same scenario recorded, imported
  first and timed), **kernel loads** (numba's cache loads of the kernels the run calls, each the
  first time: a hook on numba's cache, measurement only) and the **rest** (reading the scenario,
  building the simulation, the recording's set-up, the first run's colder caches, the outputs'
  close and the exit; it also takes the noise of a median command against a best run).

    .venv/bin/python benchmarks/bench_command.py            # the thesis scenarios and the demo (~2 min)
    .venv/bin/python benchmarks/bench_command.py --quick    # one scenario, once
    .venv/bin/python benchmarks/bench_command.py --rows thesis_6_4_crossing --repeats 5
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import mjasc  # noqa: F401  (offscreen GL backend before mujoco is imported)
from mjasc.runs.runner import Runner
from mjasc.runs.scenario import load_scenario

ROOT = Path(__file__).resolve().parent.parent
ROWS = ("thesis_6_2_dock", "thesis_6_3_velocity_correction", "thesis_6_4_crossing", "thesis_6_4_head_on",
        "thesis_6_4_bottleneck", "demo")
QUICK = {"rows": ["thesis_6_1_static"], "repeats": 1}

# The probe: the command through mjasc.cli.main, timed from inside (stdout's last line: JSON).
PROBE = r"""
import importlib, json, sys, time
t0 = time.perf_counter()
from mjasc.runs.collector import for_the_program
for_the_program()  # (the collector as the program sets it: mjasc.cli.command_line)
modules = json.load(open(sys.argv[3])) if len(sys.argv) > 3 else []  # (every module the command imports)
for name in modules:
    if name not in sys.modules and name != "__main__" and not name.startswith("mjasc.__main__"):
        try:
            importlib.import_module(name)
        except Exception:  # (a module that only imports inside its package's own set-up: left to the command)
            pass
import mjasc.cli
t1 = time.perf_counter()
loads = [0.0, 0]
try:
    import numba.core.caching as caching
    load = caching.Cache.load_overload
    def timed(self, *args, **kwargs):
        t = time.perf_counter()
        try:
            return load(self, *args, **kwargs)
        finally:
            loads[0] += time.perf_counter() - t
            loads[1] += 1
    caching.Cache.load_overload = timed
except (ImportError, AttributeError):  # another numba: no split of the kernel loads
    loads = [float("nan"), 0]
status = mjasc.cli.main(["run", sys.argv[1], "--out", sys.argv[2], "--no-progress"])
t2 = time.perf_counter()
print(json.dumps({"status": status, "imports_s": t1 - t0, "main_s": t2 - t1, "kernel_loads_s": loads[0],
                  "kernels": loads[1], "modules": list(sys.modules)}))
"""


def _env() -> dict:
    path = os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    return dict(os.environ, PYTHONPATH=path)


def _wall(argv: list[str], cwd: Path) -> tuple[float, str]:
    t = time.perf_counter()
    proc = subprocess.run(argv, cwd=cwd, env=_env(), capture_output=True, text=True, timeout=1800)
    wall = time.perf_counter() - t
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(argv[:5])}: exit status {proc.returncode}\n{proc.stderr[-2000:]}")
    return wall, proc.stdout


def _command_s(name: str, tmp: Path) -> float:
    out = tmp / "command"
    wall, _ = _wall([sys.executable, "-m", "mjasc", "run", name, "--out", str(out), "--no-progress"], tmp)
    return wall


def _probe(name: str, tmp: Path, modules: list[str] | None = None) -> dict:
    out = tmp / "probe"
    extra = []
    if modules:
        (tmp / "modules.json").write_text(json.dumps(modules))
        extra = [str(tmp / "modules.json")]
    _, stdout = _wall([sys.executable, "-c", PROBE, name, str(out), *extra], tmp)
    return json.loads(stdout.strip().splitlines()[-1])


def _run_s(name: str, tmp: Path) -> float:
    sc = load_scenario(name)
    sc = replace(sc, outputs=replace(sc.outputs, recording=True, video=False))
    t = time.perf_counter()
    Runner(sc, tmp / "warm", progress=False).run()
    return time.perf_counter() - t


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help=f"rows {QUICK['rows']}, once (well under a minute)")
    ap.add_argument("--rows", nargs="+", help="only these scenarios (bundled names)")
    ap.add_argument("--repeats", type=int, default=3, help="fresh commands (median) and warm runs (best) per row")
    args = ap.parse_args(argv)
    rows = QUICK["rows"] if args.quick else (args.rows or list(ROWS))
    repeats = QUICK["repeats"] if args.quick else args.repeats
    t_all = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        start_s = min(_wall([sys.executable, "-c", "pass"], tmp)[0] for _ in range(3))  # the interpreter alone
        _run_s(rows[0], tmp)  # (this process warm: kernels loaded, caches filled)
        table = []
        for name in rows:
            modules = _probe(name, tmp)["modules"]  # (what the command imports, for the timed probes)
            commands, runs, probes = [], [], []
            for _ in range(repeats):  # interleaved: a command, a warm run, a probe
                commands.append(_command_s(name, tmp))
                runs.append(_run_s(name, tmp))
                probes.append(_probe(name, tmp, modules))
            command, run = statistics.median(commands), min(runs)
            imports = start_s + statistics.median(p["imports_s"] for p in probes)
            kernels = statistics.median(p["kernel_loads_s"] for p in probes)
            n_kernels = max(p["kernels"] for p in probes)
            table.append((name, load_scenario(name).duration_s, command, run, imports, kernels, n_kernels))
    print(f"A scenario from the command line (python -m mjasc run NAME: recording and summary, no video), "
          f"{os.cpu_count()} CPU core(s), Python {sys.version.split()[0]} at {sys.executable}; command: median of "
          f"{repeats} fresh processes, run: best of {repeats} in a warm process; {time.perf_counter() - t_all:.0f} s "
          f"in all\n")
    print("| scenario | sim s | command s | run s | command / run | fixed cost s | start and imports s | "
          "kernel loads s (kernels) | rest s |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for name, sim, command, run, imports, kernels, n_kernels in table:
        fixed = command - run
        print(f"| {name} | {sim:g} | {command:.2f} | {run:.2f} | {command / run:.1f}× | {fixed:.2f} | {imports:.2f} | "
              f"{kernels:.2f} ({n_kernels}) | {fixed - imports - kernels:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
