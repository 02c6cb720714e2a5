"""The whole onboard stack against MuJoCo's floor: real-time factor, share of the floor, µs per
vessel-step and where the time goes, for the thesis scenarios, the demo and fleets of 3–100 Otters.

Rows: the thesis §6.2–6.4 scenarios, the demo, and :func:`mjasc.runs.fleet.formation_among_traffic`
fleets of 3, 10, 50 and 100 Otters (every vessel with sensor, tracking, avoidance and comms; a grid
formation on a common path while boats cross ahead).

For each row, in one process and interleaved (floor, recording on, recording off; best of
``--repeats``, the machine is shared):

* **floor** — what MuJoCo itself needs for the run: bare ``mj_step`` on the scenario's compiled
  model from its initial state, plus each vessel's range-sensor ``mj_multiRay`` fan at its scan
  rate, with the sensor's own beam directions, geom groups, excluded body, origin height and range
  (:class:`mjasc.perception.range_sensor.RangeSensor`). Only the MuJoCo calls are timed. The
  floor casts every beam of every fan, as the speed issue defined it; the sensors themselves cast
  only the beams that can meet a geom (:mod:`mjasc.perception.beam_culling`, the same readings),
  so part of a run's lead on the floor is ray work it does not do: the second table says which
  share of the beams the run cast.
* **real-time factor** — simulated seconds per wall second of the main loop of
  :meth:`mjasc.runs.runner.Runner.run` (its summary's ``wall_time_s``: the recording flushed at the
  end included) with the Rerun recording on (a temporary folder) and off; no video unless ``--video``.
* **share of the floor** — floor time / run time (1/50: the run costs 50× what MuJoCo needs).
* **µs per vessel-step** — run wall time / (vessels × physics steps), recording on.
* **where the time goes** — the runner's per-slot timers (``Runner.stage_seconds``) of the best run
  with recording on, as shares of its wall time; "other" is the loop itself (navigation snapshots,
  scheduling).

    .venv/bin/python benchmarks/bench_fullstack.py                 # full mode (~4 min on a quiet 2-core machine)
    .venv/bin/python benchmarks/bench_fullstack.py --quick         # a few seconds of two rows
    .venv/bin/python benchmarks/bench_fullstack.py --rows demo fleet_10 --duration 20 --repeats 2

Full mode runs each thesis scenario and the demo for its own duration, fleets of 3 and 10 for 60 s
and 30 s, fleets of 50 and 100 for 10 s and 5 s (``--duration`` overrides them all); big fleets
(more than 10 vessels) are measured ``--repeats-large`` times.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import statistics
import sys
import tempfile
import time
from dataclasses import dataclass, replace
from pathlib import Path

import mujoco
import numpy as np

import mjasc  # noqa: F401  (offscreen GL backend before mujoco renders)
from mjasc.runs.fleet import formation_among_traffic
from mjasc.runs.runner import Runner
from mjasc.runs.scenario import load_scenario

ROOT = Path(__file__).resolve().parent.parent
STAGES = ("physics", "sensing", "tracking", "comms", "prediction", "control", "record", "video")
THESIS = ("thesis_6_2_dock", "thesis_6_3_velocity_correction", "thesis_6_4_crossing", "thesis_6_4_head_on",
          "thesis_6_4_bottleneck")
#: Full-mode simulated duration of the fleet rows [s] (thesis rows and the demo: their own duration).
FLEETS = {3: 60.0, 10: 30.0, 50: 10.0, 100: 5.0}
QUICK = {"rows": ["thesis_6_4_crossing", "fleet_3"], "duration": 4.0, "repeats": 1}


@dataclass
class Row:
    name: str
    scenario: object  # Scenario
    vessels: int


def rows(names: list[str] | None, duration: float | None) -> list[Row]:
    out = []
    for name in [*THESIS, "demo", *(f"fleet_{n}" for n in FLEETS)]:
        if names and name not in names:
            continue
        if name.startswith("fleet_"):
            n = int(name.split("_")[1])
            sc = formation_among_traffic(n, name=name).with_overrides(duration_s=duration or FLEETS[n])
        else:  # this checkout's file (the installed package's bundled copy otherwise)
            path = ROOT / "tasks" / f"{name}.toml"
            sc = load_scenario(path if path.is_file() else name)
            if duration:
                sc = sc.with_overrides(duration_s=duration)
        out.append(Row(name, sc, len(sc.vessels)))
    unknown = set(names or ()) - {r.name for r in out}
    if unknown:
        raise SystemExit(f"--rows: unknown row(s) {', '.join(sorted(unknown))}")
    return out


# ---------------------------------------------------------------------- the floor
def floor_seconds(runner: Runner) -> tuple[float, float]:
    """MuJoCo's own time [s] for the run of ``runner`` (built, not run): (bare mj_step, ray fans).

    A fresh MjData of the runner's compiled model starts from the runner's initial state; the loop
    steps it exactly as many physics steps as the run does and, at each sensing slot of the
    schedule, casts each vessel's fan when its sensor is due (the perception's own rule: a scan
    once ``1 / rate_hz`` has passed). Beam directions are the sensor's ``angles_body`` about the
    mount's yaw; only the ``mj_step`` and ``mj_multiRay`` calls are timed."""
    m, src = runner.world.model, runner.sim.data
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:], d.act[:] = src.qpos, src.qvel, src.act
    d.mocap_pos[:], d.mocap_quat[:] = src.mocap_pos, src.mocap_quat
    d.time = src.time
    mujoco.mj_forward(m, d)
    fans = []
    for agent in runner.agents:
        if agent.perception is None:
            continue
        s = agent.perception.sensor
        c = s.config
        fans.append([s, 1.0 / c.rate_hz, -math.inf, s._vec.copy(), s._geomid.copy(), s._dist.copy()])
    pnt = np.zeros(3)
    total = int(round(runner.scenario.duration_s / m.opt.timestep))
    period = runner.schedule.period_steps["sensing"]
    clock, step_fn, ray_fn = time.perf_counter, mujoco.mj_step, mujoco.mj_multiRay
    t_step = t_ray = 0.0
    step = 0
    while step <= total:
        t = d.time
        for fan in fans:
            s, dt_scan, due, vec, gid, dist = fan
            if t < due - 1e-9:
                continue
            fan[2] = t + dt_scan
            xm = d.site_xmat[s.site_id]
            a = s.angles_body + math.atan2(xm[3], xm[0])
            vec[:, 0] = np.cos(a)
            vec[:, 1] = np.sin(a)
            pnt[:2] = d.site_xpos[s.site_id, :2]
            pnt[2] = s.config.ray_height_m
            t0 = clock()
            ray_fn(m, d, pnt, vec.reshape(-1), s.geomgroup, 1, s.body_id, gid, dist, None, s.config.beams,
                   s.config.max_range_m)
            t_ray += clock() - t0
        nxt = min((step // period + 1) * period, total + 1)
        if nxt > total:
            break
        t0 = clock()
        for _ in range(nxt - step):
            step_fn(m, d)
        t_step += clock() - t0
        step = nxt
    return t_step, t_ray


# ---------------------------------------------------------------------- one run
def run_once(sc, recording: bool, video: bool) -> dict:
    sc = replace(sc, outputs=replace(sc.outputs, recording=recording, video=video and recording))
    with tempfile.TemporaryDirectory() as tmp:
        runner = Runner(sc, tmp if recording else None, progress=False)
        res = runner.run()
        sensors = [a.perception.sensor for a in runner.agents if a.perception is not None]
        beams = sum(s.beams_cast for s in sensors), sum(s.fans_cast * s.config.beams for s in sensors)
        wall = res.summary["wall_time_s"]  # the main loop, outputs flushed (not the recording's set-up)
        rec = Path(tmp) / "recording.rrd"
        size = rec.stat().st_size if recording and rec.exists() else 0
    return {"wall": wall, "sim": res.summary["sim_time_s"], "stages": dict(runner.stage_seconds), "rrd_bytes": size,
            "steps": int(round(sc.duration_s / runner.sim.timestep_s)), "collisions": len(res.summary["collisions"]),
            "beams_cast": beams[0] / beams[1] if beams[1] else math.nan}


def measure(row: Row, repeats: int, video: bool) -> dict:
    best: dict = {}
    for _ in range(repeats):  # interleaved: load elsewhere on the machine hits all three alike
        floor = floor_seconds(Runner(row.scenario, None, progress=False))
        if "floor" not in best or sum(floor) < sum(best["floor"]):
            best["floor"] = floor
        for key, rec in (("on", True), ("off", False)):
            r = run_once(row.scenario, rec, video)
            if key not in best or r["wall"] < best[key]["wall"]:
                best[key] = r
    return best


# ---------------------------------------------------------------------- output
def _one_in(floor_s: float, wall_s: float) -> str:
    return f"1/{wall_s / floor_s:,.0f}" if floor_s > 0 else "—"


def table(results: list[tuple[Row, dict]], video: bool) -> str:
    lines = ["| workload | vessels | sim s | real-time × rec on | rec off | floor × | share of floor rec on | "
             "rec off | µs / vessel-step | floor µs / vessel-step | rec MB / vessel-min |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for row, b in results:
        on, off, floor = b["on"], b["off"], sum(b["floor"])
        sim, steps = on["sim"], on["steps"]
        per = 1e6 / (row.vessels * max(steps, 1))
        mb = on["rrd_bytes"] / 1e6 / (row.vessels * sim / 60.0) if sim > 0 else 0.0
        lines.append(f"| {row.name} | {row.vessels} | {sim:g} | {sim / on['wall']:,.2f} | {sim / off['wall']:,.2f} | "
                     f"{sim / floor:,.0f} | {_one_in(floor, on['wall'])} | {_one_in(floor, off['wall'])} | "
                     f"{on['wall'] * per:,.0f} | {floor * per:,.1f} | {mb:.2f} |")
    lines += ["", "Where the time goes (recording on" + (", video on" if video else "") +
              "): share of the run's wall time per stage; the floor split into mj_step and the ray fans; the share "
              "of the fans' beams the sensors cast (the others can meet nothing: the floor casts them all)",
              "", "| workload | wall ms / sim s | " + " | ".join(STAGES) +
              " | other | floor: mj_step | rays | beams cast |",
              "|---|---:|" + "---:|" * (len(STAGES) + 4)]
    for row, b in results:
        on = b["on"]
        st, wall = on["stages"], on["wall"]
        other = wall - sum(st.values())
        cells = [f"{st[s] / wall:.0%}" if s in st else "—" for s in STAGES]
        step_s, ray_s = b["floor"]
        lines.append(f"| {row.name} | {1e3 * wall / on['sim']:,.1f} | " + " | ".join(cells) +
                     f" | {other / wall:.0%} | {1e3 * step_s / on['sim']:.2f} ms/s | "
                     f"{1e3 * ray_s / on['sim']:.2f} ms/s | {on['beams_cast']:.0%} |")
    return "\n".join(lines)


def python_loop_ms(n: int = 1_000_000, repeats: int = 5) -> float:
    """The host's pure-Python speed: the best time [ms] of a loop of ``n`` integer additions (the
    stack is ~70 % Python and numpy around compiled kernels, the floor is C: hosts whose Python is
    slower relative to their C give a run a smaller share of the floor)."""
    best = math.inf
    for _ in range(repeats):
        t = time.perf_counter()
        total = 0
        for i in range(n):
            total += i
        best = min(best, time.perf_counter() - t)
    return 1e3 * best


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help=f"rows {', '.join(QUICK['rows'])} for "
                                                          f"{QUICK['duration']:g} s, once (well under a minute)")
    ap.add_argument("--rows", nargs="+", help="only these rows (names as in the table)")
    ap.add_argument("--duration", type=float, help="simulated seconds of every row (default: see above)")
    ap.add_argument("--repeats", type=int, default=3, help="runs per configuration, best kept (rows ≤ 10 vessels)")
    ap.add_argument("--repeats-large", type=int, default=3,
                    help="runs per configuration for rows > 10 vessels (one run of a big fleet moves with the host)")
    ap.add_argument("--video", action="store_true", help="the recording-on run writes the video too")
    a = ap.parse_args(argv)
    if a.quick:
        a.rows = a.rows or QUICK["rows"]
        a.duration = a.duration or QUICK["duration"]
        a.repeats = a.repeats_large = QUICK["repeats"]
    results = []
    t0 = time.perf_counter()
    for row in rows(a.rows, a.duration):
        results.append((row, measure(row, a.repeats if row.vessels <= 10 else a.repeats_large, a.video)))
    thesis = [sum(b["floor"]) / b["on"]["wall"] for r, b in results if r.name in THESIS]
    thesis_off = [sum(b["floor"]) / b["off"]["wall"] for r, b in results if r.name in THESIS]
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"Full stack vs MuJoCo's floor: best of {a.repeats} (≤ 10 vessels) / {a.repeats_large} (more) interleaved "
          f"runs per configuration, {os.cpu_count()} CPU core(s), load average {load:.1f} at the end, "
          f"{time.perf_counter() - t0:.0f} s in all; Python {platform.python_version()} at "
          f"{os.path.realpath(sys.executable)} (the interpreter's build moves the stack's speed, not the floor's); "
          f"a pure-Python loop of 10⁶ additions {python_loop_ms():.0f} ms (the host's Python speed)\n")
    print(table(results, a.video))
    if thesis:
        print(f"\nThesis scenarios: median share of the floor with recording on 1/{1 / statistics.median(thesis):.1f} "
              f"(target ≥ 1/6), without 1/{1 / statistics.median(thesis_off):.1f}.")
    collided = [r.name for r, b in results if b["on"]["collisions"]]
    if collided:
        print(f"Runs with collisions: {', '.join(collided)}")


if __name__ == "__main__":
    main()
