"""Path re-planning on a harmonic potential field built with source panels (thesis §4.1, App. A;
digest §4).

The field is written as a flow velocity **u** (world frame ENU, m/s-like units; only its
direction is used by the path) that the vessel follows along a streamline:

- uniform flow of speed U in direction α: ``u = U (cos α, sin α)``; α points from the start to
  the goal by default (digest §4; the thesis's eq. 4.23 prints the slope instead of the angle);
- goal sink of strength λ_g > 0 at g: ``u = −λ_g/(2π) · (p − g)/‖p − g‖²``;
- straight source panels j (length L_j, uniform density λ_j per unit length):
  ``u = λ_j/(2π) ∫_j (p − q)/‖p − q‖² dl_q``.

Closed form of one panel (thesis eqs. 4.3–4.4, derived again here because the printed forms are
mangled): with the panel from a to b, unit tangent t = (b − a)/L, outward unit normal n,
r_a = ‖p − a‖, r_b = ‖p − b‖ and β ∈ (−π, π) the signed angle the panel subtends at p (seen from
p, measured from a to b; positive on the normal's side),

    ∫_j (p − q)/‖p − q‖² dl_q = ln(r_a/r_b) · t + β · n.

β → +π just outside the panel and −π just inside, so the panel's own normal velocity is
±λ_j/2 (thesis eq. 4.3ff): the jump across a panel is λ_j. Summed over a polygon's panels,
Σβ/(2π) is the winding number (1 inside, 0 outside), which the streamline integrator uses to
notice a path entering an obstacle without extra work.

Boundary condition (digest §4, thesis eqs. 4.10–4.19): the outward normal velocity at each
control point c_i (panel centre) equals the chosen V_i ≥ 0:

    P λ = V + b,   P_ii = 1/2,   P_ij = I_ij/(2π) = n_i · ∫_j (c_i − q)/‖c_i − q‖² dl_q /(2π),
    b_i = −U n_i·(cos α, sin α) + λ_g/(2π) · n_i·(c_i − g)/‖c_i − g‖².

Robust field (digest §4, thesis §4.1.4, eqs. 4.26–4.33): V_j = a·L_j gives a net obstacle strength
λ_ob = Σ λ_i L_i = a·Lᵀ J L + Lᵀ J b (J = P⁻¹), which must stay below the sink λ_g, so
a < a_max = (λ_g − Lᵀ J b)/(Lᵀ J L); the safety ratio r = a/a_max ∈ [0, 1] trades path length
for clearance.

Polygons: obstacles are (k, 2) vertex arrays. They are cleaned (repeated vertices and zero-length
edges dropped, collinear vertices merged, clockwise input reversed to counter-clockwise — so
panels are numbered counter-clockwise, unlike the thesis's clockwise numbering), then inflated by
``inflation`` metres (half the beam plus the safety distance, digest §4 "structural local minima")
with a miter offset, bevelled tangentially to the clearance circle where a convex corner turns by
more than 90° (so every point of the original polygon is at least ``inflation`` inside the
inflated one). Each edge of the inflated polygon becomes ``panels_per_edge`` equal panels (more if
``max_panel_length`` asks for it).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
from scipy.linalg import lu_factor, lu_solve

TWO_PI = 2.0 * np.pi

#: Default goal-sink strength λ_g [m²/s], the thesis's robust-field runs (§6.2, Table 6.2).
DEFAULT_SINK_STRENGTH = 30.0

#: Streamline arc-length step as a fraction of the distance to the nearest panel vertex (where the
#: field bends sharply); steps turning by more than 30° are rejected and halved as well.
VERTEX_STEP_FRACTION = 0.5

#: Streamline termination reasons (``Streamline.reason``).
REASONS = ("goal", "stagnation", "runaway", "max_length", "entered_obstacle", "nonfinite")


# --------------------------------------------------------------------------------------------
# Polygons: cleaning, orientation, inflation, containment, distance
# --------------------------------------------------------------------------------------------


def polygon_signed_area(vertices: np.ndarray) -> float:
    """Signed area [m²] of a closed polygon (k, 2); positive when counter-clockwise."""
    v = np.asarray(vertices, dtype=float)
    x, y = v[:, 0], v[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def _segments_intersect(p1, p2, q1, q2, tol):
    """Vectorized closed-segment intersection test (touching counts) for broadcastable arrays
    of segment endpoints (..., 2)."""

    def orient(a, b, c):
        return (b[..., 0] - a[..., 0]) * (c[..., 1] - a[..., 1]) - (b[..., 1] - a[..., 1]) * (
            c[..., 0] - a[..., 0]
        )

    def on_segment(a, b, c):  # c collinear with a-b: inside the bounding box?
        return (
            (np.minimum(a[..., 0], b[..., 0]) - tol <= c[..., 0])
            & (c[..., 0] <= np.maximum(a[..., 0], b[..., 0]) + tol)
            & (np.minimum(a[..., 1], b[..., 1]) - tol <= c[..., 1])
            & (c[..., 1] <= np.maximum(a[..., 1], b[..., 1]) + tol)
        )

    d1, d2 = orient(q1, q2, p1), orient(q1, q2, p2)
    d3, d4 = orient(p1, p2, q1), orient(p1, p2, q2)
    tol2 = tol * tol
    proper = (((d1 > tol2) & (d2 < -tol2)) | ((d1 < -tol2) & (d2 > tol2))) & (
        ((d3 > tol2) & (d4 < -tol2)) | ((d3 < -tol2) & (d4 > tol2))
    )
    touch = (
        ((np.abs(d1) <= tol2) & on_segment(q1, q2, p1))
        | ((np.abs(d2) <= tol2) & on_segment(q1, q2, p2))
        | ((np.abs(d3) <= tol2) & on_segment(p1, p2, q1))
        | ((np.abs(d4) <= tol2) & on_segment(p1, p2, q2))
    )
    return proper | touch


def _self_intersections(v: np.ndarray, tol: float) -> list[tuple[int, int]]:
    """Pairs (i, j) of non-adjacent edges of closed polygon v that intersect or touch."""
    k = len(v)
    a, b = v, np.roll(v, -1, axis=0)
    hit = _segments_intersect(a[:, None], b[:, None], a[None, :], b[None, :], tol)
    i, j = np.triu_indices(k, 1)
    adjacent = (j == i + 1) | ((i == 0) & (j == k - 1))
    sel = hit[i, j] & ~adjacent
    return list(zip(i[sel].tolist(), j[sel].tolist()))


def clean_polygon(vertices, name: str = "obstacle") -> np.ndarray:
    """Validate one polygon and return it counter-clockwise, without degenerate vertices.

    - repeated vertices / zero-length edges (including a closing vertex equal to the first one)
      are dropped;
    - collinear vertices (edge continues straight on) are merged;
    - clockwise polygons are reversed (panels are numbered counter-clockwise);
    - fewer than 3 distinct vertices, zero area, an edge folding back on itself, or
      self-intersection raise ValueError naming ``name``.
    """
    v = np.asarray(vertices, dtype=float)
    if v.ndim != 2 or v.shape[1] != 2:
        raise ValueError(f"{name}: vertices must have shape (k, 2), got {v.shape}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{name}: vertices must be finite")
    scale = float(np.max(np.ptp(v, axis=0))) if len(v) else 0.0
    tol = 1e-9 * max(scale, 1.0)
    # Zero-length edges (cyclic), e.g. an explicitly closed ring [v0, ..., v0].
    keep = np.linalg.norm(v - np.roll(v, 1, axis=0), axis=1) > tol
    if not np.any(keep):
        raise ValueError(f"{name}: needs at least 3 distinct vertices, got 1")
    v = v[keep]
    if len(v) < 3:
        raise ValueError(f"{name}: needs at least 3 distinct vertices, got {len(v)}")
    # Collinear vertices: merge when straight on, refuse when the boundary folds back.
    changed = True
    while changed and len(v) >= 3:
        changed = False
        e_in = v - np.roll(v, 1, axis=0)
        e_out = np.roll(v, -1, axis=0) - v
        cross = e_in[:, 0] * e_out[:, 1] - e_in[:, 1] * e_out[:, 0]
        lens = np.linalg.norm(e_in, axis=1) * np.linalg.norm(e_out, axis=1)
        flat = np.abs(cross) <= 1e-9 * lens
        if np.any(flat):
            i = int(np.argmax(flat))
            if np.dot(e_in[i], e_out[i]) < 0:
                raise ValueError(
                    f"{name}: boundary folds back on itself at vertex {v[i].tolist()} "
                    "(degenerate, self-overlapping polygon)"
                )
            v = np.delete(v, i, axis=0)
            changed = True
    if len(v) < 3:
        raise ValueError(f"{name}: fewer than 3 non-collinear vertices (polygon has no area)")
    crossings = _self_intersections(v, tol)
    if crossings:
        i, j = crossings[0]
        raise ValueError(
            f"{name}: polygon is self-intersecting (edges {i} and {j} cross); "
            "give a simple polygon"
        )
    area = polygon_signed_area(v)
    if abs(area) <= 1e-12 * max(scale, 1.0) ** 2:
        raise ValueError(f"{name}: polygon has zero area")
    if area < 0:
        v = v[::-1].copy()
    return v


def inflate_polygon(vertices: np.ndarray, margin: float, name: str = "obstacle") -> np.ndarray:
    """Offset a clean counter-clockwise polygon outward by ``margin`` metres (≥ 0).

    Miter offset at every vertex; at convex corners turning by more than 90° the miter is
    replaced by a bevel tangent to the circle of radius ``margin`` around the vertex (two
    vertices), so the result contains the Minkowski sum of the polygon and that disc.
    Concave corners use the miter (the offset edges' intersection); a margin so large that it
    swallows an edge next to a concave corner raises ValueError.
    """
    v = np.asarray(vertices, dtype=float)
    if margin < 0 or not np.isfinite(margin):
        raise ValueError(f"inflation must be a finite margin ≥ 0 m, got {margin}")
    if margin == 0:
        return v.copy()
    edges = np.roll(v, -1, axis=0) - v  # edge i: v_i -> v_{i+1}
    t = edges / np.linalg.norm(edges, axis=1, keepdims=True)
    n = np.stack([t[:, 1], -t[:, 0]], axis=1)  # outward (right-hand) normal of a CCW polygon
    out = []
    for i in range(len(v)):
        t1, n1 = t[i - 1], n[i - 1]  # incoming edge
        t2, n2 = t[i], n[i]  # outgoing edge
        turn = t1[0] * t2[1] - t1[1] * t2[0]
        cos_phi = float(np.clip(n1 @ n2, -1.0, 1.0))
        if turn > 0 and cos_phi < 0.0:  # convex, sharper than 90°: tangent bevel
            s = margin * np.tan(np.arccos(cos_phi) / 4.0)
            out.append(v[i] + margin * n1 + s * t1)
            out.append(v[i] + margin * n2 - s * t2)
        else:
            out.append(v[i] + margin * (n1 + n2) / (1.0 + cos_phi))
    w = np.array(out)
    try:
        cleaned = clean_polygon(w, name=f"{name} inflated by {margin} m")
    except ValueError as err:
        raise ValueError(
            f"{name}: inflation {margin} m is too large for its concave parts ({err})"
        ) from None
    # Every original vertex and edge midpoint must end up ≥ margin inside the offset boundary
    # (fails when the margin swallows an edge next to a concave corner).
    probe = np.concatenate([v, 0.5 * (v + np.roll(v, -1, axis=0))])
    if np.any(distance_to_polygon(cleaned, probe) > -margin * (1.0 - 1e-6)):
        raise ValueError(f"{name}: inflation {margin} m is too large for its concave parts")
    return cleaned


def points_in_polygon(polygon: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Boolean (n,) — strictly inside the closed polygon (k, 2) (crossing-number test)."""
    p = np.atleast_2d(np.asarray(points, dtype=float))
    a = np.asarray(polygon, dtype=float)
    b = np.roll(a, -1, axis=0)
    px, py = p[:, 0:1], p[:, 1:2]
    straddle = (a[:, 1] > py) != (b[:, 1] > py)
    with np.errstate(divide="ignore", invalid="ignore"):
        x_cross = a[:, 0] + (py - a[:, 1]) * (b[:, 0] - a[:, 0]) / (b[:, 1] - a[:, 1])
    return np.count_nonzero(straddle & (px < x_cross), axis=1) % 2 == 1


def distance_to_polygon(polygon: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Signed distance (n,) [m] from points to the polygon boundary; negative inside."""
    p = np.atleast_2d(np.asarray(points, dtype=float))
    a = np.asarray(polygon, dtype=float)
    e = np.roll(a, -1, axis=0) - a
    d = p[:, None, :] - a[None, :, :]
    s = np.clip(np.einsum("nkj,kj->nk", d, e) / np.einsum("kj,kj->k", e, e), 0.0, 1.0)
    dist = np.linalg.norm(d - s[..., None] * e[None], axis=2).min(axis=1)
    return np.where(points_in_polygon(a, p), -dist, dist)


# --------------------------------------------------------------------------------------------
# Source panels
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Panels:
    """The m straight source panels of all obstacles, numbered counter-clockwise per obstacle.

    start, end: (m, 2) endpoints [m]; centre: (m, 2) control points [m]; tangent, normal: (m, 2)
    unit tangent (start→end) and outward unit normal; length: (m,) [m]; obstacle: (m,) index of
    the obstacle each panel belongs to; next_index: (m,) index of the panel that starts where
    panel i ends (same obstacle).
    """

    start: np.ndarray
    end: np.ndarray
    centre: np.ndarray
    tangent: np.ndarray
    normal: np.ndarray
    length: np.ndarray
    obstacle: np.ndarray
    next_index: np.ndarray

    def __len__(self) -> int:
        return len(self.length)


def make_panels(
    polygons: Sequence[np.ndarray],
    panels_per_edge: Sequence[int],
    max_panel_length: float | None = None,
) -> Panels:
    """Panels for clean counter-clockwise polygons: each edge split into
    max(panels_per_edge[k], ceil(edge length / max_panel_length)) equal panels."""
    starts, obstacle, nxt = [], [], []
    offset = 0
    for k, (poly, n_sub) in enumerate(zip(polygons, panels_per_edge)):
        a = poly
        e = np.roll(poly, -1, axis=0) - a
        counts = np.full(len(a), int(n_sub))
        if max_panel_length is not None:
            need = np.ceil(np.linalg.norm(e, axis=1) / max_panel_length - 1e-9).astype(int)
            counts = np.maximum(counts, need)
        pts = np.concatenate(
            [a[i] + (np.arange(c) / c)[:, None] * e[i] for i, c in enumerate(counts)]
        )
        m_k = len(pts)
        starts.append(pts)
        obstacle.append(np.full(m_k, k))
        nxt.append(offset + (np.arange(m_k) + 1) % m_k)
        offset += m_k
    start = np.concatenate(starts)
    next_index = np.concatenate(nxt)
    end = start[next_index]
    edge = end - start
    length = np.linalg.norm(edge, axis=1)
    tangent = edge / length[:, None]
    normal = np.stack([tangent[:, 1], -tangent[:, 0]], axis=1)
    return Panels(
        start=start,
        end=end,
        centre=0.5 * (start + end),
        tangent=tangent,
        normal=normal,
        length=length,
        obstacle=np.concatenate(obstacle),
        next_index=next_index,
    )


def panel_influence(points: np.ndarray, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """Velocity (n, m, 2) induced at points (n, 2) by unit-density source panels (m endpoints):

        w_j(p) = 1/(2π) ∫_j (p − q)/‖p − q‖² dl_q = [ln(r_a/r_b) t_j + β_j n_j]/(2π)

    (closed form of thesis eqs. 4.3–4.4; see the module docstring). On a panel itself β is
    taken from the side the float sign of the zero cross product gives; use the explicit ±1/2
    limit there. The reference (unfused) form; ``PotentialField.velocity`` uses a fused one.
    """
    p = np.atleast_2d(np.asarray(points, dtype=float))
    a, b = np.asarray(start, float), np.asarray(end, float)
    e = b - a
    L = np.linalg.norm(e, axis=1)
    t = e / L[:, None]
    n = np.stack([t[:, 1], -t[:, 0]], axis=1)
    da = p[:, None, :] - a[None]
    db = p[:, None, :] - b[None]
    ra2 = np.einsum("nmj,nmj->nm", da, da)
    rb2 = np.einsum("nmj,nmj->nm", db, db)
    cross = da[..., 1] * db[..., 0] - da[..., 0] * db[..., 1]  # = η L, η = (p − a)·n (outward)
    dot = np.einsum("nmj,nmj->nm", da, db)
    beta = np.arctan2(cross, dot)
    tang = 0.5 * np.log(ra2 / rb2)
    return (tang[..., None] * t[None] + beta[..., None] * n[None]) / TWO_PI


# --------------------------------------------------------------------------------------------
# Streamlines
# --------------------------------------------------------------------------------------------


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


# --------------------------------------------------------------------------------------------
# The field
# --------------------------------------------------------------------------------------------


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

        # Uniform-flow direction α (digest §4: an angle, not the thesis's slope).
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
                a, b = polys[i], polys[j]
                cross = _segments_intersect(
                    a[:, None], np.roll(a, -1, axis=0)[:, None], b[None], np.roll(b, -1, axis=0)[None], 1e-9
                )
                if (
                    np.any(cross)
                    or np.any(points_in_polygon(a, b[:1]))
                    or np.any(points_in_polygon(b, a[:1]))
                ):
                    raise ValueError(
                        f"obstacles {i} and {j} overlap after inflation by {self.inflation} m; "
                        "merge them into one polygon"
                    )

    def obstacle_containing(self, point) -> int | None:
        """Index of the inflated obstacle strictly containing ``point`` (2,), or None."""
        p = np.asarray(point, dtype=float)[None]
        for k, poly in enumerate(self.polygons):
            if points_in_polygon(poly, p)[0]:
                return k
        return None

    def distance_to_obstacles(self, points, inflated: bool = True) -> np.ndarray:
        """Signed distance (n,) [m] from points to the nearest obstacle (negative inside);
        ``inflated=False`` measures to the original polygons. +inf without obstacles."""
        p = np.atleast_2d(np.asarray(points, dtype=float))
        polys = self.polygons if inflated else self.obstacles
        if not polys:
            return np.full(len(p), np.inf)
        return np.min([distance_to_polygon(poly, p) for poly in polys], axis=0)

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

    # ---------------------------------------------------------------- evaluation
    def _evaluate(self, points: np.ndarray, want_geometry: bool = False):
        """Velocity (n, 2); with ``want_geometry`` also the winding number per obstacle (n, K)
        and the distance to the nearest panel vertex (n,). Callers silence numpy's divide/invalid
        warnings (points on a vertex or at the goal give inf/nan)."""
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
                out[s : s + chunk] = self._evaluate(p[s : s + chunk])
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
    def streamlines(
        self,
        starts,
        step: float = 1.0,
        max_length: float | None = None,
        goal_tolerance: float | None = None,
        min_step: float | None = None,
    ) -> list[Streamline]:
        """Trace streamlines from many starts (n, 2) at once (vectorized RK4, see
        ``streamline``)."""
        p0 = np.atleast_2d(np.asarray(starts, dtype=float))
        if p0.shape[-1] != 2 or not np.all(np.isfinite(p0)):
            raise ValueError(f"starts must be finite points of shape (n, 2), got {np.shape(starts)}")
        if not (np.isfinite(step) and step > 0):
            raise ValueError(f"step must be > 0 m, got {step}")
        for i, s in enumerate(p0):
            k = self.obstacle_containing(s)
            if k is not None:
                which = "start" if len(p0) == 1 else f"start {i}"
                raise ValueError(
                    f"{which} {s.tolist()} lies inside obstacle {k} (inflated by {self.inflation} m)"
                )
        goal = self.goal
        tol = step if goal_tolerance is None else float(goal_tolerance)
        if tol <= 0:
            raise ValueError(f"goal_tolerance must be > 0 m, got {goal_tolerance}")
        h_min = step * 1e-3 if min_step is None else float(min_step)
        # Scene scale: how far from the goal (or the starts) counts as running away.
        ref = goal if goal is not None else p0.mean(axis=0)
        extent = np.linalg.norm(p0 - ref, axis=1)
        if self.panels is not None and len(self.panels):
            scene = float(np.max(np.linalg.norm(self.panels.start - ref, axis=1)))
        else:
            scene = 0.0
        runaway = 3.0 * (np.maximum(extent, scene) + step)
        max_len = (
            np.full(len(p0), float(max_length))
            if max_length is not None
            else 4.0 * (extent + scene) + 10.0 * step
        )
        n = len(p0)
        paths = [[s.copy()] for s in p0]
        code = np.zeros(n, dtype=int)  # 0 running, else 1 + index into REASONS
        entered: list[int | None] = [None] * n
        p = p0.copy()
        travelled = np.zeros(n)
        prev_dir = np.full((n, 2), np.nan)
        h_cap = np.full(n, float(step))
        cos_max_turn = np.cos(np.radians(30.0))
        speed_floor = 1e-9 * max(self.uniform_speed, self.sink_strength / max(scene, 1.0), 1e-12)
        reason_code = {r: i + 1 for i, r in enumerate(REASONS)}

        def direction(q):
            u = self._evaluate(q)
            return u / np.hypot(u[:, 0], u[:, 1])[:, None]

        def dist(q, point):
            return np.hypot(q[:, 0] - point[0], q[:, 1] - point[1])

        errors = np.errstate(divide="ignore", invalid="ignore")  # vertices, goal: inf/nan
        with errors:
            active = np.arange(n)
            while active.size:
                q = p[active]
                # Checks at the current points (each already on its path), in order of precedence.
                u, winding, d_vertex = self._evaluate(q, want_geometry=True)
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
        reasons = [REASONS[k - 1] for k in code]
        return [
            Streamline(np.array(paths[i]), reasons[i] == "goal", reasons[i], entered[i])
            for i in range(n)
        ]

    def streamline(
        self,
        start=None,
        step: float = 1.0,
        max_length: float | None = None,
        goal_tolerance: float | None = None,
    ) -> Streamline:
        """Trace the path ṗ = u(p)/‖u(p)‖ (arc-length parametrization, digest §4) from
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
