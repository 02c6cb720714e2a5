"""Collision prediction proper: temporal and spatial correlation of a vessel's plan with its tracks,
and the decision σ (docs/thesis.md §3, steps 2–4; thesis §3.2.2, eqs. 3.16–3.17). World frame ENU, SI
units, absolute simulation times [s].

- **Temporal correlation.** d(t) = ‖P_v(t) − P_o(t)‖ on the window's time grid for all tracks at
  once: P_v = path(γ(t)) from one vectorized path evaluation (γ(t) of the plan,
  :mod:`~mjasc.avoidance.prediction.timing`), P_o of every track from one stacked evaluation
  (:class:`~mjasc.avoidance.prediction.motion.TrackMotions`: constant speed and turn, or a team
  mate's broadcast plan); its local minima refined in closed form over all (track, minimum) pairs
  (:func:`~mjasc.avoidance.prediction.cpa.closest_approaches`: the CPA of linear relative motion
  between samples, polished on true positions; exact for straight motion, the error bound in that
  module). A collision is predicted at a minimum t_c when d(t_c) ≤ R_vh + R_ob + safety (eq. 3.16
  plus the safety distance). By default t_c is the first local minimum that *is* a collision;
  ``stop_at_first_minimum`` gives the thesis's rule (the first minimum only).
- **Spatial correlation** (only after a predicted collision;
  :mod:`~mjasc.avoidance.prediction.spatial`). The obstruction interval Δt_o = [t_i, t_f] ∋ t_c,
  during which the obstacle's inflated disc meets the vessel's path ahead; [γ_A, γ_B], the
  connected stretch of path covered by the union of those discs that contains γ(t_c). A static
  obstacle obstructs for ever.
- **Decision** σ(Δt_o) (eq. 3.17): t_f − t_i ≥ Δt_threshold (or a static obstacle) → REPLAN with
  a static virtual obstacle (:mod:`mjasc.avoidance.prediction.svo`); otherwise VELOCITY_CORRECTION.

**A fleet in one call.** :func:`predict_fleet` takes one :class:`PredictionQuery` per vessel and
predicts every (vessel, track) pair in the same array operations (each vessel's own grid, padded
to the longest); :func:`predict_conflicts` is its one-vessel form. The values it takes and
returns (:class:`PredictionQuery`, :class:`PredictedConflict`, :class:`Decision`,
:class:`ConflictList`) are in :mod:`~mjasc.avoidance.prediction.conflict_values` (importable from
here as well).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from mjasc.avoidance.prediction.config import CollisionPredictionConfig
from mjasc.avoidance.prediction.conflict_values import ConflictList, Decision, PredictedConflict, PredictionQuery
from mjasc.avoidance.prediction.cpa import closest_approaches
from mjasc.avoidance.prediction.motion import TrackMotions
from mjasc.avoidance.prediction.spatial import PlanContext, obstructed_stretch, obstruction_interval
from mjasc.avoidance.prediction.svo import svo_polygon
from mjasc.avoidance.prediction.timing import SpeedProfile, gamma_of_time, prediction_window, speed_now
from mjasc.avoidance.prediction.zoom_motion import ZoomMotion
from mjasc.core.estimates import TrackEstimate, _field_names
from mjasc.guidance.paths import Path
from mjasc.guidance.stacked_paths import StackedPaths

__all__ = ["ConflictList", "Decision", "PredictedConflict", "PredictionQuery", "predict_conflicts", "predict_fleet",
           "predict_fleet_lazy"]


# ---------------------------------------------------------------------------- temporal correlation
def predict_conflicts(
    vessel_path: Path,
    gamma_now: float,
    t_now: float,
    speed_profile: SpeedProfile,
    vessel_radius_m: float,
    tracks: Sequence[TrackEstimate],
    config: CollisionPredictionConfig = CollisionPredictionConfig(),
    *,
    include_clear: bool = False,
) -> list[PredictedConflict]:
    """Predict conflicts between the vessel (on ``vessel_path`` at ``gamma_now`` at ``t_now``,
    moving by ``speed_profile``, see :func:`gamma_of_time`) and each track.

    Returns one :class:`PredictedConflict` per track with a predicted collision (every checked
    track when ``include_clear``), sorted by t_c.
    """
    query = PredictionQuery(vessel_path, gamma_now, t_now, speed_profile, vessel_radius_m, tracks, config,
                            include_clear)
    return predict_fleet([query])[0]


def _plan_context(q: PredictionQuery) -> PlanContext:
    """The validated plan of one query, with its window."""
    path, cfg = q.vessel_path, q.config
    if not isinstance(path, Path):
        raise ValueError(f"vessel_path: expected a Path, got {type(path).__name__}")
    gamma_now, t_now, r_vh = float(q.gamma_now), float(q.t_now), float(q.vessel_radius_m)
    if not (0.0 <= gamma_now <= path.length + 1e-9):
        raise ValueError(f"gamma_now: must be in [0, {path.length:g}], got {gamma_now}")
    if not np.isfinite(t_now):
        raise ValueError(f"t_now: must be finite, got {t_now}")
    if not np.isfinite(r_vh) or r_vh < 0.0:
        raise ValueError(f"vessel_radius_m: must be finite and ≥ 0, got {q.vessel_radius_m}")
    gamma_fn = gamma_of_time(q.speed_profile, gamma_now, t_now)
    delta = prediction_window(speed_now(gamma_fn, t_now), cfg.brake_decel_m_s2, cfg.margin_s, cfg.window_s)
    return PlanContext(path, gamma_now, t_now, t_now + delta, gamma_fn, r_vh, cfg)


def predict_fleet(queries: Sequence[PredictionQuery]) -> list[list[PredictedConflict]]:
    """:func:`predict_conflicts` for several vessels at once: one result list per query, equal to
    what :func:`predict_conflicts` returns for it. All (vessel, track) pairs share one stacked
    track evaluation and one closest-approach pass; each vessel's path is evaluated once per stage."""
    return [list(r) for r in predict_fleet_lazy(queries)]


