"""The fleet-batched path following against its per-vessel reference: the stacked projection equals
Path.project, a fleet's commands equal each vessel's own follower's (path switches included), and
the runner's batched control slot gives the same commands and statuses as vessel-by-vessel control.

A fleet runs the law over arrays (numpy) above ``SCALAR_FLEET_MAX`` vessels and vessel by vessel in
plain floats up to it; a follower alone always takes the plain-float form. The tests force the
fleet onto arrays, so they compare the two forms: equal bit for bit where ``math``'s sin, cos and
atan2 equal numpy's (x86-64 without AVX-512, this project's machines), else within 1e-12."""

import math

import numpy as np
import pytest

import mjasc
from mjasc.guidance import following_law, path_following
from mjasc.guidance.path_following import FleetPathFollower, PathFollower
from mjasc.guidance.paths import Path
from mjasc.guidance.stacked_paths import StackedPaths
from mjasc.physics.vessels import load_vessel_type
from mjasc.runs import runner as runner_module
from mjasc.runs.runner import Runner


_x = np.random.default_rng(0).uniform(-10.0, 10.0, 2000)
#: math's transcendental functions give numpy's bits on this machine: compare exactly
EXACT = all(math.sin(v) == np.sin(v) and math.cos(v) == np.cos(v) and math.atan2(v, 1.3) == np.arctan2(v, 1.3)
            for v in _x.tolist())


def _same(a, b):
    if EXACT:
        np.testing.assert_array_equal(a, b)
    else:
        np.testing.assert_allclose(a, b, rtol=0.0, atol=1e-12)


@pytest.fixture
def form(monkeypatch):
    """form("arrays"): fleets of any size run the law over arrays; form("floats"): vessel by vessel."""
    return lambda name: monkeypatch.setattr(path_following, "SCALAR_FLEET_MAX", 0 if name == "arrays" else 10**9)


def _paths(rng, n):
    """A mix of rounded-corner waypoint paths (lines and arcs) and dense polylines (detours)."""
    out = []
    for i in range(n):
        if i % 3 == 2:
            t = np.linspace(0.0, rng.uniform(1.0, 5.0), int(rng.integers(20, 200)))
            out.append(Path.from_points(np.column_stack([40 * np.cos(t), 25 * np.sin(t)]) + rng.uniform(-50, 50, 2)))
        else:
            legs = rng.uniform(30.0, 60.0, (4, 2)) * [1.0, rng.choice([-1.0, 1.0])]
            out.append(Path.from_waypoints(np.cumsum(np.vstack([rng.uniform(-50, 50, 2), legs]), axis=0),
                                           turn_radius_m=float(rng.choice([0.0, 5.0]))))
    return out


