"""Many tracks' predicted motion at once: :class:`TrackMotions`, the stacked form of
:meth:`TrackEstimate.predict_positions <mjasc.core.estimates.TrackEstimate.predict_positions>`.

Collision prediction needs every track's position on the window's time grid and, for refining
the closest approaches, at a few more times per track. One :class:`TrackMotions` holds the
parameters of m tracks in arrays and evaluates any (track, time) pairs in one array operation:

- **constant speed and turn** (a :class:`~mjasc.core.estimates.TrackEstimate`; thesis eq. 3.2
  without noise), with τ = t − t₀:

      straight (|ω| < 1e-9):  p(t) = p₀ + v τ (cos θ, sin θ)
      turning:                 p(t) = p₀ + (v/ω) (sin(θ + ωτ) − sin θ, cos θ − cos(θ + ωτ))
      static (or v = 0):       p(t) = p₀

  (the same formulas in the same operation order as ``predict_positions``: equal to it bit for bit);
- **a team mate's plan** (a :class:`~mjasc.core.estimates.PlannedTrack`: knots (t_k, p_k) of its
  :class:`~mjasc.cooperation.messages.TeamIntention`): linear interpolation between knots, along the
  broadcast velocity before the first knot, along the last segment after the last one (as
  ``TeamIntention.positions``, equal to it bit for bit): its row in the process-wide table of
  stacked plans (:mod:`~mjasc.avoidance.prediction.team_plans`, each distinct intention stacked
  once), evaluated by a compiled loop.

World frame ENU, metres, absolute simulation times [s].
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from mjasc.avoidance.prediction.team_plans import _NO_PLAN_OF, _NO_PLANS, _PLANS, PLAN_FIELDS, intention_positions
from mjasc.core.compiled import kernel, maximum
from mjasc.core.estimates import PlannedTrack, TrackEstimate

__all__ = ["TrackMotions", "intention_positions"]

_STRAIGHT_OMEGA = 1e-9  # |ω| below this: a straight line (as TrackEstimate.predict_positions)
_STRAIGHT_ONLY = [0]  # TrackMotions._kinds of straight or static rows only
_NO_ANGLES = np.empty(0)  # (the sines and cosines of no turning row: never read)


class TrackMotions:
    """The predicted motion of ``tracks`` (a sequence of TrackEstimate / PlannedTrack), row k for
    ``tracks[k]``. :meth:`at` evaluates positions of rows at times in one array operation per
    kind of motion (straight or static, turning, plan)."""

    __slots__ = ("n", "radius_m", "_par", "_kind", "_kinds", "_pl", "_plan_of")

    _STRAIGHT, _TURN, _PLAN = 0, 1, 2

    def __init__(self, tracks: Sequence[TrackEstimate]):
        m = self.n = len(tracks)
        plan = np.array([isinstance(tr, PlannedTrack) for tr in tracks], dtype=bool).reshape(m)
        # A plan's motion is its intention's: its other numbers are not read (zeros).
        a = np.array([(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, tr.radius_m) if p else
                      (tr.position_m[0], tr.position_m[1], tr.time_s, tr.speed_m_s, tr.heading_rad,
                       tr.turn_rate_rad_s, tr.is_static, 0.0, tr.radius_m) for tr, p in zip(tracks, plan.tolist())],
                     dtype=float).reshape(m, 9)
        self.radius_m = a[:, 8]  # each track's radius [m] (m,)
        # Columns: x₀, y₀, t₀, v, cos θ, sin θ, θ, ω, v/ω (turning tracks) and the kinds in one
        # compiled pass (math's cos and sin: numpy's bits here, docs/architecture.md).
        par = self._par = np.empty((m, 9))
        kind = self._kind = np.empty(m, dtype=np.int64)
        present = _motion_table(a, plan, par, kind)
        self._kinds = [g for g in (self._STRAIGHT, self._TURN, self._PLAN) if present >> g & 1]
        self._pl = self._plan_of = None
        if present >> self._PLAN & 1:  # each distinct intention's knots stacked once for the fleet (_PLANS)
            self._plan_of = np.full(m, -1, dtype=np.intp)
            sel = plan.ravel().nonzero()[0]
            self._pl, self._plan_of[sel] = _PLANS.rows([tracks[k].intention for k in sel.tolist()])

    def at(self, rows, times) -> np.ndarray:
        """Positions (P, K, 2) [m] of tracks ``rows`` (P,) at absolute ``times`` (P, K) — each row
        its own times — or (K,) — the same times for every row [s]."""
        rows = np.asarray(rows, dtype=np.intp)
        times = np.asarray(times, dtype=float)
        P = rows.shape[0]
        K = times.shape[-1]
        if len(self._kinds) == 1:
            return self._eval(self._kinds[0], rows, times, P, K)
        out = np.empty((P, K, 2))
        kind = self._kind[rows]
        for g in self._kinds:
            sel = (kind == g).ravel().nonzero()[0]
            if sel.size:
                out[sel] = self._eval(g, rows[sel], times if times.ndim == 1 else times[sel], sel.size, K)
        return out

    def farther_than(self, rows, times, positions_m, distance_m: float) -> bool:
        """Whether some track ``rows[k]`` (P,) at its time ``times[k]`` [s] is farther than
        ``distance_m`` [m] from ``positions_m[k]`` (P, 2): ``np.hypot`` of :meth:`at`'s positions
        minus the given ones ``> distance_m``, any. Without a plan among the rows in one compiled
        pass (:meth:`at`'s operations in its order, the turning rows' sine and cosine by ``math``,
        whose bits are numpy's here: docs/architecture.md, compiled kernels); with a plan,
        :meth:`at` itself."""
        rows = np.asarray(rows, dtype=np.intp)
        times = np.asarray(times, dtype=float)
        pos = np.asarray(positions_m, dtype=float)
        limit = float(distance_m)
        code = _farther(self._par, self._kind, rows, times, pos, limit)
        if code >= 0:
            return code == 1
        pred = self.at(rows, times[:, None])[:, 0]
        return bool((np.hypot(pred[:, 0] - pos[:, 0], pred[:, 1] - pos[:, 1]) > limit).any())

    def farther_by_id(self, row_ids, ids, times, positions_m, distance_m: float) -> bool | None:
        """:meth:`farther_than` of the tracks whose ids are known: ``row_ids`` (m,) int64 is each
        row's track id (an id on several rows: the last), ``ids`` (P,) int64 the tracks' ids, ``times`` (P,) [s] and
        ``positions_m`` (P, 2) [m] theirs; a track whose id no row has is skipped (False when
        none is known). One compiled pass (the id look-ups and :func:`_farther`'s operations);
        None when a known row follows a plan (then :meth:`farther_than` of the known rows)."""
        code = _farther_ids(self._par, self._kind, row_ids, ids, times, positions_m, float(distance_m))
        return None if code < 0 else code == 1

    def within(self, times, positions_m, radii_m) -> np.ndarray:
        """Whether each track lay at each of the times ``times`` (H,) [s] within reach of the
        positions ``positions_m`` (H, 2) [m]: (m, H) bool, ``np.hypot`` of :meth:`at`'s positions
        (every row at every time) minus ``positions_m`` ``<= np.maximum(radii_m, radius_m)``, with
        ``radii_m`` (H,) [m] and each track's own ``radius_m``. Without a plan among the rows in two
        compiled passes around numpy's sin and cos of the turning rows' angles (the array
        :meth:`at` hands them, those (row, time) pairs in order: the same bits) and :meth:`at`'s
        operations in its order; with a plan, :meth:`at` itself."""
        times = np.ascontiguousarray(times, dtype=float)
        pos = np.ascontiguousarray(positions_m, dtype=float).reshape(-1, 2)
        radii = np.ascontiguousarray(radii_m, dtype=float)
        m, h = self.n, times.size
        if self._kinds == _STRAIGHT_ONLY:  # no turning row, no plan: no angle to take (one compiled pass)
            out = np.empty((m, h), dtype=np.bool_)
            _grid_within(self._par, self._kind, times, pos, radii, self.radius_m, _NO_ANGLES, _NO_ANGLES, out)
            return out
        if self._PLAN not in self._kinds:
            angles = np.empty(m * h)
            n_turn = _grid_angles(self._par, self._kind, times, angles)
            th = angles[:n_turn]
            out = np.empty((m, h), dtype=np.bool_)
            _grid_within(self._par, self._kind, times, pos, radii, self.radius_m, np.sin(th), np.cos(th), out)
            return out
        back = self.at(np.arange(m), times)  # (m, H, 2)
        return np.hypot(back[..., 0] - pos[:, 0], back[..., 1] - pos[:, 1]) <= np.maximum(radii, self.radius_m[:, None])

    def kernel_arrays(self) -> tuple:
        """The motions as compiled kernels read them (:mod:`~mjasc.avoidance.prediction.zoom_motion`):
        (the table (m, 9) (columns x₀, y₀, t₀, v, cos θ, sin θ, θ, ω, v/ω), each row's kind (m,) (0
        straight or static, 1 turning, 2 plan), each row's plan (m,) (−1: none), the plans' arrays
        (:data:`~mjasc.avoidance.prediction.team_plans.PLAN_FIELDS` of a stacked plans table; empty without a plan)). Not to be written."""
        if self._pl is None:
            return self._par, self._kind, _NO_PLAN_OF, _NO_PLANS
        return self._par, self._kind, self._plan_of, tuple(getattr(self._pl, f) for f in PLAN_FIELDS)

    def grid(self, times) -> np.ndarray:
        """Positions (m, n, 2) of every track on the time grid ``times`` (n,) [s]."""
        return self.at(np.arange(self.n), np.asarray(times, dtype=float))

    def _eval(self, kind, rows, times, P, K) -> np.ndarray:
        out = np.empty((P, K, 2))
        if kind == self._PLAN:
            t = (times if times.shape == (P, K) else np.broadcast_to(times, (P, K))).ravel()
            return self._pl.at(np.repeat(self._plan_of[rows], K), t).reshape(P, K, 2)
        par = self._par[rows]
        x0, y0, t0 = par[:, 0:1], par[:, 1:2], par[:, 2:3]
        tau = times - t0
        if kind == self._STRAIGHT:  # x₀ + (v τ) cos θ: the order of predict_positions
            v_tau = par[:, 3:4] * tau
            out[..., 0] = x0 + v_tau * par[:, 4:5]
            out[..., 1] = y0 + v_tau * par[:, 5:6]
        else:
            th_t = par[:, 6:7] + par[:, 7:8] * tau
            r = par[:, 8:9]
            out[..., 0] = x0 + r * (np.sin(th_t) - par[:, 5:6])
            out[..., 1] = y0 - r * (np.cos(th_t) - par[:, 4:5])
        return out


@kernel
def _motion_table(a, plan, par, kind):
    """:class:`TrackMotions`' table from the tracks' numbers ``a`` (m, 9) = (x₀, y₀, t₀, v, θ, ω,
    static, plan, radius) and ``plan`` (m,): a track moves unless static, at v = 0 or a plan, and
    v, θ, ω are multiplied by 1 or 0 as numpy multiplies by the bool (θ·0 may be −0, NaN·0 NaN);
    turning when |ω| ≥ 1e-9. Writes par's columns (cos θ and sin θ of θ as numpy's cos and sin
    of the θ column give them), the kind (0 straight or static, 1 turning, 2 plan) into ``kind``;
    returns the kinds present as bits."""
    present = 0
    for i in range(a.shape[0]):
        moving = not (a[i, 6] != 0.0 or a[i, 3] == 0.0 or plan[i])
        f = 1.0 if moving else 0.0
        v, t, w = a[i, 3] * f, a[i, 4] * f, a[i, 5] * f
        turn = abs(w) >= _STRAIGHT_OMEGA
        par[i, 0], par[i, 1], par[i, 2], par[i, 3] = a[i, 0], a[i, 1], a[i, 2], v
        par[i, 6], par[i, 7] = t, w
        par[i, 8] = v / (w if turn else 1.0)
        par[i, 4], par[i, 5] = math.cos(t), math.sin(t)
        k = 2 if plan[i] else (1 if turn else 0)
        kind[i] = k
        present |= 1 << k
    return present


@kernel
def _row_at(par, r, turning, t, sin_t, cos_t):
    """Row ``r``'s position (x, y) [m] at time ``t``: turning x₀ + (v/ω)(sin θ(t) − sin θ),
    y₀ − (v/ω)(cos θ(t) − cos θ) with ``sin_t``, ``cos_t`` its sin θ(t), cos θ(t); straight
    or static x₀ + (v τ) cos θ, y₀ + (v τ) sin θ (τ = t − t₀) — :meth:`TrackMotions._eval`'s
    operations, for the compiled checks below."""
    if turning:
        return par[r, 0] + par[r, 8] * (sin_t - par[r, 5]), par[r, 1] - par[r, 8] * (cos_t - par[r, 4])
    v_tau = par[r, 3] * (t - par[r, 2])
    return par[r, 0] + v_tau * par[r, 4], par[r, 1] + v_tau * par[r, 5]


@kernel
def _position(par, kind, r, t):
    """Row ``r`` (straight, static or turning) at time ``t``: :func:`_row_at` with the turning
    row's sin θ(t), cos θ(t) by ``math`` (θ(t) = θ₀ + ω τ, τ = t − t₀)."""
    if kind[r] == 1:
        th = par[r, 6] + par[r, 7] * (t - par[r, 2])
        return _row_at(par, r, True, t, math.sin(th), math.cos(th))
    return _row_at(par, r, False, t, 0.0, 0.0)