def predict_fleet_lazy(queries: Sequence[PredictionQuery]) -> list[ConflictList]:
    """:func:`predict_fleet` with each result a :class:`ConflictList` (the same conflicts in the
    same order; a clear pair's object made when read)."""
    ctxs = [_plan_context(q) for q in queries]
    grids = []
    for c in ctxs:
        n = max(2, int(np.ceil((c.t_end - c.t_now) / c.config.time_step_s - 1e-9)) + 1)
        times = np.linspace(c.t_now, c.t_end, n)
        grids.append((times, c.vessel_at(times)))
    tracks = [tr for q in queries for tr in q.tracks]
    if not all(issubclass(c, TrackEstimate) for c in set(map(type, tracks))):
        for q in queries:
            for i, tr in enumerate(q.tracks):
                if not isinstance(tr, TrackEstimate):
                    raise ValueError(f"tracks[{i}]: expected a TrackEstimate, got {type(tr).__name__}")
    if not tracks:
        return [ConflictList([], None, [], [], [], []) for _ in queries]
    owner = np.repeat(np.arange(len(queries), dtype=np.intp), [len(q.tracks) for q in queries])
    motions = TrackMotions(tracks)
    rows = np.arange(len(tracks))
    max_range = np.array([np.inf if c.config.max_range_m is None else c.config.max_range_m for c in ctxs])
    if np.isfinite(max_range).any():  # only tracks within range of the vessel now are checked
        t_now = np.array([c.t_now for c in ctxs])
        own_now = np.array([c.path.point(c.gamma_now) for c in ctxs])
        gap = motions.at(rows, t_now[owner][:, None])[:, 0] - own_now[owner]
        rows = rows[~(np.hypot(gap[:, 0], gap[:, 1]) > max_range[owner])]
    r_ob = motions.radius_m[rows]
    bad = (~(np.isfinite(r_ob) & (r_ob >= 0.0))).ravel().nonzero()[0]
    if bad.size:
        tr = tracks[rows[bad[0]]]
        raise ValueError(f"tracks[{tr.track_id}].radius_m: must be finite and ≥ 0, got {r_ob[bad[0]]}")
    if rows.size == 0:
        return [ConflictList([], None, [], [], [], []) for _ in queries]
    vessel = owner[rows]  # the query of each pair
    n_max = max(g[0].size for g in grids)
    if len(grids) == 1:
        times_q, xy_q = grids[0][0][None, :], grids[0][1][None, :, :]
    else:
        times_q, xy_q = np.full((len(grids), n_max), np.nan), np.full((len(grids), n_max, 2), np.nan)
        for k, (times, xy) in enumerate(grids):
            times_q[k, :times.size], xy_q[k, :times.size] = times, xy
    times_p = times_q[vessel]
    obst = motions.at(rows, times_p)
    vessel_l, rows_l = vessel.tolist(), rows.tolist()
    # R_vh + R_ob + safety per pair (elementwise: the numbers of the sum per pair)
    r_col = np.array([c.r_vh for c in ctxs])[vessel] + r_ob + np.array([c.config.safety_distance_m
                                                                        for c in ctxs])[vessel]
    stop_first = np.array([c.config.stop_at_first_minimum for c in ctxs], dtype=bool)[vessel]

    paths = StackedPaths([c.path for c in ctxs]) if len(ctxs) > 1 else None
    # γ(t) = γ_now + v (t − t_now) of the vessels at a constant speed, for all their pairs at once
    # (the numbers of gamma_of_time's form, elementwise); the others by their own γ(t).
    speed = [_constant_speed(q.speed_profile) for q in queries]
    steady = np.array([v is not None for v in speed])
    g_now = np.array([c.gamma_now for c in ctxs])
    t_now_q = np.array([c.t_now for c in ctxs])
    v_q = np.array([0.0 if v is None else v for v in speed])

    def rel_at(pairs, t):
        """Track minus vessel position (k, j, 2) of pairs (k,) at times t (k, j): each vessel's
        γ(t) from its own plan, every vessel's path evaluated in one pass, once per distinct
        (vessel, times) row (many pairs of a vessel share a bracket: elementwise, the same numbers)."""
        r = motions.at(rows[pairs], t)
        v = vessel[pairs]
        u, inv = _distinct_rows(v, t)
        if u is None:
            return r - own_at(v, t)
        return r - own_at(v[u], t[u])[inv]

    def own_at(v, t):
        """The vessels' positions (k, j, 2) [m]: vessel v (k,) at its times t (k, j)."""
        if paths is None:
            return ctxs[0].vessel_at(t)
        return paths.point(v.repeat(t.shape[1]).reshape(t.shape), gamma_at(v, t))  # (each pair's vessel per time)

    def gamma_at(v, t):
        """The vessels' γ (k, j) [m] (not clamped): vessel v (k,) at its times t (k, j)."""
        if paths is None:
            return ctxs[0].gamma_fn(t)
        st = steady[v]
        if st.all():
            g = g_now[v][:, None] + v_q[v][:, None] * (t - t_now_q[v][:, None])
        else:
            g = np.empty(t.shape)
            if st.any():
                vs = v[st]
                g[st] = g_now[vs][:, None] + v_q[vs][:, None] * (t[st] - t_now_q[vs][:, None])
            other = (~st).ravel().nonzero()[0]
            order = other[np.argsort(v[other], kind="stable")]
            vs = v[order]
            cut = (vs[1:] != vs[:-1]).ravel().nonzero()[0] + 1
            for sel in np.split(order, cut):
                g[sel] = ctxs[v[sel[0]]].gamma_fn(t[sel])
        return g

    if paths is None:
        p0 = ctxs[0].path
        path_arrays = (p0.table, _ZERO_ROW, np.array([p0.table.shape[1]], dtype=np.intp), np.array([p0.length]))
    else:
        path_arrays = paths.segment_arrays()
    zoom = ZoomMotion(rel_at, motions, rows, vessel, path_arrays, steady, g_now, v_q, t_now_q, gamma_at)
    t_c, d_c = closest_approaches(times_p, obst - xy_q[vessel], r_col, zoom, stop_first)
    hit = (d_c <= r_col).tolist()  # a collision: d(t_c) ≤ R_col (as _conflict decides it)
    tc_l, dc_l, rc_l = t_c.tolist(), d_c.tolist(), r_col.tolist()
    # A clear pair (the common case: ~10⁵ a minute in a fleet of fifty) is made when read, without
    # the dataclass's __init__ (as estimate_of); a collision at once by _conflict.
    names, new, cls, nan, none = _field_names(PredictedConflict), object.__new__, PredictedConflict, float("nan"), \
        Decision.NONE

    def make_clear(p: int) -> PredictedConflict:
        k, tr = vessel_l[p], tracks[rows_l[p]]
        times, xy = grids[k]
        c = new(cls)
        c.__dict__.update(zip(names, (tr.track_id, tc_l[p], dc_l[p], False, nan, nan, nan, nan, None, None, none, None,
                                      xy, obst[p, :times.size], times, rc_l[p],
                                      bool(tr.is_static) or tr.speed_m_s == 0.0, False)))
        return c

    items: list[list] = [[] for _ in queries]  # per query: a collision, or a clear pair's index
    keys: list[list] = [[] for _ in queries]
    clear_too = [q.include_clear for q in queries]
    for p, (k, h) in enumerate(zip(vessel_l, hit)):
        if h:
            times, xy = grids[k]
            items[k].append(_conflict(ctxs[k], tracks[rows_l[p]], tc_l[p], dc_l[p], rc_l[p], times, xy,
                                      obst[p, :times.size]))
        elif clear_too[k]:
            items[k].append(p)
        else:
            continue
        keys[k].append(tc_l[p])
    out = []
    for its, ks in zip(items, keys):  # sorted by t_c: list.sort's order (stable, on the same keys)
        order = sorted(range(len(its)), key=ks.__getitem__)
        its = [its[i] for i in order]
        out.append(ConflictList(its, make_clear, [c for c in its if type(c) is not int],
                                [dc_l[c] if type(c) is int else c.min_distance_m for c in its],
                                [tracks[rows_l[c]].track_id if type(c) is int else c.track_id for c in its],
                                [rc_l[c] if type(c) is int else c.collision_distance_m for c in its]))
    return out


