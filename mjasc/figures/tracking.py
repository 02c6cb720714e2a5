"""Thesis §6.1 reproduced with the ASC's own range sensor: figures after Fig. 6.1 / 6.2 and a table.

The scenarios are ``tasks/thesis_6_1_tracking.toml`` (a target at 1.5 m/s turning at 0.03 rad/s,
first seen ~107 m away) and ``tasks/thesis_6_1_static.toml`` (a static 2.5 m buoy, first seen
~101 m away). Each is run through the normal runner (physics, path following, sensing at 5 Hz,
tracking); perception keeps the history of its confirmed tracks; the truth comes from the scenario's
obstacle definitions (never seen by the vessel).

``make_tracking_figures(out_dir) -> list[Path]`` writes ``thesis_fig_6_1_tracking.png`` and
``thesis_fig_6_2_static.png`` (true vs estimated speed, turn rate and heading over time, and the
target's path). ``thesis_6_1_results(seeds)`` returns the per-seed numbers of docs/perception.md.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mjasc.core.resources import tasks_dir

__all__ = ["make_tracking_figures", "run_tracking_scenario", "thesis_6_1_results", "TrackingRun",
           "THESIS_V_M_S", "THESIS_OMEGA_RAD_S"]

TASKS = tasks_dir()
DYNAMIC = TASKS / "thesis_6_1_tracking.toml"
STATIC = TASKS / "thesis_6_1_static.toml"
#: Thesis §6.1: the estimates at the time of the collision prediction of Fig. 6.1 (one run).
THESIS_V_M_S = 1.5723
THESIS_OMEGA_RAD_S = 0.0312


@dataclass
class TrackingRun:
    """Time histories of the target's track (the confirmed track that stays nearest to it) and truth."""

    scenario: str
    seed: int
    t: np.ndarray
    est: dict  # x, y, heading, speed, omega (arrays over t)
    true: dict  # x, y, heading (nan when undefined), speed, omega
    own_path: np.ndarray  # (k, 2) the ASC's positions
    summary: dict


def run_tracking_scenario(path: Path = DYNAMIC, seed: int | None = None) -> TrackingRun:
    from mjasc.physics.obstacles import MovingObstacleSet
    from mjasc.runs.runner import Runner
    from mjasc.runs.scenario import load_scenario

    sc = load_scenario(path)
    if seed is not None:
        sc = sc.with_overrides(seed=seed)
    runner = Runner(sc, None, progress=False)
    perception = runner.agents[0].perception
    perception.keep_history = True
    own = []
    # the ASC's own path for the figure, where it was at each sensing slot
    runner.observe("sensing", lambda event: own.append(np.asarray(event.navs[0].position_m, dtype=float).copy()))
    res = runner.run()
    h = perception.history_arrays()
    if sc.moving_obstacles:
        traffic = MovingObstacleSet(list(sc.moving_obstacles))

        def truth(t):
            p, th, v = traffic.state(t)
            return p[0], th[0], float(np.hypot(*v[0])), sc.moving_obstacles[0].turn_rate_rad_s
    else:
        centre = sc.static_obstacles[0].centre

        def truth(t):
            return centre, np.nan, 0.0, 0.0
    # the track of the target: the id whose estimates stay nearest to the truth most often
    near = np.array([np.hypot(*(np.array([x, y]) - truth(t)[0])) < 3.0 for t, x, y in zip(h["t"], h["x"], h["y"])])
    ids, counts = np.unique(h["id"][near], return_counts=True)
    if ids.size == 0:
        raise RuntimeError(f"{sc.name}: the target was never tracked")
    m = h["id"] == ids[np.argmax(counts)]
    t = h["t"][m]
    tv = [truth(ti) for ti in t]
    true = {"x": np.array([p[0] for p, *_ in tv]), "y": np.array([p[1] for p, *_ in tv]),
            "heading": np.array([th for _, th, _, _ in tv]), "speed": np.array([v for *_, v, _ in tv]),
            "omega": np.array([w for *_, w in tv])}
    est = {k: h[k][m] for k in ("x", "y", "heading", "speed", "omega")}
    return TrackingRun(sc.name, sc.seed, t, est, true, np.array(own), res.summary["vessels"][sc.vessels[0].name])


def _degrees_0_360(heading):
    h = np.degrees(np.unwrap(heading))
    return h - 360.0 * np.floor(np.nanmin(h) / 360.0) if np.isfinite(h).any() else h


