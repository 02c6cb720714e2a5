"""Environment steps per second of every mjasc suite task (random actions), one run, one process.

    .venv/bin/python benchmarks/bench_suite.py [--steps 2000] [--all]
    .venv/bin/python benchmarks/bench_suite.py --quick   # the first task of each domain, 50 steps (a smoke test)

Prints a markdown table: build time (compose + compile the model), reset time, and the rate of
``env.step`` (one control step = 5 physics steps of mjasc's hydrodynamics + observation + reward).
The machine is shared and noisy: compare rows of one run, not runs.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import mjasc  # noqa: F401  (offscreen GL backend before mujoco is imported)
from mjasc import suite


def bench(domain: str, task: str, steps: int) -> tuple[float, float, float, int]:
    t0 = time.perf_counter()
    env = suite.load(domain, task, task_kwargs={"random": 0})
    build_s = time.perf_counter() - t0
    spec = env.action_spec()
    rng = np.random.default_rng(0)
    actions = rng.uniform(spec.minimum, spec.maximum, (steps,) + spec.shape)
    t0 = time.perf_counter()
    for _ in range(5):
        env.reset()
    reset_s = (time.perf_counter() - t0) / 5
    n_obs = sum(int(np.prod(s.shape)) for s in env.observation_spec().values())
    env.reset()
    t0 = time.perf_counter()
    for k in range(steps):
        if env.step(actions[k]).last():
            env.reset()
    rate = steps / (time.perf_counter() - t0)
    env.close()
    return build_s, reset_s, rate, n_obs


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--all", action="store_true", help="include the extra (delfim) tasks")
    parser.add_argument("--quick", action="store_true", help="the first task of each domain, 50 steps (a smoke test)")
    args = parser.parse_args()
    tasks = suite.ALL_TASKS if args.all else suite.BENCHMARKING
    if args.quick:
        args.steps, tasks = 50, [t for i, t in enumerate(tasks) if t[0] not in {d for d, _ in tasks[:i]}]
    print("| domain | task | vessels | obs size | build [ms] | reset [ms] | env steps/s | physics steps/s |")
    print("|---|---|---:|---:|---:|---:|---:|---:|")
    for domain, task in tasks:
        build_s, reset_s, rate, n_obs = bench(domain, task, args.steps)
        env = suite.load(domain, task)
        n_vessels, sub = env.physics.n_vessels, int(round(env.control_timestep() / env.physics.timestep()))
        env.close()
        print(f"| {domain} | {task} | {n_vessels} | {n_obs} | {1e3 * build_s:.0f} | {1e3 * reset_s:.1f} | "
              f"{rate:.0f} | {rate * sub:.0f} |", flush=True)


if __name__ == "__main__":
    main()
