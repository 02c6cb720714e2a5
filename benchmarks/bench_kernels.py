"""Where a run's time goes at the compiled kernels: how many calls of ``mjasc.core.compiled.kernel``
functions a run makes, with how many arguments and returned arrays, their time, and what the
call interface itself costs (numba's dispatch per call and per argument, boxing per returned
array) — measured in one process.

The speed issue's remaining cost is spread over many small calls; this table says how much of a
run is inside kernels (compiled work plus their interface) and which kernels are called most, so
that fusing stages into fewer compiled calls can be planned from numbers.

* The run: the scenario without recording or video, once to load every kernel, then once plain
  (its wall time is the reference) and once with every kernel reachable as a module or class
  attribute of ``mjasc`` wrapped by a counter (kernels held elsewhere, and kernels called from
  inside other kernels, are not counted; the counter's own cost is outside the times measured).
* The interface: trivial kernels with 1, 8 and 16 array arguments returning nothing, and with one
  argument returning 1 and 4 new arrays, each called in a loop: µs per call, per argument, per
  returned array. The interface estimate is calls × per-call + arguments × per-argument +
  returned arrays × per-array.

    .venv/bin/python benchmarks/bench_kernels.py                    # the demo, 240 s (~15 s)
    .venv/bin/python benchmarks/bench_kernels.py --scenario thesis_6_4_crossing --top 30
    .venv/bin/python benchmarks/bench_kernels.py --quick            # 4 s of the demo
"""

from __future__ import annotations

import argparse
import collections
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import mjasc  # noqa: E402  (MUJOCO_GL before mujoco)
from mjasc.runs.runner import Runner  # noqa: E402


def scenario(name: str, duration_s: float | None):
    sc = mjasc.load_scenario(name)
    if duration_s is not None:
        sc = sc.with_overrides(duration_s=duration_s)
    return replace(sc, outputs=replace(sc.outputs, recording=False, video=False))


def _arrays_in(result) -> int:
    if isinstance(result, np.ndarray):
        return 1
    if isinstance(result, tuple):
        return sum(_arrays_in(r) for r in result)
    return 0


class KernelCounter:
    """Wraps every dispatcher found as a module or class attribute under ``mjasc`` with a counter
    of calls, arguments, returned arrays and inclusive time; :meth:`restore` puts them back."""

    def __init__(self):
        from numba.core.registry import CPUDispatcher

        self.calls, self.args = collections.Counter(), collections.Counter()
        self.arrays, self.seconds = collections.Counter(), collections.Counter()
        self._wrappers: dict = {}
        self._replaced: list = []
        for name, mod in list(sys.modules.items()):
            if not (name == "mjasc" or name.startswith("mjasc.")):
                continue
            for attr, value in list(vars(mod).items()):
                if isinstance(value, CPUDispatcher):
                    self._replace(mod, attr, value, self._wrap(value))
                elif isinstance(value, type) and value.__module__ == name:
                    for a2, v2 in list(vars(value).items()):
                        if isinstance(v2, CPUDispatcher):
                            self._replace(value, a2, v2, staticmethod(self._wrap(v2)))

    def _replace(self, owner, attr, old, new) -> None:
        self._replaced.append((owner, attr, old))
        setattr(owner, attr, new)

    def _wrap(self, d):
        w = self._wrappers.get(d)
        if w is None:
            key = f"{d.py_func.__module__.removeprefix('mjasc.')}.{d.py_func.__name__}"
            calls, args, arrays, seconds, clock = self.calls, self.args, self.arrays, self.seconds, time.perf_counter

            def w(*a, **k):
                t0 = clock()
                r = d(*a, **k)
                seconds[key] += clock() - t0
                calls[key] += 1
                args[key] += len(a) + len(k)
                arrays[key] += _arrays_in(r)
                return r
            self._wrappers[d] = w
        return w

    def restore(self) -> None:
        for owner, attr, old in reversed(self._replaced):
            setattr(owner, attr, old)
        self._replaced.clear()


def interface_costs(loops: int) -> dict:
    """µs per call (one array argument, nothing returned), per further array argument, per returned
    array, of trivial compiled functions called in a Python loop."""
    import numba

    def timed(f, args) -> float:
        f(*args)
        t0 = time.perf_counter()
        for _ in range(loops):
            f(*args)
        return (time.perf_counter() - t0) / loops * 1e6

    arrays = [np.zeros(8) for _ in range(16)]
    per_k = {}
    for k in (1, 8, 16):
        ns: dict = {}
        exec(f"def f({', '.join(f'a{i}' for i in range(k))}):\n    return None\n", ns)
        per_k[k] = timed(numba.njit(ns["f"]), arrays[:k])
    ret1 = timed(numba.njit(lambda a: np.empty(4)), arrays[:1])
    ret4 = timed(numba.njit(lambda a: (np.empty(4), np.empty(4), np.empty(4), np.empty(4))), arrays[:1])
    return {"call": per_k[1], "argument": (per_k[16] - per_k[1]) / 15, "array": (ret4 - ret1) / 3,
            "by_args": per_k, "return_1": ret1, "return_4": ret4}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", default="demo", help="a bundled scenario's name or a file (default: demo)")
    ap.add_argument("--duration", type=float, help="simulated seconds (default: the scenario's)")
    ap.add_argument("--top", type=int, default=20, help="kernels listed (default: 20)")
    ap.add_argument("--quick", action="store_true", help="4 s of the demo, a short interface loop")
    a = ap.parse_args(argv)
    duration = 4.0 if a.quick else a.duration
    Runner(scenario(a.scenario, duration), out_dir=None).run()  # every kernel loaded
    runner = Runner(scenario(a.scenario, duration), out_dir=None)
    t0 = time.perf_counter()
    runner.run()
    plain = time.perf_counter() - t0
    counter = KernelCounter()
    try:
        Runner(scenario(a.scenario, duration), out_dir=None).run()
    finally:
        counter.restore()
    cost = interface_costs(2_000 if a.quick else 50_000)
    calls, args, arrays = (sum(c.values()) for c in (counter.calls, counter.args, counter.arrays))
    inside = sum(counter.seconds.values())
    interface = (calls * cost["call"] + args * cost["argument"] + arrays * cost["array"]) * 1e-6
    sim = runner.scenario.duration_s
    print(f"Compiled kernels in a run of {a.scenario} ({sim:g} simulated s, no recording): plain run {plain:.2f} s "
          f"wall; {calls:,} kernel calls ({len(counter.calls)} kernels), {args:,} arguments, {arrays:,} returned "
          f"arrays; time inside kernels {inside:.2f} s ({100 * inside / plain:.0f} % of the plain run), of which "
          f"the call interface ≈ {interface:.2f} s ({100 * interface / plain:.0f} %): {cost['call']:.2f} µs per call, "
          f"{cost['argument']:.3f} µs per array argument, {cost['array']:.2f} µs per returned array "
          f"(trivial kernels, {', '.join(f'{k} args {v:.2f} µs' for k, v in cost['by_args'].items())}).\n")
    print("| kernel | calls | per control tick | arguments / call | arrays returned / call | µs / call | share of the run |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    ticks = max(1, round(sim * runner.scenario.rates.control_hz))
    for key, _ in counter.seconds.most_common(a.top):
        n = counter.calls[key]
        print(f"| {key} | {n:,} | {n / ticks:.1f} | {counter.args[key] / n:.1f} | {counter.arrays[key] / n:.1f} | "
              f"{counter.seconds[key] / n * 1e6:.1f} | {100 * counter.seconds[key] / plain:.1f} % |")


if __name__ == "__main__":
    main()
