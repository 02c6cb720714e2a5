"""Tests for mjasc.cooperation.coordination: the γ/L consensus speed law converges (exponentially, at the
linearized rate n·k·v/e_s) with perfect comms, still converges with 30 % loss and 1 s delay,
holds a formation on paths of different lengths, times out stale neighbours, and brings the
thesis §6.4 formation scenario together through the real runner."""

import tomllib
from pathlib import Path as FilePath
from types import SimpleNamespace

import numpy as np
import pytest

from mjasc.cooperation.comms import CommsNetwork, NetworkConfig
from mjasc.cooperation.coordination import Coordination as _Coordination
from mjasc.cooperation.coordination import CoordinationConfig, parse_coordination_options
from mjasc.core.navigation import OwnNavigation
from mjasc.guidance.paths import Path
from mjasc.guidance.state import GuidanceState
from mjasc.runs.scenario import ScenarioError, parse_scenario

SCENARIO = FilePath(__file__).resolve().parents[1] / "tasks" / "formation_l_path.toml"
PERFECT = NetworkConfig(base_delay_s=0.0, jitter_s=0.0, loss_probability=0.0)


def l_paths():
    """Parallel L-paths 10 m apart with concentric rounded corners (lengths differ by ~20 m)."""
    return [Path.from_waypoints(np.array([[0.0, 10.0 * (1 - k)], [300.0 + 10 * k, 10.0 * (1 - k)],
                                          [300.0 + 10 * k, 300.0]]), turn_radius_m=15.0 + 10 * k)
            for k in range(3)]


class Coordination:
    """The coordination stage driven the way the vessel agent drives it, from a fake agent: its
    mission path, speed, radius and top speed at construction; at each exchange its guidance state
    (when its follower has a γ) and its avoidance's planned trajectory (when it has one). Other
    attributes are the controller's own."""

    def __init__(self, agent, network, config=None):
        vessel = getattr(agent, "vessel", None)
        path = getattr(getattr(agent, "config", None), "path", None)
        self.agent = agent
        self.c = _Coordination(agent.name, network, config, mission_path=path,
                               mission_speed_m_s=getattr(agent, "mission_speed_m_s", 1.0),
                               radius_m=getattr(vessel, "radius_m", None),
                               top_speed_m_s=getattr(vessel, "top_speed_m_s", np.inf))

    def __getattr__(self, name):
        return getattr(self.c, name)

    def exchange(self, t, nav, gamma_m):
        f = getattr(self.agent, "follower", None)
        guidance = None
        if f is not None and hasattr(f, "gamma_m"):
            guidance = GuidanceState(f.path, f.gamma_m, self.c.mission_speed_m_s * self.c.last_factor)
        plan, req = None, self.c.plan_request()
        avoidance = getattr(self.agent, "avoidance", None)
        if req is not None and avoidance is not None:
            plan = avoidance.planned_trajectory(t, nav, *req)
        self.c.exchange(t, nav, gamma_m, guidance, plan)


def fake_agent(name, path, speed=1.0):
    return SimpleNamespace(name=name, config=SimpleNamespace(path=path), follower=SimpleNamespace(path=path),
                           mission_speed_m_s=speed, vessel=SimpleNamespace(top_speed_m_s=2.5))


def nav(path, t, gamma, speed):
    chi = float(path.tangent_angle(gamma))
    v = speed * np.array([np.cos(chi), np.sin(chi)])
    return OwnNavigation(t, path.point(gamma), chi, v, np.array([speed, 0.0, 0.0]))