def _figure(run: TrackingRun, out: Path, title: str, plt, formats=("png",)) -> list[Path]:
    fig, ax = plt.subplots(2, 2, figsize=(11, 7.5))
    t = run.t
    for a, key, label in ((ax[0, 0], "speed", "V [m/s]"), (ax[0, 1], "omega", "ω [rad/s]")):
        a.plot(t, run.true[key], "k-", lw=1.5, label="True")
        a.plot(t, run.est[key], "r-", lw=1.0, label="Estimated")
        a.set_xlabel("time [s]")
        a.set_ylabel(label)
        a.grid(alpha=0.3)
        a.legend(loc="best")
    a = ax[1, 0]
    if np.isfinite(run.true["heading"]).any():
        a.plot(t, _degrees_0_360(run.true["heading"]), "k-", lw=1.5, label="True")
        a.plot(t, _degrees_0_360(run.est["heading"]), "r-", lw=1.0, label="Estimated")
    else:  # a static target's course is undefined: show the estimate's wanderings, wrapped
        a.plot(t, np.degrees(run.est["heading"]) % 360.0, "r.", ms=2, label="Estimated (no true course)")
    a.set_xlabel("time [s]")
    a.set_ylabel("Ψ (course) [deg]")
    a.grid(alpha=0.3)
    a.legend(loc="best")
    a = ax[1, 1]
    a.plot(run.own_path[:, 0], run.own_path[:, 1], "b-", lw=1.0, label="ASC (observer)")
    a.plot(run.est["x"], run.est["y"], "r.", ms=3, label="Estimated")
    if np.ptp(run.true["x"]) + np.ptp(run.true["y"]) > 0:
        a.plot(run.true["x"], run.true["y"], "k-", lw=0.8, label="Target")
    else:
        a.plot(run.true["x"][:1], run.true["y"][:1], "k+", ms=12, label="Target")
    a.set_aspect("equal", adjustable="datalim")
    a.set_xlabel("x (east) [m]")
    a.set_ylabel("y (north) [m]")
    a.grid(alpha=0.3)
    a.legend(loc="best")
    v, w = run.est["speed"][-1], run.est["omega"][-1]
    fig.suptitle(f"{title}\nat t = {t[-1]:.0f} s: V̂ = {v:.4f} m/s, ω̂ = {w:.4f} rad/s (seed {run.seed})")
    fig.tight_layout()
    from mjasc.figures.thesis import save_figure

    paths = save_figure(fig, out, formats)
    plt.close(fig)
    return paths


def make_tracking_figures(out_dir, formats=("png",)) -> list[Path]:
    """Run both §6.1 scenarios (their own seeds) and write the two figures (each in ``formats``);
    returns their paths."""
    from mjasc.figures.thesis import figure_backend

    plt, out_dir = figure_backend(out_dir)
    return [
        *_figure(run_tracking_scenario(DYNAMIC), out_dir / "thesis_fig_6_1_tracking.png",
                "IMM tracking of a 1.5 m/s, 0.03 rad/s target from the ASC's range sensor (after thesis Fig. 6.1;"
                f" thesis: V̂ = {THESIS_V_M_S}, ω̂ = {THESIS_OMEGA_RAD_S})",
                plt, formats),
        *_figure(run_tracking_scenario(STATIC), out_dir / "thesis_fig_6_2_static.png",
                 "IMM tracking of a static target (after thesis Fig. 6.2; its course is unobservable)", plt, formats),
    ]


def thesis_6_1_results(seeds=range(1, 11), last_s: float = 30.0) -> list[dict]:
    """Per seed and scenario: the final V̂, ω̂, and RMS errors of V, ω and position over the last
    ``last_s`` seconds of tracking."""
    rows = []
    for path in (DYNAMIC, STATIC):
        for seed in seeds:
            run = run_tracking_scenario(path, seed)
            m = run.t >= run.t[-1] - last_s
            dv = run.est["speed"][m] - run.true["speed"][m]
            dw = run.est["omega"][m] - run.true["omega"][m]
            dp = np.hypot(run.est["x"][m] - run.true["x"][m], run.est["y"][m] - run.true["y"][m])
            rows.append({"scenario": run.scenario, "seed": seed, "t_end_s": float(run.t[-1]),
                         "V_hat": float(run.est["speed"][-1]), "omega_hat": float(run.est["omega"][-1]),
                         "rms_V": float(np.sqrt(np.mean(dv**2))), "rms_omega": float(np.sqrt(np.mean(dw**2))),
                         "rms_pos_m": float(np.sqrt(np.mean(dp**2))),
                         "tracks_confirmed": run.summary["perception"]["tracks_confirmed"]})
    return rows


if __name__ == "__main__":  # python -m mjasc.figures.tracking [out_dir]: figures + the results table
    import sys

    for p in make_tracking_figures(sys.argv[1] if len(sys.argv) > 1 else "runs/figures"):
        print(p)
    rows = thesis_6_1_results()
    print("| scenario | seed | V̂ at end [m/s] | ω̂ at end [rad/s] | RMS V err | RMS ω err | RMS pos err [m] | confirmed |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['scenario']} | {r['seed']} | {r['V_hat']:.4f} | {r['omega_hat']:.4f} | {r['rms_V']:.4f} | "
              f"{r['rms_omega']:.4f} | {r['rms_pos_m']:.3f} | {r['tracks_confirmed']} |")
