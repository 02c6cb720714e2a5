"""Re-planning (docs/thesis.md §4): a detour along a streamline of the harmonic potential field.

When a conflict calls for re-planning (σ = REPLAN: a long obstruction, a static obstacle, or a
velocity correction that cannot clear a track), :func:`plan_detour` builds a
:class:`~mjasc.avoidance.potential_field.PotentialField` around the static virtual obstacles
(SVO: each swept area, already grown by R_vh + safety) and the static polygons near the route
(grown by half the beam + safety distance), with the goal back on the mission path beyond the
obstruction and the robust rule V_j = r·a_max·L_j (safety ratio r). The streamline from the vessel
to the goal becomes a :class:`~mjasc.guidance.paths.Path`, spliced in front of the rest of the
mission path: a :class:`Detour`. World frame ENU, SI units, absolute times [s].
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from mjasc.avoidance.potential_field import PotentialField
from mjasc.avoidance.prediction import swept_disc_polygon
from mjasc.avoidance.static_conflicts import StaticConflict
from mjasc.avoidance.team_mates import PlannedTrack
from mjasc.core.estimates import TrackEstimate
from mjasc.core.geometry import (
    clean_polygon,
    convex_hull,
    disc_hull,
    distance_to_polygon,
    inflate_polygon,
    point_in_polygon,
)
from mjasc.guidance.paths import Path

__all__ = ["Detour", "swept_area", "merge_overlapping", "plan_detour"]


@dataclass(frozen=True, eq=False)
class Detour:
    """A re-planned path: ``path`` = streamline (length ``detour_length_m``) + the rest of the
    mission path from ``mission_gamma_goal_m``; it replaced the mission path from
    ``mission_gamma_start_m``. ``obstacles`` the field's polygons, ``field`` the field itself
    (None for a lane change, :mod:`~mjasc.avoidance.lane_change`, which has neither).
    ``hold_until_s``: the detour is not finished before this time [s] (a lane that holds its
    offset to the end of the mission path: the vessel waits at the lane's end, out of the
    threat's lane, until the obstruction is over; −∞: none)."""

    path: Path
    detour_length_m: float
    mission_gamma_start_m: float
    mission_gamma_goal_m: float
    streamline: np.ndarray
    obstacles: tuple
    field: PotentialField | None
    time_s: float
    hold_until_s: float = -np.inf

    def mission_gamma(self, gamma_m: float) -> float:
        """Mission-path γ [m] for γ on this path: linear over the detour, then one to one."""
        s, L = float(gamma_m), self.detour_length_m
        if s <= L:
            return self.mission_gamma_start_m + (self.mission_gamma_goal_m - self.mission_gamma_start_m) * max(s, 0.0) / L
        return self.mission_gamma_goal_m + (s - L)


def swept_area(track: TrackEstimate, t_a: float, t_b: float, radius_m: float) -> np.ndarray:
    """Polygon (k, 2) containing the disc of ``radius_m`` swept along the track's prediction over
    [t_a, t_b]: :func:`~mjasc.avoidance.prediction.swept_disc_polygon` for constant speed and turn
    rate, the convex hull of discs every 0.5 s along a :class:`PlannedTrack`'s plan."""
    if not isinstance(track, PlannedTrack):
        return swept_disc_polygon(track, t_a, t_b, radius_m)
    ts = np.linspace(t_a, t_b, max(2, int(np.ceil((t_b - t_a) / 0.5)) + 1))
    return disc_hull(track.predict_positions(ts), radius_m, 16)


def merge_overlapping(polygons: list[np.ndarray], clearance_m: float = 0.0, keep_out=None,
                      solid=None) -> list[np.ndarray] | None:
    """Replace polygons that overlap (or come closer than ``clearance_m``) by their convex hull,
    until none do. The potential field needs disjoint obstacles. ``keep_out`` (2,), the vessel's
    position: None when a polygon marked ``solid`` (default: every one) would merge with another
    over it — the vessel in a gap beside structure, where no detour of disjoint obstacles exists.
    Such a hull, shrunk to leave the vessel outside (:func:`_shrink_to_exclude`), kept no island:
    in the §6.4.3 bottleneck both islands' safety regions, joined across the gap by a crossing
    vessel's swept area, shrank to a blob in its middle, and the detour ran through the north
    island's face. Merged hulls of moving tracks' regions alone are still shrunk so."""
    merged = _merged(polygons, [True] * len(polygons) if solid is None else list(solid), clearance_m, keep_out)
    return None if merged is None else merged[0]


def _merged(polygons, solid: list, clearance_m: float, keep_out):
    """:func:`merge_overlapping` with each polygon's ``solid`` flag carried to its hulls: the
    polygons and their flags, or None."""
    polys = [np.asarray(p, dtype=float) for p in polygons]
    changed = True
    while changed and len(polys) > 1:
        changed = False
        for i in range(len(polys)):
            for j in range(i + 1, len(polys)):
                a, b = polys[i], polys[j]
                close = (np.any(point_in_polygon(a, b)) or np.any(point_in_polygon(b, a))
                         or float(np.min(distance_to_polygon(a, b))) <= clearance_m
                         or float(np.min(distance_to_polygon(b, a))) <= clearance_m)
                if close:
                    hull = convex_hull(np.vstack([a, b]), canonical=False)
                    if keep_out is not None and (solid[i] or solid[j]) and point_in_polygon(keep_out[None], hull)[0]:
                        return None
                    rest = [k for k in range(len(polys)) if k not in (i, j)]
                    polys, solid = [polys[k] for k in rest] + [hull], [solid[k] for k in rest] + [solid[i] or solid[j]]
                    changed = True
                    break
            if changed:
                break
    return polys, solid


def _inflation_leaving(point, polygon, inflation_m: float, margin_m: float = 0.5) -> float:
    """``inflation_m``, or less when ``point`` (the vessel) is within it of ``polygon``: the margin
    that leaves the point ``margin_m`` outside (0 at least). The safety region then keeps the
    polygon's shape all round; scaled about its centre to leave the vessel outside (what moving
    obstacles' regions still get, :func:`_shrink_to_exclude`) an island's region fell inside the
    island's own faces elsewhere, and a detour ran along them."""
    if point_in_polygon(point[None], polygon)[0]:
        return inflation_m  # (inside the polygon itself: nothing to plan from; said below)
    return min(inflation_m, max(float(distance_to_polygon(point[None], polygon)[0]) - margin_m, 0.0))


def _shrink_to_exclude(poly, point, margin_m: float = 0.5):
    """``poly`` scaled about its vertex centroid so that ``point`` lies ``margin_m`` outside."""
    poly = np.asarray(poly, dtype=float)
    c = poly.mean(axis=0)
    lo, hi = 0.0, 1.0
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        q = c + mid * (poly - c)
        ok = not point_in_polygon(point[None], q)[0] and distance_to_polygon(point[None], q)[0] >= margin_m
        lo, hi = (mid, hi) if ok else (lo, mid)
    return c + max(lo, 0.05) * (poly - c)


def _svo_clear_of(start, track, c, t, obstruction_threshold_s: float):
    """The swept area cut short where the obstacle's disc would reach the vessel's present
    position (a head-on obstacle sweeps over the vessel's own place; by then the vessel has
    left it on the detour). None when the obstacle is already there."""
    r_col = c.collision_distance_m
    t_f = c.t_f if np.isfinite(c.t_f) else c.t_i + obstruction_threshold_s
    t_a = max(c.t_i, t)
    ts = np.arange(t_a, t_f, 0.25)
    if ts.size < 2:
        return None
    d = np.hypot(*(track.predict_positions(ts) - start).T)
    near = np.flatnonzero(d <= r_col + 1.0)
    t_cut = ts[near[0] - 1] if near.size else t_f
    if near.size and near[0] < 2:
        return None
    return swept_area(track, t_a, t_cut, r_col)


def _statics_near(start, mission: Path, g_a, g_b, polygons, range_m: float) -> list[np.ndarray]:
    polys = [np.asarray(p, dtype=float) for p in polygons or ()]
    if not polys:
        return []
    g_b = min(max(g_b, g_a + 1.0), mission.length)
    route = np.vstack([start[None], mission.point(np.linspace(g_a, g_b, 60))])
    return [p for p in polys if float(np.min(distance_to_polygon(route, p))) <= range_m]


def _streamline(start, goal, obstacles, cfg):
    """The streamline from start to goal of the robust field; retries with a stronger sink, a
    smaller safety ratio and slightly shifted starts (off a stagnation saddle)."""
    U = cfg.uniform_speed
    if cfg.sink_strength is not None:
        sink = cfg.sink_strength
    else:
        d = goal - start
        n = np.array([-d[1], d[0]]) / max(np.hypot(*d), 1e-9)
        width = max((float(np.ptp(p @ n)) for p in obstacles), default=0.0)
        sink = max(30.0, 2.0 * U * (width + 10.0))
    attempts = [(cfg.safety_ratio, sink), (cfg.safety_ratio, 2 * sink), (0.5 * cfg.safety_ratio, 2 * sink),
                (0.5 * cfg.safety_ratio, 4 * sink)]
    step = cfg.streamline_step_m
    span = np.hypot(*(goal - start))
    d = (goal - start) / span
    normal = np.array([-d[1], d[0]])
    for ratio, lam in attempts:
        try:
            fld = PotentialField(obstacles, goal=goal, start=start, uniform_speed=U, sink_strength=lam,
                                 safety_ratio=ratio if obstacles else None,
                                 max_panel_length=cfg.max_panel_length_m)
        except ValueError:
            continue
        offsets = [0.0, 0.3, -0.3, 1.0, -1.0]
        starts = [start + o * normal for o in offsets]
        starts = [s for s in starts if fld.obstacle_containing(s) is None]
        lines = fld.streamlines(np.array(starts), step=step, max_length=6.0 * span + 100.0)
        for s0, line in zip(starts, lines):
            if line.reached_goal:
                pts = line.points if np.allclose(s0, start) else np.vstack([start[None], line.points])
                return pts, fld
    return None, None


def plan_detour(t: float, start, mission: Path, g_now_m: float, svos, static_polygons, by_id, static_outlines,
                cfg, radius_m: float, static_inflation_m: float,
                emit: Callable[[float, str], None]) -> Detour | str:
    """Build the field, trace the streamline, splice the detour: the :class:`Detour`, or the reason
    it failed (a string).

    start (2,): the vessel's position; mission: its mission path, on which it is at γ = ``g_now_m``;
    svos: (polygon, conflict) pairs to go around; static_polygons: the mapped static polygons;
    by_id: track id → track; static_outlines: the outlines of static tracks; cfg: the
    :class:`~mjasc.avoidance.config.AvoidanceConfig`. Mapped static polygons are grown by
    ``static_inflation_m``; the outlines of static tracks by R_vh + safety (the distance at which
    prediction flags them, exactly as a static disc's SVO is R_vh + R_ob + safety) plus
    ``replan_margin_m`` (the hysteresis the SVOs get)."""
    by_id = by_id or {}
    start = np.asarray(start, dtype=float)
    # End of the obstruction on the mission path.
    g_end = g_now_m
    for poly, c in svos:  # (its end point and vertices in one call: each point's answer is its own)
        pts = np.vstack([np.asarray(c.point_b, dtype=float).reshape(1, 2), np.asarray(poly, dtype=float)])
        gs, ds = mission.closest_points(pts, g_now_m, mission.length)
        for g, d in zip(gs.tolist(), ds.tolist()):
            if d <= 3.0 * (radius_m + cfg.safety_distance_m) + 5.0:
                g_end = max(g_end, g)
        g_end = max(g_end, float(mission.project(c.point_b, gamma_hint=g_now_m,
                                                 search_window_m=max(mission.length, 1.0))))
    obstacles = []
    for poly, c in svos:
        if isinstance(c, StaticConflict):
            continue
        poly = np.asarray(poly, dtype=float)
        track = by_id.get(c.track_id)
        if track is not None and not c.is_static and point_in_polygon(start[None], poly)[0]:
            poly = _svo_clear_of(start, track, c, t, cfg.obstruction_threshold_s)
            if poly is None:
                return f"track {c.track_id} is already at the vessel"
        if cfg.replan_margin_m > 0:
            try:
                grown = inflate_polygon(clean_polygon(poly, "svo"), cfg.replan_margin_m)
                if not point_in_polygon(start[None], grown)[0]:
                    poly = grown
            except ValueError:
                pass
        obstacles.append(poly)
    reach = g_end + cfg.goal_margin_m + 20.0
    statics_near = _statics_near(start, mission, g_now_m, reach, static_polygons, cfg.static_range_m)
    moving = len(obstacles)  # (the swept areas so far; then mapped structure, then static tracks' outlines)
    try:  # (a vessel within the inflation of a mapped polygon: grown by less, to leave it 0.5 m outside)
        obstacles += [inflate_polygon(p, _inflation_leaving(start, p, static_inflation_m))
                      for p in (clean_polygon(q, "static obstacle") for q in statics_near)]
    except ValueError as exc:
        return f"static polygon unusable: {exc}"
    solid = [moving <= k for k in range(len(obstacles))]
    check = radius_m + cfg.safety_distance_m
    for p in _statics_near(start, mission, g_now_m, reach, static_outlines, cfg.static_range_m):
        try:
            p = clean_polygon(p, "static track outline")
            grown = inflate_polygon(p, check + cfg.replan_margin_m)
            obstacles.append(grown if not point_in_polygon(start[None], grown)[0] else inflate_polygon(p, check))
            solid.append(False)
        except ValueError as exc:
            return f"static track outline unusable: {exc}"
    # Regions merge, never mapped structure over the vessel (merge_overlapping); inside a merged
    # region of moving tracks or outlines, it is shrunk to just exclude the vessel
    merged = _merged(obstacles, solid, 0.5, start)
    if merged is not None:
        obstacles, solid = merged
        for k, p in enumerate(obstacles):
            if point_in_polygon(start[None], p)[0]:
                obstacles[k] = _shrink_to_exclude(p, start)
                emit(t, "the vessel is inside an obstacle's safety region: that region is shrunk to leave it outside")
        merged = _merged(obstacles, solid, 0.5, start)
    if merged is None:
        return "the vessel is between structure and obstacles whose safety regions join around it"
    obstacles = merged[0]
    if any(point_in_polygon(start[None], p)[0] for p in obstacles):
        return "the vessel is inside an obstacle's safety region"
    # Goal: on the mission path beyond the obstruction, clear of every obstacle.
    g_goal = min(g_end + cfg.goal_margin_m, mission.length)
    clear = radius_m + cfg.safety_distance_m
    while True:
        goal = mission.point(g_goal)
        d = min(float(distance_to_polygon(goal[None], p)[0]) if not point_in_polygon(goal[None], p)[0] else -1.0
                for p in obstacles) if obstacles else np.inf
        if d >= clear or g_goal >= mission.length:
            break
        g_goal = min(g_goal + 1.0, mission.length)
    if d < clear:
        return "no goal on the mission path clear of the obstacles"
    if np.hypot(*(goal - start)) < 2.0 * cfg.streamline_step_m:
        return "goal too close to re-plan"
    sl, fld = _streamline(start, goal, obstacles, cfg)
    if sl is None:
        return "no streamline of the potential field reaches the goal"
    pts = sl
    keep = np.concatenate([[True], np.hypot(*np.diff(pts, axis=0).T) > 0.05])
    pts = pts[keep]
    detour_only = Path.from_points(pts)
    full = detour_only
    if g_goal < mission.length - 1e-6:
        rest = mission.sub_path(g_goal, mission.length)
        full = detour_only.concatenate(rest)
    return Detour(full, detour_only.length, g_now_m, g_goal, pts, tuple(obstacles), fld, t)
