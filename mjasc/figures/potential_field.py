"""Figures of the harmonic potential-field path planner, after thesis §6.2 (Figs. 6.3, 6.4).

The thesis does not give its dock geometry, only that "a team of three ASC [is] placed inside a
dock", that "each ASC derives its path from a different potential field, unique to the given
vehicle", and that at r = 1 "the path selected avoids the bottleneck altogether". Its Table 6.2
fixes the panel counts: 24 panels of equal length for the robust sweep (two obstacles of 12 panels
— consistent with the two team mates as obstacles, ~12.4 m of panel outline each) and 32 panels
for the λ_g = 70 run (four obstacles of 8). The geometry below is invented to match that:

- the dock: a quay wall west of the berths (drawn; it lies upstream of every start, so the
  streamlines leave it and it is not paneled — like the thesis's 24-panel fields);
- three Delfim-sized ASCs (3.5 m × 2.0 m, hexagonal outline) at their berths: vessels 1 and 3
  side by side at the dock mouth with a narrow gap (the bottleneck), vessel 2 behind them;
- each vessel's field holds the *other two* vessels (hexagons, 2 panels per edge → 24 panels),
  inflated by half the beam + 0.5 m safety distance; the λ_g = 70 run adds a moored pontoon on
  vessel 2's route (4 edges × 2 panels → 32 panels).

What to expect against thesis Table 6.2: with V_j = a·L_j and nearly equal panels, V_i ≈
r·λ_g / (total panel outline) — the thesis's V_i = 1.2115 at r = 1 implies ≈ 24.8 m of outline;
ours is 39.0 m (two inflated hulls), so V_i ≈ 0.72–0.74 at r = 1, 0.50–0.52 at 0.7, 0.22 at 0.3 and
0.14–0.15 at 0.2. The thesis's own column is proportional to r except at r = 0.2, where its
0.1211 is exactly a tenth of the r = 1 value (a typo or a run at r = 0.1).

Entry point: ``make_figures(out_dir) -> list[Path]``. ``dock_scenario()`` returns the geometry as
data (for a scenario file).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mjasc.avoidance.potential_field import PotentialField, Streamline

#: Thesis Table 6.2, simulation (b): λ_g = 30, U = 1, 24 panels: safety ratio → V_i (all panels).
THESIS_TABLE_6_2_V = {0.2: 0.1211, 0.3: 0.3634, 0.7: 0.848, 1.0: 1.2115}
#: Thesis Table 6.2, simulation (c): λ_g = 70, U = 1.85, r = 0.2, 32 panels: V_i range.
THESIS_TABLE_6_2_C_V_RANGE = (0.3786, 1.0572)

SWEEP_RATIOS = (0.2, 0.3, 0.7, 1.0)


def vessel_outline(centre, length_m: float = 3.5, beam_m: float = 2.0) -> np.ndarray:
    """Hexagonal hull outline (6, 2) [m], bow to the east, counter-clockwise."""
    s = 0.9 * length_m / 3.5  # shoulders: where the pointed ends start
    x, y = float(centre[0]), float(centre[1])
    half_l, half_b = length_m / 2.0, beam_m / 2.0
    return np.array(
        [[half_l, 0.0], [s, half_b], [-s, half_b], [-half_l, 0.0], [-s, -half_b], [s, -half_b]]
    ) + [x, y]


@dataclass(frozen=True)
class DockScenario:
    """Invented dock scene of thesis §6.2 (see the module docstring). World frame ENU [m].

    quay: (4, 2) quay wall polygon (drawn only). hulls: three (6, 2) vessel outlines at the
    berths. starts, goals: (3, 2) per vessel. pontoon: (4, 2) moored pontoon used by the
    λ_g = 70 run. inflation_m: half beam + safety distance [m]. beam_m: vessel beam [m].
    """

    quay: np.ndarray
    hulls: tuple[np.ndarray, ...]
    starts: np.ndarray
    goals: np.ndarray
    pontoon: np.ndarray
    inflation_m: float
    beam_m: float = 2.0
    panels_per_edge: int = 2
    names: tuple[str, ...] = field(default=("vessel 1", "vessel 2", "vessel 3"))

    def obstacles_for(self, vessel: int, with_pontoon: bool = False) -> list[np.ndarray]:
        """Obstacles in vessel ``vessel``'s own field: the other vessels' hulls (+ pontoon)."""
        if vessel not in range(len(self.hulls)):
            raise ValueError(f"vessel must be 0..{len(self.hulls) - 1}, got {vessel}")
        obs = [h for k, h in enumerate(self.hulls) if k != vessel]
        return obs + ([self.pontoon] if with_pontoon else [])

    def field(self, vessel: int, with_pontoon: bool = False, **kwargs) -> PotentialField:
        """The vessel's ``PotentialField`` (kwargs: sink_strength, uniform_speed, safety_ratio,
        normal_velocity, ...)."""
        return PotentialField(
            self.obstacles_for(vessel, with_pontoon),
            goal=self.goals[vessel],
            start=self.starts[vessel],
            inflation=self.inflation_m,
            panels_per_edge=self.panels_per_edge,
            **kwargs,
        )

    def as_dict(self) -> dict:
        """Plain lists, for writing a scenario file."""
        return {
            "quay": self.quay.tolist(),
            "hulls": [h.tolist() for h in self.hulls],
            "starts": self.starts.tolist(),
            "goals": self.goals.tolist(),
            "pontoon": self.pontoon.tolist(),
            "inflation_m": self.inflation_m,
            "panels_per_edge": self.panels_per_edge,
        }


def dock_scenario() -> DockScenario:
    """The invented dock scene (three vessels, a bottleneck between vessels 1 and 3)."""
    starts = np.array([[4.0, 3.5], [-3.0, 0.0], [4.0, -2.5]])
    goals = np.array([[70.0, 25.0], [65.0, -5.0], [70.0, -25.0]])
    beam = 2.0
    return DockScenario(
        quay=np.array([[-17.0, -20.0], [-13.0, -20.0], [-13.0, 20.0], [-17.0, 20.0]]),
        hulls=tuple(vessel_outline(s, beam_m=beam) for s in starts),
        starts=starts,
        goals=goals,
        pontoon=np.array([[28.0, -6.5], [33.0, -6.5], [33.0, -3.5], [28.0, -3.5]]),
        inflation_m=0.5 * beam + 0.5,
        beam_m=beam,
    )


# ------------------------------------------------------------------------------------------------
# Studies (numbers, no plotting) — used by the figures and by the tests
# ------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SweepRun:
    """One robust-field run: safety ratio, the field, and its streamline from the start."""

    safety_ratio: float
    field: PotentialField
    path: Streamline


def safety_ratio_sweep(
    ratios=SWEEP_RATIOS,
    sink_strength: float = 30.0,
    uniform_speed: float = 1.0,
    with_pontoon: bool = False,
    vessel: int = 1,
    scenario: DockScenario | None = None,
    step: float = 0.5,
) -> list[SweepRun]:
    """Thesis §6.2 (b)/(c): vessel ``vessel``'s robust field for each safety ratio."""
    sc = scenario or dock_scenario()
    runs = []
    for r in ratios:
        f = sc.field(
            vessel,
            with_pontoon=with_pontoon,
            sink_strength=sink_strength,
            uniform_speed=uniform_speed,
            safety_ratio=r,
        )
        runs.append(SweepRun(float(r), f, f.streamline(step=step)))
    return runs


