"""Collision prediction proper: temporal and spatial correlation of a vessel's plan with its tracks,
and the decision σ (docs/thesis.md §3, steps 2–4; thesis §3.2.2, eqs. 3.16–3.17). World frame ENU, SI
units, absolute simulation times [s].

- **Temporal correlation.** d(t) = ‖P_v(t) − P_o(t)‖ on the window's time grid (P_v from the
  plan's γ(t), :mod:`mjasc.avoidance.prediction.timing`; P_o the track's constant-speed,
  constant-turn prediction), its local minima refined between grid points (bounded Brent). A
  collision is predicted at a minimum t_c when d(t_c) ≤ R_vh + R_ob + safety (eq. 3.16 plus the
  safety distance). By default t_c is the first local minimum that *is* a collision;
  ``stop_at_first_minimum`` gives the thesis's rule (the first minimum only).
- **Spatial correlation** (only after a predicted collision). The obstruction interval
  Δt_o = [t_i, t_f] ∋ t_c, during which the obstacle's inflated disc meets the vessel's path ahead
  (bisection on the gap between disc and path); [γ_A, γ_B], the connected stretch of path covered
  by the union of those discs that contains γ(t_c). A static obstacle obstructs for ever.
- **Decision** σ(Δt_o) (eq. 3.17): t_f − t_i ≥ Δt_threshold (or a static obstacle) → REPLAN with
  a static virtual obstacle (:mod:`mjasc.avoidance.prediction.svo`); otherwise VELOCITY_CORRECTION.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np
from scipy.optimize import minimize_scalar

from mjasc.avoidance.prediction.config import CollisionPredictionConfig
from mjasc.avoidance.prediction.svo import svo_polygon
from mjasc.avoidance.prediction.timing import SpeedProfile, gamma_of_time, prediction_window, speed_now
from mjasc.core.estimates import TrackEstimate
from mjasc.guidance.paths import Path

__all__ = ["Decision", "PredictedConflict", "predict_conflicts"]


class Decision(enum.Enum):
    """σ(Δt_o) of thesis eq. 3.17 (NONE when no collision is predicted)."""

    NONE = "none"
    VELOCITY_CORRECTION = "velocity_correction"
    REPLAN = "replan"


@dataclass(frozen=True, eq=False)
class PredictedConflict:
    """The outcome of collision prediction for one track.

    t_closest_s: t_c, the chosen local minimum of d(t) [s]; min_distance_m: d(t_c) [m].
    collision: d(t_c) ≤ R_vh + R_ob + safety. When False the spatial fields are NaN/None.
    t_i, t_f: obstruction interval [s] (t_f = inf for a static obstacle).
    gamma_a, gamma_b: the obstructed stretch of the vessel's path [m]; point_a, point_b: (2,) its ends.
    decision: σ(Δt_o). svo_polygon: (k, 2) CCW polygon of the static virtual obstacle when
    decision is REPLAN, else None.
    obstruction_truncated: the obstruction was still going on at the end of the searched span,
    so t_f is a lower bound.
    times, vessel_positions, obstacle_positions: the grid (n,) and both predictions on it (n, 2).
    """

    track_id: int
    t_closest_s: float
    min_distance_m: float
    collision: bool
    t_i: float
    t_f: float
    gamma_a: float
    gamma_b: float
    point_a: np.ndarray | None
    point_b: np.ndarray | None
    decision: Decision
    svo_polygon: np.ndarray | None
    vessel_positions: np.ndarray
    obstacle_positions: np.ndarray
    times: np.ndarray
    collision_distance_m: float = float("nan")
    is_static: bool = False
    obstruction_truncated: bool = False

    @property
    def obstruction_s(self) -> float:
        """Δt_o = t_f − t_i [s] (inf for static obstacles, NaN without a collision)."""
        return self.t_f - self.t_i


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
    if not isinstance(vessel_path, Path):
        raise ValueError(f"vessel_path: expected a Path, got {type(vessel_path).__name__}")
    gamma_now, t_now, r_vh = float(gamma_now), float(t_now), float(vessel_radius_m)
    if not (0.0 <= gamma_now <= vessel_path.length + 1e-9):
        raise ValueError(f"gamma_now: must be in [0, {vessel_path.length:g}], got {gamma_now}")
    if not np.isfinite(t_now):
        raise ValueError(f"t_now: must be finite, got {t_now}")
    if not np.isfinite(r_vh) or r_vh < 0.0:
        raise ValueError(f"vessel_radius_m: must be finite and ≥ 0, got {vessel_radius_m}")
    gamma_fn = gamma_of_time(speed_profile, gamma_now, t_now)
    delta = prediction_window(
        speed_now(gamma_fn, t_now), config.brake_decel_m_s2, config.margin_s, config.window_s
    )
    n = max(2, int(np.ceil(delta / config.time_step_s - 1e-9)) + 1)
    times = np.linspace(t_now, t_now + delta, n)
    ctx = _Context(vessel_path, gamma_now, t_now, t_now + delta, gamma_fn, r_vh, config)
    vessel_xy = ctx.vessel_at(times)
    own_now = vessel_path.point(gamma_now)
    out = []
    for i, track in enumerate(tracks):
        if not isinstance(track, TrackEstimate):
            raise ValueError(f"tracks[{i}]: expected a TrackEstimate, got {type(track).__name__}")
        if config.max_range_m is not None:
            if np.hypot(*(track.predict_positions(np.array([t_now]))[0] - own_now)) > config.max_range_m:
                continue
        conflict = _predict_one(ctx, track, times, vessel_xy)
        if conflict.collision or include_clear:
            out.append(conflict)
    out.sort(key=lambda c: c.t_closest_s)
    return out


@dataclass(frozen=True)
class _Context:
    path: Path
    gamma_now: float
    t_now: float
    t_end: float
    gamma_fn: Callable
    r_vh: float
    config: CollisionPredictionConfig

    def vessel_at(self, t):
        g = np.clip(self.gamma_fn(np.atleast_1d(np.asarray(t, dtype=float))), 0.0, self.path.length)
        return self.path.point(g)


def _local_minima(d: np.ndarray) -> np.ndarray:
    """Grid indices of local minima of d (window ends included when d rises from / falls to them)."""
    n = d.size
    left = np.concatenate([[True], d[1:] <= d[:-1]])  # not higher than the left neighbour
    right = np.concatenate([d[:-1] < d[1:], [True]])  # strictly lower than the right neighbour
    idx = np.flatnonzero(left & right)
    if idx.size == 0:  # flat everywhere (e.g. both at rest)
        idx = np.array([int(np.argmin(d))])
    return idx[idx < n]


def _predict_one(ctx: _Context, track: TrackEstimate, times, vessel_xy) -> PredictedConflict:
    cfg = ctx.config
    r_ob = float(track.radius_m)
    if not np.isfinite(r_ob) or r_ob < 0.0:
        raise ValueError(f"tracks[{track.track_id}].radius_m: must be finite and ≥ 0, got {r_ob}")
    r_col = ctx.r_vh + r_ob + cfg.safety_distance_m
    static = bool(track.is_static) or track.speed_m_s == 0.0
    obst_xy = track.predict_positions(times)
    d = np.hypot(*(vessel_xy - obst_xy).T)

    def dist(t):
        return float(np.hypot(*(ctx.vessel_at(t)[0] - track.predict_positions(np.array([t]))[0])))

    t_c, d_c = None, None
    for i in _local_minima(d):
        lo, hi = times[max(i - 1, 0)], times[min(i + 1, times.size - 1)]
        res = minimize_scalar(dist, bounds=(lo, hi), method="bounded", options={"xatol": 1e-7})
        tt, dd = (float(res.x), float(res.fun)) if res.fun <= d[i] else (float(times[i]), float(d[i]))
        if t_c is None:
            t_c, d_c = tt, dd
        if dd <= r_col:
            t_c, d_c = tt, dd
            break
        if cfg.stop_at_first_minimum:
            break
    collision = d_c <= r_col
    base = dict(
        track_id=track.track_id,
        t_closest_s=t_c,
        min_distance_m=d_c,
        collision=collision,
        vessel_positions=vessel_xy,
        obstacle_positions=obst_xy,
        times=times,
        collision_distance_m=r_col,
        is_static=static,
    )
    if not collision:
        nan = float("nan")
        return PredictedConflict(
            t_i=nan, t_f=nan, gamma_a=nan, gamma_b=nan, point_a=None, point_b=None,
            decision=Decision.NONE, svo_polygon=None, **base,
        )
    t_i, t_f, truncated = _obstruction_interval(ctx, track, t_c, r_col, static)
    gamma_c = float(np.clip(ctx.gamma_fn(np.array([t_c]))[0], 0.0, ctx.path.length))
    gamma_a, gamma_b = _obstructed_stretch(ctx, track, t_i, t_f, gamma_c, r_col, static)
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


# ---------------------------------------------------------------------------- spatial correlation
def _path_gap(ctx: _Context, track: TrackEstimate, t, r_col: float) -> np.ndarray:
    """Distance from the obstacle centre at times t to the path ahead, minus r_col (≤ 0: obstructing)."""
    q = track.predict_positions(np.atleast_1d(np.asarray(t, dtype=float)))
    _, dist = ctx.path.closest_points(q, ctx.gamma_now, ctx.path.length)
    return dist - r_col


def _bisect_time(f, t_in: float, t_out: float, tol: float = 1e-6) -> float:
    """Boundary between t_in (f ≤ 0) and t_out (f > 0)."""
    for _ in range(100):
        if abs(t_out - t_in) <= tol:
            break
        mid = 0.5 * (t_in + t_out)
        if f(mid) <= 0.0:
            t_in = mid
        else:
            t_out = mid
    return 0.5 * (t_in + t_out)


def _obstruction_interval(ctx: _Context, track, t_c: float, r_col: float, static: bool):
    """[t_i, t_f] ∋ t_c: the continuous span during which the inflated disc meets the path ahead."""
    cfg = ctx.config
    if static:
        return ctx.t_now, float("inf"), False

    def f(t):
        return float(_path_gap(ctx, track, t, r_col)[0])

    dt = cfg.time_step_s
    # Backwards from t_c to t_now.
    back = np.arange(t_c, ctx.t_now - 1e-12, -dt)
    back = np.append(back, ctx.t_now) if back[-1] > ctx.t_now else back
    gb = _path_gap(ctx, track, back, r_col)
    out = np.flatnonzero(gb > 0.0)
    t_i = ctx.t_now if out.size == 0 else _bisect_time(f, back[out[0] - 1] if out[0] > 0 else t_c, back[out[0]])
    # Forwards from t_c, far enough to decide σ (at least Δt_threshold past t_i).
    horizon = max(ctx.t_end, t_i + cfg.obstruction_threshold_s) + dt
    fwd = np.arange(t_c, horizon + 1e-12, dt)
    gf = _path_gap(ctx, track, fwd, r_col)
    out = np.flatnonzero(gf > 0.0)
    if out.size == 0:
        return t_i, float(fwd[-1]), True
    t_f = _bisect_time(f, fwd[out[0] - 1] if out[0] > 0 else t_c, fwd[out[0]])
    return t_i, t_f, False


def _obstructed_stretch(ctx: _Context, track, t_i, t_f, gamma_c, r_col, static):
    """[γ_A, γ_B]: the connected stretch of the path ahead that contains γ(t_c) and is covered
    by the union of the inflated discs over [t_i, t_f]."""
    path = ctx.path
    h = min(0.25, r_col / 20.0) if r_col > 0 else 0.25
    if static or track.speed_m_s == 0.0:
        q = track.predict_positions(np.array([ctx.t_now]))
    else:
        n_t = int(np.clip(np.ceil(track.speed_m_s * (t_f - t_i) / h), 1, 4000)) + 1
        q = track.predict_positions(np.linspace(t_i, t_f, n_t))
    g_lo, g_hi = ctx.gamma_now, path.length
    n_s = int(np.ceil((g_hi - g_lo) / h)) + 1
    gs = np.linspace(g_lo, g_hi, max(n_s, 2))
    pts = path.point(gs)
    # Only path samples near the swept area's bounding box need the full distance matrix.
    bb_lo, bb_hi = q.min(axis=0) - r_col, q.max(axis=0) + r_col
    near = np.all((pts >= bb_lo) & (pts <= bb_hi), axis=1)
    covered = np.zeros(gs.size, dtype=bool)
    idx = np.flatnonzero(near)

    def min_dist(p):
        """Distance from points p (m, 2) to the obstacle's trajectory, a polyline through q
        (exact for straight motion; the chord sagitta h²/8ρ for a turning one)."""
        if q.shape[0] == 1:
            return np.hypot(*(p - q[0]).T)
        a, ab = q[:-1], np.diff(q, axis=0)
        ab2 = np.maximum(np.sum(ab**2, axis=1), 1e-300)
        rel = p[:, None, :] - a[None, :, :]
        u = np.clip(np.sum(rel * ab, axis=-1) / ab2, 0.0, 1.0)
        return np.sqrt(np.min(np.sum((rel - u[..., None] * ab) ** 2, axis=-1), axis=1))

    chunk = max(1, 400_000 // q.shape[0])
    for c in range(0, idx.size, chunk):
        sel = idx[c : c + chunk]
        covered[sel] = min_dist(pts[sel]) <= r_col
    if not covered.any():  # cannot happen after a collision unless the disc only grazes the path
        return gamma_c, gamma_c
    k = int(np.argmin(np.where(covered, np.abs(gs - gamma_c), np.inf)))
    a = k
    while a > 0 and covered[a - 1]:
        a -= 1
    b = k
    while b < gs.size - 1 and covered[b + 1]:
        b += 1

    def f(g):
        return float(min_dist(path.point(np.array([g])))[0] - r_col)

    gamma_a = gs[a] if a == 0 else _bisect_time(f, gs[a], gs[a - 1], tol=1e-6)
    gamma_b = gs[b] if b == gs.size - 1 else _bisect_time(f, gs[b], gs[b + 1], tol=1e-6)
    return float(gamma_a), float(gamma_b)