def simulate(gamma0, network_cfg, cfgs=None, duration_s=80.0, dt=0.1, comms_period_s=1.0, seed=0,
             speeds=(1.0, 1.0, 1.0), silent=()):
    """Pure kinematics γ̇_i = f_i v_i with the coordination in the loop: comms every
    ``comms_period_s``, control every ``dt``. Returns times, ξ (n_t, 3), L̄ and the controllers."""
    paths = l_paths()
    names = ["a", "b", "c"]
    net = CommsNetwork(names, network_cfg, np.random.default_rng(seed))
    cfgs = cfgs or [CoordinationConfig()] * 3
    coords = [Coordination(fake_agent(n, p, s), net, c) for n, p, s, c in zip(names, paths, speeds, cfgs)]
    gam = np.array(gamma0, dtype=float)
    vel = np.array(speeds, dtype=float)
    every = int(round(comms_period_s / dt))
    ts, xis = [], []
    for k in range(int(round(duration_s / dt)) + 1):
        t = k * dt
        navs = [nav(p, t, g, v) for p, g, v in zip(paths, gam, vel)]
        if k % every == 0:
            for i, (c, n) in enumerate(zip(coords, navs)):
                if names[i] not in silent or t < 10.0:
                    c.exchange(t, n, gam[i])
        vel = np.array([c.speed_correction(t, n, g) * s for c, n, g, s in zip(coords, navs, gam, speeds)])
        ts.append(t)
        xis.append(gam / [p.length for p in paths])
        gam = gam + vel * dt
    return np.array(ts), np.array(xis), float(np.mean([p.length for p in paths])), coords


def spread_m(xis, l_bar):
    return l_bar * (xis.max(axis=1) - xis.min(axis=1))


def test_perfect_comms_converges_exponentially_at_the_linearized_rate():
    cfg = CoordinationConfig(max_speed_correction=0.5, error_scale_m=10.0)
    t, xis, l_bar, coords = simulate([10.0, 14.0, 7.0], PERFECT, [cfg] * 3, duration_s=80.0)
    s = spread_m(xis, l_bar)
    assert s[0] == pytest.approx(7.0, abs=0.5)
    assert s[-1] < 1e-3 * s[0]
    # log-linear decay between 2 m and 0.01 m: slope ≈ −λ, λ = n k v̄ / e_s = 3·0.5·1/10
    lam = 3 * 0.5 * 1.0 / 10.0
    sel = (s < 2.0) & (s > 0.01)
    slope = np.polyfit(t[sel], np.log(s[sel]), 1)[0]
    assert slope == pytest.approx(-lam, rel=0.15)
    # the error is monotone (no overshoot) and every vessel reports it has converged
    assert np.all(np.diff(s[t > 1.0]) <= 1e-9)
    for c in coords:
        summ = c.summary()
        assert abs(summ["final_error_m"]) < 0.01 and summ["final_spread_m"] < 0.01
        # first sample at t = 1 s, from the t = 0 messages extrapolated with the uncorrected speed
        assert summ["initial_spread_m"] == pytest.approx(s[10], abs=1.0)
        assert summ["in_formation_from_s"] is not None and summ["in_formation_from_s"] < 30.0
        assert summ["messages_lost"] == 0


def test_in_formation_the_feed_forward_keeps_paths_of_different_lengths_together():
    paths = l_paths()
    lengths = np.array([p.length for p in paths])
    assert np.ptp(lengths) > 15.0
    gamma0 = 0.05 * lengths  # all at ξ = 0.05: abreast
    t, xis, l_bar, coords = simulate(gamma0, PERFECT, duration_s=60.0)
    # (the first control tick, before any message has arrived, sails at the plain mission speed)
    s = spread_m(xis, l_bar)
    assert s[1] == pytest.approx(l_bar * 0.1 * (1 / lengths.min() - 1 / lengths.max()))
    assert s[-1] < 1e-6
    # speeds proportional to path length: f_i = L_i / L̄ with equal mission speeds
    np.testing.assert_allclose([c.last_factor for c in coords], lengths / lengths.mean(), rtol=1e-6)


def test_lossy_delayed_link_still_converges_but_slower():
    cfg = CoordinationConfig(max_speed_correction=0.5, error_scale_m=10.0)
    lossy = NetworkConfig(base_delay_s=1.0, jitter_s=0.0, loss_probability=0.3)
    g0 = [10.0, 30.0, 0.0]
    t, xp, l_bar, _ = simulate(g0, PERFECT, [cfg] * 3, duration_s=120.0)
    _, xl, _, coords = simulate(g0, lossy, [cfg] * 3, duration_s=120.0, seed=1)
    sp, sl = spread_m(xp, l_bar), spread_m(xl, l_bar)
    assert sl[-1] < 0.01 * sl[0]  # converges
    t_p = t[np.argmax(sp < 0.5)]
    t_l = t[np.argmax(sl < 0.5)]
    assert t_l > t_p  # ... slower
    link = coords[0].summary()
    assert link["loss_rate"] == pytest.approx(0.3, abs=0.1)
    assert link["mean_delay_s"] == pytest.approx(1.0)
    # without the extrapolation (the paper's held values) it converges too, with a 1 s delay
    held = CoordinationConfig(max_speed_correction=0.5, error_scale_m=10.0, extrapolate=False)
    _, xh, _, _ = simulate(g0, lossy, [held] * 3, duration_s=120.0, seed=1)
    assert spread_m(xh, l_bar)[-1] < 0.01 * sl[0]