#: (vessel index, V_i as a fraction of V_max) for Fig. 6.3 (a): like the thesis, one vessel is
#: run twice — once above the bound (misses the goal), once below it.
TEAM_RUNS = ((0, 0.4), (2, 0.6), (1, 1.5), (1, 0.8))


def team_paths(runs=TEAM_RUNS, sink_strength: float = 30.0, uniform_speed: float = 1.0,
               scenario: DockScenario | None = None, step: float = 0.5):
    """Thesis Fig. 6.3 (a): each vessel's own field with a hand-set uniform V_i.

    The thesis's V_i ∈ {10, 15, 30, 18} belong to its geometry; here V_i is set as a fraction of
    the largest uniform V that keeps λ_ob < λ_g for that vessel's field (the bound of thesis
    eq. 4.29 for V_j = V: V_max = (λ_g − Lᵀ J b)/(Lᵀ J 1)). ``runs``: (vessel, fraction) pairs;
    the default runs vessel 2 (whose path crosses the bottleneck) above and below the bound, as
    the thesis did for its vehicle 3 (V_i = 30 missed the goal, V_i = 18 reached it).
    Returns a list of (vessel index, V_i, fraction, field, streamline).
    """
    sc = scenario or dock_scenario()
    out = []
    for v, frac in runs:
        probe = sc.field(v, sink_strength=sink_strength, uniform_speed=uniform_speed)
        L = probe.panels.length
        P = probe.influence_matrix
        J1 = np.linalg.solve(P, np.ones_like(L))
        Jb = np.linalg.solve(P, probe.rhs_free_stream)
        v_max = (sink_strength - L @ Jb) / (L @ J1)
        V = float(frac * v_max)
        f = sc.field(v, sink_strength=sink_strength, uniform_speed=uniform_speed, normal_velocity=V)
        out.append((v, V, float(frac), f, f.streamline(step=step)))
    return out


