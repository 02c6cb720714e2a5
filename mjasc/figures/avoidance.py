"""Figures of the collision avoidance runs (thesis §6.2–6.4): top-down tracks with the mission
paths, the obstacles' tracks, the predicted collision points (merged into numbered groups with a key:
:mod:`mjasc.figures.conflict_labels`), the static virtual obstacles and the re-planned paths, framed
on where things happen (:func:`action_extent`), plus speed and mode against time.

Each figure is made by running the scenario file in ``tasks/`` through the real runner (the
vessels avoid with their own perception), recording what the avoidance components did on the way.

Entry point: ``make_avoidance_figures(out_dir, scenarios=None, duration_s=None) -> list[Path]``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mjasc.avoidance.request import MODES
from mjasc.core.resources import tasks_dir
from mjasc.runs.recording import vessel_colour
from mjasc.runs.runner import Runner
from mjasc.runs.scenario import load_scenario

TASKS_DIR = tasks_dir()

#: Scenario file stem → figure title.
FIGURE_SCENARIOS = {
    "thesis_6_2_dock": "§6.2 dock: potential-field path out of the dock",
    "thesis_6_3_velocity_correction": "§6.3 velocity correction: slow down, let the obstacle pass",
    "thesis_6_4_crossing": "§6.4.1 a large vessel crosses the formation",
    "thesis_6_4_head_on": "§6.4.2 head-on obstacle: velocity correction, then SVO re-plan",
    "thesis_6_4_bottleneck": "§6.4.3 bottleneck between two islands, starboard priority",
}


@dataclass
class RunTrace:
    """What one run did, sampled at the record rate (world ENU, SI)."""

    scenario: object
    times: list = field(default_factory=list)
    positions: list = field(default_factory=list)  # (n_vessels, 2) per tick
    headings: list = field(default_factory=list)  # (n_vessels,) per tick [rad]
    speeds: list = field(default_factory=list)
    references: list = field(default_factory=list)
    modes: list = field(default_factory=list)  # per tick: list of mode codes
    traffic: list = field(default_factory=list)  # (n_moving, 2) per tick
    detours: dict = field(default_factory=dict)  # vessel → list of (t, streamline (k, 2), obstacles)
    svos: dict = field(default_factory=dict)  # vessel → list of (t, polygon)
    collision_points: dict = field(default_factory=dict)  # vessel → list of (t, point (2,), t_i, t_f)
    summary: dict = field(default_factory=dict)


class _Tracer:
    """A runner observer of the record slot: what each vessel's avoidance did, sampled at the
    record rate (reads the agents' and components' public state only)."""

    def __init__(self, trace: RunTrace, n_vessels: int):
        self.trace = trace
        self._seen_detours = [None] * n_vessels
        self._seen_predictions = [None] * n_vessels

    def __call__(self, event) -> None:
        runner, states, tr = event.runner, event.states, self.trace
        tr.times.append(states.time_s)
        tr.positions.append(states.position_m.copy())
        tr.headings.append(states.heading_rad.copy())
        tr.speeds.append(states.speed_m_s.copy())
        tr.references.append([o.speed_ref_m_s if o else 0.0 for o in runner.last_outputs])
        tr.modes.append([MODES.get(a.mode, 0) if a.avoidance is not None else 0 for a in runner.agents])
        if len(runner.world.moving_obstacles):
            tr.traffic.append(runner.sim.traffic_state()[0].copy())
        for i, agent in enumerate(runner.agents):
            av = agent.avoidance
            if av is None:
                continue
            if av.detour is not None and av.detour is not self._seen_detours[i]:
                self._seen_detours[i] = av.detour
                tr.detours.setdefault(agent.name, []).append((states.time_s, av.detour.streamline,
                                                              av.detour.obstacles))
            last = av.last_prediction
            if last is not None and last is not self._seen_predictions[i]:
                self._seen_predictions[i] = last
                for c in last.conflicts:
                    k = int(np.argmin(np.abs(c.times - c.t_closest_s)))
                    tr.collision_points.setdefault(agent.name, []).append(
                        (last.time_s, c.vessel_positions[k], c.t_i, c.t_f))
                    if c.svo_polygon is not None:
                        tr.svos.setdefault(agent.name, []).append((last.time_s, c.svo_polygon))


def trace_run(name: str, duration_s: float | None = None) -> RunTrace:
    """Run ``tasks/<name>.toml`` and record what its avoidance did."""
    sc = load_scenario(TASKS_DIR / f"{name}.toml")
    if duration_s is not None:
        sc = sc.with_overrides(duration_s=duration_s)
    trace = RunTrace(sc)
    runner = Runner(sc, None, progress=False)
    runner.observe("record", _Tracer(trace, len(runner.agents)))
    trace.summary = runner.run().summary
    return trace


def _closed(p):
    p = np.asarray(p)
    return np.vstack([p, p[:1]])


def action_extent(trace: RunTrace, margin: float = 0.08, min_span_m: float = 40.0) -> tuple[np.ndarray, np.ndarray]:
    """Lower-left and upper-right corners [m] of where things happen: the vessels' sailed tracks,
    the static obstacles, the predicted collision points, the SVOs and the detours, with ``margin``
    of the span on each side (at least ``min_span_m`` across). Mission paths and traffic beyond it
    are cut off: they would otherwise stretch the axis over empty water."""
    sc = trace.scenario
    pts = [np.asarray(trace.positions, float).reshape(-1, 2)]
    for o in sc.static_obstacles:
        pts.append(np.asarray(o.vertices if hasattr(o, "vertices") else o.polygon(32), float))
    for rows in trace.collision_points.values():
        pts += [np.asarray(p, float).reshape(1, 2) for _, p, _, _ in rows]
    for rows in trace.svos.values():
        pts += [np.asarray(poly, float) for _, poly in rows]
    for rows in trace.detours.values():
        pts += [np.asarray(sl, float) for _, sl, _ in rows]
    allp = np.vstack(pts)
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    centre, span = 0.5 * (lo + hi), np.maximum(hi - lo, min_span_m)
    half = 0.5 * span * (1.0 + 2.0 * margin)
    return centre - half, centre + half


#: Styles of the top-down view, shared by what is drawn and the legend's entries.
STRUCTURE_STYLE = dict(color=(0.6, 0.45, 0.3), alpha=0.6)
TRAFFIC_COLOUR = "0.3"  # dark grey: apart from the red of the predicted conflicts and the vessel colours
SVO_STYLE = dict(color="gold", alpha=0.25)
FIELD_OBSTACLE_STYLE = dict(color="purple", lw=0.8, alpha=0.6)
DETOUR_DASHES = (6, 2, 1, 2)  # dash-dot: apart from the traffic's dashed track
#: A vessel that sailed less than this [m] is drawn (and listed) as moored: its track is a dot.
MOORED_M = 1.0
#: The gid of each vessel's hull drawn at its last pose (tests find them by it).
HULL_GID = "hull"


def hull_outline(position_m, heading_rad: float, length_m: float, beam_m: float) -> np.ndarray:
    """A hull's hexagonal outline (6, 2) [m] at a pose (bow along ``heading_rad``, world ENU)."""
    from mjasc.figures.potential_field import vessel_outline

    c, s = np.cos(heading_rad), np.sin(heading_rad)
    body = vessel_outline((0.0, 0.0), length_m, beam_m)
    return body @ np.array([[c, s], [-s, c]]) + np.asarray(position_m, float)