def test_leader_keeps_its_speed_and_the_others_join_it():
    cfgs = [CoordinationConfig(role="leader"), CoordinationConfig(), CoordinationConfig()]
    t, xis, l_bar, coords = simulate([10.0, 20.0, 0.0], PERFECT, cfgs, duration_s=150.0)
    paths = l_paths()
    lengths = np.array([p.length for p in paths])
    # the leader progresses at the nominal formation rate v̄/L̄ throughout
    rate = np.diff(xis[1:, 0]) / np.diff(t[1:])  # from the first message on
    np.testing.assert_allclose(rate, 1.0 / lengths.mean(), rtol=1e-9)
    assert spread_m(xis, l_bar)[-1] < 0.01
    assert xis[-1, 1] == pytest.approx(xis[-1, 0], abs=1e-4)


def test_stale_neighbours_time_out_and_come_back():
    paths = l_paths()
    net = CommsNetwork(["a", "b"], PERFECT, np.random.default_rng(0))
    a = Coordination(fake_agent("a", paths[0]), net, CoordinationConfig(neighbour_timeout_s=3.0))
    b = Coordination(fake_agent("b", paths[1]), net, CoordinationConfig(neighbour_timeout_s=3.0))
    ga, gb = 10.0, 30.0  # b is 20 m ahead
    for t in range(0, 5):
        b.exchange(float(t), nav(paths[1], t, gb, 1.0), gb)
        a.exchange(float(t), nav(paths[0], t, ga, 1.0), ga)
    assert a.active_neighbours() == ["b"]
    assert a.speed_correction(4.5, nav(paths[0], 4.5, ga, 1.0), ga) > 1.2  # behind: speeds up
    assert set(a.team_positions()) == {"b"}
    assert a.team_positions()["b"][0] == 4.0
    # b falls silent after t = 4: a drops it after 3 s and sails at the feed-forward speed
    for t in range(5, 10):
        a.exchange(float(t), nav(paths[0], t, ga, 1.0), ga)
    assert a.active_neighbours() == []
    ff = 0.5 * (paths[0].length + paths[1].length)
    assert a.speed_correction(9.5, nav(paths[0], 9.5, ga, 1.0), ga) == pytest.approx(paths[0].length / ff)
    events = a.drain_events()
    assert len(events) == 1 and events[0][0] == 8.0 and "lost b" in events[0][1]
    b.exchange(10.0, nav(paths[1], 10.0, gb, 1.0), gb)
    a.exchange(11.0, nav(paths[0], 11.0, ga, 1.0), ga)
    assert a.active_neighbours() == ["b"]
    events = a.drain_events()
    assert len(events) == 1 and "regained b" in events[0][1]
    assert a.drain_events() == []
    assert a.summary()["neighbours_active"] == ["b"]


def test_parse_coordination_options():
    cfg = parse_coordination_options({"error_scale_m": 5, "role": "leader", "extrapolate": False}, "vessels[2].comms")
    assert cfg == CoordinationConfig(error_scale_m=5.0, role="leader", extrapolate=False)
    for table, msg in [({"max_speed_correction": 1.0}, "max_speed_correction: must be in \\(0, 1\\)"),
                       ({"error_scale_m": 0}, "error_scale_m: must be > 0"),
                       ({"role": "boss"}, "role: must be one of leader, peer"),
                       ({"extrapolate": "yes"}, "extrapolate: must be true or false"),
                       ({"neighbour_timeout_s": -1}, "neighbour_timeout_s: must be > 0"),
                       ({"gain": 1}, "gain: unknown field")]:
        with pytest.raises(ValueError, match=r"^vessels\[2\]\.comms\." + msg):
            parse_coordination_options(table, "vessels[2].comms")
    data = tomllib.loads(SCENARIO.read_text())
    data["vessels"][1]["comms"] = {"error_scale_m": -1.0}
    with pytest.raises(ScenarioError, match=r"vessels\[1\]\.comms\.error_scale_m: must be > 0"):
        parse_scenario(data)


