"""Spatial correlation of collision prediction: when and where a predicted collision obstructs the
vessel's path (docs/thesis.md §3, step 3; thesis §3.2.2). Runs only for a pair with a predicted
collision at t_c. World frame ENU, SI units, absolute simulation times [s].

- **Obstruction interval** Δt_o = [t_i, t_f] ∋ t_c: the continuous span during which the
  obstacle's inflated disc (radius R_col = R_vh + R_ob + safety) meets the vessel's path ahead
  (γ ≥ γ_now): the gap g(t) = dist(P_o(t), path ahead) − R_col is sampled every grid step back to
  t_now and forward to max(window end, t_i + Δt_threshold), and each sign change is located by
  bisection to 1e-6 s (its midpoints evaluated 31 at a time, :func:`_bisect`; for a track at
  constant speed and turn in one compiled call, :mod:`~mjasc.avoidance.prediction.spatial_kernels`).
  A static obstacle obstructs for ever: t_f = +inf.
- **Obstructed stretch** [γ_A, γ_B]: the connected stretch of the path ahead that contains γ(t_c)
  and is covered by the union of the inflated discs over [t_i, t_f]: path samples every
  h = min(0.25 m, R_col/20) against the obstacle's trajectory as a polyline of steps ≤ h (exact for
  straight motion; within the chord sagitta h²/8ρ for a turning one; the distances in a compiled
  loop, :mod:`~mjasc.avoidance.prediction.sweep_kernels`), ends located by the same bisection to
  1e-6 m (compiled on a :class:`~mjasc.guidance.paths.Path`, :mod:`~mjasc.avoidance.prediction.spatial_kernels`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from mjasc.avoidance.prediction.config import CollisionPredictionConfig
from mjasc.avoidance.prediction.path_distance import path_distances
from mjasc.avoidance.prediction.spatial_kernels import interval_end, stretch_end
from mjasc.avoidance.prediction.sweep_kernels import polyline_distances
from mjasc.core.compiled import clip_float
from mjasc.core.estimates import TrackEstimate
from mjasc.guidance.paths import Path

__all__ = ["PlanContext", "obstruction_interval", "obstructed_stretch"]


@dataclass(frozen=True)
class PlanContext:
    """The vessel's plan a prediction runs on: its path, γ and time now, the window's end, γ(t)
    (absolute times in, γ [m] out, not clamped), its radius R_vh [m] and the prediction config."""

    path: Path
    gamma_now: float
    t_now: float
    t_end: float
    gamma_fn: Callable
    r_vh: float
    config: CollisionPredictionConfig

    def vessel_at(self, t):
        """P_v(t) = path(clip(γ(t), 0, L)): (..., 2) [m] at absolute times t (...) [s]."""
        g = self.gamma_fn(np.atleast_1d(np.asarray(t, dtype=float)))
        return self.path.point(np.minimum(np.maximum(g, 0.0), self.path.length))


def _path_gap(ctx: PlanContext, track: TrackEstimate, t, r_col: float) -> np.ndarray:
    """Distance from the obstacle centre at times t to the path ahead, minus r_col (≤ 0: obstructing)."""
    q = track.predict_positions(np.atleast_1d(np.asarray(t, dtype=float)))
    return path_distances(ctx.path, q, ctx.gamma_now) - r_col  # (closest_points' distances, far segments skipped)


_TREE_DEPTH = 5  # bisection steps decided per vectorized evaluation


def _bisect(f, t_in: float, t_out: float, tol: float = 1e-6) -> float:
    """Boundary between t_in (f ≤ 0) and t_out (f > 0) by bisection to ``tol`` — the same steps and
    the same result as evaluating f at one midpoint per step, with f (vectorized) evaluated once per
    5 steps on every midpoint those steps can visit (a binary tree of 31; a 0.5 s bracket takes
    4 evaluations instead of 19)."""
    steps = 0
    while steps < 100 and abs(t_out - t_in) > tol:
        mids, level = [], [(t_in, t_out)]
        for _ in range(_TREE_DEPTH):  # breadth first: node j's children are 2j (f ≤ 0) and 2j + 1
            nxt = []
            for a, b in level:
                m = 0.5 * (a + b)
                mids.append(m)
                nxt += [(m, b), (a, m)]
            level = nxt
        vals = f(np.array(mids))
        j = 0
        for depth in range(_TREE_DEPTH):
            if steps >= 100 or abs(t_out - t_in) <= tol:
                break
            k = (1 << depth) - 1 + j
            if vals[k] <= 0.0:
                t_in, j = mids[k], 2 * j
            else:
                t_out, j = mids[k], 2 * j + 1
            steps += 1
    return 0.5 * (t_in + t_out)


def obstruction_interval(ctx: PlanContext, track, t_c: float, r_col: float, static: bool):
    """[t_i, t_f] ∋ t_c: the continuous span during which the inflated disc meets the path ahead."""
    cfg = ctx.config
    if static:
        return ctx.t_now, float("inf"), False

    def f(t):
        return _path_gap(ctx, track, t, r_col)

    end = _interval_bisection(ctx, track, r_col, f)
    dt = cfg.time_step_s
    # Backwards from t_c to t_now.
    back = np.arange(t_c, ctx.t_now - 1e-12, -dt)
    back = np.append(back, ctx.t_now) if back[-1] > ctx.t_now else back
    gb = _path_gap(ctx, track, back, r_col)
    out = (gb > 0.0).ravel().nonzero()[0]
    t_i = ctx.t_now if out.size == 0 else end(back[out[0] - 1] if out[0] > 0 else t_c, back[out[0]])
    # Forwards from t_c, far enough to decide σ (at least Δt_threshold past t_i).
    horizon = max(ctx.t_end, t_i + cfg.obstruction_threshold_s) + dt
    fwd = np.arange(t_c, horizon + 1e-12, dt)
    gf = _path_gap(ctx, track, fwd, r_col)
    out = (gf > 0.0).ravel().nonzero()[0]
    if out.size == 0:
        return t_i, float(fwd[-1]), True
    t_f = end(fwd[out[0] - 1] if out[0] > 0 else t_c, fwd[out[0]])
    return t_i, t_f, False


def obstructed_stretch(ctx: PlanContext, track, t_i, t_f, gamma_c, r_col, static):
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
    idx = near.ravel().nonzero()[0]

    def min_dist(p):
        """Distance from points p (m, 2) to the obstacle's trajectory, a polyline through q
        (exact for straight motion; the chord sagitta h²/8ρ for a turning one)."""
        if q.shape[0] == 1:
            return np.hypot(*(p - q[0]).T)
        return polyline_distances(p, q)

    covered[idx] = min_dist(pts[idx]) <= r_col
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
        return min_dist(path.point(g)) - r_col

    if q.shape[0] > 1 and type(path) is Path:  # each end in one compiled bisection (spatial_kernels)
        qc = np.ascontiguousarray(q, dtype=float)

        def end(g_in, g_out):
            return stretch_end(path._table, path._cum, path._length, qc, float(r_col), float(g_in), float(g_out), 1e-6)
    else:
        def end(g_in, g_out):
            return _bisect(f, g_in, g_out, tol=1e-6)

    gamma_a = gs[a] if a == 0 else end(gs[a], gs[a - 1])
    gamma_b = gs[b] if b == gs.size - 1 else end(gs[b], gs[b + 1])
    return float(gamma_a), float(gamma_b)


_PREDICT_POSITIONS = TrackEstimate.predict_positions


def _interval_bisection(ctx: PlanContext, track, r_col: float, f):
    """The bisection of the obstruction interval's ends, ``end(t_in, t_out)``: for a track moving
    at constant speed and turn (``TrackEstimate.predict_positions``) one compiled call
    (:func:`~mjasc.avoidance.prediction.spatial_kernels.interval_end`), else :func:`_bisect` of
    the gap ``f``."""
    if type(track).predict_positions is not _PREDICT_POSITIONS:
        return lambda t_in, t_out: _bisect(f, t_in, t_out)
    path = ctx.path
    table, length = path.table, path.length
    g_lo = clip_float(float(ctx.gamma_now), 0.0, length)  # (path_distances' stretch)
    motion = np.array([float(track.position_m[0]), float(track.position_m[1]), track.time_s, track.speed_m_s,
                       track.heading_rad, track.turn_rate_rad_s, 1.0 if track.is_static else 0.0], dtype=float)

    def end(t_in, t_out):
        done, t = interval_end(table, g_lo, length, motion, float(r_col), float(t_in), float(t_out), 1e-6)
        return np.float64(t) if done else _bisect(f, t_in, t_out)  # (the numpy form's type: a numpy float)

    return end