def _legend_entries(trace: RunTrace, plt) -> list:
    """Legend handles for what the view shows beyond the vessels' own lines (only what is there):
    structures, traffic, detours, the potential field's obstacles and the static virtual obstacles."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    sc, out = trace.scenario, []
    if sc.static_obstacles:
        out.append(Patch(**STRUCTURE_STYLE, label="structure (static obstacle)"))
    if trace.traffic:
        lo, hi = action_extent(trace)
        ends = np.asarray(trace.traffic[-1], float).reshape(-1, 2)
        if np.any(np.all((ends >= lo) & (ends <= hi), axis=1)):  # a hull at the end in view
            out.append(Line2D([], [], color=TRAFFIC_COLOUR, ls="--", lw=1, marker="o", ms=7,
                              mfc=(0.3, 0.3, 0.3, 0.3), mec=TRAFFIC_COLOUR, label="traffic: track, hull at the end"))
        else:  # (the traffic sailed out of the view: its track alone is seen)
            out.append(Line2D([], [], color=TRAFFIC_COLOUR, ls="--", lw=1, label="traffic: track"))
    if any(trace.detours.values()):
        out.append(Line2D([], [], color="k", lw=1, dashes=DETOUR_DASHES, label="detour (vessel colour)"))
        out.append(Line2D([], [], **FIELD_OBSTACLE_STYLE, label="potential-field obstacle"))
    if any(trace.svos.values()):
        out.append(Patch(**SVO_STYLE, label="static virtual obstacle (SVO)"))
    return out


def trace_figure(trace: RunTrace, title: str, plt):
    """The figure of a run: top-down (framed on :func:`action_extent`, conflicts numbered with a
    key, :mod:`mjasc.figures.conflict_labels`) on the left, speed and mode against time on the right.
    Each vessel's hull is drawn at its last pose (a moored vessel's track is only a dot); the legend
    lists every style the view uses."""
    from mjasc.figures.conflict_labels import label_conflicts
    from mjasc.physics.vessels import load_vessel_type

    sc = trace.scenario
    fig = plt.figure(figsize=(14, 6.5))
    gs = fig.add_gridspec(2, 2, width_ratios=[3, 2], height_ratios=[3, 1])
    ax, ax2, key_ax = fig.add_subplot(gs[:, 0]), fig.add_subplot(gs[0, 1]), fig.add_subplot(gs[1, 1])
    key_ax.axis("off")
    pos = np.array(trace.positions)
    names = [v.name for v in sc.vessels]
    for o in sc.static_obstacles:
        poly = o.vertices if hasattr(o, "vertices") else o.polygon(32)
        ax.fill(*_closed(poly).T, **STRUCTURE_STYLE)
    if trace.traffic:
        tp = np.array(trace.traffic)
        for k, o in enumerate(sc.moving_obstacles):
            ax.plot(tp[:, k, 0], tp[:, k, 1], "--", color=TRAFFIC_COLOUR, lw=1)
            ax.add_patch(plt.Circle(tp[-1, k], o.radius_m, fc=(0.3, 0.3, 0.3, 0.3), ec=TRAFFIC_COLOUR, lw=1))
    heading = np.array(trace.headings) if trace.headings else np.zeros(pos.shape[:2])
    for i, v in enumerate(sc.vessels):
        col = np.array(vessel_colour(i)) / 255
        if v.path is not None:
            ax.plot(*v.path.sample(1.0).T, ":", color=col, lw=1, label=f"{v.name} mission path")
        sailed = float(np.hypot(*np.diff(pos[:, i], axis=0).T).sum()) if len(pos) > 1 else 0.0
        if sailed >= MOORED_M:
            ax.plot(pos[:, i, 0], pos[:, i, 1], color=col, lw=2, label=f"{v.name} track, hull at the end")
        vt = load_vessel_type(v.type)
        ax.fill(*_closed(hull_outline(pos[-1, i], heading[-1, i], vt.length_m, vt.beam_m)).T, fc=col, ec="k", lw=0.6,
                zorder=3, gid=HULL_GID, label=None if sailed >= MOORED_M else f"{v.name} (moored)")
        for t, sl, obstacles in trace.detours.get(v.name, []):
            ax.plot(*sl.T, color=col, lw=1, alpha=0.8, dashes=DETOUR_DASHES)
            for p in obstacles:
                ax.plot(*_closed(p).T, **FIELD_OBSTACLE_STYLE)
        for t, poly in trace.svos.get(v.name, []):
            ax.fill(*_closed(poly).T, **SVO_STYLE)
    # Autoscale on the action's extent alone; the equal aspect then widens one axis to fill the box.
    ax.ignore_existing_data_limits = True
    ax.update_datalim(np.array(action_extent(trace)))
    ax.autoscale_view(tight=True)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x east [m]")
    ax.set_ylabel("y north [m]")
    ax.set_title(title, fontsize=10)
    handles, _ = ax.get_legend_handles_labels()
    ax.legend(handles=handles + _legend_entries(trace, plt), fontsize=7, loc="best")
    t = np.array(trace.times)
    sp, ref, modes = np.array(trace.speeds), np.array(trace.references), np.array(trace.modes)
    for i, v in enumerate(sc.vessels):
        if "avoidance" not in v.options:
            continue
        col = np.array(vessel_colour(i)) / 255
        ax2.plot(t, sp[:, i], color=col, lw=1.5, label=f"{v.name} speed")
        ax2.plot(t, ref[:, i], color=col, lw=0.8, ls="--", label=f"{v.name} commanded")
        ax2.fill_between(t, 0, 0.1 * modes[:, i], color=col, alpha=0.3, step="post")
    ax2.set_xlabel("time [s]")
    ax2.set_ylabel("speed [m/s]  (bands: mode, 0.1 = yield … 0.3 = detour)")
    s = trace.summary
    clear = {n: s["vessels"][n]["min_clearance_to_any_m"] for n in names}
    ax2.set_title(f"collision: {s['any_collision']}; min clearance [m]: " +
                  ", ".join(f"{n} {c:.1f}" for n, c in clear.items() if c is not None), fontsize=8)
    ax2.legend(fontsize=7)
    fig.tight_layout()
    label_conflicts(ax, key_ax, trace.collision_points)
    return fig


def plot_trace(trace: RunTrace, title: str, path: Path, plt, formats=("png",)) -> list[Path]:
    """Write :func:`trace_figure` as ``path`` in each of ``formats``; returns the paths."""
    from mjasc.figures.thesis import save_figure

    fig = trace_figure(trace, title, plt)
    paths = save_figure(fig, path, formats)
    plt.close(fig)
    return paths


def make_avoidance_figures(out_dir, scenarios=None, duration_s: float | None = None, formats=("png",)) -> list[Path]:
    """Run each scenario (default: all of :data:`FIGURE_SCENARIOS`) and write
    ``avoidance_<name>.<format>`` to ``out_dir`` for each of ``formats``. Returns the written paths."""
    from mjasc.figures.thesis import figure_backend

    plt, out = figure_backend(out_dir)
    written = []
    for name in scenarios or FIGURE_SCENARIOS:
        trace = trace_run(name, duration_s)
        written += plot_trace(trace, FIGURE_SCENARIOS.get(name, name), out / f"avoidance_{name}.png", plt, formats)
    return written