# ---------------------------------------------------------------------- through the runner
def _formation_spread(data, duration_s):
    from mjasc.runs.runner import Runner

    data = {**data, "duration_s": duration_s, "outputs": {"recording": False}}
    runner = Runner(parse_scenario(data, str(SCENARIO)))
    lengths = np.array([a.follower.path.length for a in runner.agents])

    def spread():
        xi = np.array([a.follower.gamma_m for a in runner.agents]) / lengths
        return float(lengths.mean() * np.ptp(xi))

    before = spread()
    result = runner.run()
    return before, spread(), result.summary


def test_formation_scenario_through_the_runner():
    data = tomllib.loads(SCENARIO.read_text())
    data["comms"] = {"loss_probability": 0.0}  # perfect radio link
    before, after, summary = _formation_spread(data, 60.0)
    off = {**data, "vessels": [{k: v for k, v in vessel.items() if k != "comms"} for vessel in data["vessels"]]}
    off.pop("comms")
    before_off, after_off, summary_off = _formation_spread(off, 60.0)
    assert before == pytest.approx(before_off) and before > 20.0
    assert after < 0.1 * before  # the coordination closes the gaps …
    assert after < 0.1 * after_off  # … which do not close by themselves
    coord = summary["vessels"]["bravo"]["coordination"]
    assert coord["messages_lost"] == 0 and coord["messages_received"] > 100
    assert abs(coord["final_error_m"]) < 0.1 * coord["max_abs_error_m"]
    # each vessel's view of the formation spread agrees with the truth at the start and the end
    for name in ("alpha", "bravo", "charlie"):
        c = summary["vessels"][name]["coordination"]
        assert c["initial_spread_m"] == pytest.approx(before, abs=2.0)
        assert c["final_spread_m"] == pytest.approx(after, abs=0.2)
    assert "coordination" not in summary_off["vessels"]["bravo"]


def test_vessel_without_a_path_shares_its_position_only():
    paths = l_paths()
    net = CommsNetwork(["a", "buoy"], PERFECT, np.random.default_rng(0))
    a = Coordination(fake_agent("a", paths[0]), net, CoordinationConfig())
    buoy_agent = SimpleNamespace(name="buoy", config=SimpleNamespace(path=None), follower=None)
    buoy = Coordination(buoy_agent, net, CoordinationConfig())
    still = OwnNavigation(0.0, np.array([50.0, 50.0]), 0.0, np.zeros(2), np.zeros(3))
    buoy.exchange(0.0, still, 0.0)
    a.exchange(1.0, nav(paths[0], 1.0, 10.0, 1.0), 10.0)
    assert buoy.speed_correction(1.0, still, 0.0) == 1.0
    assert a.speed_correction(1.0, nav(paths[0], 1.0, 10.0, 1.0), 10.0) == 1.0  # nothing to coordinate with
    np.testing.assert_allclose(a.team_positions()["buoy"][1], [50.0, 50.0])


# ------------------------------------------------------------------------------------ intentions
def _following_agent(name, path, gamma, speed=1.0):
    a = fake_agent(name, path, speed)
    a.follower = SimpleNamespace(path=path, gamma_m=gamma)
    a.vessel = SimpleNamespace(top_speed_m_s=2.5, radius_m=2.1)
    return a