def _check_projection(stack, rng):
    n = len(stack)
    L = np.array([p.length for p in stack.paths])
    gamma = rng.uniform(-5.0, L + 5.0)
    along = np.array([p.point(float(np.clip(g, 0, p.length))) for p, g in zip(stack.paths, gamma)])
    xy = along + rng.normal(0.0, rng.choice([0.01, 3.0, 30.0]), (n, 2))
    hint = gamma + rng.normal(0.0, 5.0, n)
    window = rng.choice([5.0, 24.0, 80.0], n)
    rows = np.sort(rng.choice(n, size=max(1, n // 2), replace=False))
    for sel in (None, rows):
        idx = np.arange(n) if sel is None else sel
        q = stack.project(xy[idx, 0], xy[idx, 1], hint[idx], window[idx], sel)
        for k, i in enumerate(idx):
            p = stack.paths[i]
            g = p.project(xy[i], gamma_hint=float(hint[i]), search_window_m=float(window[i]))
            assert q.gamma_m[k] == g
            np.testing.assert_array_equal([q.x_m[k], q.y_m[k]], p.point(g))
            assert q.course_rad[k] == p.tangent_angle(g) and q.curvature_1_m[k] == p.curvature(g)


def test_stacked_projection_equals_path_project_through_path_switches():
    rng = np.random.default_rng(9)
    stack = StackedPaths(_paths(rng, 9))
    _check_projection(stack, rng)
    for _ in range(40):  # switches append blocks and compact the table now and then
        i = int(rng.integers(len(stack)))
        stack.set_path(i, _paths(rng, 3)[int(rng.integers(3))])
        _check_projection(stack, rng)


def test_stacked_point_equals_path_point_bit_for_bit():
    """StackedPaths.point gives each vessel's Path.point for array γ (joints, ends and beyond included)."""
    rng = np.random.default_rng(11)
    stack = StackedPaths(_paths(rng, 7))
    stack.set_path(2, _paths(rng, 1)[0])
    rows = rng.integers(0, len(stack), 300)
    length = np.array([p.length for p in stack.paths])[rows]
    g = np.stack([rng.uniform(-0.1, 1.1, 300) * length,
                  np.zeros(300), length], axis=1)
    g[:40, 0] = [stack.paths[r].segment_starts[-1] for r in rows[:40]]  # at a joint
    got = stack.point(np.broadcast_to(rows[:, None], g.shape), g)
    want = np.stack([stack.paths[r].point(gg) for r, gg in zip(rows, g)])
    np.testing.assert_array_equal(got, want)


def _eval_points_reference(seg, s):
    """segment_geometry.eval_points as it was: both formulas everywhere, picked by np.where."""
    from mjasc.guidance.segment_geometry import COS0, K, SIN0, TH0, X0, Y0

    k = seg[K]
    straight = k == 0.0
    k_safe = np.where(straight, 1.0, k)
    th = seg[TH0] + k * s
    dx = np.where(straight, s * seg[COS0], (np.sin(th) - seg[SIN0]) / k_safe)
    dy = np.where(straight, s * seg[SIN0], (seg[COS0] - np.cos(th)) / k_safe)
    return seg[X0] + dx, seg[Y0] + dy


@pytest.mark.parametrize("turn_radius_m", [0.0, 5.0])
def test_stacked_point_equals_the_segment_formula_with_and_without_arcs(turn_radius_m):
    """Lines only (no trigonometry), or lines and arcs: the bits of the general formula."""
    from mjasc.guidance.segment_geometry import eval_points

    rng = np.random.default_rng(5)
    paths = [Path.from_waypoints(np.cumsum(np.vstack([rng.uniform(-50, 50, 2), rng.uniform(30, 60, (4, 2))]), axis=0),
                                 turn_radius_m=turn_radius_m) for _ in range(6)]
    stack = StackedPaths(paths)
    assert stack._arcs == (turn_radius_m > 0.0)
    rows = rng.integers(0, len(stack), (200, 7))
    length = np.array([p.length for p in stack.paths])[rows]
    g = rng.uniform(-0.1, 1.1, rows.shape) * length
    got = stack.point(rows, g)
    want = np.empty_like(got)
    for r in range(len(stack)):
        sel = rows == r
        _, idx, local = stack.paths[r]._locate(g[sel])  # each path's own segment and local arc length
        want[sel] = np.stack(_eval_points_reference(stack.paths[r].table[:, idx], local), axis=-1)
    np.testing.assert_array_equal(got, want)
    for r, p in enumerate(stack.paths):  # Path.point over arrays (lines only: no table gather, no trigonometry)
        gg = np.concatenate([g[:3].ravel(), [-0.0, 0.0, p.length, p.length + 1.0]])  # > 8: the array form
        _, idx, local = p._locate(gg)
        ref = np.stack(_eval_points_reference(p.table[:, idx], local), axis=-1)
        assert np.array_equal(p.point(gg), ref) and np.array_equal(np.signbit(p.point(gg)), np.signbit(ref))
    seg = stack._table[:, rng.integers(0, stack._used, 500)]
    s = rng.uniform(0.0, 30.0, 500)
    for a, b in zip(eval_points(seg, s), _eval_points_reference(seg, s)):
        np.testing.assert_array_equal(a, b)


def _follower(path, i):
    vt = load_vessel_type("otter" if i % 2 == 0 else "delfim")
    mass = np.diag([60.0 + 5.0 * i, 90.0, 25.0 + 3.0 * i])  # surge and yaw inertia set the gains
    return PathFollower(path, vt, mass, 0.4 + 0.1 * i)


def test_fleet_commands_equal_each_vessels_own_follower_with_path_switches(form):
    """Kinematic inputs, 200 ticks: the same commands and statuses in a fleet of five (the law over
    arrays; also for a per-vessel call on a gathered follower) as each follower alone (plain floats)."""
    rng = np.random.default_rng(3)
    paths = _paths(rng, 5)
    alone = [_follower(p, i) for i, p in enumerate(paths)]
    mine = [_follower(p, i) for i, p in enumerate(paths)]
    fleet = FleetPathFollower.of(mine)
    assert FleetPathFollower.of(mine) is fleet and all(f.fleet is fleet for f in mine)
    gamma = np.zeros(5)
    for tick in range(200):
        gamma += 1.2 * 0.1
        xy = np.array([p.point(g) for p, g in zip([f.path for f in alone], gamma)]) + rng.normal(0, 2.0, (5, 2))
        heading = rng.uniform(-np.pi, np.pi, 5)
        bv = np.column_stack([rng.uniform(0, 2, 5), rng.normal(0, 0.1, 5), rng.normal(0, 0.2, 5)])
        speed = rng.uniform(0.5, 2.0, 5)
        if tick % 37 == 36:  # a detour spliced in for one vessel
            i = int(rng.integers(5))
            new, g0 = _paths(rng, 3)[2], 0.0
            alone[i].set_path(new, g0)
            mine[i].set_path(new, g0)
            gamma[i] = g0
        form("floats")
        ref = [f.command(xy[i], heading[i], None, bv[i], speed[i], 0.1) for i, f in enumerate(alone)]
        form("arrays")
        if tick % 50 == 7:  # one vessel commanded on its own while in the fleet
            cmd, st = mine[2].command(xy[2], heading[2], None, bv[2], speed[2], 0.1)
            cmds, statuses = fleet.command(xy[[0, 1, 3, 4]], heading[[0, 1, 3, 4]], bv[[0, 1, 3, 4]],
                                           speed[[0, 1, 3, 4]], 0.1, rows=np.array([0, 1, 3, 4]))
            cmds = np.insert(cmds, 2, cmd, axis=0)
            statuses.insert(2, st)
        else:
            cmds, statuses = fleet.command(xy, heading, bv, speed, 0.1)
        _same(cmds, np.array([c for c, _ in ref]))
        _same(np.array([[getattr(s, f) for f in s.__dataclass_fields__] for s in statuses], dtype=float),
              np.array([[getattr(s, f) for f in s.__dataclass_fields__] for _, s in ref], dtype=float))


def _record_control(per_vessel: bool, duration_s: float = 30.0):
    """The demo's three vessels for ``duration_s``: every control tick's commands and statuses,
    with the runner's batched control slot or vessel by vessel (``agent.control``; set the law's
    form before)."""
    sc = mjasc.load_scenario("demo").with_overrides(duration_s=duration_s, video=False)
    runner = Runner(sc)
    log = []
    original = runner_module.run_onboard_slot

    def slot(name, agents, navs, dt):
        if name == "control" and per_vessel:
            out = [a.control(nav, dt) for a, nav in zip(agents, navs)]
        else:
            out = original(name, agents, navs, dt)
        if name == "control":
            log.append([(o.commands.copy(), o.status, o.mode) for o in out])
        return out

    runner_module.run_onboard_slot = slot
    try:
        runner.run()
    finally:
        runner_module.run_onboard_slot = original
    return log, runner


def test_batched_control_slot_equals_vessel_by_vessel_on_the_demo(form):
    """The demo's three vessels for 30 s: the runner's control slot with the fleet's law over arrays
    gives the commands, statuses and modes of vessel-by-vessel control (plain floats) at every tick."""
    form("arrays")
    batched, r1 = _record_control(per_vessel=False)
    form("floats")
    single, r2 = _record_control(per_vessel=True)
    assert len(batched) == len(single) == 301
    fleet = r1.agents[0].follower.fleet
    assert len(fleet) == 3 and all(a.follower.fleet is fleet for a in r1.agents)  # one fleet of three …
    assert all(len(a.follower.fleet) == 1 for a in r2.agents)  # … against three fleets of one
    for tick_b, tick_s in zip(batched, single):
        for (cb, sb, mb), (cs, ss, ms) in zip(tick_b, tick_s):
            _same(cb, cs)
            _same(np.array([getattr(sb, f) for f in sb.__dataclass_fields__], dtype=float),
                  np.array([getattr(ss, f) for f in ss.__dataclass_fields__], dtype=float))
            assert mb == ms


def test_float_law_and_near_projection_equal_their_reference_forms_on_the_demo(monkeypatch):
    """The control tick's plain-float law (:func:`~mjasc.guidance.following_law.law_floats`) equals the law written once over the
    operations table (``law(FloatOps, …)``), and the follower's projection ``Path.project_near``
    equals ``Path.project`` with the same hint and window, bit for bit at every tick of the demo."""
    law, near = following_law.law_floats, Path.project_near
    seen = {"law": 0, "projection": 0}

    def law_checked(P, S, *args):
        got = law(P, S, *args)
        ref = following_law.law(following_law.FloatOps, P, list(S), *args)
        assert got == ref and [type(v) for v in got[3]] == [type(v) for v in ref[3]]
        seen["law"] += 1
        return got

    def near_checked(path, px, py, hint, window):
        got = near(path, px, py, hint, window)
        assert got == path.project((px, py), gamma_hint=hint, search_window_m=window)
        seen["projection"] += 1
        return got

    monkeypatch.setattr(following_law, "law_floats", law_checked)
    monkeypatch.setattr(Path, "project_near", near_checked)
    # the Python form the compiled kernel is held to (tests/test_follow_kernel.py)
    monkeypatch.setattr(FleetPathFollower, "_command_compiled", lambda self, *args: None)
    _record_control(per_vessel=False, duration_s=20.0)
    assert seen["law"] == seen["projection"] == 3 * 201
