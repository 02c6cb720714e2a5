"""Velocity obstacles over arrays: which candidate velocities lead to a collision with which obstacle,
and when (Fiorini & Shiller 1998).

World frame ENU, SI. The own vessel A sits at p_A; an obstacle B at p_B moves with the constant
velocity v_B. Both are discs; a collision is their discs touching, i.e. the distance of the centres
below the **combined radius** R = r_A + r_B + d_safety (the safety distance added, as in the thesis's
collision prediction). With the relative position r = p_B − p_A and the relative velocity
w = v_A − v_B, A's motion relative to B is the ray r_A(τ) = w τ, τ ≥ 0, and:

* the **collision cone** (Fiorini & Shiller eq. 3) is the set of relative velocities whose ray
  meets the disc of radius R about r::

      CC_AB = { w : ∃ τ ≥ 0, ‖w τ − r‖ < R }

  For ‖r‖ = d > R it is the cone with apex at the origin, axis r and half-angle

      α = asin(R / d)             (a velocity on the edge is tangent to the disc: no collision)

  i.e. w ∈ CC_AB ⇔ r·w > 0 and (r·w)² − ‖w‖² (d² − R²) > 0;

* the **velocity obstacle** (eq. 4) is the collision cone translated by v_B, in A's absolute
  velocities: ``VO_AB = CC_AB ⊕ v_B = { v_A : v_A − v_B ∈ CC_AB }``;

* the **time to collision** of w is the first root of ‖r − w τ‖ = R::

      τ_c(w) = (r·w − √((r·w)² − ‖w‖² (d² − R²))) / ‖w‖²  =  (d² − R²) / (r·w + √(…))

  (the second form is the one computed: no cancellation for small ‖w‖); τ_c = ∞ outside the cone;

* a **time horizon** T truncates the cone to the collisions within T (Fiorini & Shiller §4.2:
  collisions beyond T are left to later decisions): ``VO_AB^T = { v_A : τ_c(v_A − v_B) ≤ T }``.
  Along the axis (w parallel to r) τ_c = (d − R)/‖w‖, so the truncated cone excludes the slow
  velocities ‖w‖ < (d − R)/T: its apex is cut by the arc of radius (d − R)/T.

Already inside (d ≤ R, e.g. a safety distance violated), every closing velocity (r·w > 0) collides
at once (τ_c = 0) and every opening one does not (τ_c = ∞): the method then prefers leaving.

**Reciprocal velocity obstacles** (van den Berg, Lin & Manocha 2008) for a team mate that avoids
too: each takes half the effort, ``RVO_AB = { v_A : 2 v_A − v_A,now − v_B ∈ CC_AB }``. Both forms are
the relative velocity ``w = a v_A − b`` with (a, b) = (1, v_B) for a plain obstacle and
(2, v_A,now + v_B) for a reciprocal one (:func:`relative_velocities`).

Everything is computed for many candidates × many obstacles at once: arrays (c, t) with no Python
loop over either. Static structures (mapped polygons, the outlines of static tracks) become
obstacles at rest: points along their edges (:func:`edge_points`), each a disc of radius
√(ρ² + (s/2)²) for points s apart, so the union covers the strip of half-width ρ = r_A + d_safety
along the edge (the chord between two points is s long).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Obstacles", "half_angle_rad", "relative_velocities", "at_speed", "time_to_collision",
           "in_velocity_obstacle", "closest_approach", "edge_points", "static_disc_radius_m"]


@dataclass(frozen=True, eq=False)
class Obstacles:
    """Obstacles as rows (t = their number), world ENU, SI.

    position_m (t, 2); velocity_m_s (t, 2); radius_m (t,) the combined radius R (own radius +
    obstacle radius + safety, and any uncertainty margin); reciprocal (t,) bool (a team mate that
    avoids too: RVO); track_id (t,) int (−1 for a static structure's edge point); static (t,) bool."""

    position_m: np.ndarray
    velocity_m_s: np.ndarray
    radius_m: np.ndarray
    reciprocal: np.ndarray
    track_id: np.ndarray
    static: np.ndarray

    def __len__(self) -> int:
        return int(self.radius_m.shape[0])

    @classmethod
    def empty(cls) -> "Obstacles":
        return cls(np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0), np.zeros(0, bool), np.zeros(0, int),
                   np.zeros(0, bool))

    @classmethod
    def concatenate(cls, parts) -> "Obstacles":
        parts = [p for p in parts if len(p)]
        if not parts:
            return cls.empty()
        return cls(*(np.concatenate([getattr(p, f) for p in parts]) for f in
                     ("position_m", "velocity_m_s", "radius_m", "reciprocal", "track_id", "static")))


def half_angle_rad(distance_m, radius_m):
    """The collision cone's half-angle α = asin(R / d) [rad] (π/2 when d ≤ R: every closing direction)."""
    d = np.asarray(distance_m, dtype=float)
    return np.arcsin(np.clip(np.asarray(radius_m, dtype=float) / np.maximum(d, 1e-12), 0.0, 1.0))