def test_messages_carry_the_path_ahead_as_an_intention():
    """Without an avoidance component the plan is the follower's path ahead at the mission speed:
    b's intention 30 s later lies 30 m further along a's path (around the corner too)."""
    paths = l_paths()
    net = CommsNetwork(["a", "b"], PERFECT, np.random.default_rng(0))
    a = Coordination(_following_agent("a", paths[0], 290.0), net, CoordinationConfig(intent_horizon_s=40.0))
    b = Coordination(_following_agent("b", paths[1], 0.0), net, CoordinationConfig())
    a.exchange(5.0, nav(paths[0], 5.0, 290.0, 1.0), 290.0)
    b.exchange(5.1, nav(paths[1], 5.1, 0.0, 1.0), 0.0)
    it = b.team_intentions()["a"]
    assert it.has_plan and it.plan_times_s[0] == 5.0 and it.plan_times_s[-1] == pytest.approx(45.0)
    assert it.radius_m == 2.1
    np.testing.assert_allclose(it.positions([35.0])[0], paths[0].point(320.0), atol=1e-6)
    np.testing.assert_allclose(it.positions([20.5])[0], paths[0].point(305.5), atol=0.05)  # interpolated
    # After the plan's end: along its last segment (north, on the L's second leg).
    np.testing.assert_allclose(it.positions([55.0])[0] - it.positions([45.0])[0], [0.0, 10.0], atol=0.05)
    # Age filter.
    assert b.team_intentions(10.0, max_age_s=3.0) == {}
    assert set(b.team_intentions(7.0, max_age_s=3.0)) == {"a"}


def test_the_avoidance_plan_is_what_is_broadcast():
    """A vessel with an avoidance component broadcasts its ``planned_trajectory`` (its detour, its
    slowed speed) instead of the mission path."""
    paths = l_paths()
    net = CommsNetwork(["a", "b"], PERFECT, np.random.default_rng(0))
    agent = _following_agent("a", paths[0], 10.0)
    detour = (5.0 + np.arange(3.0) * 10.0, np.array([[10.0, 10.0], [15.0, 20.0], [20.0, 30.0]]))
    agent.avoidance = SimpleNamespace(planned_trajectory=lambda t, n, h, dt: detour)
    a = Coordination(agent, net, CoordinationConfig())
    b = Coordination(_following_agent("b", paths[1], 0.0), net, CoordinationConfig())
    a.exchange(5.0, nav(paths[0], 5.0, 10.0, 1.0), 10.0)
    b.exchange(5.1, nav(paths[1], 5.1, 0.0, 1.0), 0.0)
    it = b.team_intentions()["a"]
    np.testing.assert_allclose(it.positions([10.0, 20.0]), [[12.5, 15.0], [17.5, 25.0]])
    # intent_horizon_s = 0: position and velocity only, extrapolated in a straight line.
    net = CommsNetwork(["a", "b"], PERFECT, np.random.default_rng(0))
    a = Coordination(agent, net, CoordinationConfig(intent_horizon_s=0.0))
    b = Coordination(_following_agent("b", paths[1], 0.0), net, CoordinationConfig())
    a.exchange(5.0, nav(paths[0], 5.0, 10.0, 1.0), 10.0)
    b.exchange(5.1, nav(paths[1], 5.1, 0.0, 1.0), 0.0)
    it = b.team_intentions()["a"]
    assert not it.has_plan
    np.testing.assert_allclose(it.positions([15.0])[0], paths[0].point(10.0) + [10.0, 0.0])


def test_intent_options_are_validated():
    with pytest.raises(ValueError, match=r"^vessels\[0\]\.comms\.intent_step_s: must be > 0"):
        parse_coordination_options({"intent_step_s": 0}, "vessels[0].comms")
    with pytest.raises(ValueError, match=r"^comms\.intent_horizon_s: must be ≥ 0"):
        CoordinationConfig(intent_horizon_s=-1.0)


