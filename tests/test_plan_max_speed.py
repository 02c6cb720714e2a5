"""The compiled largest speed along a team mate's plan (``messages._plan_max_speed``, used by
:meth:`~mjasc.cooperation.messages.TeamIntention.max_speed_m_s`) is numpy's form bit for bit,
including repeated, too close and NaN times and NaN points."""

import numpy as np

from mjasc.cooperation.messages import TeamIntention, TeamMessage, _plan_max_speed


def _numpy(ts, pts):
    return float((np.hypot(*np.diff(pts, axis=0).T) / np.maximum(np.diff(ts), 1e-9)).max())


def _same(a, b):
    return (a == b and np.signbit(a) == np.signbit(b)) or (a != a and b != b)


def test_plan_max_speed_is_numpys_form():
    rng = np.random.default_rng(3)
    for k in range(3000):
        n = int(rng.integers(2, 80))
        ts = np.cumsum(rng.choice([0.5, 0.0, 1e-10, -0.1], n, p=[0.85, 0.05, 0.05, 0.05])) + rng.uniform(0, 100)
        pts = rng.normal(0.0, 1e3 * rng.random(), (n, 2))
        if k % 17 == 0:
            pts[rng.integers(n)] = np.nan
        if k % 19 == 0:
            ts[rng.integers(n)] = np.nan
        assert _same(float(_plan_max_speed(ts, pts)), _numpy(ts, pts)), k


def test_intention_max_speed_takes_the_plan_and_the_broadcast_velocity():
    ts = 10.0 + 0.5 * np.arange(61)
    pts = np.cumsum(np.full((61, 2), 0.4), axis=0)
    msg = TeamMessage("a", np.zeros(2), 0.0, np.array([3.0, 4.0]), 1.0, plan_times_s=ts, plan_points_m=pts)
    it = TeamIntention.from_message(msg, 10.0)
    assert it.max_speed_m_s() == max(5.0, _numpy(ts, pts))
    slow = TeamIntention.from_message(TeamMessage("b", np.zeros(2), 0.0, np.array([0.1, 0.0]), 1.0,
                                                  plan_times_s=ts, plan_points_m=pts), 10.0)
    assert slow.max_speed_m_s() == _numpy(ts, pts)