_ZERO_ROW = np.zeros(1, dtype=np.intp)  # (one path's first segment column)


def _distinct_rows(v: np.ndarray, t: np.ndarray) -> tuple:
    """(u, inv): rows ``u`` of the distinct (v, t-row) pairs and ``inv`` (k,) each row's among them,
    so that ``t[u][inv]`` is ``t`` (a zoom's rows are told apart by their first and last time, then
    checked whole); (None, None) when few rows repeat."""
    k = v.size
    if k < 8 or t.ndim != 2:
        return None, None
    a, b = t[:, 0], t[:, -1]
    order = np.lexsort((b, a, v))
    vs, a_s, b_s = v[order], a[order], b[order]
    new = np.empty(k, dtype=bool)
    new[0] = True
    new[1:] = (vs[1:] != vs[:-1]) | (a_s[1:] != a_s[:-1]) | (b_s[1:] != b_s[:-1])
    n = int(np.count_nonzero(new))
    if 4 * n > 3 * k:
        return None, None
    inv = np.empty(k, dtype=np.intp)
    inv[order] = np.cumsum(new) - 1
    u = order[new]
    if not np.array_equal(t[u][inv], t):
        return None, None
    return u, inv


def _constant_speed(profile) -> float | None:
    """The speed [m/s] of a constant speed profile (a number; :func:`gamma_of_time` has checked it),
    None for a callable or knots."""
    if isinstance(profile, (float, int)) and not isinstance(profile, bool):
        return float(profile)
    if isinstance(profile, np.ndarray) and profile.ndim == 0 or isinstance(profile, np.floating):
        return float(profile)
    return None