def _fleet_run(batched, n=12, duration_s=25.0, dt=0.1):
    """n vessels on parallel lines over a lossy, jittery link (one leader, one holding values, one
    falling silent for a while); vessel by vessel, or batched as the runner's tick does it."""
    paths = [Path.from_waypoints(np.array([[0.0, 10.0 * k], [400.0 + 3 * k, 10.0 * k]])) for k in range(n)]
    names = [f"v{k}" for k in range(n)]
    net = CommsNetwork(names, NetworkConfig(loss_probability=0.2, jitter_s=0.4, base_delay_s=0.05, range_m=120.0),
                       np.random.default_rng(4))
    cfgs = [CoordinationConfig(role="leader" if k == 0 else "peer", extrapolate=k != 3,
                               formation_offset_m=2.0 * (k % 3)) for k in range(n)]
    coords = [_Coordination(nm, net, c, mission_path=p, mission_speed_m_s=1.0 + 0.05 * k, top_speed_m_s=1.6)
              for k, (nm, p, c) in enumerate(zip(names, paths, cfgs))]
    gam = np.linspace(0.0, 30.0, n)
    out = []
    for step in range(int(round(duration_s / dt)) + 1):
        t = step * dt
        navs = [nav(p, t, g, 1.0) for p, g in zip(paths, gam)]
        talking = [k for k in range(n) if not (k == 5 and 6.0 < t < 14.0)]
        if step % 10 == 0:
            if batched:
                ids = [coords[k].broadcast(t, navs[k], gam[k]) for k in talking]
                if batched == "fleet":  # (take_in_fleet: the link delivering at once)
                    _Coordination.take_in_fleet([coords[k] for k in talking], t, [navs[k].position_m for k in talking],
                                                [gam[k] for k in talking], [i + 1 for i in ids])
                else:
                    _Coordination.decide_link([coords[k] for k in talking], t, [navs[k].position_m for k in talking],
                                              [i + 1 for i in ids])
                    for k in talking:
                        coords[k].take_in(t, navs[k], gam[k], decided=True)
            else:
                for k in talking:
                    coords[k].exchange(t, navs[k], gam[k])
        if batched == "fleet":
            f = _Coordination.speed_correction_fleet(coords, t, [v.position_m for v in navs], gam.tolist())
        elif batched:
            _Coordination.decide_link(coords, t, [v.position_m for v in navs])
            f = _Coordination.speed_correction_many([(c, t, v, g) for c, v, g in zip(coords, navs, gam)])
        else:
            f = [c.speed_correction(t, v, g) for c, v, g in zip(coords, navs, gam)]
        out.append(f)
        gam = gam + np.array(f) * dt
    return np.array(out), coords, net


def test_batched_coordination_equals_vessel_by_vessel_bit_for_bit():
    """The runner's tick: every message sent, the link decided once per slot, one tanh for the
    fleet — the same factors, states, events and link statistics as the calls one by one."""
    f1, c1, n1 = _fleet_run(False)
    assert np.ptp(f1) > 0.1  # the law acts
    events = [c.drain_events() for c in c1]
    assert any(events)
    for batched in (True, "fleet"):  # (speed_correction_many; speed_correction_fleet: the link delivering at once)
        f2, c2, n2 = _fleet_run(batched)
        np.testing.assert_array_equal(f1, f2)
        for a, b, ev in zip(c1, c2, events):
            assert (a.last_error_m, a.last_xi, a.last_spread_m, a.received) == (b.last_error_m, b.last_xi,
                                                                               b.last_spread_m, b.received)
            assert a._history == b._history and ev == b.drain_events()
            assert a.summary() == b.summary()
        assert n1.link_matrix() == n2.link_matrix() and n1.stats() == n2.stats()
    assert any(len(c.active_neighbours()) >= 8 for c in c1)  # the compiled gaps ran


def test_gap_sum_equals_the_sum_of_the_gaps_to_xi_hat():
    """_TeamView.gap_sum (compiled above 8 neighbours) against _sum(own − xi_hat) bit for bit."""
    from mjasc.cooperation.coordination import _sum, _TeamView

    rng = np.random.default_rng(8)
    for n in (3, 8, 9, 40, 200):
        view = object.__new__(_TeamView)
        view.rows = [tuple(r) for r in np.column_stack([rng.uniform(0, 1, n), rng.normal(0, 0.01, n),
                                                        rng.uniform(0, 10, n), rng.uniform(0.5, 1, n)]).tolist()]
        view.arrays = np.ascontiguousarray(np.array(view.rows).T) if n >= 8 else None
        for extrapolate in (True, False):
            own, t = float(rng.uniform(0, 1)), float(rng.uniform(10, 40))
            xis = view.xi_hat(t, extrapolate)
            want = _sum(own - xis if isinstance(xis, np.ndarray) else [own - x for x in xis])
            assert view.gap_sum(t, extrapolate, own) == want