# ------------------------------------------------------------------------------------------------
# Plotting
# ------------------------------------------------------------------------------------------------


#: The gid of each vessel's name label by its hull (tests find them by it).
HULL_LABEL_GID = "hull-label"
#: A hull's name label stands this far [pt] from the hull's centre, on the side away from the other hulls.
HULL_LABEL_OFFSET_PT = 11.0


#: [m] A side whose label would reach an obstacle (the quay) this close to the hull is not used.
HULL_LABEL_REACH_M = 15.0


def hull_label_offsets(hulls, offset_pt: float = HULL_LABEL_OFFSET_PT, obstacles=()) -> list[tuple[float, float]]:
    """Per hull the label's offset [pt] from its centre: ``offset_pt`` along the direction from
    the other hulls' mean centre to this hull's centre, snapped to the nearest of the four sides
    (up, down, left, right), so that a label never sits between two hulls (3 hulls 6 m apart are
    a few points wide at a figure's scale: a label above each one lands on its neighbour). A side
    facing one of ``obstacles`` (polygons (k, 2) [m]) within :data:`HULL_LABEL_REACH_M` is skipped
    for the next best (vessel 2's label, left of it, lay on the quay)."""
    from mjasc.core.geometry import point_in_polygon

    centres = np.array([np.mean(h, axis=0) for h in hulls])
    sides = np.array([[0.0, 1.0], [0.0, -1.0], [-1.0, 0.0], [1.0, 0.0]])
    reach = np.linspace(0.0, HULL_LABEL_REACH_M, 16)
    out = []
    for k, c in enumerate(centres):
        others = np.delete(centres, k, axis=0)
        d = c - others.mean(axis=0) if len(others) else np.array([0.0, 1.0])
        # the sides by how well they point away from the others (ties: up first, as before)
        order = sorted(range(4), key=lambda j: (-(sides[j] @ d) / (np.hypot(*d) or 1.0), j))
        for j in order:
            probe = c + reach[:, None] * sides[j]
            if not any(np.any(point_in_polygon(probe, np.asarray(p, float))) for p in obstacles):
                break
        else:
            j = order[0]
        out.append((offset_pt * sides[j][0], offset_pt * sides[j][1]))
    return out


