"""Team mates' plans as collision prediction reads them: many intentions' knots stacked in one table.

A team mate predicted from its broadcast (a :class:`~mjasc.core.estimates.PlannedTrack`, its
:class:`~mjasc.cooperation.messages.TeamIntention`'s knots (t_k, p_k)) moves by linear
interpolation between knots, along the broadcast velocity before the first knot, along the last
segment after the last one (as ``TeamIntention.positions``, equal to it bit for bit).

- :class:`_StackedPlans`: the knots of several plans in one array, and the per-plan numbers
  (first / last knot, anchor, velocities) a compiled loop reads (:data:`PLAN_FIELDS`);
  :func:`plan_position` finds a query's knot interval by bisection on its plan's knot times and
  interpolates (:func:`plan_between`). A prediction asks for a plan at many rising times in a row
  (a track's samples): along such a run :func:`walk_knots` steps on from the previous interval
  instead (the same interval when the knots are sorted), in the table's reads and in the
  closest-approach zoom (:mod:`~mjasc.avoidance.prediction.zoom_motion`).
- :class:`_PlanTable` (the process-wide :data:`_PLANS`): each distinct intention stacked once for
  the process in one growing table — the fleet's receivers hold the same message object, so 50
  vessels' copies of a team mate are one plan, stacked when first predicted and only looked up after.
- :func:`intention_positions`: k intentions at n times at once (a small team: each intention's own
  arrays in one compiled pass, :func:`_intention_positions`; else through the table).

:class:`~mjasc.avoidance.prediction.motion.TrackMotions` holds the rows of its planned tracks in
this table. World frame ENU, metres, absolute simulation times [s].
"""

from __future__ import annotations

import threading

import numpy as np

from mjasc.core.compiled import inlined_kernel, kernel, maximum, search_right

__all__ = ["PLAN_FIELDS", "intention_positions", "plan_between", "plan_position", "walk_knots"]


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
        n0, k0 = self._n, self._knots
        arrays = _intention_arrays(distinct)
        if arrays is None:  # (not float arrays of the expected shapes: the readable form's numbers)
            part = _StackedPlans(distinct)
            n1, k1 = n0 + len(distinct), k0 + part.ts.size
            for names, used, need in ((self._KNOTS, k0, k1), (self._PER_PLAN, n0, n1)):
                for name in names:
                    src = getattr(part, name)
                    self._room(name, used, need, src.shape[1:], src.dtype)[used:need] = \
                        src + k0 if name == "start" else src
        else:  # each intention's row and knots written into the table in one compiled pass
            counts, ts, pts, pos, sent, vel = arrays
            n1, k1 = n0 + len(distinct), k0 + ts.size
            room = self._room
            _stack_into(n0, k0, counts, ts, pts, pos, sent, vel,
                        *(room(name, k0, k1, (), np.float64) for name in self._KNOTS),
                        *(room(name, n0, n1, _PLAN_TAIL[name], _PLAN_DTYPE.get(name, np.float64))
                          for name in self._PER_PLAN))
        self._n, self._knots = n1, k1
        view = object.__new__(_StackedPlans)
        for name in self._KNOTS:
            setattr(view, name, self._buf[name][:k1])
        for name in self._PER_PLAN:
            setattr(view, name, self._buf[name][:n1])
        self._plans = view
        for u, it in enumerate(distinct):
            self._row[id(it)] = (it, n0 + u)


    def _room(self, name: str, used: int, need: int, tail: tuple, dtype) -> np.ndarray:
        """The buffer of field ``name`` with room for ``need`` rows, its first ``used`` kept (grown
        to twice its size, at least 64, when too small)."""
        buf = self._buf.get(name)
        if buf is None or buf.shape[0] < need:
            grown = np.empty((max(need, 2 * (0 if buf is None else buf.shape[0]), 64),) + tuple(tail), dtype=dtype)
            if buf is not None:
                grown[:used] = buf[:used]
            buf = self._buf[name] = grown
        return buf


_PLANS = _PlanTable()
#: Each per-plan field's trailing shape and dtype (float64 unless named) in the table.
_PLAN_TAIL = {"start": (), "count": (), "t_first": (), "t_last": (), "anchor": (2,), "t_anchor": (), "vel": (2,),
              "p_last": (2,), "v_end": (2,)}
_PLAN_DTYPE = {"start": np.intp, "count": np.intp}


def _intention_arrays(intentions):
    """(knot counts (k,), the knots' times and points of the plans with two knots or more, in order,
    positions (k, 2), send times (k,), velocities (k, 2)) as :class:`_StackedPlans` reads them, or
    None when a plan's arrays are not float64 of the expected shapes."""
    with_plan, counts = [], []
    for it in intentions:
        ts, pts = it.plan_times_s, it.plan_points_m
        if not (type(ts) is np.ndarray and type(pts) is np.ndarray and ts.dtype == pts.dtype == np.float64
                and ts.ndim == 1 and pts.shape == (ts.size, 2)):
            return None
        counts.append(ts.size)
        if ts.size >= 2:
            with_plan.append(it)
    ts = np.concatenate([it.plan_times_s for it in with_plan]) if with_plan else np.zeros(0)
    pts = np.concatenate([it.plan_points_m for it in with_plan]) if with_plan else np.zeros((0, 2))
    pos = np.array([it.position_m for it in intentions], dtype=float).reshape(-1, 2)
    sent = np.array([it.sent_time_s for it in intentions], dtype=float)
    vel = np.array([it.velocity_m_s for it in intentions], dtype=float).reshape(-1, 2)
    return np.array(counts, dtype=np.intp), ts, pts, pos, sent, vel


