"""The harmonic potential field of one vessel: uniform flow + goal sink + obstacle source panels
(thesis §4.1, App. A; docs/thesis.md §4).

The field is written as a flow velocity **u** (world frame ENU, m/s-like units; only its
direction is used by the path) that the vessel follows along a streamline
(:mod:`mjasc.avoidance.potential_field.streamlines`):

- uniform flow of speed U in direction α: ``u = U (cos α, sin α)``; α points from the start to
  the goal by default (docs/thesis.md §4; the thesis's eq. 4.23 prints the slope instead of the angle);
- goal sink of strength λ_g > 0 at g: ``u = −λ_g/(2π) · (p − g)/‖p − g‖²``;
- straight source panels j (length L_j, uniform density λ_j per unit length):
  ``u = λ_j/(2π) ∫_j (p − q)/‖p − q‖² dl_q`` (closed form: :mod:`mjasc.avoidance.potential_field.panels`).

Boundary condition (docs/thesis.md §4, thesis eqs. 4.10–4.19): the outward normal velocity at each
control point c_i (panel centre) equals the chosen V_i ≥ 0:

    P λ = V + b,   P_ii = 1/2,   P_ij = I_ij/(2π) = n_i · ∫_j (c_i − q)/‖c_i − q‖² dl_q /(2π),
    b_i = −U n_i·(cos α, sin α) + λ_g/(2π) · n_i·(c_i − g)/‖c_i − g‖².

Robust field (docs/thesis.md §4, thesis §4.1.4, eqs. 4.26–4.33): V_j = a·L_j gives a net obstacle strength
λ_ob = Σ λ_i L_i = a·Lᵀ J L + Lᵀ J b (J = P⁻¹), which must stay below the sink λ_g, so
a < a_max = (λ_g − Lᵀ J b)/(Lᵀ J L); the safety ratio r = a/a_max ∈ [0, 1] trades path length
for clearance.

Polygons: obstacles are (k, 2) vertex arrays. They are cleaned (repeated vertices and zero-length
edges dropped, collinear vertices merged, clockwise input reversed to counter-clockwise — so
panels are numbered counter-clockwise, unlike the thesis's clockwise numbering;
:func:`mjasc.core.geometry.clean_polygon`), then inflated by ``inflation`` metres (half the beam
plus the safety distance, docs/thesis.md §4 "structural local minima") with a miter offset, bevelled
tangentially to the clearance circle where a convex corner turns by more than 90° (so every point
of the original polygon is at least ``inflation`` inside the inflated one;
:func:`mjasc.core.geometry.inflate_polygon`). Each edge of the inflated polygon becomes
``panels_per_edge`` equal panels (more if ``max_panel_length`` asks for it).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
from scipy.linalg import lu_factor, lu_solve

from mjasc.avoidance.potential_field.panels import TWO_PI, make_panels, panel_influence
from mjasc.avoidance.potential_field.streamlines import Streamline, trace_streamlines
from mjasc.core.geometry import (
    clean_polygon,
    inflate_polygon,
    point_in_polygon,
    polygons_overlap,
    signed_distance_to_polygon,
)

__all__ = ["DEFAULT_SINK_STRENGTH", "PotentialField"]

#: Default goal-sink strength λ_g [m²/s], the thesis's robust-field runs (§6.2, Table 6.2).
DEFAULT_SINK_STRENGTH = 30.0


def _as_point(value, field: str) -> np.ndarray:
    p = np.asarray(value, dtype=float)
    if p.shape != (2,) or not np.all(np.isfinite(p)):
        raise ValueError(f"{field} must be a finite (x, y) point in metres, got {value!r}")
    return p


class PotentialField:
    """Harmonic potential field of one vessel: uniform flow + goal sink + obstacle source panels.

    Parameters
    ----------
    obstacles: list of (k, 2) polygons [m], world frame; counter-clockwise preferred (clockwise
        ones are reversed); degenerate vertices are cleaned (see ``clean_polygon``).
    goal: (2,) goal point [m] holding the sink, or None (uniform flow + panels only).
    uniform_speed: U ≥ 0 [m/s].
    uniform_direction: α [rad, CCW from east]. Default: from ``start`` toward ``goal``
        (thesis eq. 4.23, corrected to an angle); required when there is no goal or no start.
    sink_strength: λ_g > 0 [m²/s] of the goal sink (default 30, thesis Table 6.2).
    normal_velocity: V_i ≥ 0 outward normal velocity at the control points: a scalar for all
        panels or an array (m,) per panel (m = ``len(field.panels)``). Must stay 0 when
        ``safety_ratio`` is given.
    safety_ratio: r switching on the robust rule V_j = r·a_max·L_j (thesis §4.1.4). Needs a
        goal. r ∈ [0, 1] guarantees λ_ob < λ_g; larger values are accepted (to show the goal
        being missed) but must be ≥ 0.
    inflation: margin [m] added around every obstacle before paneling (half beam + safety
        distance).
    panels_per_edge: int ≥ 1, or one int per obstacle: equal panels each edge is split into.
    max_panel_length: optional [m]: edges longer than this are split further, into equal
        panels no longer than it (keeps panel lengths similar, which the robust rule
        V_j = a·L_j assumes).
    start: (2,) start point [m], optional: sets the default α and the default streamline start;
        it must lie outside every inflated obstacle.

    Attributes
    ----------
    polygons: inflated, cleaned CCW polygons that carry the panels.
    panels: ``Panels``. strengths: λ (m,) [m/s]. normal_velocities: V (m,) [m/s].
    alpha_max: a_max of thesis eq. 4.32 [1/s] (None without a goal).
    net_obstacle_strength: λ_ob = Σ λ_i L_i [m²/s] (thesis eq. 4.25).
    """

    def __init__(
        self,
        obstacles: Sequence[np.ndarray],
        goal=None,
        uniform_speed: float = 1.0,
        uniform_direction: float | None = None,
        sink_strength: float = DEFAULT_SINK_STRENGTH,
        normal_velocity=0.0,
        safety_ratio: float | None = None,
        inflation: float = 0.0,
        panels_per_edge: int | Sequence[int] = 1,
        start=None,
        max_panel_length: float | None = None,
    ):
        obstacles = list(obstacles)
        if not np.isfinite(uniform_speed) or uniform_speed < 0:
            raise ValueError(f"uniform_speed must be finite and ≥ 0 m/s, got {uniform_speed}")
        if not np.isfinite(inflation) or inflation < 0:
            raise ValueError(f"inflation must be finite and ≥ 0 m, got {inflation}")
        self.goal = None if goal is None else _as_point(goal, "goal")
        self.start = None if start is None else _as_point(start, "start")
        self.uniform_speed = float(uniform_speed)
        self.sink_strength = float(sink_strength) if self.goal is not None else 0.0
        if self.goal is not None and not (np.isfinite(sink_strength) and sink_strength > 0):
            raise ValueError(f"sink_strength must be finite and > 0, got {sink_strength}")
        self.inflation = float(inflation)

        # Uniform-flow direction α (docs/thesis.md §4: an angle, not the thesis's slope).
        if uniform_direction is None:
            if self.goal is None or self.start is None:
                raise ValueError(
                    "uniform_direction is required unless both goal and start are given "
                    "(the default α points from the start to the goal)"
                )
            d = self.goal - self.start
            if np.hypot(*d) == 0:
                raise ValueError("start and goal coincide: give uniform_direction")
            uniform_direction = float(np.arctan2(d[1], d[0]))
        if not np.isfinite(uniform_direction):
            raise ValueError(f"uniform_direction must be a finite angle [rad], got {uniform_direction}")
        self.uniform_direction = float(uniform_direction)
        self._u_inf = self.uniform_speed * np.array(
            [np.cos(self.uniform_direction), np.sin(self.uniform_direction)]
        )

        # Geometry: clean, inflate, check overlaps, panel.
        if isinstance(panels_per_edge, (int, np.integer)):
            per_edge = [int(panels_per_edge)] * len(obstacles)
        else:
            per_edge = [int(x) for x in panels_per_edge]
            if len(per_edge) != len(obstacles):
                raise ValueError(
                    f"panels_per_edge: one count per obstacle expected ({len(obstacles)}), "
                    f"got {len(per_edge)}"
                )
        if any(x < 1 for x in per_edge):
            raise ValueError(f"panels_per_edge must be ≥ 1, got {panels_per_edge}")
        self.obstacles = [clean_polygon(o, name=f"obstacle {k}") for k, o in enumerate(obstacles)]
        self.polygons = [
            inflate_polygon(o, self.inflation, name=f"obstacle {k}")
            for k, o in enumerate(self.obstacles)
        ]
        self._check_overlaps()
        for label, point in (("goal", self.goal), ("start", self.start)):
            if point is not None:
                k = self.obstacle_containing(point)
                if k is not None:
                    raise ValueError(
                        f"{label} {point.tolist()} lies inside obstacle {k} "
                        f"(inflated by {self.inflation} m)"
                    )
        if max_panel_length is not None and not (
            np.isfinite(max_panel_length) and max_panel_length > 0
        ):
            raise ValueError(f"max_panel_length must be > 0 m, got {max_panel_length}")
        self.panels = (
            make_panels(self.polygons, per_edge, max_panel_length) if self.polygons else None
        )
        self._solve(normal_velocity, safety_ratio)

    # ---------------------------------------------------------------- geometry checks
    def _check_overlaps(self) -> None:
        polys = self.polygons
        for i in range(len(polys)):
            for j in range(i + 1, len(polys)):
                if polygons_overlap(polys[i], polys[j], 1e-9):
                    raise ValueError(
                        f"obstacles {i} and {j} overlap after inflation by {self.inflation} m; "
                        "merge them into one polygon"
                    )

    def obstacle_containing(self, point) -> int | None:
        """Index of the inflated obstacle strictly containing ``point`` (2,), or None."""
        p = np.asarray(point, dtype=float)[None]
        for k, poly in enumerate(self.polygons):
            if point_in_polygon(p, poly)[0]:
                return k
        return None

    def distance_to_obstacles(self, points, inflated: bool = True) -> np.ndarray:
        """Signed distance (n,) [m] from points to the nearest obstacle (negative inside);
        ``inflated=False`` measures to the original polygons. +inf without obstacles."""
        p = np.atleast_2d(np.asarray(points, dtype=float))
        polys = self.polygons if inflated else self.obstacles
        if not polys:
            return np.full(len(p), np.inf)
        return np.min([signed_distance_to_polygon(p, poly) for poly in polys], axis=0)

    # ---------------------------------------------------------------- linear system
    def _free_stream(self, points: np.ndarray) -> np.ndarray:
        """Uniform flow + goal sink (n, 2) at points (n, 2)."""
        if self.goal is None:
            return np.tile(self._u_inf, (len(points), 1))
        d = points - self.goal
        r2 = d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1]
        return self._u_inf - (self.sink_strength / TWO_PI) * d / r2[:, None]

    def _solve(self, normal_velocity, safety_ratio) -> None:
        pan = self.panels
        m = 0 if pan is None else len(pan)
        self.alpha_max: float | None = None
        self.safety_ratio = None if safety_ratio is None else float(safety_ratio)
        if m == 0:
            self.strengths = np.zeros(0)
            self.normal_velocities = np.zeros(0)
            self.influence_matrix = np.zeros((0, 0))
            self.net_obstacle_strength = 0.0
            self._prepare_fast_path()
            return
        # P_ij = n_i · w_j(c_i) (= I_ij/2π), P_ii = 1/2 (exterior limit of the panel's own field).
        w = panel_influence(pan.centre, pan.start, pan.end)  # (m, m, 2)
        P = np.einsum("ijk,ik->ij", w, pan.normal)
        np.fill_diagonal(P, 0.5)
        self.influence_matrix = P
        b = -np.einsum("ij,ij->i", self._free_stream(pan.centre), pan.normal)
        self.rhs_free_stream = b
        lu = lu_factor(P)
        L = pan.length
        if self.goal is not None:
            JL = lu_solve(lu, L)
            Jb = lu_solve(lu, b)
            LJL = float(L @ JL)
            if LJL <= 0:
                raise ValueError("degenerate panel geometry: Lᵀ P⁻¹ L ≤ 0")
            self.alpha_max = (self.sink_strength - float(L @ Jb)) / LJL
        if safety_ratio is not None:
            if self.goal is None:
                raise ValueError("safety_ratio (robust field) needs a goal sink")
            if not np.isfinite(safety_ratio) or safety_ratio < 0:
                raise ValueError(f"safety_ratio must be finite and ≥ 0, got {safety_ratio}")
            if np.any(np.asarray(normal_velocity, dtype=float) != 0):
                raise ValueError("give either normal_velocity or safety_ratio, not both")
            if self.alpha_max <= 0:
                raise ValueError(
                    f"sink_strength {self.sink_strength} is too weak for these obstacles even "
                    f"with zero normal velocity (a_max = {self.alpha_max:.4g} ≤ 0)"
                )
            V = safety_ratio * self.alpha_max * L
        else:
            V = np.asarray(normal_velocity, dtype=float)
            if V.ndim == 0:
                V = np.full(m, float(V))
            if V.shape != (m,):
                raise ValueError(
                    f"normal_velocity must be a scalar or an array of one value per panel "
                    f"({m} panels), got shape {V.shape}"
                )
            if not np.all(np.isfinite(V)):
                raise ValueError("normal_velocity must be finite")
        self.normal_velocities = V
        self.strengths = lu_solve(lu, V + b)
        self.net_obstacle_strength = float(L @ self.strengths)
        self._prepare_fast_path()

    def _prepare_fast_path(self) -> None:
        """Fold λ_j, t_j, n_j into two small matrices so that, with ρ_v = ln r_v² per vertex
        (= panel start) and β_j per panel, u_panels = ρ @ A + β @ B (n, 2)."""
        if self.panels is None or len(self.panels) == 0:
            self._A = self._B = None
            return
        pan, lam = self.panels, self.strengths
        c_t = lam[:, None] * pan.tangent / (2.0 * TWO_PI)  # ½ ln r² → ln r, then /2π
        A = c_t.copy()  # vertex v is the start of panel v ...
        np.subtract.at(A, pan.next_index, c_t)  # ... and the end of the panel before it
        self._A = A
        self._B = lam[:, None] * pan.normal / TWO_PI
        counts = np.bincount(pan.obstacle)
        self._obstacle_offsets = np.concatenate([[0], np.cumsum(counts)[:-1]])

    def kernel_arrays(self) -> tuple:
        """The field as the compiled tracer reads it (:mod:`~mjasc.avoidance.potential_field.streamline_kernels`):
        (u∞ (2,), λ_g / 2π, the panels' start vertices (m, 2) [m], the index of each panel's end
        vertex (m,), :meth:`_prepare_fast_path`'s A and B (m, 2), each obstacle's first panel (K,)).
        Not to be written."""
        sink_c = self.sink_strength / TWO_PI
        if self._A is None:
            none = np.zeros((0, 2))
            return self._u_inf, sink_c, none, np.zeros(0, dtype=np.int64), none, none, np.zeros(0, dtype=np.int64)
        return (self._u_inf, sink_c, self.panels.start, self.panels.next_index, self._A, self._B,
                self._obstacle_offsets)

    # ---------------------------------------------------------------- evaluation
    def evaluate(self, points: np.ndarray, want_geometry: bool = False):
        """Velocity (n, 2) at points (n, 2), one block (the fused form of ``velocity``); with
        ``want_geometry`` also the winding number per obstacle (n, K) and the distance to the
        nearest panel vertex (n,) (the streamline integrator's checks). Callers silence numpy's
        divide/invalid warnings (points on a vertex or at the goal give inf/nan)."""
        u = self._free_stream(points)
        if self._A is None:
            if want_geometry:
                return u, np.zeros((len(points), 0)), np.full(len(points), np.inf)
            return u
        v = self.panels.start
        nxt = self.panels.next_index
        dx = points[:, 0:1] - v[:, 0]
        dy = points[:, 1:2] - v[:, 1]
        r2 = dx * dx + dy * dy
        dxb, dyb = dx[:, nxt], dy[:, nxt]
        beta = np.arctan2(dy * dxb - dx * dyb, dx * dxb + dy * dyb)  # = atan2(η L, ·)
        u += np.log(r2) @ self._A + beta @ self._B
        if not want_geometry:
            return u
        winding = np.add.reduceat(beta, self._obstacle_offsets, axis=1) / TWO_PI
        return u, winding, np.sqrt(r2.min(axis=1))

    def velocity(self, points, chunk: int = 1024) -> np.ndarray:
        """Flow velocity u (n, 2) at points (n, 2) (or (2,) → (2,)): uniform flow + goal sink +
        panels, fully vectorized over points × panels (points processed in chunks of ``chunk``
        rows to stay in cache). Undefined on the panels and at the goal."""
        p = np.asarray(points, dtype=float)
        single = p.ndim == 1
        p = np.atleast_2d(p)
        if p.shape[-1] != 2:
            raise ValueError(f"points must have shape (n, 2), got {np.shape(points)}")
        out = np.empty_like(p)
        with np.errstate(divide="ignore", invalid="ignore"):
            for s in range(0, len(p), chunk):
                out[s : s + chunk] = self.evaluate(p[s : s + chunk])
        return out[0] if single else out

    def control_point_velocity(self) -> np.ndarray:
        """Velocity (m, 2) at the control points, exterior limit (each panel's own normal
        contribution +λ_i/2, own tangential contribution 0 at its centre)."""
        pan = self.panels
        w = panel_influence(pan.centre, pan.start, pan.end)
        idx = np.arange(len(pan))
        w[idx, idx] = 0.5 * pan.normal
        return self._free_stream(pan.centre) + np.einsum("ijk,j->ik", w, self.strengths)

    # ---------------------------------------------------------------- streamlines

    # ---------------------------------------------------------------- streamlines
    def streamlines(
        self,
        starts,
        step: float = 1.0,
        max_length: float | None = None,
        goal_tolerance: float | None = None,
        min_step: float | None = None,
    ) -> list[Streamline]:
        """Trace streamlines from many starts (n, 2) at once (vectorized RK4, see
        ``streamline`` and :func:`mjasc.avoidance.potential_field.streamlines.trace_streamlines`)."""
        return trace_streamlines(self, starts, step, max_length, goal_tolerance, min_step)

    def streamline(
        self,
        start=None,
        step: float = 1.0,
        max_length: float | None = None,
        goal_tolerance: float | None = None,
    ) -> Streamline:
        """Trace the path ṗ = u(p)/‖u(p)‖ (arc-length parametrization, docs/thesis.md §4) from
        ``start`` (default: the field's start) with RK4.

        The arc-length step is at most ``step`` [m] and shrinks to half the distance to the
        nearest panel vertex and to half the distance to the goal (and is halved when it would
        turn by more than 30°), so corners are resolved and the goal is approached without
        overshoot. Stops with ``reason``:
        "goal" (within ``goal_tolerance``, default ``step``; the goal is appended as the last
        point), "stagnation" (speed ~ 0 or the direction reverses: a stagnation saddle),
        "runaway" (farther than 3× the scene size from the goal: the sink missed, e.g.
        λ_ob > λ_g), "max_length" (default 4× scene size), "entered_obstacle" (winding number
        of an inflated obstacle became 1), "nonfinite". Raises ValueError if ``start`` lies
        inside an inflated obstacle (naming its index).
        """
        if start is None:
            if self.start is None:
                raise ValueError("streamline needs a start (none given here or to the field)")
            start = self.start
        s = _as_point(start, "start")
        return self.streamlines(s[None], step, max_length, goal_tolerance)[0]