@kernel
def _farther(par, kind, rows, times, pos, limit):
    """:meth:`TrackMotions.farther_than` without plans: 1 when a row's position at its time lies
    farther than ``limit`` from ``pos`` (``hypot``), else 0; −1 when a row follows a plan. Straight
    (or static) rows x₀ + (v τ) cos θ, y₀ + (v τ) sin θ (τ = t − t₀), turning rows
    x₀ + (v/ω)(sin θ(t) − sin θ), y₀ − (v/ω)(cos θ(t) − cos θ), θ(t) = θ₀ + ω τ
    (:meth:`TrackMotions._eval`'s operations)."""
    for i in range(rows.size):
        if kind[rows[i]] == 2:
            return -1
    for i in range(rows.size):
        x, y = _position(par, kind, rows[i], times[i])
        if math.hypot(x - pos[i, 0], y - pos[i, 1]) > limit:
            return 1
    return 0


@kernel
def _row_of(row_ids, track_id):
    """The last row whose id is ``track_id`` (as a mapping id → row filled in row order), −1 when
    none."""
    for r in range(row_ids.size - 1, -1, -1):
        if row_ids[r] == track_id:
            return r
    return -1


@kernel
def _farther_ids(par, kind, row_ids, ids, times, pos, limit):
    """:meth:`TrackMotions.farther_by_id`: :func:`_farther` of the rows whose ids are among ``ids``
    (each at its track's time and against its position; the others skipped): 1, 0, or −1 when one
    of those rows follows a plan."""
    for i in range(ids.size):
        r = _row_of(row_ids, ids[i])
        if r >= 0 and kind[r] == 2:
            return -1
    for i in range(ids.size):
        r = _row_of(row_ids, ids[i])
        if r < 0:
            continue
        x, y = _position(par, kind, r, times[i])
        if math.hypot(x - pos[i, 0], y - pos[i, 1]) > limit:
            return 1
    return 0


