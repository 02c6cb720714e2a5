"""Tracking accuracy against the truth: GOSPA with its localization / missed / false parts, identity
switches, and the time to confirm a new target.

**GOSPA** (generalized optimal sub-pattern assignment; Rahmathullah, García-Fernández & Svensson,
"Generalized optimal sub-pattern assignment metric", FUSION 2017), with α = 2, cut-off c [m] and
order p, between the true positions X = {x_i} and the estimated ones Y = {y_j} at one time::

    d(X, Y) = ( min_γ  Σ_{(i,j) ∈ γ} d(x_i, y_j)^p  +  c^p / 2 · (|X| + |Y| − 2|γ|) )^{1/p}

over partial assignments γ of pairs closer than c. It splits exactly into a localization part
(the assigned pairs' d^p), a missed part (c^p/2 per unassigned truth) and a false part (c^p/2 per
unassigned estimate). The optimal γ is a linear assignment on the costs min(d, c)^p (a pair at ≥ c
costs the same as leaving both unassigned) — :func:`scipy.optimize.linear_sum_assignment`.

**Optional objects.** A track its tracker flags static may stand for a truth object (a boat that
stopped, a drifting target) or for something the truth does not hold (a buoy, a moored boat: static
obstacles are not traffic); a truth object the sensor cannot see (beyond its range, outside its
field of view) may still be tracked (a track coasting for a moment after the object left the range,
a track a team mate shared). Either takes part in the assignment but costs nothing when left
unassigned (a static track is never false, an unseen object never missed), so a pair with k ∈ {1, 2}
optional members is assigned only when that lowers the sum, d^p + k·c^p/2 < c^p, and costs
min(d^p + k·c^p/2, c^p) in the assignment (c^p: the same as leaving both unassigned). Without
optional objects the metric is the one above, number for number. Scoring only the moving tracks
against only the objects in range counted a correctly tracked stopped object as missed, and the
track of an object that had just left the range as false, at c^p/2 per evaluation.

**Identity**: at each evaluation time every truth object is matched to at most one track (the same
assignment); a truth's track id changing from one matched time to the next is an identity switch.
**Time to confirm**: from the first time a truth object is within the sensor's range to the first
time a confirmed track is matched to it while it is.
**Position RMSE**: the root mean square distance [m] between a truth object and the track assigned
to it, over every assigned pair of every evaluation (whatever GOSPA's order).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from mjasc.core.assignment import linear_sum_assignment
from mjasc.evaluation.gospa_kernels import score_ticks

__all__ = ["gospa", "GospaTerms", "TrackingScore", "flat_rows", "assignment_costs"]


@dataclass(frozen=True)
class GospaTerms:
    """One evaluation: ``distance`` = (localization + missed + false)^{1/p}, the three parts in
    [m^p], the counts, and the assignment (truth index → estimate index)."""

    distance: float
    localization: float
    missed: float
    false: float
    n_missed: int
    n_false: int
    assignment: dict


def gospa(truth_xy, estimates_xy, cutoff_m: float = 10.0, order: float = 2.0, optional=None,
          truth_optional=None) -> GospaTerms:
    """GOSPA (α = 2) between truth positions (m, 2) and estimates (n, 2) [m] (module docstring);
    ``optional`` (n,) bool: the static tracks (never false); ``truth_optional`` (m,) bool: the truth
    objects the sensor cannot see (never missed)."""
    x = np.asarray(truth_xy, dtype=float).reshape(-1, 2)
    y = np.asarray(estimates_xy, dtype=float).reshape(-1, 2)
    opt = _flags(optional, y.shape[0], "optional")
    x_opt = _flags(truth_optional, x.shape[0], "truth_optional")
    c, p = float(cutoff_m), float(order)
    if not (c > 0 and p >= 1):
        raise ValueError(f"cutoff_m, order: must be > 0 and ≥ 1, got {cutoff_m}, {order}")
    half = 0.5 * c ** p
    assignment: dict = {}
    loc = 0.0
    if x.shape[0] and y.shape[0]:
        d = np.hypot(x[:, None, 0] - y[None, :, 0], x[:, None, 1] - y[None, :, 1])
        n_opt = x_opt[:, None].astype(np.int64) + opt[None, :]
        rows, cols = linear_sum_assignment(assignment_costs(d, n_opt, c, p))
        for r, k in zip(rows, cols):
            dr = float(d[r, k])
            if _accepted(dr, int(n_opt[r, k]), c, p, half):
                assignment[int(r)] = int(k)
                loc += dr ** p
    n_missed = int((~x_opt).sum()) - sum(1 for r in assignment if not x_opt[r])
    n_false = int((~opt).sum()) - sum(1 for k in assignment.values() if not opt[k])
    missed, false = half * n_missed, half * n_false
    return GospaTerms((loc + missed + false) ** (1.0 / p), loc, missed, false, n_missed, n_false, assignment)


def _flags(flags, n: int, name: str) -> np.ndarray:
    out = np.zeros(n, dtype=bool) if flags is None else np.asarray(flags, dtype=bool).reshape(-1)
    if out.shape[0] != n:
        raise ValueError(f"{name}: must have one flag per object ({n}), got {out.shape[0]}")
    return out


def _accepted(dr: float, n_opt: int, c: float, p: float, half: float) -> bool:
    """Whether an assigned pair at distance dr [m] with n_opt optional members counts as assigned
    (the same test as the compiled scoring's)."""
    return dr < c if n_opt == 0 else dr ** p + half * n_opt < c ** p


def assignment_costs(d: np.ndarray, n_optional: np.ndarray, c: float, p: float) -> np.ndarray:
    """GOSPA's assignment costs of the distances ``d`` [m]: min(d, c)^p, and min(d^p + k·c^p/2, c^p)
    where the pair has k = ``n_optional`` (broadcast against ``d``) optional members (module docstring)."""
    cost = np.minimum(d, c) ** p
    n_optional = np.asarray(n_optional)
    if n_optional.any():
        cost = np.where(n_optional > 0, np.minimum(d ** p + 0.5 * c ** p * n_optional, c ** p), cost)
    return cost


def flat_rows(track_ids: list, track_xy: list) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-time tracks (ids (k_t,), positions (k_t, 2) [m] per time) flat: the counts k_t (T,),
    the ids (R,) int64 and the positions (R, 2) [m], the times' rows one after the other."""
    counts = np.array([len(ids) for ids in track_ids], dtype=np.int64)
    if not counts.sum():
        return counts, np.zeros(0, dtype=np.int64), np.zeros((0, 2))
    return counts, _rows(track_ids, np.int64, (-1,)), _rows(track_xy, float, (-1, 2))


def _rows(parts: list, dtype, shape: tuple) -> np.ndarray:
    """The per-time arrays ``parts`` one after the other, as ``dtype`` rows of ``shape``: one
    concatenation when they already are such arrays (a run's tracks are), else each converted."""
    try:
        out = np.concatenate(parts)
        if out.dtype == dtype and out.ndim == len(shape):
            return out
    except ValueError:
        pass
    return np.concatenate([np.asarray(x, dtype=dtype).reshape(shape) for x in parts])


@dataclass
class TrackingScore:
    """Accumulates one vessel's tracking quality over a run, one :meth:`add` per evaluation time.

    cutoff_m, order: GOSPA's c and p; sensor_range_m, sensor_fov_rad: a truth object counts as
    observable (for the missed part and the time to confirm) only when its nearest point is within
    this range of the vessel and some of its disc within the field of view, centred on the bow
    (less than a full circle: :meth:`add` needs the vessel's heading)."""

    cutoff_m: float = 10.0
    order: float = 2.0
    sensor_range_m: float = float("inf")
    sensor_fov_rad: float = 2.0 * math.pi
    _n: int = 0
    _sum: dict = field(default_factory=lambda: {"distance": 0.0, "localization": 0.0, "missed": 0.0, "false": 0.0})
    _last_id: dict = field(default_factory=dict)
    id_switches: int = 0
    _first_seen: dict = field(default_factory=dict)
    _confirmed_at: dict = field(default_factory=dict)
    _pairs: int = 0  # assigned pairs so far, and the sum of their squared distances [m²]
    _sq: float = 0.0

    def add(self, time_s: float, own_position_m, truth_ids, truth_xy, track_ids, track_xy,
            truth_radii_m=None, track_static=None, own_heading_rad=None) -> GospaTerms:
        """Compare the vessel's confirmed tracks (ids, positions (n, 2), static flags (n,): None, none
        static) with the truth objects (ids, positions (m, 2), radii (m,)) the sensor could see at
        ``time_s`` (the vessel's heading [rad, ENU]: for a field of view less than a full circle)."""
        truth_xy = np.asarray(truth_xy, dtype=float).reshape(-1, 2)
        in_range = self._observable(np.asarray(own_position_m, dtype=float).reshape(1, 2), truth_xy[None],
                                    truth_radii_m, None if own_heading_rad is None else [own_heading_rad])[0]
        for i in np.flatnonzero(in_range):
            self._first_seen.setdefault(truth_ids[i], float(time_s))
        y = np.asarray(track_xy, dtype=float).reshape(-1, 2)
        terms = gospa(truth_xy, y, self.cutoff_m, self.order, track_static, ~in_range)
        self._n += 1
        for k in self._sum:
            self._sum[k] += getattr(terms, k)
        for i_truth, j_track in terms.assignment.items():
            dr = float(np.hypot(truth_xy[i_truth, 0] - y[j_track, 0], truth_xy[i_truth, 1] - y[j_track, 1]))
            self._pairs += 1
            self._sq += dr * dr
            tid, trk = truth_ids[i_truth], int(track_ids[j_track])
            if in_range[i_truth]:
                self._confirmed_at.setdefault(tid, float(time_s))
            old = self._last_id.get(tid)
            if old is not None and old != trk:
                self.id_switches += 1
            self._last_id[tid] = trk
        return terms

    def add_run(self, times_s, own_positions_m, truth_ids, truth_xy, track_ids, track_xy,
                truth_radii_m=None, track_static=None, own_headings_rad=None) -> None:
        """:meth:`add` at every time of a run at once: the same state after it, bit for bit (the
        same GOSPA terms summed in the same order, the same assignments, identity switches and
        first times). times_s (T,) [s]; own_positions_m (T, 2) [m]; truth_ids (M,) and truth_xy
        (T, M, 2) [m] (radii (M,)): the truth objects at every time; track_ids and track_xy: per
        time, the tracks' ids (k_t,) and positions (k_t, 2) [m] (:meth:`add_rows` with them flat),
        track_static: per time their static flags (k_t,) (None: none static); own_headings_rad (T,)
        [rad, ENU] (for a field of view less than a full circle). ``truth_ids`` must be distinct."""
        counts, ids, xy = flat_rows(track_ids, track_xy)
        static = None if track_static is None else np.concatenate(
            [np.zeros(0, dtype=bool)] + [np.asarray(f, dtype=bool).reshape(-1) for f in track_static])
        self.add_rows(times_s, own_positions_m, truth_ids, truth_xy, counts, ids, xy, truth_radii_m, static,
                      own_headings_rad)

    def add_rows(self, times_s, own_positions_m, truth_ids, truth_xy, counts, track_ids, track_xy,
                 truth_radii_m=None, track_static=None, own_headings_rad=None) -> None:
        """:meth:`add_run` with the tracks flat: counts (T,) the number of tracks at each time,
        track_ids (R,) int64, track_xy (R, 2) [m] and track_static (R,) bool (None: none static)
        the rows of every time one after the other (R = Σ counts; :func:`flat_rows`).

        The distances of every (time, track, truth) triple are computed in one pass (elementwise,
        the numbers :func:`gospa` computes per time); the per-time assignments and sums are one
        compiled pass (:func:`mjasc.evaluation.gospa_kernels.score_ticks`), scipy deciding the
        times whose least costs do not. ``truth_ids`` must be distinct.
        """
        times = [float(t) for t in times_s]
        n_t = len(times)
        if n_t == 0:
            return
        own = np.asarray(own_positions_m, dtype=float).reshape(n_t, 2)
        q = np.asarray(truth_xy, dtype=float).reshape(n_t, -1, 2)
        n_truth = q.shape[1]
        c, p = float(self.cutoff_m), float(self.order)
        if not (c > 0 and p >= 1):
            raise ValueError(f"cutoff_m, order: must be > 0 and ≥ 1, got {self.cutoff_m}, {self.order}")
        half = 0.5 * c ** p
        # which truth objects are observable at each time, and when each one first was
        in_range = self._observable(own, q, truth_radii_m, own_headings_rad)
        seen = np.flatnonzero(in_range.any(axis=0))
        first = in_range[:, seen].argmax(axis=0)
        for k in np.lexsort((seen, first)).tolist():
            self._first_seen.setdefault(truth_ids[int(seen[k])], times[int(first[k])])
        # every track's distance to every truth object of its time: (R, M), track-major
        counts = np.asarray(counts, dtype=np.int64).reshape(n_t)
        ends = np.cumsum(counts)
        n_rows = int(ends[-1])
        fast = True
        static = np.zeros(n_rows, dtype=bool) if track_static is None else \
            np.asarray(track_static, dtype=bool).reshape(n_rows)
        if n_rows and n_truth:
            y = np.asarray(track_xy, dtype=float).reshape(n_rows, 2)
            tick = np.repeat(np.arange(n_t), counts)  # each track row's time
            qt = q[tick]  # (R, M, 2): the truth at each track's time
            d = np.hypot(qt[:, :, 0] - y[:, None, 0], qt[:, :, 1] - y[:, None, 1])
            # (every truth object takes part; those the sensor cannot see are optional: module docstring)
            cost = assignment_costs(d, static[:, None].astype(np.int64) + ~in_range[tick], c, p)
            fast = bool(np.isfinite(cost).all())  # (scipy refuses NaN: it decides every time then)
        else:
            d = cost = np.zeros((n_rows, n_truth))
        ids = np.asarray(track_ids, dtype=np.int64).reshape(n_rows)
        # the per-time loop (compiled; a time whose assignment the least costs do not decide: scipy)
        names = list(truth_ids)
        if len(set(names)) != len(names):
            raise ValueError(f"truth_ids: must be distinct, got {names}")
        last, confirmed_at = self._last_id, self._confirmed_at
        last_a = np.array([last.get(x, 0) for x in names], dtype=np.int64)
        has_last = np.array([x in last for x in names], dtype=bool)
        conf = np.array([confirmed_at.get(x, np.nan) for x in names], dtype=float)
        order = np.full(len(names), -1, dtype=np.int64)
        sums = np.array([self._sum["distance"], self._sum["localization"], self._sum["missed"], self._sum["false"]])
        counters = np.array([self.id_switches, 0, self._pairs], dtype=np.int64)
        sq = np.array([self._sq])
        t_a = np.asarray(times, dtype=float)
        given_r = given_c = np.zeros(0, dtype=np.int64)
        k, n_given = 0, -1
        while k < n_t:
            k = score_ticks(k, ends, in_range, d, cost, ids, static, t_a, c, p, half, fast, given_r, given_c, n_given,
                            sums, sq, last_a, has_last, conf, order, counters)
            if k < n_t:  # (its pairs, scipy's order: truth rows ascending; the next pass starts with them)
                a = int(ends[k - 1]) if k else 0
                given_r, given_c = linear_sum_assignment(cost[a:int(ends[k])].T)
                given_r, given_c, n_given = given_r.astype(np.int64), given_c.astype(np.int64), given_r.size
        self._sum.update(zip(("distance", "localization", "missed", "false"), sums.tolist()))
        self.id_switches = int(counters[0])
        self._pairs, self._sq = int(counters[2]), float(sq[0])
        for m in np.argsort(order, kind="stable")[int((order < 0).sum()):].tolist():  # in the order first matched
            confirmed_at[names[m]] = float(conf[m])
            last[names[m]] = int(last_a[m])
        for m in np.flatnonzero(has_last).tolist():
            last[names[m]] = int(last_a[m])
        self._n += n_t

    def _observable(self, own: np.ndarray, q: np.ndarray, radii, headings) -> np.ndarray:
        """(T, M) bool: truth object m at time k (positions q (T, M, 2), radii (M,) or None [m])
        within the sensor's range of ``own`` (T, 2) [m], and, for a field of view less than a full
        circle, some of its disc within ±fov/2 of the heading (T,) [rad]."""
        dx, dy = q[:, :, 0] - own[:, None, 0], q[:, :, 1] - own[:, None, 1]
        rng = np.hypot(dx, dy)
        r = np.zeros(q.shape[1]) if radii is None else np.asarray(radii, dtype=float).reshape(-1)
        out = (rng if radii is None else rng - r) <= self.sensor_range_m
        if self.sensor_fov_rad < 2.0 * math.pi:
            if headings is None:
                raise ValueError("own_heading_rad: needed with a field of view less than a full circle")
            off = np.abs(np.angle(np.exp(1j * (np.arctan2(dy, dx) - np.asarray(headings, dtype=float).reshape(-1, 1)))))
            half_width = np.arcsin(np.clip(r / np.maximum(rng, 1e-9), 0.0, 1.0))
            out &= off <= 0.5 * self.sensor_fov_rad + half_width
        return out

    def summary(self) -> dict:
        """Mean GOSPA and its parts over the evaluation times, identity switches, and per truth
        object the time to confirm [s] (None: never confirmed while in range)."""
        n = max(self._n, 1)
        confirm = {str(t): (round(self._confirmed_at[t] - t0, 3) if t in self._confirmed_at else None)
                   for t, t0 in self._first_seen.items()}
        return {"gospa_cutoff_m": self.cutoff_m, "gospa_order": self.order,
                "gospa_mean_m": round(self._sum["distance"] / n, 4),
                "gospa_localization_mean": round(self._sum["localization"] / n, 4),
                "gospa_missed_mean": round(self._sum["missed"] / n, 4),
                "gospa_false_mean": round(self._sum["false"] / n, 4),
                "position_rmse_m": round(math.sqrt(self._sq / self._pairs), 4) if self._pairs else None,
                "evaluations": self._n, "id_switches": self.id_switches, "time_to_confirm_s": confirm}