def _draw_scene(ax, sc: DockScenario, field: PotentialField | None = None, pontoon=False):
    ax.fill(*sc.quay.T, color="0.35", label="dock (quay)")
    for k, (h, (dx, dy)) in enumerate(zip(sc.hulls, hull_label_offsets(sc.hulls, obstacles=[sc.quay]))):
        ax.fill(*h.T, color="tab:blue", alpha=0.5)
        ha = "center" if dx == 0 else ("left" if dx > 0 else "right")
        va = "center" if dy == 0 else ("bottom" if dy > 0 else "top")
        ax.annotate(sc.names[k], h.mean(axis=0), textcoords="offset points", xytext=(dx, dy),
                    ha=ha, va=va, fontsize=7, gid=HULL_LABEL_GID,
                    bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.8))
    if pontoon:
        ax.fill(*sc.pontoon.T, color="0.55")
    if field is not None:
        for poly in field.polygons:
            ring = np.vstack([poly, poly[:1]])
            ax.plot(*ring.T, "k--", lw=0.6)
    ax.plot(*sc.goals.T, "r*", ms=9, label="goals")
    ax.set_xlabel("x east (m)")
    ax.set_ylabel("y north (m)")
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)


def _figure_dock(out_dir: Path, plt, formats=("png",)) -> tuple[list[Path], dict]:
    sc = dock_scenario()
    fig, axes = plt.subplots(1, 3, figsize=(18, 6.2))
    # (a) team, hand-set V_i
    ax = axes[0]
    _draw_scene(ax, sc)
    team = team_paths(scenario=sc)
    colours = ["tab:green", "tab:orange", "tab:red", "tab:purple"]
    for (v, V, frac, f, s), c in zip(team, colours):
        ax.plot(*s.points.T, color=c, label=f"{sc.names[v]}: V_i = {V:.3f} ({frac:g} V_max)"
                + ("" if s.reached_goal else f" — {s.reason}"))
    ax.set_xlim(-20, 110)
    ax.set_ylim(-55, 55)
    ax.set_title("(a) each vessel's own field, hand-set V_i (λ_g = 30, U = 1)")
    ax.legend(fontsize=7, loc="upper left")
    # (b) robust sweep
    ax = axes[1]
    runs = safety_ratio_sweep(scenario=sc)
    _draw_scene(ax, sc, runs[0].field)
    for run in runs:
        ax.plot(*run.path.points.T, label=f"safe ratio = {run.safety_ratio:g}"
                + ("" if run.path.reached_goal else f" ({run.path.reason})"))
    ax.set_xlim(-20, 80)
    ax.set_ylim(-35, 35)
    ax.set_title(f"(b) robust field, vessel 2, λ_g = 30, U = 1, {len(runs[0].field.panels)} panels")
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=3)  # (inside: over the quay)
    # (c) λ_g = 70, U = 1.85, r = 0.2 with the pontoon
    ax = axes[2]
    (run_c,) = safety_ratio_sweep((0.2,), 70.0, 1.85, with_pontoon=True, scenario=sc)
    _draw_scene(ax, sc, run_c.field, pontoon=True)
    ax.plot(*run_c.path.points.T, color="tab:red", label="safe ratio = 0.2")
    ax.set_xlim(-20, 80)
    ax.set_ylim(-35, 35)
    ax.set_title(f"(c) robust field, λ_g = 70, U = 1.85, {len(run_c.field.panels)} panels")
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=3)
    fig.suptitle("Harmonic potential field path planning in the dock (after thesis Fig. 6.3)")
    fig.tight_layout()
    from mjasc.figures.thesis import save_figure

    path = save_figure(fig, out_dir / "potential_field_dock.png", formats)
    plt.close(fig)
    table = {
        "sweep": [
            {
                "r": run.safety_ratio,
                "alpha_max": run.field.alpha_max,
                "V_min": float(run.field.normal_velocities.min()),
                "V_max": float(run.field.normal_velocities.max()),
                "thesis_V": THESIS_TABLE_6_2_V.get(run.safety_ratio),
                "net_obstacle_strength": run.field.net_obstacle_strength,
                "reached_goal": run.path.reached_goal,
                "path_length_m": run.path.length,
                "min_clearance_m": float(run.field.distance_to_obstacles(run.path.points).min()),
            }
            for run in runs
        ],
        "c": {
            "panels": len(run_c.field.panels),
            "V_min": float(run_c.field.normal_velocities.min()),
            "V_max": float(run_c.field.normal_velocities.max()),
            "reached_goal": run_c.path.reached_goal,
        },
    }
    return path, table