@kernel
def _grid_angles(par, kind, times, out):
    """The angles θ₀ + ω τ (τ = t − t₀) of every turning row at every time of ``times`` (H,), row
    by row, into ``out`` (:meth:`TrackMotions._eval`'s operations); returns how many."""
    n = 0
    for r in range(kind.size):
        if kind[r] == 1:
            for j in range(times.size):
                out[n] = par[r, 6] + par[r, 7] * (times[j] - par[r, 2])
                n += 1
    return n


@kernel
def _grid_within(par, kind, times, pos, radii, radius, sin_t, cos_t, out):
    """:meth:`TrackMotions.within` without plans into ``out`` (m, H): each row's position at each
    time (as :func:`_farther`: straight or static x₀ + (v τ) cos θ, turning x₀ + (v/ω)(sin θ(t) −
    sin θ) with ``sin_t``, ``cos_t`` of :func:`_grid_angles`' angles in order), ``hypot`` to
    ``pos[j]`` ``<= maximum(radii[j], radius[row])`` (numpy's maximum: NaN propagates)."""
    n = 0
    for r in range(kind.size):
        turning = kind[r] == 1
        for j in range(times.size):
            if turning:
                x, y = _row_at(par, r, True, times[j], sin_t[n], cos_t[n])
                n += 1
            else:
                x, y = _row_at(par, r, False, times[j], 0.0, 0.0)
            out[r, j] = math.hypot(x - pos[j, 0], y - pos[j, 1]) <= maximum(radii[j], radius[r])