def test_message_equals_the_team_message_constructor():
    """Coordination._message builds its TeamMessage without the frozen __init__: every field the
    constructor gives, in field order, with fresh default arrays where the message has no plan."""
    from dataclasses import fields

    from mjasc.cooperation.coordination import Coordination as Method
    from mjasc.cooperation.messages import TeamMessage

    paths = l_paths()
    net = CommsNetwork(["a", "b"], PERFECT, np.random.default_rng(0))
    own = nav(paths[0], 3.0, 40.0, 1.2)
    plan = (np.arange(3.0), np.ones((3, 2)))
    for path, cfg, kw in [(paths[0], CoordinationConfig(), {"plan": plan}),
                          (paths[0], CoordinationConfig(intent_horizon_s=0.0, formation_offset_m=2.0), {}),
                          (None, CoordinationConfig(intent_horizon_s=0.0), {"tracks": ("t1", "t2"), "mission": "m"}),
                          (paths[1], CoordinationConfig(), {"plan": plan, "mission": "m"}),
                          (paths[0], CoordinationConfig(), {"plan": plan, "gives_way_to": ["b"]})]:
        c = Method("a", net, cfg, mission_path=path, mission_speed_m_s=1.5, radius_m=2.0, top_speed_m_s=3.0)
        c.phase = 2
        got = c._message(3.0, own, 40.0, None, kw.get("plan"), kw.get("tracks", ()), kw.get("mission"),
                         kw.get("gives_way_to", ()))
        ref = {}
        if "mission" in kw:
            ref.update(phase=2, mission="m")
        if "plan" in kw:
            ref["plan_times_s"], ref["plan_points_m"] = plan
        if path is not None:
            chi = float(path.tangent_angle(40.0))
            along = float(np.dot(own.velocity_m_s[:2], (np.cos(chi), np.sin(chi))))
            ref.update(gamma_m=40.0, path_length_m=float(path.length), xi=c.xi(40.0),
                       xi_rate_1_s=along / float(path.length), offset_m=cfg.formation_offset_m)
        if kw.get("tracks"):
            ref["tracks"] = tuple(kw["tracks"])
        if kw.get("gives_way_to"):
            ref["gives_way_to"] = tuple(kw["gives_way_to"])
        want = TeamMessage("a", np.array(own.position_m[:2]), float(own.heading_rad), np.array(own.velocity_m_s[:2]),
                           1.5, 2.0, **ref)
        assert list(got.__dict__) == [f.name for f in fields(TeamMessage)]
        for f in fields(TeamMessage):
            a, b = getattr(got, f.name), getattr(want, f.name)
            if isinstance(b, np.ndarray):
                assert type(a) is np.ndarray and a.shape == b.shape and a.tobytes() == b.tobytes()
            else:
                assert type(a) is type(b) and a == b, f.name
        if "plan" not in kw:
            assert got.plan_times_s is not c._message(3.0, own, 40.0).plan_times_s  # fresh defaults


def test_intention_from_a_typed_message_equals_the_converted_form_on_the_demo(monkeypatch):
    """TeamIntention.from_message takes a TeamMessage's float arrays as they are; the same message's
    fields handed as a plain object (every array converted: np.asarray, reshape, [:2]) give the
    same intention, value for value and bit for bit, for every message of 20 s of the demo."""
    import dataclasses

    import mjasc
    from mjasc.cooperation.messages import TeamIntention, TeamMessage
    from mjasc.runs.runner import Runner

    original = TeamIntention.from_message.__func__
    seen = []

    def checked(cls, msg, sent_time_s):
        got = original(cls, msg, sent_time_s)
        if type(msg) is TeamMessage:
            fields = {f.name: getattr(msg, f.name) for f in dataclasses.fields(TeamMessage)}
            ref = original(cls, SimpleNamespace(**fields), sent_time_s)
            for f in dataclasses.fields(TeamIntention):
                a, b = getattr(got, f.name), getattr(ref, f.name)
                if isinstance(a, np.ndarray):
                    assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
                else:
                    assert a == b or (a is None and b is None)
            seen.append(msg.plan_times_s.size)
        return got

    monkeypatch.setattr(TeamIntention, "from_message", classmethod(checked))
    sc = mjasc.load_scenario(str(FilePath(__file__).resolve().parents[1] / "tasks/demo.toml"))
    sc = dataclasses.replace(sc.with_overrides(duration_s=20.0),
                             outputs=dataclasses.replace(sc.outputs, recording=False, video=False))
    Runner(sc, out_dir=None).run()
    assert len(seen) > 50 and max(seen) > 2