def _figure_gradient(out_dir: Path, plt, formats=("png",)) -> list[Path]:
    """Thesis Fig. 6.4: direction of the field (normalized velocity) around vessel 2's
    obstacles, with streamlines and the planned path."""
    sc = dock_scenario()
    f = sc.field(1, safety_ratio=0.3, sink_strength=30.0, uniform_speed=1.0)
    xs = np.linspace(-20, 20, 41)
    ys = np.linspace(-20, 20, 41)
    X, Y = np.meshgrid(xs, ys)
    pts = np.column_stack([X.ravel(), Y.ravel()])
    u = f.velocity(pts)
    u[f.distance_to_obstacles(pts) < 0] = np.nan
    speed = np.linalg.norm(u, axis=1)
    d = u / speed[:, None]
    fig, ax = plt.subplots(figsize=(7.5, 7))
    ax.quiver(X, Y, d[:, 0].reshape(X.shape), d[:, 1].reshape(X.shape), np.log10(speed).reshape(X.shape),
              cmap="viridis", scale=45, width=0.003)
    xf = np.linspace(-20, 20, 161)
    Xf, Yf = np.meshgrid(xf, xf)
    pts_f = np.column_stack([Xf.ravel(), Yf.ravel()])
    uf = f.velocity(pts_f)
    uf[f.distance_to_obstacles(pts_f) < 0] = np.nan
    ax.streamplot(Xf, Yf, uf[:, 0].reshape(Xf.shape), uf[:, 1].reshape(Xf.shape), color="0.6",
                  density=1.2, linewidth=0.5, arrowsize=0.6)
    for poly, hull in zip(f.polygons, sc.obstacles_for(1)):
        ax.fill(*hull.T, color="tab:blue", alpha=0.6)
        ax.plot(*np.vstack([poly, poly[:1]]).T, "k--", lw=0.8)
    s = f.streamline(step=0.5)
    ax.plot(*s.points.T, "r", lw=1.5, label="path of vessel 2 (r = 0.3)")
    ax.plot(*sc.starts[1], "ro")
    ax.set_xlim(-20, 20)
    ax.set_ylim(-20, 20)
    ax.set_aspect("equal")
    ax.set_xlabel("x east (m)")
    ax.set_ylabel("y north (m)")
    ax.set_title("Field direction (colour: log10 speed) — after thesis Fig. 6.4")
    ax.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    from mjasc.figures.thesis import save_figure

    path = save_figure(fig, out_dir / "potential_field_gradient.png", formats)
    plt.close(fig)
    return path


def make_figures(out_dir, formats=("png",)) -> list[Path]:
    """Write the §6.2 figures (each in ``formats``) into ``out_dir`` (created if needed); return their paths."""
    from mjasc.figures.thesis import figure_backend

    plt, out = figure_backend(out_dir)
    dock_paths, _ = _figure_dock(out, plt, formats)
    return [*dock_paths, *_figure_gradient(out, plt, formats)]


def sweep_table() -> dict:
    """The numbers behind the dock figure (V_i vs thesis Table 6.2 etc.), without plotting."""
    sc = dock_scenario()
    runs = safety_ratio_sweep(scenario=sc)
    return {
        run.safety_ratio: {
            "V": (float(run.field.normal_velocities.min()), float(run.field.normal_velocities.max())),
            "thesis_V": THESIS_TABLE_6_2_V.get(run.safety_ratio),
            "reached_goal": run.path.reached_goal,
        }
        for run in runs
    }


if __name__ == "__main__":  # pragma: no cover
    import sys

    for p in make_figures(sys.argv[1] if len(sys.argv) > 1 else "figures"):
        print(p)
