"""Benchmark the harmonic potential field (mjasc.avoidance.potential_field): vectorized velocity
evaluations per second, solve time and streamline time, for 24 and 32 panels (thesis Table 6.2).

Run: .venv/bin/python benchmarks/bench_potential_field.py [--quick]   (quick: up to 10⁴ points, one short repeat)
Prints a markdown table with the targets next to the measurements (best of a few repeats; the
machine is shared and noisy).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from mjasc.avoidance.potential_field import PotentialField
from mjasc.figures.potential_field import dock_scenario


QUICK = False  # --quick: one short batch per measurement


def best_time(fn, repeats=5, min_time=0.2):
    """Best wall time [s] of one call, over `repeats` batches of ≥ min_time each."""
    if QUICK:
        repeats, min_time = 1, 0.0
    fn()
    best = np.inf
    for _ in range(repeats):
        n, t0 = 0, time.perf_counter()
        while True:
            fn()
            n += 1
            dt = time.perf_counter() - t0
            if dt >= min_time:
                break
        best = min(best, dt / n)
    return best


def scenes():
    sc = dock_scenario()
    return {
        24: dict(obstacles=sc.obstacles_for(1), kwargs=dict(sink_strength=30.0, uniform_speed=1.0)),
        32: dict(obstacles=sc.obstacles_for(1, with_pontoon=True), kwargs=dict(sink_strength=70.0, uniform_speed=1.85)),
    }, sc


def main():
    global QUICK
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="up to 10⁴ points, one short repeat (a smoke test)")
    QUICK = ap.parse_args().quick
    rows = []
    all_scenes, sc = scenes()
    rng = np.random.default_rng(0)
    for m, s in all_scenes.items():
        make = lambda: PotentialField(  # noqa: E731
            s["obstacles"], goal=sc.goals[1], start=sc.starts[1], safety_ratio=0.3,
            inflation=sc.inflation_m, panels_per_edge=2, **s["kwargs"])
        field = make()
        assert len(field.panels) == m
        for n in (10**3, 10**4) if QUICK else (10**3, 10**4, 10**5, 10**6):
            pts = rng.uniform([-20, -30], [80, 30], (n, 2))
            t = best_time(lambda: field.velocity(pts), repeats=3 if n >= 10**5 else 5)
            target = "< 0.1 s per 10⁵ points (≥ 10⁶ points/s)"
            rows.append((f"velocity, {n:.0e} points × {m} panels", f"{t * 1e3:.2f} ms",
                         f"{n / t / 1e6:.2f} M points/s ({n * m / t / 1e6:.0f} M point·panel/s)",
                         target))
        t_solve = best_time(make)
        rows.append((f"build + solve (robust, r = 0.3), {m} panels", f"{t_solve * 1e3:.2f} ms", "", "—"))
        for step in (1.0, 0.5):
            line = field.streamline(step=step)
            t_line = best_time(lambda: field.streamline(step=step))
            rows.append((f"streamline step {step} m, {m} panels ({len(line.points)} pts, "
                         f"{line.length:.0f} m, {line.reason})", f"{t_line * 1e3:.2f} ms", "", "—"))
            rows.append((f"solve + streamline (step {step} m), {m} panels",
                         f"{(t_solve + t_line) * 1e3:.2f} ms", "", "≤ 20 ms"))
        starts = rng.uniform([-10, -20], [20, 20], (200, 2))
        starts = starts[field.distance_to_obstacles(starts) > 0.5][:100]
        t_many = best_time(lambda: field.streamlines(starts, step=1.0), repeats=2)
        rows.append((f"{len(starts)} streamlines at once (vectorized), {m} panels",
                     f"{t_many * 1e3:.1f} ms", f"{t_many / len(starts) * 1e3:.2f} ms per line", "—"))
    print("| case | time | rate | target |")
    print("|---|---|---|---|")
    for r in rows:
        print("| " + " | ".join(r) + " |")


if __name__ == "__main__":
    main()
