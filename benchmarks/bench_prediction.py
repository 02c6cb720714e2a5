"""Microseconds per track of collision prediction: the former per-track bounded Brent search vs the
closed-form minima over stacked tracks (:mod:`mjasc.avoidance.prediction.cpa`), and a fleet's
predictions in one :func:`~mjasc.avoidance.prediction.predict_fleet` call vs one call per vessel.

Synthetic encounters: the vessel sails a waypoint path with rounded corners (lines and arcs) at
1.5 m/s, a 30 s window on a 0.5 s grid (61 samples); its tracks are placed within 120 m, 10 %
static, 20 % team mates predicted along a broadcast plan (knots every 0.5 s along a turning
course), the rest constant-speed constant-turn tracks (0–2 m/s, ω ~ N(0, 0.02) rad/s). The
reference is the former code (a grid, then ``scipy.optimize.minimize_scalar(method="bounded",
xatol=1e-7)`` per local minimum per track, every distance evaluated through ``Path.point`` and
``predict_positions`` on one time), followed by the same spatial correlation. Both produce the
full :class:`~mjasc.avoidance.prediction.PredictedConflict` list (``include_clear``). Times are the
process's CPU time, best of a few repeats, reference and new alternating in one process. Prints a
markdown table: µs per track before/after and the speed-up, the largest |Δ d_min| and |Δ t_c|,
and whether every collision flag and decision is equal.

    .venv/bin/python benchmarks/bench_prediction.py [--quick] [--repeats 5]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from scipy.optimize import minimize_scalar

from mjasc.avoidance.prediction import CollisionPredictionConfig, PredictionQuery, predict_conflicts, predict_fleet
from mjasc.avoidance.prediction.conflicts import _conflict, _plan_context
from mjasc.core.estimates import PlannedTrack, TrackEstimate
from mjasc.cooperation.messages import TeamIntention
from mjasc.guidance.paths import Path

_clock = time.process_time
CONFIG = CollisionPredictionConfig(window_s=30.0, time_step_s=0.5, obstruction_threshold_s=15.0)


def scene(n_tracks: int, seed: int = 0, offset=(0.0, 0.0)):
    """(path, gamma_now, t_now, speed, radius, tracks) of one synthetic vessel."""
    rng = np.random.default_rng(seed)
    o = np.asarray(offset, dtype=float)
    path = Path.from_waypoints(o + [[0, 0], [60, 0], [90, 30], [90, 90], [20, 120]], turn_radius_m=15.0)
    t_now, gamma_now, speed = 50.0, 10.0, 1.5
    here = path.point(gamma_now)
    tracks = []
    for k in range(n_tracks):
        pos = here + rng.uniform(-120, 120, 2)
        u = rng.uniform()
        if u < 0.1:
            tracks.append(TrackEstimate(k, t_now, pos, 0.0, 0.0, 0.0, 2.0, is_static=True))
        elif u < 0.3:
            v, th, w = rng.uniform(0.5, 2.0), rng.uniform(-np.pi, np.pi), rng.normal(0, 0.03)
            ts = t_now - 0.3 + np.arange(0.0, 40.5, 0.5)
            ths = th + w * (ts - ts[0])
            pts = pos + np.cumsum(np.stack([np.cos(ths), np.sin(ths)], 1) * v * 0.5, axis=0) - \
                v * 0.5 * np.array([np.cos(th), np.sin(th)])
            vel = v * np.array([np.cos(th), np.sin(th)])
            it = TeamIntention(f"m{k}", t_now - 0.3, pos, th, vel, 2.5, ts, pts)
            tracks.append(PlannedTrack(k, t_now - 0.3, pos, th, v, w, 2.5, team_member=f"m{k}", intention=it))
        else:
            tracks.append(TrackEstimate(k, t_now - rng.uniform(0, 0.2), pos, rng.uniform(-np.pi, np.pi),
                                        rng.uniform(0.0, 2.0), rng.normal(0, 0.02), rng.uniform(1.0, 4.0)))
    return path, gamma_now, t_now, speed, 2.5, tracks


def brent_reference(path, gamma_now, t_now, speed, r_vh, tracks, cfg=CONFIG):
    """The former predict_conflicts (include_clear): per track a grid, then a bounded Brent search
    per local minimum, then the same spatial correlation and decision."""
    q = PredictionQuery(path, gamma_now, t_now, speed, r_vh, tracks, cfg, True)
    ctx = _plan_context(q)
    n = max(2, int(np.ceil((ctx.t_end - t_now) / cfg.time_step_s - 1e-9)) + 1)
    times = np.linspace(t_now, ctx.t_end, n)
    vessel_xy = ctx.vessel_at(times)
    out = []
    for track in tracks:
        r_col = r_vh + float(track.radius_m) + cfg.safety_distance_m
        obst_xy = track.predict_positions(times)
        d = np.hypot(*(vessel_xy - obst_xy).T)

        def dist(t):
            return float(np.hypot(*(ctx.vessel_at(t)[0] - track.predict_positions(np.array([t]))[0])))

        left = np.concatenate([[True], d[1:] <= d[:-1]])
        right = np.concatenate([d[:-1] < d[1:], [True]])
        t_c = d_c = None
        for i in np.flatnonzero(left & right):
            lo, hi = times[max(i - 1, 0)], times[min(i + 1, times.size - 1)]
            res = minimize_scalar(dist, bounds=(lo, hi), method="bounded", options={"xatol": 1e-7})
            tt, dd = (float(res.x), float(res.fun)) if res.fun <= d[i] else (float(times[i]), float(d[i]))
            if t_c is None:
                t_c, d_c = tt, dd
            if dd <= r_col:
                t_c, d_c = tt, dd
                break
            if cfg.stop_at_first_minimum:
                break
        out.append(_conflict(ctx, track, t_c, d_c, r_col, times, vessel_xy, obst_xy))
    out.sort(key=lambda c: c.t_closest_s)
    return out


def _best(fn, repeats):
    best = np.inf
    for _ in range(repeats):
        t0 = _clock()
        fn()
        best = min(best, _clock() - t0)
    return best


def compare(ref, new):
    """(max |Δ d_min|, max |Δ t_c|, collisions equal, decisions equal) of two conflict lists."""
    a = {c.track_id: c for c in ref}
    b = {c.track_id: c for c in new}
    assert a.keys() == b.keys()
    dd = max((abs(a[k].min_distance_m - b[k].min_distance_m) for k in a), default=0.0)
    dt = max((abs(a[k].t_closest_s - b[k].t_closest_s) for k in a), default=0.0)
    col = all(a[k].collision == b[k].collision for k in a)
    dec = all(a[k].decision == b[k].decision for k in a)
    return dd, dt, col, dec


def run(sizes, repeats, fleet):
    rows = []
    for m in sizes:
        args = scene(m)
        ref = brent_reference(*args)
        new = predict_conflicts(*args, CONFIG, include_clear=True)
        dd, dt, col, dec = compare(ref, new)
        t_ref = t_new = np.inf
        for _ in range(repeats):  # alternate
            t_ref = min(t_ref, _best(lambda: brent_reference(*args), 1))
            t_new = min(t_new, _best(lambda: predict_conflicts(*args, CONFIG, include_clear=True), 1))
        n_col = sum(c.collision for c in new)
        rows.append((m, n_col, 1e6 * t_ref / m, 1e6 * t_new / m, t_ref / t_new, dd, dt, col and dec))
    print("| tracks | collisions | Brent µs/track | closed form µs/track | speed-up | max abs Δ d_min [m] "
          "| max abs Δ t_c [s] | decisions equal |")
    print("|---:|---:|---:|---:|---:|---:|---:|:---:|")
    for r in rows:
        print(f"| {r[0]} | {r[1]} | {r[2]:.0f} | {r[3]:.1f} | {r[4]:.0f}× | {r[5]:.2e} | {r[6]:.2e} | {r[7]} |")
    if fleet:
        n_v, m = fleet
        queries = [PredictionQuery(*scene(m, seed=v, offset=(300.0 * v, 0.0)), CONFIG, True) for v in range(n_v)]
        one = predict_fleet(queries)
        each = [predict_conflicts(q.vessel_path, q.gamma_now, q.t_now, q.speed_profile, q.vessel_radius_m,
                                  q.tracks, q.config, include_clear=True) for q in queries]
        same = all(compare(a, b)[:2] == (0.0, 0.0) for a, b in zip(one, each))
        t_each = t_one = np.inf
        for _ in range(repeats):
            t_each = min(t_each, _best(lambda: [predict_conflicts(q.vessel_path, q.gamma_now, q.t_now,
                                                                  q.speed_profile, q.vessel_radius_m, q.tracks,
                                                                  q.config, include_clear=True)
                                                for q in queries], 1))
            t_one = min(t_one, _best(lambda: predict_fleet(queries), 1))
        pairs = n_v * m
        print(f"\nfleet: {n_v} vessels × {m} tracks: one call per vessel {1e6 * t_each / pairs:.1f} µs/pair, "
              f"predict_fleet {1e6 * t_one / pairs:.1f} µs/pair ({t_each / t_one:.2f}×), identical results: {same}")
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="small sizes, one repeat (the test suite runs this)")
    ap.add_argument("--repeats", type=int, default=5)
    a = ap.parse_args(argv)
    if a.quick:
        return run([1, 5], 1, (3, 5))
    return run([1, 5, 20, 50], a.repeats, (20, 20))


if __name__ == "__main__":
    main()
