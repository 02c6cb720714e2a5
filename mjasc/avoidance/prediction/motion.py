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
  ``TeamIntention.positions``, equal to it bit for bit). Each distinct intention is stacked once
  for the process in one growing knot table (:class:`_PlanTable`: the fleet's receivers hold the
  same message object, so 50 vessels' copies of a team mate are one plan, stacked when first
  predicted and only looked up after); a compiled loop (:func:`mjasc.core.compiled.kernel`) finds
  each query's knot interval by bisection on its plan's knot times and interpolates.

World frame ENU, metres, absolute simulation times [s].
"""

from __future__ import annotations

import math
import threading
from typing import Sequence

import numpy as np

from mjasc.core.compiled import kernel, maximum, search_right
from mjasc.core.estimates import PlannedTrack, TrackEstimate

__all__ = ["TrackMotions", "intention_positions"]

_STRAIGHT_OMEGA = 1e-9  # |ω| below this: a straight line (as TrackEstimate.predict_positions)


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
        # Columns: x₀, y₀, t₀, v, cos θ, sin θ, θ, ω, v/ω (turning tracks); all but cos θ and sin θ
        # (numpy's, of the θ column as its own array) and the kinds in one compiled pass.
        par = self._par = np.empty((m, 9))
        th = np.empty(m)
        kind = self._kind = np.empty(m, dtype=np.int64)
        present = _motion_table(a, plan, par, th, kind)
        par[:, 4], par[:, 5] = np.cos(th), np.sin(th)
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
        minus the given ones ``> distance_m``, any. Without a plan among the rows in two compiled
        passes around numpy's sin and cos of the turning rows' angles — the array :meth:`at` hands
        them (those rows in order), so the same bits — and :meth:`at`'s operations in its order;
        with a plan, :meth:`at` itself."""
        rows = np.asarray(rows, dtype=np.intp)
        times = np.asarray(times, dtype=float)
        pos = np.asarray(positions_m, dtype=float)
        limit = float(distance_m)
        angles = np.empty(rows.size)
        n_turn = _turn_angles(self._par, self._kind, rows, times, angles)
        if n_turn == 0:  # no turning row: no sine or cosine read
            return bool(_farther(self._par, self._kind, rows, times, pos, limit, angles, angles))
        if n_turn > 0:
            th = angles[:n_turn]
            return bool(_farther(self._par, self._kind, rows, times, pos, limit, np.sin(th), np.cos(th)))
        pred = self.at(rows, times[:, None])[:, 0]
        return bool((np.hypot(pred[:, 0] - pos[:, 0], pred[:, 1] - pos[:, 1]) > limit).any())

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
        (:data:`PLAN_FIELDS` of a :class:`_StackedPlans`; empty without a plan)). Not to be written."""
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
def _motion_table(a, plan, par, th, kind):
    """:class:`TrackMotions`' table from the tracks' numbers ``a`` (m, 9) = (x₀, y₀, t₀, v, θ, ω,
    static, plan, radius) and ``plan`` (m,): a track moves unless static, at v = 0 or a plan, and
    v, θ, ω are multiplied by 1 or 0 as numpy multiplies by the bool (θ·0 may be −0, NaN·0 NaN);
    turning when |ω| ≥ 1e-9. Writes par's columns but cos θ and sin θ, θ into ``th``, the kind
    (0 straight or static, 1 turning, 2 plan) into ``kind``; returns the kinds present as bits."""
    present = 0
    for i in range(a.shape[0]):
        moving = not (a[i, 6] != 0.0 or a[i, 3] == 0.0 or plan[i])
        f = 1.0 if moving else 0.0
        v, t, w = a[i, 3] * f, a[i, 4] * f, a[i, 5] * f
        turn = abs(w) >= _STRAIGHT_OMEGA
        par[i, 0], par[i, 1], par[i, 2], par[i, 3] = a[i, 0], a[i, 1], a[i, 2], v
        par[i, 6], par[i, 7] = t, w
        par[i, 8] = v / (w if turn else 1.0)
        th[i] = t
        k = 2 if plan[i] else (1 if turn else 0)
        kind[i] = k
        present |= 1 << k
    return present


def intention_positions(intentions, times) -> np.ndarray:
    """Positions (k, n, 2) [m] of k team mates' intentions
    (:meth:`TeamIntention.positions <mjasc.cooperation.messages.TeamIntention.positions>`, the same
    numbers) at absolute ``times`` (n,) [s], all in one array operation."""
    times = np.asarray(times, dtype=float)
    k, n = len(intentions), times.size
    if k <= 4:  # a small team: each message is compared by one or two receivers, stacking it costs more
        if times.ndim != 1 or not times.flags.c_contiguous:
            return np.stack([it.positions(times) for it in intentions]) if k else np.zeros((0, n, 2))
        out = np.empty((k, n, 2))
        for u, it in enumerate(intentions):  # each one's own arrays in one compiled pass
            ts, pts, pos, vel = it.plan_times_s, it.plan_points_m, it.position_m, it.velocity_m_s
            if (type(ts) is np.ndarray and type(pts) is np.ndarray and type(pos) is np.ndarray
                    and type(vel) is np.ndarray and ts.dtype == pts.dtype == pos.dtype == vel.dtype == np.float64
                    and ts.ndim == 1 and pts.shape == (ts.size, 2) and pos.shape == vel.shape == (2,)):
                _intention_positions(ts, pts, pos, float(it.sent_time_s), vel, times, out[u])
            else:
                out[u] = it.positions(times)
        return out
    plans, rows = _PLANS.rows(intentions)  # each message stacked once for the fleet
    return plans.at(np.repeat(rows, n), np.tile(times, k)).reshape(k, n, 2)


#: The arrays of :class:`_StackedPlans` that :func:`plan_position` reads, in its order.
PLAN_FIELDS = ("ts", "xs", "ys", "start", "count", "t_first", "t_last", "anchor", "t_anchor", "vel", "p_last", "v_end")
_NO_PLAN_OF = np.zeros(0, dtype=np.intp)
_NO_PLANS = (np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp),
             np.zeros(0), np.zeros(0), np.zeros((0, 2)), np.zeros(0), np.zeros((0, 2)), np.zeros((0, 2)),
             np.zeros((0, 2)))


class _StackedPlans:
    """The knots of several plans in one array (see the module docstring), each distinct
    intention once: ``intentions`` (k,), plan u for ``intentions[u]``."""

    def __init__(self, intentions):
        k = len(intentions)
        counts = np.array([it.plan_times_s.size for it in intentions], dtype=np.intp)
        counts[counts < 2] = 0  # fewer than 2 knots: no plan
        has = counts > 0
        ends = np.cumsum(counts)
        self.start, self.count = ends - counts, counts
        with_plan = [it for it, c in zip(intentions, counts) if c]
        self.ts = np.concatenate([it.plan_times_s for it in with_plan]) if with_plan else np.zeros(0)
        pts = np.concatenate([it.plan_points_m for it in with_plan]) if with_plan else np.zeros((0, 2))
        self.xs, self.ys = pts[:, 0].copy(), pts[:, 1].copy()
        first, lastk = (ends - counts)[has], ends[has] - 1
        # Before the first knot: along the broadcast velocity from the first knot (no plan: from
        # the broadcast position at the send time); after the last: along the last segment.
        self.t_first, self.t_last = np.full(k, np.inf), np.full(k, np.inf)
        self.t_first[has], self.t_last[has] = self.ts[first], self.ts[lastk]
        self.anchor = np.array([it.position_m for it in intentions], dtype=float).reshape(-1, 2)
        self.t_anchor = np.array([it.sent_time_s for it in intentions], dtype=float)
        self.anchor[has], self.t_anchor[has] = pts[first], self.ts[first]
        self.vel = np.array([it.velocity_m_s for it in intentions], dtype=float).reshape(-1, 2)
        self.p_last, self.v_end = np.zeros((k, 2)), np.zeros((k, 2))
        self.p_last[has] = pts[lastk]
        self.v_end[has] = (pts[lastk] - pts[lastk - 1]) / \
            np.maximum(self.ts[lastk] - self.ts[lastk - 1], 1e-9)[:, None]

    def at(self, plans, t) -> np.ndarray:
        """Positions (k, 2) of plans ``plans`` (k,) at times ``t`` (k,)."""
        out = np.empty(plans.shape + (2,))
        _plan_positions(plans, t, self.ts, self.xs, self.ys, self.start, self.count, self.t_first, self.t_last,
                        self.anchor, self.t_anchor, self.vel, self.p_last, self.v_end, out)
        return out


class _PlanTable:
    """Every intention's plan stacked once (a :class:`_StackedPlans` that grows): the fleet's
    receivers hold the same message objects, so each message's knots are stacked when it is first
    predicted and every later prediction only looks its row up (id(intention) → (intention, row);
    the intention is held so that its id stays its own). New plans are written into spare room
    (doubled when full: a plan's rows never move while the table lives); when the table holds
    :data:`_MAX_ROWS` plans it starts again empty. Each row holds the numbers ``_StackedPlans``
    makes for that intention alone (they are per intention: the table's layout changes no result)."""

    _MAX_ROWS = 4096
    _KNOTS = ("ts", "xs", "ys")
    _PER_PLAN = ("start", "count", "t_first", "t_last", "anchor", "t_anchor", "vel", "p_last", "v_end")

    def __init__(self):
        self._row: dict[int, tuple] = {}
        self._plans: _StackedPlans | None = None
        self._buf: dict[str, np.ndarray] = {}
        self._n = self._knots = 0  # plans and knots in use
        self._lock = threading.Lock()

    def rows(self, intentions) -> tuple["_StackedPlans", np.ndarray]:
        """(the stacked plans, each intention's row (k,)), stacking those not seen before (one
        caller at a time: runs sharing a process in threads share the table)."""
        with self._lock:
            return self._rows(intentions)

    def _rows(self, intentions) -> tuple["_StackedPlans", np.ndarray]:
        get = self._row.get
        rows = []
        new = []
        for it in intentions:
            e = get(id(it))
            if e is None or e[0] is not it:
                new.append(it)
                rows.append(-1)
            else:
                rows.append(e[1])
        if new:
            if self._n + len(new) > self._MAX_ROWS:  # start again, with this call's intentions
                self._row, self._plans, self._buf, self._n, self._knots = {}, None, {}, 0, 0
                new = intentions
            self._add(new)
            rows = [self._row[id(it)][1] for it in intentions]
        return self._plans, np.array(rows, dtype=np.intp)

    def _add(self, new) -> None:
        distinct = list({id(it): it for it in new}.values())
        part = _StackedPlans(distinct)
        n0, k0 = self._n, self._knots
        n1, k1 = n0 + len(distinct), k0 + part.ts.size
        for names, used, need in ((self._KNOTS, k0, k1), (self._PER_PLAN, n0, n1)):
            for name in names:
                src, buf = getattr(part, name), self._buf.get(name)
                if buf is None or buf.shape[0] < need:
                    grown = np.empty((max(need, 2 * (0 if buf is None else buf.shape[0]), 64),) + src.shape[1:],
                                     dtype=src.dtype)
                    if buf is not None:
                        grown[:used] = buf[:used]
                    buf = self._buf[name] = grown
                buf[used:need] = src + k0 if name == "start" else src
        self._n, self._knots = n1, k1
        view = object.__new__(_StackedPlans)
        for name in self._KNOTS:
            setattr(view, name, self._buf[name][:k1])
        for name in self._PER_PLAN:
            setattr(view, name, self._buf[name][:n1])
        self._plans = view
        for u, it in enumerate(distinct):
            self._row[id(it)] = (it, n0 + u)


_PLANS = _PlanTable()


@kernel
def _plan_positions(plans, t, ts, xs, ys, start, count, t_first, t_last, anchor, t_anchor, vel, p_last, v_end, out):
    """:meth:`_StackedPlans.at` into ``out``: :func:`plan_position` of each item."""
    for i in range(plans.size):
        out[i, 0], out[i, 1] = plan_position(plans[i], t[i], ts, xs, ys, start, count, t_first, t_last, anchor,
                                             t_anchor, vel, p_last, v_end)


@kernel
def plan_position(p, ti, ts, xs, ys, start, count, t_first, t_last, anchor, t_anchor, vel, p_last, v_end):
    """Plan ``p``'s position (x, y) [m] at time ``ti`` [s] in a :class:`_StackedPlans`' arrays: before /
    after / inside its knots, the knot interval by bisection on the plan's own knot times (the last
    knot ≤ t, as ``np.interp``), each coordinate (x_b − x_a) / (t_b − t_a) · (t − t_a) + x_a."""
    if ti < t_first[p]:
        dt = ti - t_anchor[p]
        return anchor[p, 0] + dt * vel[p, 0], anchor[p, 1] + dt * vel[p, 1]
    if ti >= t_last[p]:
        dt = ti - t_last[p]
        return p_last[p, 0] + dt * v_end[p, 0], p_last[p, 1] + dt * v_end[p, 1]
    lo = search_right(ts, ti, start[p], start[p] + count[p])  # the first knot > ti
    j = min(max(lo - 1, start[p]), start[p] + count[p] - 2)
    dt, dtt = ts[j + 1] - ts[j], ti - ts[j]
    return (xs[j + 1] - xs[j]) / dt * dtt + xs[j], (ys[j + 1] - ys[j]) / dt * dtt + ys[j]


@kernel
def _intention_positions(ts, pts, position, sent_time_s, velocity, times, out):
    """:meth:`TeamIntention.positions <mjasc.cooperation.messages.TeamIntention.positions>` of one
    intention (plan knots ``ts`` (k,), ``pts`` (k, 2); broadcast position, send time and velocity)
    at ``times`` (n,) into ``out`` (n, 2), its operations in its order: fewer than two knots, along
    the broadcast velocity from the broadcast position; after the last knot along the last segment; before the
    first along the broadcast velocity from it (its span at least 1e-9 s, as
    ``max``); else ``np.interp``'s rule (the last knot's value at the last knot, a knot's value on
    a knot, else slope · (t − t_j) + x_j, with its fall-backs for a NaN)."""
    k = ts.size
    for i in range(times.size):
        t = times[i]
        if k < 2:
            dt = t - sent_time_s
            out[i, 0] = position[0] + dt * velocity[0]
            out[i, 1] = position[1] + dt * velocity[1]
        elif t > ts[k - 1]:
            span = ts[k - 1] - ts[k - 2]
            if 1e-9 > span:
                span = 1e-9
            dt = t - ts[k - 1]
            out[i, 0] = pts[k - 1, 0] + dt * ((pts[k - 1, 0] - pts[k - 2, 0]) / span)
            out[i, 1] = pts[k - 1, 1] + dt * ((pts[k - 1, 1] - pts[k - 2, 1]) / span)
        elif t < ts[0]:
            dt = t - ts[0]
            out[i, 0] = pts[0, 0] + dt * velocity[0]
            out[i, 1] = pts[0, 1] + dt * velocity[1]
        elif t == ts[k - 1]:
            out[i, 0] = pts[k - 1, 0]
            out[i, 1] = pts[k - 1, 1]
        else:
            j = search_right(ts, t, 0, k) - 1  # the last knot ≤ t
            if ts[j] == t:
                out[i, 0] = pts[j, 0]
                out[i, 1] = pts[j, 1]
            else:
                for c in range(2):
                    slope = (pts[j + 1, c] - pts[j, c]) / (ts[j + 1] - ts[j])
                    v = slope * (t - ts[j]) + pts[j, c]
                    if v != v:
                        v = slope * (t - ts[j + 1]) + pts[j + 1, c]
                        if v != v and pts[j, c] == pts[j + 1, c]:
                            v = pts[j, c]
                    out[i, c] = v


@kernel
def _turn_angles(par, kind, rows, times, out):
    """The angles θ₀ + ω τ (τ = t − t₀) of the turning rows among ``rows``, in order, into ``out``
    (:meth:`TrackMotions._eval`'s operations); returns how many, or −1 when a row follows a plan."""
    n = 0
    for i in range(rows.size):
        r = rows[i]
        if kind[r] == 2:
            return -1
        if kind[r] == 1:
            out[n] = par[r, 6] + par[r, 7] * (times[i] - par[r, 2])
            n += 1
    return n


@kernel
def _row_at(par, r, turning, t, sin_t, cos_t, n):
    """Row ``r``'s position (x, y) [m] at time ``t``: turning x₀ + (v/ω)(sin θ(t) − sin θ),
    y₀ − (v/ω)(cos θ(t) − cos θ) with ``sin_t[n]``, ``cos_t[n]`` its sin θ(t), cos θ(t); straight
    or static x₀ + (v τ) cos θ, y₀ + (v τ) sin θ (τ = t − t₀) — :meth:`TrackMotions._eval`'s
    operations, for the compiled checks below."""
    if turning:
        return par[r, 0] + par[r, 8] * (sin_t[n] - par[r, 5]), par[r, 1] - par[r, 8] * (cos_t[n] - par[r, 4])
    v_tau = par[r, 3] * (t - par[r, 2])
    return par[r, 0] + v_tau * par[r, 4], par[r, 1] + v_tau * par[r, 5]


@kernel
def _farther(par, kind, rows, times, pos, limit, sin_t, cos_t):
    """:meth:`TrackMotions.farther_than` without plans: True when a row's position at its time lies
    farther than ``limit`` from ``pos`` (``hypot``); straight (or static) rows x₀ + (v τ) cos θ,
    y₀ + (v τ) sin θ, turning rows x₀ + (v/ω)(sin θ(t) − sin θ), y₀ − (v/ω)(cos θ(t) − cos θ) with
    ``sin_t``, ``cos_t`` the turning rows' sin θ(t), cos θ(t) in order (:meth:`TrackMotions._eval`)."""
    n = 0
    for i in range(rows.size):
        r = rows[i]
        turning = kind[r] == 1
        x, y = _row_at(par, r, turning, times[i], sin_t, cos_t, n)
        n += turning
        if math.hypot(x - pos[i, 0], y - pos[i, 1]) > limit:
            return True
    return False


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
            x, y = _row_at(par, r, turning, times[j], sin_t, cos_t, n)
            n += turning
            out[r, j] = math.hypot(x - pos[j, 0], y - pos[j, 1]) <= maximum(radii[j], radius[r])
