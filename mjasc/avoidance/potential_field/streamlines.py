"""Streamlines of the harmonic potential field: the re-planned path (thesis §4.1; docs/thesis.md §4).

The path follows the flow direction, ṗ = u(p)/‖u(p)‖ (arc-length parametrization, docs/thesis.md §4),
traced with RK4 from the start, many starts at once: in one compiled call
(:mod:`~mjasc.avoidance.potential_field.streamline_kernels`, the bits of the numpy form over the
starts, :func:`_trace_numpy`, kept as its reference and fallback). World frame ENU, metres.

The arc-length step is at most ``step`` [m] and shrinks to :data:`VERTEX_STEP_FRACTION` of the
distance to the nearest panel vertex (where the field bends sharply) and to half the distance to
the goal (no overshoot); a step over which the direction turns by more than 30° is rejected and
retried with half the step. The winding number of each inflated obstacle (Σβ/(2π) over its
panels, see :mod:`mjasc.avoidance.potential_field.panels`) comes with every velocity evaluation,
so a path entering an obstacle is noticed without extra work.

A streamline stops with one of :data:`REASONS`: "goal" (within the goal tolerance; the goal is
appended as the last point), "stagnation" (speed ~ 0, or the direction reverses: a stagnation
saddle), "runaway" (farther than 3× the scene size from the goal: the sink missed, e.g.
λ_ob > λ_g), "max_length" (default 4× the scene size), "entered_obstacle" (the winding number of
an inflated obstacle became 1), "nonfinite".
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from mjasc.avoidance.potential_field.streamline_kernels import MAX_PANELS, trace_compiled

if TYPE_CHECKING:
    from mjasc.avoidance.potential_field.field import PotentialField

__all__ = ["VERTEX_STEP_FRACTION", "REASONS", "Streamline", "trace_streamlines"]

#: Streamline arc-length step as a fraction of the distance to the nearest panel vertex (where the
#: field bends sharply); steps turning by more than 30° are rejected and halved as well.
VERTEX_STEP_FRACTION = 0.5

#: Streamline termination reasons (``Streamline.reason``).
REASONS = ("goal", "stagnation", "runaway", "max_length", "entered_obstacle", "nonfinite")


@dataclass(frozen=True)
class Streamline:
    """A path traced along the field: points (k, 2) [m] from the start; ``reached_goal``;
    ``reason`` one of REASONS ("goal", "stagnation", "runaway", "max_length",
    "entered_obstacle", "nonfinite") saying why integration stopped; ``obstacle`` the index of
    the obstacle entered when reason == "entered_obstacle", else None."""

    points: np.ndarray
    reached_goal: bool
    reason: str
    obstacle: int | None = None

    @property
    def reaches_goal(self) -> bool:
        return self.reached_goal

    @property
    def length(self) -> float:
        """Arc length [m] of the traced path."""
        return float(np.sum(np.linalg.norm(np.diff(self.points, axis=0), axis=1)))



def trace_streamlines(
    field: PotentialField,
    starts,
    step: float = 1.0,
    max_length: float | None = None,
    goal_tolerance: float | None = None,
    min_step: float | None = None,
) -> list[Streamline]:
    """Trace streamlines of ``field`` from many starts (n, 2) at once (vectorized RK4; see the
    module docstring and :meth:`PotentialField.streamline`). ``step`` [m]: the largest arc-length
    step; ``min_step`` [m]: the smallest (default step/1000)."""
    p0 = np.atleast_2d(np.asarray(starts, dtype=float))
    if p0.shape[-1] != 2 or not np.all(np.isfinite(p0)):
        raise ValueError(f"starts must be finite points of shape (n, 2), got {np.shape(starts)}")
    if not (np.isfinite(step) and step > 0):
        raise ValueError(f"step must be > 0 m, got {step}")
    for i, s in enumerate(p0):
        k = field.obstacle_containing(s)
        if k is not None:
            which = "start" if len(p0) == 1 else f"start {i}"
            raise ValueError(
                f"{which} {s.tolist()} lies inside obstacle {k} (inflated by {field.inflation} m)"
            )
    goal = field.goal
    tol = step if goal_tolerance is None else float(goal_tolerance)
    if tol <= 0:
        raise ValueError(f"goal_tolerance must be > 0 m, got {goal_tolerance}")
    h_min = step * 1e-3 if min_step is None else float(min_step)
    # Scene scale: how far from the goal (or the starts) counts as running away.
    ref = goal if goal is not None else p0.mean(axis=0)
    extent = np.linalg.norm(p0 - ref, axis=1)
    if field.panels is not None and len(field.panels):
        scene = float(np.max(np.linalg.norm(field.panels.start - ref, axis=1)))
    else:
        scene = 0.0
    runaway = 3.0 * (np.maximum(extent, scene) + step)
    max_len = (
        np.full(len(p0), float(max_length))
        if max_length is not None
        else 4.0 * (extent + scene) + 10.0 * step
    )
    cos_max_turn = np.cos(np.radians(30.0))
    speed_floor = 1e-9 * max(field.uniform_speed, field.sink_strength / max(scene, 1.0), 1e-12)
    arrays = field.kernel_arrays() if type(field).evaluate is _plain_evaluate() else None
    if arrays is not None and arrays[2].shape[0] <= MAX_PANELS:  # compiled (streamline_kernels), the same bits
        pts, count, code, entered = trace_compiled(
            p0, np.zeros(2) if goal is None else goal, goal is not None, ref, runaway, max_len, float(tol),
            float(step), float(h_min), float(cos_max_turn), float(speed_floor), VERTEX_STEP_FRACTION, *arrays)
        paths = [pts[i, :count[i]].copy() for i in range(len(p0))]
        entered = [None if k < 0 else k for k in entered.tolist()]
    else:
        paths, code, entered = _trace_numpy(field, p0, goal, ref, runaway, max_len, tol, step, h_min, cos_max_turn,
                                            speed_floor)
    reasons = [REASONS[k - 1] for k in code]
    return [
        Streamline(np.array(paths[i]), reasons[i] == "goal", reasons[i], entered[i])
        for i in range(len(p0))
    ]


def _plain_evaluate():
    """``PotentialField.evaluate`` (the field the compiled tracer writes out; imported late: the
    field module imports this one)."""
    from mjasc.avoidance.potential_field.field import PotentialField

    return PotentialField.evaluate


def _trace_numpy(field, p0, goal, ref, runaway, max_len, tol, step, h_min, cos_max_turn, speed_floor):
    """The RK4 loop over the lines in numpy (:func:`trace_streamlines`' arguments as it works them
    out): (each line's points, its reason code (1 + index into REASONS), the obstacle entered or
    None). The reference form of :func:`~mjasc.avoidance.potential_field.streamline_kernels.trace_compiled`
    and its fallback (more panels than it sums in OpenBLAS's order, a field whose ``evaluate`` is
    not the plain one)."""
    n = len(p0)
    paths = [[s.copy()] for s in p0]
    code = np.zeros(n, dtype=int)  # 0 running, else 1 + index into REASONS
    entered: list[int | None] = [None] * n
    p = p0.copy()
    travelled = np.zeros(n)
    prev_dir = np.full((n, 2), np.nan)
    h_cap = np.full(n, float(step))
    reason_code = {r: i + 1 for i, r in enumerate(REASONS)}

    def direction(q):
        u = field.evaluate(q)
        return u / np.hypot(u[:, 0], u[:, 1])[:, None]

    def dist(q, point):
        return np.hypot(q[:, 0] - point[0], q[:, 1] - point[1])

    errors = np.errstate(divide="ignore", invalid="ignore")  # vertices, goal: inf/nan
    with errors:
        active = np.arange(n)
        while active.size:
            q = p[active]
            # Checks at the current points (each already on its path), in order of precedence.
            u, winding, d_vertex = field.evaluate(q, want_geometry=True)
            speed = np.hypot(u[:, 0], u[:, 1])
            d_goal = dist(q, goal) if goal is not None else np.full(len(q), np.inf)
            inside = np.abs(winding) > 0.5
            c = np.zeros(len(q), dtype=int)
            checks = (
                ("max_length", travelled[active] >= max_len[active]),
                ("runaway", dist(q, ref) > runaway[active]),
                ("stagnation", speed < speed_floor),
                ("nonfinite", ~np.isfinite(speed)),
                ("goal", d_goal <= tol),
                ("entered_obstacle", inside.any(axis=1)),
            )
            for name, hit in checks:  # later entries take precedence
                c[hit] = reason_code[name]
            for j in np.flatnonzero(c):
                i = active[j]
                code[i] = c[j]
                if c[j] == reason_code["entered_obstacle"]:
                    entered[i] = int(np.argmax(inside[j]))
                elif c[j] == reason_code["goal"]:
                    paths[i].append(goal.copy())
            go = c == 0
            active, q, speed, d_vertex, d_goal = active[go], q[go], speed[go], d_vertex[go], d_goal[go]
            if not active.size:
                break
            k1 = u[go] / speed[:, None]
            # Arc-length step: ≤ step, ≤ VERTEX_STEP_FRACTION × distance to the nearest
            # panel vertex (where the field bends), ≤ ½ distance to the goal (no overshoot),
            # ≤ the line's cap (halved after a rejected step), ≥ h_min.
            h_local = np.minimum(VERTEX_STEP_FRACTION * d_vertex, 0.5 * d_goal)
            h = np.clip(np.minimum(h_local, h_cap[active]), h_min, step)[:, None]
            k2 = direction(q + 0.5 * h * k1)
            k3 = direction(q + 0.5 * h * k2)
            k4 = direction(q + h * k3)
            dirn = (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0
            new = q + h * dirn
            # Reject a step over which the direction turns by more than 30° (a corner or a
            # stagnation point inside the step); retry with half the step.
            turn_ok = np.einsum("ij,ij->i", k1, k4) >= cos_max_turn
            # The direction reversing between steps: the path sits on a stagnation saddle.
            cusp = np.einsum("ij,ij->i", prev_dir[active], dirn) < -0.5
            bad = ~np.all(np.isfinite(new), axis=1)
            at_floor = h[:, 0] <= h_min * (1.0 + 1e-9)
            stalled = cusp | (~turn_ok & at_floor)
            code[active[stalled & ~bad]] = reason_code["stagnation"]
            code[active[bad]] = reason_code["nonfinite"]
            retry = ~turn_ok & ~at_floor & ~bad
            h_cap[active[retry]] = 0.5 * h[retry, 0]
            move = turn_ok & ~stalled & ~bad
            idx = active[move]
            p[idx] = new[move]
            prev_dir[idx] = dirn[move]
            travelled[idx] += h[move, 0]
            h_cap[idx] = np.minimum(2.0 * h_cap[idx], step)
            for i in idx:
                paths[i].append(p[i].copy())
            active = active[code[active] == 0]
    return paths, code, entered
