"""Whether a team mate's new plan left the one the last prediction used (the control tick's plan
comparison, :meth:`~mjasc.avoidance.team_mates.TeamMates.plans_changed`).

:func:`plans_deviate_reference` is the readable form: both plans of every (new, old) pair at the
comparison times (:func:`~mjasc.avoidance.prediction.team_plans.intention_positions`), and the largest
``np.hypot`` of their differences ``> deviation_m`` (one limit for every pair, or one per pair:
the last prediction's clearance to that team mate when it is smaller). :func:`plans_deviate`
gives the same answer for a small team (at most two pairs: each pair's positions are those
:func:`~mjasc.avoidance.prediction.team_plans.intention_positions` works out for at most four
intentions, one compiled pass per intention) in one compiled call per pair: both plans'
positions and the distances in one pass, no array made per pair. ``np.max`` propagates NaN, so a
NaN distance anywhere makes the answer False, as the reference's ``NaN > deviation_m``.

World frame ENU, SI units, absolute simulation times [s].
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.avoidance.prediction.team_plans import _intention_positions, intention_positions
from mjasc.core.compiled import kernel

__all__ = ["plans_deviate", "plans_deviate_reference"]


def plans_deviate_reference(pairs, times, deviation_m) -> bool:
    """Whether some (new, old) intention pair of ``pairs`` lies farther apart than its limit at
    some of ``times`` (n,) [s]: ``deviation_m`` [m], one number for every pair or one per pair
    (a NaN distance anywhere: False, as the largest distance's NaN compares)."""
    both = intention_positions([p[0] for p in pairs] + [p[1] for p in pairs], times)  # new plans, then the old
    new, old = both[:len(pairs)], both[len(pairs):]
    dist = np.hypot(new[..., 0] - old[..., 0], new[..., 1] - old[..., 1])  # (pairs, n)
    if np.isnan(dist).any():
        return False
    return bool(np.any(np.max(dist, axis=1) > np.asarray(deviation_m, dtype=float)))


def _arrays(it):
    """The intention's arrays as the compiled pass reads them, or None when they are not float64
    arrays of the expected shapes (then :func:`intention_positions` takes another way)."""
    ts, pts, pos, vel = it.plan_times_s, it.plan_points_m, it.position_m, it.velocity_m_s
    if (type(ts) is np.ndarray and type(pts) is np.ndarray and type(pos) is np.ndarray
            and type(vel) is np.ndarray and ts.dtype == pts.dtype == pos.dtype == vel.dtype == np.float64
            and ts.ndim == 1 and pts.shape == (ts.size, 2) and pos.shape == vel.shape == (2,)):
        return ts, pts, pos, float(it.sent_time_s), vel
    return None


def plans_deviate(pairs, times, deviation_m) -> bool:
    """:func:`plans_deviate_reference`, the same answer: for at most two pairs whose intentions
    hold float64 arrays, one compiled call per pair (module docstring); else the reference."""
    times = np.asarray(times, dtype=float)
    if not pairs or len(pairs) > 2 or times.ndim != 1 or not times.flags.c_contiguous or times.size == 0:
        return plans_deviate_reference(pairs, times, deviation_m)
    args = []
    for new, old in pairs:
        a, b = _arrays(new), _arrays(old)
        if a is None or b is None:
            return plans_deviate_reference(pairs, times, deviation_m)
        args.append(a + b)
    limits = np.broadcast_to(np.asarray(deviation_m, dtype=float), (len(pairs),)).tolist()
    buf = np.empty((2, times.size, 2))
    farther = False
    for a, limit in zip(args, limits):
        code = _pair_code(*a, times, limit, buf)
        if code == 2:
            return False  # a NaN distance: the largest is NaN
        farther = farther or code == 1
    return farther


@kernel
def _pair_code(ts_a, pts_a, pos_a, sent_a, vel_a, ts_b, pts_b, pos_b, sent_b, vel_b, times, limit, buf):
    """One (new, old) pair: both intentions' positions at ``times`` into ``buf`` (2, n, 2)
    (:func:`_intention_positions`), then 2 when a distance (``hypot``) is NaN, else 1 when one is
    ``> limit``, else 0."""
    _intention_positions(ts_a, pts_a, pos_a, sent_a, vel_a, times, buf[0])
    _intention_positions(ts_b, pts_b, pos_b, sent_b, vel_b, times, buf[1])
    code = 0
    for i in range(times.size):
        d = math.hypot(buf[0, i, 0] - buf[1, i, 0], buf[0, i, 1] - buf[1, i, 1])
        if d != d:
            return 2
        if d > limit:
            code = 1
    return code