def relative_velocities(candidates_m_s, own_velocity_m_s, obstacles: Obstacles) -> np.ndarray:
    """w (c, t, 2): each candidate velocity (c, 2) relative to each obstacle — v − v_B, or for a
    reciprocal obstacle 2 v − v_A,now − v_B (module docstring)."""
    v = np.asarray(candidates_m_s, dtype=float)[:, None, :]
    a = np.where(obstacles.reciprocal, 2.0, 1.0)[None, :, None]
    b = obstacles.velocity_m_s + np.where(obstacles.reciprocal[:, None], np.asarray(own_velocity_m_s, float), 0.0)
    return a * v - b[None, :, :]


def at_speed(velocities_m_s, speed_m_s: float) -> np.ndarray:
    """Each velocity (c, 2) turned into its direction at ``speed_m_s`` (the zero velocity stays zero):
    a structure at rest is checked along the candidate's course at the preferred speed, so its
    truncated cone is cut by distance (speed · T), not by the candidate's own speed."""
    v = np.asarray(velocities_m_s, dtype=float)
    n = np.hypot(v[:, 0], v[:, 1])
    return np.where(n[:, None] > 1e-12, v * (float(speed_m_s) / np.maximum(n, 1e-12))[:, None], 0.0)


def time_to_collision(relative_position_m, w, radius_m) -> np.ndarray:
    """τ_c (c, t) [s] of each relative velocity w (c, t, 2) with each obstacle at relative position
    r = p_B − p_A (t, 2) and combined radius R (t,): the first time the centres come within R
    (module docstring); 0 when already within R and closing, ∞ when the ray misses the disc, is
    tangent to it or opens."""
    r = np.asarray(relative_position_m, dtype=float)[None, :, :]
    R = np.asarray(radius_m, dtype=float)[None, :]
    rw = np.sum(r * w, axis=-1)
    ww = np.sum(w * w, axis=-1)
    c0 = np.sum(r * r, axis=-1) - R * R  # d² − R²
    disc = rw * rw - ww * c0
    hit = (rw > 0.0) & (disc > 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        tau = np.where(hit, c0 / (rw + np.sqrt(np.where(hit, disc, 0.0))), np.inf)
    inside = c0 <= 0.0
    return np.where(inside, np.where(rw > 0.0, 0.0, np.inf), tau)


def in_velocity_obstacle(ttc_s, horizon_s: float) -> np.ndarray:
    """Membership of the truncated velocity obstacle VO^T: τ_c ≤ T (c, t) bool."""
    return np.asarray(ttc_s) <= float(horizon_s)


def closest_approach(relative_position_m, w) -> tuple[np.ndarray, np.ndarray]:
    """(t_cpa (c, t) [s] ≥ 0, d_cpa (c, t) [m]) of each relative velocity w (c, t, 2) with each
    obstacle at relative position r (t, 2), under straight motion."""
    r = np.asarray(relative_position_m, dtype=float)[None, :, :]
    ww = np.sum(w * w, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(ww > 1e-12, np.sum(r * w, axis=-1) / ww, 0.0)
    t = np.maximum(t, 0.0)
    miss = r - w * t[..., None]
    return t, np.hypot(miss[..., 0], miss[..., 1])


def static_disc_radius_m(strip_half_width_m: float, spacing_m: float) -> float:
    """Radius of the discs at points ``spacing_m`` apart along an edge whose union covers the strip
    of half-width ``strip_half_width_m`` about the edge: √(ρ² + (s/2)²)."""
    return float(np.hypot(strip_half_width_m, 0.5 * spacing_m))


def edge_points(polygons, spacing_m: float, centre_m=None, range_m: float | None = None) -> np.ndarray:
    """Points (k, 2) along every edge of the closed ``polygons`` (each (n_i, 2), world), at most
    ``spacing_m`` apart, both ends included; only those within ``range_m`` of ``centre_m`` when
    given. The edges of all polygons are sampled in one pass."""
    edges = []
    for poly in polygons:  # gathering the edges (one row per edge); the sampling below is one pass
        p = np.asarray(poly, dtype=float).reshape(-1, 2)
        if len(p) == 0:
            continue
        edges.append(np.stack([p, np.roll(p, -1, axis=0)], axis=1))
    if not edges:
        return np.zeros((0, 2))
    e = np.concatenate(edges)  # (E, 2, 2): start, end
    length = np.hypot(*(e[:, 1] - e[:, 0]).T)
    n = np.maximum(np.ceil(length / float(spacing_m)).astype(int), 1)  # intervals per edge
    k = np.repeat(np.arange(len(e)), n)
    frac = (np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)) / np.repeat(n, n)
    pts = e[k, 0] + frac[:, None] * (e[k, 1] - e[k, 0])  # each edge's start and interior points
    if centre_m is not None and range_m is not None:
        c = np.asarray(centre_m, dtype=float)[:2]
        pts = pts[np.hypot(pts[:, 0] - c[0], pts[:, 1] - c[1]) <= float(range_m)]
    return pts
