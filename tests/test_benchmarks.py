"""Every benchmark stays alive: each script in benchmarks/ runs its ``--quick`` mode (a few seconds
of real work) as its own process, exits 0 and prints a markdown table. A new script is picked up
without touching this file. Also: the shipped fleet scenario is the generator's output."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
BENCHMARKS = sorted((ROOT / "benchmarks").glob("bench_*.py"))


def test_there_are_benchmarks():
    assert len(BENCHMARKS) >= 7


@pytest.mark.parametrize("script", BENCHMARKS, ids=lambda p: p.stem)
def test_benchmark_quick_mode_runs_and_prints_a_table(script, tmp_path):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep))
    env.setdefault("MUJOCO_GL", "osmesa")
    proc = subprocess.run([sys.executable, str(script), "--quick"], cwd=tmp_path, env=env, capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode == 0, f"{script.name} --quick failed:\n{proc.stdout[-2000:]}\n{proc.stderr[-4000:]}"
    lines = proc.stdout.splitlines()
    header = [i for i, line in enumerate(lines[:-1]) if line.startswith("|") and lines[i + 1].startswith("|---")]
    assert header, f"{script.name} --quick printed no markdown table:\n{proc.stdout[-2000:]}"
    assert any(line.startswith("|") for line in lines[header[0] + 2:]), f"{script.name}: a table without rows"


def test_shipped_fleet_scenario_is_the_generators_output():
    proc = subprocess.run([sys.executable, str(ROOT / "scripts" / "make_fleet_scenario.py"), "--check"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_fleet_scenario_loads_with_every_vessel_on_the_whole_stack():
    from mjasc.runs.fleet import formation_among_traffic
    from mjasc.runs.scenario import load_scenario

    sc = load_scenario(ROOT / "tasks" / "fleet_50.toml")
    assert len(sc.vessels) == 50 and len(sc.moving_obstacles) >= 3
    assert all({"sensor", "tracking", "avoidance", "comms"} <= set(v.options) for v in sc.vessels)
    names = [v.name for v in formation_among_traffic(7, columns=3).vessels]
    assert names == [f"v{i:03d}" for i in range(7)]