def _conflict(ctx: PlanContext, track: TrackEstimate, t_c: float, d_c: float, r_col: float, times, vessel_xy,
              obst_xy) -> PredictedConflict:
    """The PredictedConflict of a pair with a predicted collision (d_c ≤ r_col) from its closest
    approach (t_c, d_c): spatial correlation and decision σ (a clear pair is made in
    :func:`predict_fleet`)."""
    cfg = ctx.config
    static = bool(track.is_static) or track.speed_m_s == 0.0
    base = dict(
        track_id=track.track_id,
        t_closest_s=t_c,
        min_distance_m=d_c,
        collision=True,
        vessel_positions=vessel_xy,
        obstacle_positions=obst_xy,
        times=times,
        collision_distance_m=r_col,
        is_static=static,
    )
    t_i, t_f, truncated = obstruction_interval(ctx, track, t_c, r_col, static)
    gamma_c = float(np.clip(ctx.gamma_fn(np.array([t_c]))[0], 0.0, ctx.path.length))
    gamma_a, gamma_b = obstructed_stretch(ctx, track, t_i, t_f, gamma_c, r_col, static)
    if static or t_f - t_i >= cfg.obstruction_threshold_s:
        decision = Decision.REPLAN
        svo = svo_polygon(track, t_i, t_f, r_col, ctx.r_vh + cfg.safety_distance_m, static, cfg.svo_vertices)
    else:
        decision, svo = Decision.VELOCITY_CORRECTION, None
    return PredictedConflict(
        t_i=t_i,
        t_f=t_f,
        gamma_a=gamma_a,
        gamma_b=gamma_b,
        point_a=ctx.path.point(gamma_a),
        point_b=ctx.path.point(gamma_b),
        decision=decision,
        svo_polygon=svo,
        obstruction_truncated=truncated,
        **base,
    )
