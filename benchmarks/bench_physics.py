"""Physics throughput: simulated seconds per wall second (real-time factor) for 1, 3, 10 and 50
Otters in a current, at the scene's default physics step, with mjasc's hydrodynamics and
propellers (mj_step1 → forces → mj_step2) and with bare ``mj_step`` on the same model, in one run.

    .venv/bin/python benchmarks/bench_physics.py [--steps 4000] [--repeats 5]
    .venv/bin/python benchmarks/bench_physics.py --quick   # 1 and 3 vessels, 200 steps, once

Targets (issue 2): ≥ 1000× real time for 3 vessels with hydrodynamics and current; hydrodynamics
costing ≤ 5× bare mj_step. Best of ``repeats`` interleaved runs (the machines are shared).
"""

from __future__ import annotations

import argparse
import time

import mujoco
import numpy as np

import mjasc  # noqa: F401
from mjasc.physics.currents import UniformCurrent
from mjasc.physics.simulation import Simulation
from mjasc.physics.vessels import load_vessel_type
from mjasc.physics.world import build_world


def make(n: int) -> Simulation:
    vt = load_vessel_type("otter")
    world = build_world([(f"v{i}", vt) for i in range(n)])
    sim = Simulation(world, UniformCurrent((0.3, 0.2)))
    side = int(np.ceil(np.sqrt(n)))
    poses = [[30.0 * (i % side), 30.0 * (i // side), 0.1 * i] for i in range(n)]
    sim.reset(poses, [[1.0, 0.0, 0.0]] * n)
    sim.set_commands(np.tile([0.8, 0.6], (n, 1)))
    sim.divergence_checks = False
    return sim


def time_hydro(sim: Simulation, steps: int) -> float:
    t0 = time.perf_counter()
    sim.step(steps)
    return time.perf_counter() - t0


def time_bare(sim: Simulation, data: mujoco.MjData, steps: int) -> float:
    """Bare mj_step on the same model, on its own MjData (no applied forces, nothing stale)."""
    m, d = sim.model, data
    t0 = time.perf_counter()
    for _ in range(steps):
        mujoco.mj_step(m, d)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=4000)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--vessels", type=int, nargs="+", default=[1, 3, 10, 50])
    ap.add_argument("--quick", action="store_true", help="1 and 3 vessels, 200 steps, once (a smoke test)")
    args = ap.parse_args()
    if args.quick:
        args.steps, args.repeats, args.vessels = 200, 1, [1, 3]
    rows = []
    for n in args.vessels:
        sim = make(n)
        bare = mujoco.MjData(sim.model)
        bare.qpos[:] = sim.data.qpos
        bare.qvel[:] = sim.data.qvel
        dt = sim.timestep_s
        best_h, best_b = np.inf, np.inf
        for _ in range(args.repeats):  # interleave so that machine load hits both alike
            best_h = min(best_h, time_hydro(sim, args.steps))
            best_b = min(best_b, time_bare(sim, bare, args.steps))
        rtf_h = args.steps * dt / best_h
        rtf_b = args.steps * dt / best_b
        rows.append((n, dt, best_h / args.steps * 1e6, rtf_h, best_b / args.steps * 1e6, rtf_b, best_h / best_b))
    print(f"Physics step {rows[0][1]*1000:.0f} ms, Otters in a 0.36 m/s uniform current, best of {args.repeats}.\n")
    print("| vessels | µs/step (hydro) | real-time × (hydro) | µs/step (bare mj_step) | real-time × (bare) | hydro / bare |")
    print("|---:|---:|---:|---:|---:|---:|")
    for n, _, us_h, rtf_h, us_b, rtf_b, ratio in rows:
        print(f"| {n} | {us_h:.1f} | {rtf_h:,.0f} | {us_b:.1f} | {rtf_b:,.0f} | {ratio:.1f}× |")
    print("\nTargets: ≥ 1000× real time for 3 vessels with hydrodynamics; hydro ≤ 5× bare mj_step.")


if __name__ == "__main__":
    main()
