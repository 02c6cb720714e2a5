"""The closest-approach zoom's relative motion in compiled passes: one zoom level of many (vessel,
track) pairs in two kernel calls around numpy's sin and cos, instead of the readable ``rel_at``'s
few dozen numpy calls (:func:`mjasc.avoidance.prediction.cpa.closest_approaches`, step 3).

A level samples every zooming bracket at K times and needs r(t) = P_o(t) − P_v(t) there: the
track's position (:class:`~mjasc.avoidance.prediction.motion.TrackMotions`: straight or static,
turning, or a team mate's plan) minus the vessel's, path(clip(γ(t), 0, L)) on its own path (a
:class:`~mjasc.guidance.stacked_paths.StackedPaths` row, or one :class:`~mjasc.guidance.paths.Path`).
:func:`level_angles` writes the sample times, each vessel's γ, segment and local arc length, and
in walk order the angles whose sine and cosine the positions need (a turning track's θ₀ + ω τ, an
arc's θ₀ + κ s); numpy evaluates ``np.sin`` and ``np.cos`` of them (trigonometry on arrays stays
numpy's); :func:`level_relative` writes r and runs the level's minimum search
(:func:`~mjasc.avoidance.prediction.cpa._zoom_level`).

Bits: every position is the expression of the readable form in its order (``TrackMotions._eval``,
:func:`~mjasc.avoidance.prediction.team_plans.plan_position`, ``StackedPaths.point`` /
``Path.point`` with ``eval_points``, γ = γ_now + v (t − t_now) as ``gamma_of_time`` writes it);
a vessel whose speed is not constant has its γ(t) from its own Python γ function first (each
sample's γ depends on its time only). ``tests/test_zoom_kernels.py`` runs the zoom both ways on
real runs, bit for bit.
"""

from __future__ import annotations

import numpy as np

from mjasc.avoidance.prediction.cpa import _zoom_level, _zoom_samples
from mjasc.avoidance.prediction.team_plans import plan_between, plan_position, walk_knots
from mjasc.core.compiled import kernel, maximum, minimum
from mjasc.guidance.segment_geometry import COS0, SIN0, TH0, X0, Y0, C, K

__all__ = ["ZoomMotion", "level_angles", "level_relative"]


class ZoomMotion:
    """The relative motion r(t) of P (vessel, track) pairs for the zoom, as arrays: ``rel_at`` (the
    readable form, pairs (k,), times (k, J) → (k, J, 2)) is kept for calls; :meth:`level` is one
    zoom level compiled.

    motions: the tracks' :class:`~mjasc.avoidance.prediction.motion.TrackMotions`; rows (P,) each
    pair's track row; vessel (P,) each pair's vessel; path_arrays: (segment table, first column
    (n,), segment count (n,), length (n,)) of the vessels' paths; steady (n,) whether vessel i
    moves at the constant speed v_q[i] from γ g_now[i] at t_now[i]; gamma_at(v, t): the vessels'
    γ (k, J) at times t (k, J), used when one is not steady."""

    __slots__ = ("rel_at", "_track", "_vessel", "_paths", "_motion", "_all_steady", "_steady", "_gamma_at")

    def __init__(self, rel_at, motions, rows, vessel, path_arrays, steady, g_now, v_q, t_now, gamma_at):
        self.rel_at = rel_at
        self._track, self._vessel = rows, vessel
        self._paths = tuple(path_arrays)
        self._motion = motions.kernel_arrays()
        self._steady = (np.asarray(g_now, dtype=float), np.asarray(v_q, dtype=float), np.asarray(t_now, dtype=float))
        self._all_steady = bool(np.all(steady))
        self._gamma_at = gamma_at

    def __call__(self, pairs, t) -> np.ndarray:
        """``rel_at(pairs, t)``: the readable form (the compiled levels' reference)."""
        return self.rel_at(pairs, t)

    def level(self, pairs, a, b, act, frac, final, tol, t_out, d_out, keep) -> int:
        """One zoom level (``cpa._zoom``'s loop body) of the items ``act`` of ``pairs``: sample the
        brackets [a, b], r at the samples, the level's minimum search and new brackets
        (:func:`~mjasc.avoidance.prediction.cpa._zoom_level`); returns how many items go on."""
        k, J = act.size, frac.size
        ts = np.empty((k, J))
        rows, vessel = self._track, self._vessel
        table, first, count, length = self._paths
        par, kind, plan_of, plans = self._motion
        g_now, v_q, t_now = self._steady
        seg = np.empty((k, J), dtype=np.intp)
        s_loc = np.empty((k, J))
        angles = np.empty(2 * k * J)
        if self._all_steady:
            g_in = s_loc  # (not read)
        else:
            _zoom_samples(a, b, act, frac, ts)
            g_in = np.ascontiguousarray(self._gamma_at(vessel[pairs[act]], ts), dtype=float)
        n = level_angles(self._all_steady, a, b, act, frac, ts, pairs, rows, vessel, g_now, v_q, t_now, g_in, table,
                         first, count, length, par, kind, seg, s_loc, angles)
        th = angles[:n]
        sin_a, cos_a = np.sin(th), np.cos(th)
        r = np.empty((k, J, 2))
        return level_relative(act, ts, pairs, rows, seg, s_loc, table, par, kind, sin_a, cos_a, plan_of, *plans, r,
                              a, b, final, tol, t_out, d_out, keep)


