"""The compiled path following (:func:`mjasc.guidance.follow_kernel.follow_fleet`) against its
readable plain-float form (``FleetPathFollower._command_floats`` and the inverse propeller curve
``command_for_thrust_scalar``): the same commands, statuses and loop states bit for bit, on random
paths (lines, arcs, dense polylines, path switches, course overrides, positions far off the path)
and at every control tick of the demo."""

import math

import numpy as np

from mjasc.guidance import following_law
from mjasc.guidance.path_following import FleetPathFollower
from mjasc.physics.thrusters import command_for_thrust_scalar
from tests.test_fleet_following import _follower, _paths, _record_control


def _reference(fleet, idx, xy, heading, bv, speed, course, dt_s=0.1):
    thrust, statuses = fleet._command_floats(idx, xy.tolist(), heading.tolist(), bv.tolist(), speed.tolist(), dt_s,
                                             course.tolist())
    cols = fleet._P_cols
    cmds = np.array([[command_for_thrust_scalar(t, *cols[i][following_law.KF:following_law.NMIN + 1]) for t in pair]
                     for i, pair in zip(idx, thrust)]).reshape(-1, 2)
    return cmds, statuses


def _same_status(a, b):
    assert a.__dict__ == b.__dict__
    assert [type(v) for v in a.__dict__.values()] == [type(v) for v in b.__dict__.values()]


def test_compiled_following_equals_the_float_form_on_random_paths():
    rng = np.random.default_rng(5)
    n = 6
    paths = _paths(rng, n)
    mine = [_follower(p, i) for i, p in enumerate(paths)]
    ref = [_follower(p, i) for i, p in enumerate(paths)]
    fa, fb = FleetPathFollower.of(mine), FleetPathFollower.of(ref)
    gamma = np.zeros(n)
    for tick in range(600):
        gamma += 0.12
        xy = np.array([f.path.point(g) for f, g in zip(mine, gamma)]) + rng.normal(0, rng.choice([0.01, 2.0, 20.0]),
                                                                                   (n, 2))
        heading = rng.uniform(-np.pi, np.pi, n)
        bv = np.column_stack([rng.uniform(0, 2, n), rng.normal(0, 0.1, n), rng.normal(0, 0.2, n)])
        speed = rng.uniform(0.5, 2.0, n)
        course = np.where(rng.uniform(size=n) < 0.2, rng.uniform(-3, 3, n), np.nan)
        if tick % 37 == 36:  # a detour spliced in
            i = int(rng.integers(n))
            new = _paths(rng, 3)[int(rng.integers(3))]
            mine[i].set_path(new, 0.0)
            ref[i].set_path(new, 0.0)
            gamma[i] = 0.0
        if tick % 101 == 100:  # a jump of γ (far from the hint)
            i = int(rng.integers(n))
            g = float(rng.uniform(0, mine[i].path.length))
            mine[i].gamma_m = g
            ref[i].gamma_m = g
        idx = list(range(n)) if tick % 5 else [4, 1, 2]
        rows = None if tick % 5 else np.array(idx)
        got = fa._command_compiled(idx, xy[idx], heading[idx], bv[idx], speed[idx], 0.1, course[idx], rows)
        want = _reference(fb, idx, xy[idx], heading[idx], bv[idx], speed[idx], course[idx])
        np.testing.assert_array_equal(got[0], want[0])
        np.testing.assert_array_equal(fa._S, fb._S)
        for a, b in zip(got[1], want[1]):
            _same_status(a, b)


def test_compiled_following_declines_a_position_that_is_not_finite():
    rng = np.random.default_rng(1)
    fleet = FleetPathFollower.of([_follower(p, i) for i, p in enumerate(_paths(rng, 2))])
    before = fleet._S.copy()
    xy = np.array([[1.0, 2.0], [math.nan, 0.0]])
    assert fleet._command_compiled([0, 1], xy, np.zeros(2), np.zeros((2, 3)), np.ones(2), 0.1,
                                   np.full(2, np.nan), None) is None
    np.testing.assert_array_equal(fleet._S, before)


def test_compiled_following_equals_the_float_form_on_the_demo(monkeypatch):
    """Every control tick of the demo's first 20 s: the kernel's answer and the Python form's on
    the same fleet state."""
    compiled = FleetPathFollower._command_compiled
    seen = []

    def checked(self, idx, pos, heading, bv, speed, dt_s, course, rows):
        S = self._S.copy()
        want = _reference(self, idx, np.asarray(pos), np.asarray(heading), bv, np.asarray(speed), course, dt_s)
        S_want, self._S[:] = self._S.copy(), S
        got = compiled(self, idx, pos, heading, bv, speed, dt_s, course, rows)
        np.testing.assert_array_equal(got[0], want[0])
        np.testing.assert_array_equal(self._S, S_want)
        for a, b in zip(got[1], want[1]):
            _same_status(a, b)
        seen.append(len(idx))
        return got

    monkeypatch.setattr(FleetPathFollower, "_command_compiled", checked)
    _record_control(per_vessel=False, duration_s=20.0)
    assert seen == [3] * 201
