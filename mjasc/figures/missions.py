"""Figures of the missions (docs/missions.md): a chained run seen from above and in time.

One figure per scenario: (left) the top-down tracks, each vessel's line styled by its mission
phase, its formation pose, the traffic and the target's true track with the leader's estimate;
(right, top) the phase timeline per vessel; (right, bottom) each vessel's true station error while
it tracks the target (the run's own truth-side judge). The run is the scenario file through the
real runner; a record-slot observer samples public state only (the agents' mission phase, the
traffic's and vessels' truth for drawing).

Entry point: ``make_mission_figures(out_dir, formats=("png",), scenarios=None) -> list[Path]``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from mjasc.core.resources import tasks_dir
from mjasc.missions.sequencer import PHASE_STATES
from mjasc.runs.recording import vessel_colour
from mjasc.runs.runner import Runner
from mjasc.runs.scenario import load_scenario

__all__ = ["FIGURE_SCENARIOS", "make_mission_figures", "mission_figure", "trace_mission"]

#: Scenario file stem → figure title.
FIGURE_SCENARIOS = {
    "chain_formation_path_target": "Chained mission: go to formation, follow the paths past a ferry, track a target",
}

_STYLE = {"go_to_formation": ":", "follow_path": "-", "track_target": "--", "done": "-"}


def trace_mission(scenario):
    """Run ``scenario`` and sample, at the record rate: time, vessel positions (n, 2), each vessel's
    phase, the traffic's positions (m, 2), the leader's target estimate (2,) or NaN; and per vessel
    the truth-side judge's (times, station errors) (:class:`~mjasc.evaluation.mission_judge.TargetJudge`).
    Returns (trace dict, summary)."""
    runner = Runner(scenario, None, progress=False)
    tr = {"t": [], "pos": [], "phase": [], "traffic": [], "estimate": []}

    def record(ev):
        tr["t"].append(ev.time_s)
        tr["pos"].append(np.array(ev.states.position_m, dtype=float))
        tr["phase"].append([a.mission.phase_name if a.mission is not None else "follow_path" for a in ev.runner.agents])
        tr["traffic"].append(np.array(ev.runner.sim.traffic_state()[0], dtype=float).reshape(-1, 2))
        est = np.full(2, np.nan)
        for a in ev.runner.agents:
            ph = a.mission.phase if a.mission is not None else None
            if ph is not None and getattr(ph, "is_leader", False) and ph.estimate is not None:
                est = ph.estimate.position_at(ev.time_s)
        tr["estimate"].append(est)

    runner.observe("record", record)
    summary = runner.run().summary
    judge = runner.target_judge  # the truth-side judge's rows: (t, station error, stand-off) per vessel
    tr["station_errors"] = {} if judge is None else {n: np.array(r)[:, :2].T for n, r in judge.rows.items() if r}
    return tr, summary


#: The gid of the top-down view's name labels (vessels, traffic): tests find them by it.
NAME_LABEL_GID = "name-label"


def _edge_label(ax, xy, text, lo, hi, **kw) -> None:
    """``text`` by the point ``xy`` [m], on the side facing the frame's centre (a track entering
    at the top edge is labelled below its entry point, not cut off by the frame)."""
    centre = 0.5 * (np.asarray(lo) + np.asarray(hi))
    d = centre - np.asarray(xy, float)
    ha, va = ("left" if d[0] >= 0 else "right"), ("bottom" if d[1] >= 0 else "top")
    off = (4 if d[0] >= 0 else -4, 4 if d[1] >= 0 else -4)
    ax.annotate(text, xy, textcoords="offset points", xytext=off, ha=ha, va=va, gid=NAME_LABEL_GID, **kw)


def mission_figure(sc, tr, summary, title: str, plt):
    """The figure of a chained run (see the module docstring) from :func:`trace_mission`'s trace
    and summary. The top-down view's legend stands below the axes, where it cannot cover a track
    or a name (inside, "upper center" covered the ferry's label where its track enters the frame)."""
    t = np.array(tr["t"])
    pos = np.array(tr["pos"])
    traffic = np.array(tr["traffic"])
    est = np.array(tr["estimate"])
    fig = plt.figure(figsize=(13, 6.5))
    ax = fig.add_axes([0.05, 0.2, 0.5, 0.72])
    for i, v in enumerate(sc.vessels):
        col = np.array(vessel_colour(i)) / 255.0
        phases = [p[i] for p in tr["phase"]]
        start = 0
        for j in range(1, len(phases) + 1):
            if j == len(phases) or phases[j] != phases[start]:
                seg = pos[start:j + 1, i]
                ax.plot(seg[:, 0], seg[:, 1], _STYLE.get(phases[start], "-"), color=col, lw=1.6)
                start = j
        ax.plot(*pos[0, i], "o", color=col, ms=5)
        if v.path is not None and sc.mission is not None and "go_to_formation" in sc.mission.phases:
            p0, c0 = v.path.point(0.0), float(v.path.tangent_angle(0.0))
            ax.annotate("", xy=p0 + 6 * np.array([math.cos(c0), math.sin(c0)]), xytext=p0,
                        arrowprops=dict(arrowstyle="-|>", color=col, lw=1.5))
            ax.plot(*p0, "s", mfc="none", color=col, ms=7)
        ax.annotate(v.name, pos[0, i], textcoords="offset points", xytext=(4, 4), color=col, fontsize=8,
                    gid=NAME_LABEL_GID)
    lo, hi = pos.reshape(-1, 2).min(axis=0) - 30.0, pos.reshape(-1, 2).max(axis=0) + 30.0
    for k, o in enumerate(sc.moving_obstacles):
        ax.plot(traffic[:, k, 0], traffic[:, k, 1], color="0.45", lw=1.0, alpha=0.8)
        inside = np.flatnonzero(((traffic[:, k] > lo + 5.0) & (traffic[:, k] < hi - 5.0)).all(axis=1))
        if inside.size:  # label the track where it enters the frame
            _edge_label(ax, traffic[inside[0], k], o.name, lo, hi, color="0.35", fontsize=8)
    if np.isfinite(est).any():
        ax.plot(est[:, 0], est[:, 1], ".", color="tab:red", ms=1.5, label="leader's target estimate")
    for name, style in _STYLE.items():
        if name != "done":
            ax.plot([], [], style, color="k", label=PHASE_STATES[name][0])
    ax.plot([], [], "s", mfc="none", color="k", label="formation pose")
    ax.plot([], [], color="0.45", label="traffic and target (truth)")
    ax.set_xlim(lo[0], hi[0])  # framed on the team (traffic tracks run beyond)
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal")
    ax.set_xlabel("east [m]")
    ax.set_ylabel("north [m]")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=3, fontsize=8, frameon=False)
    ax.set_title(title, fontsize=10)
    gantt = fig.add_axes([0.62, 0.58, 0.35, 0.32])
    for i, v in enumerate(sc.vessels):
        for entry in summary["vessels"][v.name].get("mission", {}).get("phases", []):
            end = entry["end_s"] if entry["end_s"] is not None else t[-1]
            gantt.barh(i, end - entry["start_s"], left=entry["start_s"],
                       color=np.array(PHASE_STATES[entry["phase"]][1]) / 255.0, edgecolor="k", lw=0.5)
    gantt.set_yticks(range(len(sc.vessels)), [v.name for v in sc.vessels])
    gantt.set_xlabel("time [s]")
    gantt.set_title("mission phases", fontsize=10)
    from matplotlib.patches import Patch

    gantt.legend(handles=[Patch(color=np.array(PHASE_STATES[n][1]) / 255.0, label=PHASE_STATES[n][0])
                          for n in ("go_to_formation", "follow_path", "track_target")], fontsize=7,
                 loc="upper left", bbox_to_anchor=(0.0, -0.18), ncol=3, frameon=False)
    err_ax = fig.add_axes([0.62, 0.08, 0.35, 0.3])
    for i, v in enumerate(sc.vessels):
        errs = tr["station_errors"].get(v.name)
        if errs is not None:
            err_ax.plot(*errs, color=np.array(vessel_colour(i)) / 255.0, lw=1.2, label=v.name)
    err_ax.set_xlabel("time [s]")
    err_ax.set_ylabel("true station error [m]")
    err_ax.set_title("target tracking: distance from the station (truth)", fontsize=10)
    if tr["station_errors"]:
        err_ax.legend(fontsize=7)
    err_ax.grid(alpha=0.3)
    return fig


def make_mission_figures(out_dir, formats=("png",), scenarios=None) -> list[Path]:
    """Run each scenario (default: :data:`FIGURE_SCENARIOS`) and write ``mission_<name>.<format>``
    to ``out_dir`` for each of ``formats``. Returns the written paths."""
    from mjasc.figures.thesis import figure_backend, save_figure

    plt, out = figure_backend(out_dir)
    paths = []
    for stem in scenarios or FIGURE_SCENARIOS:
        sc = load_scenario(tasks_dir() / f"{stem}.toml")
        tr, summary = trace_mission(sc)
        fig = mission_figure(sc, tr, summary, FIGURE_SCENARIOS.get(stem, stem), plt)
        paths += save_figure(fig, out / f"mission_{stem}", formats)
        plt.close(fig)
    return paths