@kernel
def level_angles(sample, a, b, act, frac, ts, pairs, rows, vessel, g_now, v_q, t_now, g_in, table, first, count, length,
                 par, kind, seg, s_loc, angles):
    """The first pass of a level (module docstring): with ``sample``, the sample times into ``ts``
    (k, J) (``cpa._zoom_samples``' expressions) and each vessel's γ = g_now + v_q (t − t_now) (else
    γ from ``g_in`` (k, J)); γ clamped to [0, L] (``np.minimum(np.maximum(γ, 0), L)``), its
    segment (the last of the path's block starting at or before γ, as ``StackedPaths``'
    ``_segment_of``) into ``seg`` and local arc length γ − C into ``s_loc``; item i is pair
    ``p = pairs[act[i]]`` of track ``rows[p]`` and vessel ``vessel[p]``. Into ``angles``, in walk
    order (item, sample; the track's before the vessel's), a turning track's θ₀ + ω (t − t₀) and an
    arc's θ₀ + κ s. Returns how many angles."""
    n = 0
    J = frac.shape[0]
    for i in range(act.shape[0]):
        e = act[i]
        if sample:  # (_samples' expressions)
            lo = a[e]
            span = b[e] - lo
            for q in range(J):
                ts[i, q] = lo + span * frac[q]
        r = rows[pairs[e]]
        v = vessel[pairs[e]]
        lo0, cnt = first[v], count[v]
        for q in range(J):
            t = ts[i, q]
            if kind[r] == 1:
                angles[n] = par[r, 6] + par[r, 7] * (t - par[r, 2])
                n += 1
            g = g_now[v] + v_q[v] * (t - t_now[v]) if sample else g_in[i, q]
            g = minimum(maximum(g, 0.0), length[v])
            lo, hi = lo0, lo0 + cnt
            while lo < hi:
                mid = (lo + hi) >> 1
                if table[C, mid] <= g:
                    lo = mid + 1
                else:
                    hi = mid
            j = min(max(lo - 1, lo0), lo0 + cnt - 1)
            s = g - table[C, j]
            seg[i, q] = j
            s_loc[i, q] = s
            if table[K, j] != 0.0:
                angles[n] = table[TH0, j] + table[K, j] * s
                n += 1
    return n


@kernel
def level_relative(act, ts, pairs, rows, seg, s_loc, table, par, kind, sin_a, cos_a, plan_of, p_ts, p_xs, p_ys,
                   p_start, p_count, p_first, p_last_t, p_anchor, p_t_anchor, p_vel, p_last, p_v_end, r, a, b, final,
                   tol, t_out, d_out, keep):
    """The second pass of a level: r (k, J, 2) = track − vessel position at the samples, with the
    sines and cosines of :func:`level_angles`' angles in its walk order (straight or static track
    x₀ + (v τ) cos θ; turning x₀ + (v/ω)(sin θ(t) − sin θ), y₀ − (v/ω)(cos θ(t) − cos θ); a plan
    :func:`plan_position`, its knot interval found by
    :func:`~mjasc.avoidance.prediction.team_plans.walk_knots` along a pair's rising samples; the
    vessel on a line X0 + s cos θ₀, on an arc X0 + (sin θ − sin θ₀)/κ, Y0 + (cos θ₀ − cos θ)/κ), then
    :func:`~mjasc.avoidance.prediction.cpa._zoom_level`: its result."""
    n = 0
    run, checked, sorted_run, lo, t_lo = -1, False, False, 0, 0.0  # (team_plans.walk_knots' run)
    for i in range(act.shape[0]):
        e = act[i]
        o = rows[pairs[e]]
        ko = kind[o]
        for q in range(ts.shape[1]):
            t = ts[i, q]
            if ko == 1:
                ox = par[o, 0] + par[o, 8] * (sin_a[n] - par[o, 5])
                oy = par[o, 1] - par[o, 8] * (cos_a[n] - par[o, 4])
                n += 1
            elif ko == 0:
                v_tau = par[o, 3] * (t - par[o, 2])
                ox = par[o, 0] + v_tau * par[o, 4]
                oy = par[o, 1] + v_tau * par[o, 5]
            else:
                pl = plan_of[o]
                if t < p_first[pl] or t >= p_last_t[pl] or t != t:  # (before, after its knots, NaN)
                    ox, oy = plan_position(pl, t, p_ts, p_xs, p_ys, p_start, p_count, p_first, p_last_t, p_anchor,
                                           p_t_anchor, p_vel, p_last, p_v_end)
                else:  # (a pair's samples rise: walk along the plan's knots)
                    lo, checked, sorted_run = walk_knots(p_ts, t, p_start[pl], p_start[pl] + p_count[pl], pl == run,
                                                         checked, sorted_run, lo, t_lo)
                    run, t_lo = pl, t
                    ox, oy = plan_between(pl, t, lo, p_ts, p_xs, p_ys, p_start, p_count)
            j = seg[i, q]
            kj = table[K, j]
            if kj != 0.0:
                px = table[X0, j] + (sin_a[n] - table[SIN0, j]) / kj
                py = table[Y0, j] + (table[COS0, j] - cos_a[n]) / kj
                n += 1
            else:
                s = s_loc[i, q]
                px = table[X0, j] + s * table[COS0, j]
                py = table[Y0, j] + s * table[SIN0, j]
            r[i, q, 0] = ox - px
            r[i, q, 1] = oy - py
    return _zoom_level(r, ts, act, a, b, final, tol, t_out, d_out, keep)