@kernel
def _stack_into(n0, k0, counts, ts, pts, pos, sent, vel, b_ts, b_xs, b_ys, start, count, t_first, t_last, anchor,
                t_anchor, b_vel, p_last, v_end):
    """:class:`_StackedPlans`' numbers of intentions u (their knot counts, knots, positions, send
    times, velocities: :func:`_intention_arrays`) written into the table's rows n0 + u and knot
    columns from k0: fewer than two knots, no plan (count 0, first / last knot times inf, the
    broadcast position at the send time as anchor, zero last point and end velocity); else the
    knots, the first knot as anchor, the last one, and the last segment's velocity
    (p_l − p_{l−1}) / max(t_l − t_{l−1}, 1e-9) (numpy's maximum)."""
    off = 0  # the knot column within this batch
    for u in range(counts.size):
        c = counts[u]
        if c < 2:
            c = 0
        r = n0 + u
        start[r] = off + k0
        count[r] = c
        b_vel[r, 0], b_vel[r, 1] = vel[u, 0], vel[u, 1]
        if c == 0:
            t_first[r] = t_last[r] = np.inf
            anchor[r, 0], anchor[r, 1] = pos[u, 0], pos[u, 1]
            t_anchor[r] = sent[u]
            p_last[r, 0] = p_last[r, 1] = v_end[r, 0] = v_end[r, 1] = 0.0
            continue
        for j in range(c):
            b_ts[k0 + off + j] = ts[off + j]
            b_xs[k0 + off + j] = pts[off + j, 0]
            b_ys[k0 + off + j] = pts[off + j, 1]
        f, last = off, off + c - 1
        t_first[r], t_last[r] = ts[f], ts[last]
        anchor[r, 0], anchor[r, 1] = pts[f, 0], pts[f, 1]
        t_anchor[r] = ts[f]
        p_last[r, 0], p_last[r, 1] = pts[last, 0], pts[last, 1]
        span = maximum(ts[last] - ts[last - 1], 1e-9)
        v_end[r, 0] = (pts[last, 0] - pts[last - 1, 0]) / span
        v_end[r, 1] = (pts[last, 1] - pts[last - 1, 1]) / span
        off += c


@kernel
def _plan_positions(plans, t, ts, xs, ys, start, count, t_first, t_last, anchor, t_anchor, vel, p_last, v_end, out):
    """:meth:`_StackedPlans.at` into ``out``: :func:`plan_position` of each item, the same numbers.
    A prediction asks for a plan at many rising times in a row (a track's samples): inside the
    knots, the interval is found by :func:`walk_knots` along each such run."""
    run, checked, sorted_run, lo, t_lo = -1, False, False, 0, 0.0
    for i in range(plans.size):
        p, ti = plans[i], t[i]
        if ti < t_first[p] or ti >= t_last[p] or ti != ti:  # (before, after the knots, NaN: plan_position's)
            out[i, 0], out[i, 1] = plan_position(p, ti, ts, xs, ys, start, count, t_first, t_last, anchor, t_anchor,
                                                 vel, p_last, v_end)
            continue
        lo, checked, sorted_run = walk_knots(ts, ti, start[p], start[p] + count[p], p == run, checked, sorted_run, lo,
                                             t_lo)
        run, t_lo = p, ti
        out[i, 0], out[i, 1] = plan_between(p, ti, lo, ts, xs, ys, start, count)


@inlined_kernel
def walk_knots(ts, ti, a, e, same_run, checked, sorted_run, lo, t_lo):
    """The first knot > ``ti`` among a plan's knots ``ts[a:e]`` (:func:`~mjasc.core.compiled.search_right`'s
    index) and the run's (``checked``, ``sorted_run``) after it. A run is a plan asked for at
    successive times (``same_run``: the previous item inside these knots was this plan's, at time
    ``t_lo``, its answer ``lo``); when its knots are sorted (checked once per run, at its second
    item) and the time did not fall, the walk goes on from ``lo`` (:func:`_walk_right`): the same
    index, without a bisection over all the knots each time."""
    if not same_run:
        return search_right(ts, ti, a, e), False, False
    if not checked:
        checked, sorted_run = True, _ascending(ts, a, e)
    if sorted_run and ti >= t_lo:
        return _walk_right(ts, ti, lo, e), checked, sorted_run
    return search_right(ts, ti, a, e), checked, sorted_run


@kernel
def _ascending(ts, a, e):
    """Are the knots ``ts[a:e]`` in ascending order (no NaN)?"""
    for k in range(a, e - 1):
        if not ts[k] <= ts[k + 1]:
            return False
    return True


@kernel
def _walk_right(ts, x, lo, hi):
    """:func:`~mjasc.core.compiled.search_right` ``(ts, x, ·, hi)`` when every knot before ``lo`` is
    ≤ x and ``ts`` is ascending: a few steps forward from ``lo``, then a bisection of the rest."""
    for _ in range(8):
        if lo >= hi or ts[lo] > x:
            return lo
        lo += 1
    return search_right(ts, x, lo, hi)


@kernel
def plan_between(p, ti, lo, ts, xs, ys, start, count):
    """Plan ``p``'s position at ``ti`` inside its knots, ``lo`` the first knot > ti: each coordinate
    (x_b − x_a) / (t_b − t_a) · (t − t_a) + x_a on the knot interval [a, b] (clamped to the plan's)."""
    j = min(max(lo - 1, start[p]), start[p] + count[p] - 2)
    dt, dtt = ts[j + 1] - ts[j], ti - ts[j]
    return (xs[j + 1] - xs[j]) / dt * dtt + xs[j], (ys[j + 1] - ys[j]) / dt * dtt + ys[j]


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
    return plan_between(p, ti, search_right(ts, ti, start[p], start[p] + count[p]), ts, xs, ys, start, count)


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
