"""Static obstructions of the path ahead: mapped polygons and the outlines of static tracks.

Static objects are not predicted in time: the stretch of the vessel's current path, within the
distance it covers in the prediction window, that passes closer than R_vh + safety distance to a
static polygon is an obstruction, and a static obstruction is always resolved by re-planning
(docs/thesis.md §3–4: σ = REPLAN for anything that does not move). World frame ENU, SI units.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mjasc.avoidance.prediction import Decision, gamma_of_time, prediction_window
from mjasc.core.estimates import TrackEstimate
from mjasc.core.geometry import distance_to_polygon, point_in_polygon
from mjasc.guidance.paths import _SCALAR_SEGMENTS, Path

__all__ = ["StaticConflict", "static_conflicts", "static_conflicts_of", "track_outline", "track_outlines"]

#: Path samples (every 0.25 m) taken beyond the prediction window's end before the whole rest of
#: the path is needed (a stretch obstructed past them).
_BEYOND = 40
#: Path.point evaluates up to this many values one by one, more as an array.
_FEW_SAMPLES = _SCALAR_SEGMENTS


@dataclass(frozen=True, eq=False)
class StaticConflict:
    """A static polygon obstructing the path ahead: stretch [γ_A, γ_B] of the current path whose
    points are closer than R_vh + safety to ``polygon`` (k, 2). Always → re-planning."""

    gamma_a: float
    gamma_b: float
    point_a: np.ndarray
    point_b: np.ndarray
    polygon: np.ndarray
    t_i: float
    min_distance_m: float
    decision: Decision = Decision.REPLAN
    track_id: int | None = None  # the static track whose outline this is (None: a static-map polygon)


def track_outline(track: TrackEstimate) -> np.ndarray | None:
    """A static track's outline (k ≥ 3, 2) [m], or None when it is degenerate (then its disc is used)."""
    p = np.asarray(track.outline_m, dtype=float).reshape(-1, 2)
    if p.shape[0] < 3 or not np.all(np.isfinite(p)):
        return None
    return p


def static_conflicts(t: float, path: Path, gamma: float, profile, polygons, radius_m: float,
                     config) -> list[StaticConflict]:
    """Stretches of ``path`` ahead of γ = ``gamma`` [m] (within the distance covered in the
    prediction window under the speed ``profile``) closer than ``radius_m`` + safety distance to a
    static polygon (each (k, 2)). ``config``: the
    :class:`~mjasc.avoidance.prediction.CollisionPredictionConfig`."""
    return [c for _, c in static_conflicts_of(t, path, gamma, profile, polygons, radius_m, config)]


def static_conflicts_of(t: float, path: Path, gamma: float, profile, polygons, radius_m: float,
                        config) -> list[tuple[int, StaticConflict]]:
    """:func:`static_conflicts` with each conflict's polygon index: [(k, conflict with
    ``polygons[k]``)], in polygon order (at most one per polygon; each polygon's conflict is the
    one :func:`static_conflicts` finds for it alone)."""
    polygons = [np.asarray(p, dtype=float) for p in polygons or ()]
    if not polygons:
        return []
    cfg = config
    gfn = gamma_of_time(profile, gamma, t)
    v_now = max(0.0, float(gfn(t + 1e-3) - gfn(t)) / 1e-3)
    delta = prediction_window(max(v_now, 1e-3), cfg.brake_decel_m_s2, max(cfg.margin_s, 1.0), cfg.window_s)
    reach = float(gfn(t + delta))
    g_end = min(path.length, max(reach, gamma) + radius_m)
    if g_end - gamma < 0.25:
        return []
    limit = radius_m + cfg.safety_distance_m
    gs = np.arange(gamma, path.length + 1e-9, 0.25)
    n_ahead = int(np.searchsorted(gs, g_end, side="right"))
    # The samples up to the window's end and a little beyond: the path beyond the window only
    # matters for a stretch that starts in it and goes on past them (then all of it, below). Each
    # sample's point is the one of the whole array's evaluation (elementwise; at least
    # _FEW_SAMPLES + 1 of them, as the whole array: the same form of Path.point).
    n_eval = gs.size if gs.size <= _FEW_SAMPLES else min(gs.size, max(n_ahead + _BEYOND, _FEW_SAMPLES + 1))
    pts = path.point(gs[:n_eval] if n_eval < gs.size else gs)
    near = pts[:n_ahead]
    near_lo, near_hi = near.min(axis=0), near.max(axis=0)
    out = []
    # Only path samples within a polygon's bounding box grown by the limit can be closer than the
    # limit or inside (the same answer as testing them all): the boxes of all polygons at once
    # (min and max are exact: the numbers of each polygon's own min and max).
    if len(polygons) > 1 and all(p.ndim == 2 and p.shape[0] and p.shape[1] == 2 for p in polygons):
        starts = np.cumsum([0] + [p.shape[0] for p in polygons[:-1]])
        stacked = np.concatenate(polygons)
        lo_all = np.minimum.reduceat(stacked, starts, axis=0) - limit
        hi_all = np.maximum.reduceat(stacked, starts, axis=0) + limit
        apart = ((lo_all > near_hi) | (hi_all < near_lo)).any(axis=1)
        boxes = [(k, poly, lo_all[k], hi_all[k]) for k, poly in enumerate(polygons) if not apart[k]]
    else:
        boxes = []
        for k, poly in enumerate(polygons):
            lo, hi = poly.min(axis=0) - limit, poly.max(axis=0) + limit
            if not ((lo > near_hi).any() or (hi < near_lo).any()):
                boxes.append((k, poly, lo, hi))
    for k_poly, poly, lo, hi in boxes:
        cand = near[((near >= lo) & (near <= hi)).all(axis=1)]
        if not cand.size or not ((distance_to_polygon(cand, poly) < limit) | point_in_polygon(cand, poly)).any():
            continue
        d = distance_to_polygon(pts, poly)
        blocked = (d < limit) | point_in_polygon(pts, poly)
        ahead = blocked & (gs[:pts.shape[0]] <= g_end)
        if not ahead.any():
            continue
        a = int(np.argmax(ahead))
        b = a
        while b + 1 < pts.shape[0] and blocked[b + 1]:
            b += 1
        if b + 1 == pts.shape[0] < gs.size:  # the stretch goes on past the samples taken: the whole path
            pts = path.point(gs)
            d = distance_to_polygon(pts, poly)
            blocked = (d < limit) | point_in_polygon(pts, poly)
            while b + 1 < gs.size and blocked[b + 1]:
                b += 1
        t_i = float(t + (gs[a] - gamma) / max(v_now, 1e-3))
        out.append((k_poly, StaticConflict(float(gs[a]), float(gs[b]), pts[a], pts[b], poly, t_i,
                                           float(d[a:b + 1].min()))))
    return out


def track_outlines(tracks) -> dict:
    """Track id → outline polygon of the static tracks that carry one (checked like a mapped
    polygon; the other tracks are predicted as discs)."""
    outlined = {tr.track_id: track_outline(tr) for tr in tracks if tr.is_static and tr.outline_m is not None}
    return {k: o for k, o in outlined.items() if o is not None}
