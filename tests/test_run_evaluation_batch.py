"""The run evaluator keeps samples per record tick and scores them at the end
(:meth:`mjasc.evaluation.tracking_metrics.TrackingScore.add_run`): the same state, bit for bit,
as scoring every tick as it comes with :meth:`TrackingScore.add` on the vessels' estimates and the
simulation's traffic arrays (the readable reference form, kept here), on a real run."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from mjasc.evaluation.tracking_metrics import TrackingScore


class _PerTick:
    """The reference: every record tick scored at once from the perception's TrackEstimates and
    ``Simulation.traffic_state()`` (what the evaluator did before it deferred the work)."""

    def __init__(self, runner, config):
        world = runner.world
        self.ids = list(world.vessel_names) + [o.name for o in world.moving_obstacles]
        self.radii = np.array([t.radius_m for t in world.vessel_types] + [o.radius_m for o in world.moving_obstacles])
        self.scores = {i: TrackingScore(config.gospa_cutoff_m, config.gospa_order,
                                        float(a.perception.sensor_config.max_range_m))
                       for i, a in enumerate(runner.agents) if a.perception is not None}
        self.tp, self.th, self.tv = [], [], []
        self.moving_same = True
        self.aged = False  # (some estimate moved on by more than 1 cm: the prediction to the tick matters)
        self.fleet_rows = []  # per tick: FleetTracker.confirmed_rows (vessels, ids, positions, static flags)

    def __call__(self, event):
        s, runner = event.states, event.runner
        tp, th, tv = runner.sim.traffic_state()
        self.tp.append(np.array(tp, dtype=float).reshape(-1, 2))
        self.th.append(np.array(th, dtype=float).reshape(-1))
        self.tv.append(np.array(tv, dtype=float).reshape(-1, 2))
        xy = np.vstack([s.position_m, self.tp[-1]])
        fleet = runner.agents[0].perception.tracker.fleet
        owner, fids, _, fstatic = fleet.confirmed_rows()
        rows = fleet.cols.confirmed.nonzero()[0]
        x = fleet.bank.state_rows[rows]
        self.fleet_rows.append((owner, fids, _ahead(x[:, :2], fleet.bank.time_rows[rows], x[:, 2], x[:, 3], s.time_s),
                                fstatic))
        for i, score in self.scores.items():
            perception = runner.agents[i].perception
            tracks = perception.tracks()
            ids = [tr.track_id for tr in tracks]
            # each estimate predicted to the tick along its velocity (its estimate is up to a tracking period old)
            ahead = _ahead(np.array([tr.position_m for tr in tracks]).reshape(-1, 2), [tr.time_s for tr in tracks],
                           [tr.heading_rad for tr in tracks], [tr.speed_m_s for tr in tracks], s.time_s)
            static = [tr.is_static for tr in tracks]
            got_ids, pos, got_static = perception.scored_tracks(s.time_s)
            self.moving_same &= got_ids.tolist() == ids and np.allclose(pos, ahead, rtol=0.0, atol=1e-9) and \
                got_static.tolist() == static
            self.aged |= bool(np.any(np.abs(pos - np.array([tr.position_m for tr in tracks]).reshape(-1, 2)) > 0.01))
            others = [k for k in range(len(self.ids)) if k != i]
            score.add(s.time_s, s.position_m[i], [self.ids[k] for k in others], xy[others], ids, pos,
                      self.radii[others], static)


def _ahead(positions, times, headings, speeds, t_s):
    """Positions (k, 2) moved on from their times to t_s along heading and speed (the reference form)."""
    dv = np.maximum(t_s - np.asarray(times, dtype=float), 0.0) * np.asarray(speeds, dtype=float)
    th = np.asarray(headings, dtype=float)
    out = np.array(positions, dtype=float).reshape(-1, 2)
    out[:, 0] = out[:, 0] + dv * np.cos(th)
    out[:, 1] = out[:, 1] + dv * np.sin(th)
    return out


def _assignment(rows, a, b, truths, fast=True):
    """The pairs of the compiled shortcut (least_pairs) or, where it declines (or not ``fast``),
    scipy's: what the scoring pass uses at one time (cost rows track-major)."""
    from scipy.optimize import linear_sum_assignment

    from mjasc.evaluation.gospa_kernels import least_pairs

    cost = np.array(rows, dtype=float)
    idx = np.array(truths, dtype=np.int64)
    r, c = np.empty(len(truths), dtype=np.int64), np.empty(len(truths), dtype=np.int64)
    n = least_pairs(cost, a, b, idx, r, c) if fast else -1
    if n >= 0:
        return list(zip(r[:n].tolist(), c[:n].tolist()))
    r, c = linear_sum_assignment(cost[a:b][:, idx].T)
    return list(zip(r.tolist(), c.tolist()))


def _state(score: TrackingScore):
    return (score._n, dict(score._sum), list(score._sum), score.id_switches, list(score._first_seen.items()),
            list(score._confirmed_at.items()), dict(score._last_id), score._pairs, score._sq)


def test_deferred_scoring_matches_scoring_every_tick_on_a_demo_run():
    import mjasc
    from mjasc.evaluation.run_evaluation import RunEvaluator
    from mjasc.runs.runner import Runner

    sc = mjasc.load_scenario("demo").with_overrides(duration_s=40.0)
    sc = replace(sc, outputs=replace(sc.outputs, recording=False, video=False))
    runner = Runner(sc, None, progress=False)
    ev = RunEvaluator(runner)
    ref = _PerTick(runner, ev.config)
    runner.observe("record", ev)
    runner.observe("record", ref)
    runner.run()
    out = ev.summary()
    assert ref.moving_same and ref.aged
    assert set(ev._scores) == set(ref.scores) and len(ref.scores) >= 3
    for i, score in ref.scores.items():
        assert _state(ev._scores[i]) == _state(score)
        assert out["tracking"][ev.vessel_names[i]] == score.summary()
    # the run exercises what matters: several truths and tracks at once, identity switches
    assert sum(s.id_switches for s in ref.scores.values()) > 0
    assert ev.summary() == out  # scoring again adds nothing
    # the evaluator's samples of the confirmed tracks: the fleet's confirmed_rows at each tick, predicted to it
    tick, owner, ids, xy, static = ev._moving.rows(0, len(ref.fleet_rows))
    assert np.array_equal(tick, np.repeat(np.arange(len(ref.fleet_rows)), [m[0].size for m in ref.fleet_rows]))
    for got, k in zip((owner, ids, xy, static), range(4)):
        want = np.concatenate([m[k] for m in ref.fleet_rows])
        assert got.dtype == want.dtype and got.tobytes() == want.tobytes()
    # the traffic kept as the simulation's rows: the arrays of traffic_state(), bit for bit
    q, qh, w = ev._traffic()
    assert np.array_equal(q, np.array(ref.tp)) and np.array_equal(qh, np.array(ref.th))
    assert np.array_equal(w, np.array(ref.tv))


def test_add_run_equals_add_per_time_on_synthetic_ties_and_gaps():
    """Times without truths in range or without tracks, exact ties, tracks beyond the cut-off."""
    rng = np.random.default_rng(5)
    n_t, truth_ids = 60, ["a", "b", "c"]
    own = rng.normal(size=(n_t, 2)) * 5
    truth = rng.normal(size=(n_t, 3, 2)) * 30
    truth[10:20, 2] = 500.0  # out of range
    tracks_ids, tracks_xy = [], []
    for k in range(n_t):
        n = int(rng.integers(0, 5))
        xy = truth[k, rng.integers(0, 3, size=n)] + rng.normal(size=(n, 2)) * (3 if k % 3 else 15)
        if k % 7 == 0 and n >= 2:
            xy[1] = xy[0]  # an exact tie
        tracks_ids.append(np.array(rng.integers(1, 6, size=n)))
        tracks_xy.append(xy)
    radii = np.array([1.0, 2.0, 0.5])
    a = TrackingScore(8.0, 2.0, 60.0)
    b = TrackingScore(8.0, 2.0, 60.0)
    for k in range(n_t):
        a.add(float(k) * 0.1, own[k], truth_ids, truth[k], tracks_ids[k], tracks_xy[k], radii)
    b.add_run([float(k) * 0.1 for k in range(n_t)], own, truth_ids, truth, tracks_ids, tracks_xy, radii)
    assert _state(a) == _state(b) and a.id_switches > 0
    # with static tracks (optional estimates: never false) the same, and other sums
    static = [rng.random(len(ids)) < 0.4 for ids in tracks_ids]
    a2, b2 = TrackingScore(8.0, 2.0, 60.0), TrackingScore(8.0, 2.0, 60.0)
    for k in range(n_t):
        a2.add(float(k) * 0.1, own[k], truth_ids, truth[k], tracks_ids[k], tracks_xy[k], radii, static[k])
    b2.add_run([float(k) * 0.1 for k in range(n_t)], own, truth_ids, truth, tracks_ids, tracks_xy, radii, static)
    assert _state(a2) == _state(b2) and a2._sum["false"] < a._sum["false"]


def test_one_truth_or_one_track_is_assigned_as_scipy_assigns_it():
    """The single-row and single-column shortcut of the assignment, ties included (scipy decides)."""
    from scipy.optimize import linear_sum_assignment


    rng = np.random.default_rng(9)
    for trial in range(400):
        n_truth, n_tracks = int(rng.integers(1, 4)), int(rng.integers(1, 6))
        cost = np.minimum(rng.uniform(0, 12, size=(n_tracks, n_truth)).round(int(rng.integers(0, 3))), 10.0) ** 2
        rows = cost.tolist()
        truths = sorted(rng.choice(n_truth, size=int(rng.integers(1, n_truth + 1)), replace=False).tolist())
        if trial % 2:
            truths = truths[:1]
        a, b = (0, n_tracks) if trial % 3 else (n_tracks - 1, n_tracks)
        got = [tuple(map(int, rc)) for rc in _assignment(rows, a, b, truths)]
        r, c = linear_sum_assignment(cost[a:b][:, truths].T)
        assert got == list(zip(r.tolist(), c.tolist()))


def test_unique_least_costs_are_assigned_as_scipy_assigns_them():
    """The shortcut for any shape: every truth's (or, with more truths than tracks, every track's)
    unique least cost in a column of its own; exact ties, costs at the cut-off and shared least-cost
    tracks go to scipy. The same pairs in the same order as scipy's, on problems of every size."""
    from scipy.optimize import linear_sum_assignment

    from mjasc.evaluation.gospa_kernels import least_pairs

    rng = np.random.default_rng(11)
    shortcut = 0
    for trial in range(3000):
        n_truth, n_tracks = int(rng.integers(1, 6)), int(rng.integers(1, 7))
        cost = np.minimum(rng.uniform(0, 12, size=(n_tracks, n_truth)).round(int(rng.integers(0, 3))), 10.0) ** 2
        truths = sorted(rng.choice(n_truth, size=int(rng.integers(1, n_truth + 1)), replace=False).tolist())
        a = int(rng.integers(0, n_tracks))
        rows = cost.tolist()
        got = [tuple(map(int, rc)) for rc in _assignment(rows, a, n_tracks, truths)]
        r, c = linear_sum_assignment(cost[a:][:, truths].T)
        assert got == list(zip(r.tolist(), c.tolist()))
        assert got == [tuple(map(int, rc)) for rc in _assignment(rows, a, n_tracks, truths, fast=False)]
        rest = cost[a:][:, truths]
        by_truth = len(truths) <= n_tracks - a
        mins = rest.min(axis=0 if by_truth else 1)
        picks = rest.argmin(axis=0 if by_truth else 1)
        unique = ((rest == (mins[None, :] if by_truth else mins[:, None])).sum(axis=0 if by_truth else 1) == 1).all()
        decided = bool(unique and len(set(picks.tolist())) == len(picks))
        out = np.empty(len(truths), dtype=np.int64), np.empty(len(truths), dtype=np.int64)
        assert (least_pairs(cost, a, n_tracks, np.array(truths, dtype=np.int64), *out) >= 0) == decided
        shortcut += decided
    assert 500 < shortcut < 2500  # both paths taken often


def test_progress_gamma_is_each_agents_mission_gamma_also_on_a_detour():
    """The trace's γ (the thesis method's mission_gamma_m written out) is each vessel's
    ``mission_gamma_m()``, bit for bit, before, on and after an avoidance detour."""
    import mjasc
    from mjasc.evaluation.mission_cost import ProgressTrace
    from mjasc.runs.runner import Runner

    sc = mjasc.load_scenario("thesis_6_4_head_on").with_overrides(duration_s=100.0)
    sc = replace(sc, outputs=replace(sc.outputs, recording=False, video=False))
    runner = Runner(sc, None, progress=False)
    trace = ProgressTrace(runner)
    want, on_detour = [], [0]

    def reference(event):
        agents = event.runner.agents
        want.append([a.mission_gamma_m() if ok else np.nan for a, ok in zip(agents, trace.has_path)])
        for a in agents:
            d = getattr(a.avoidance, "detour", None)
            on_detour[0] += d is not None and a.follower is not None and a.follower.path is d.path

    runner.observe("record", trace)
    runner.observe("record", reference)
    runner.run()
    assert on_detour[0] > 50 and len(want) == len(trace.gamma) > 400
    assert np.asarray(trace.gamma, dtype=float).tobytes() == np.asarray(want, dtype=float).tobytes()


def test_traffic_at_the_record_times_has_the_bits_of_rows():
    """The evaluator's traffic, evaluated after the run at all record times at once, is
    ``MovingObstacleSet.rows`` at each time (constant turns, straight, along a path and past its end)."""
    from mjasc.evaluation.traffic_truth import traffic_at
    from mjasc.guidance.paths import Path as GuidancePath
    from mjasc.physics.obstacles import MovingObstacle, MovingObstacleSet

    bend = GuidancePath.from_waypoints([[0, 0], [50, 0], [50, 50]], turn_radius_m=10.0)
    s = MovingObstacleSet([MovingObstacle("a", 2.0, position_m=(3.0, -4.0), heading_rad=2.1, speed_m_s=1.7),
                           MovingObstacle("b", 3.0, speed_m_s=0.8, path=bend, start_gamma_m=3.3),
                           MovingObstacle("c", 1.0, position_m=(-7, 9), heading_rad=-0.4, speed_m_s=2.2,
                                          turn_rate_rad_s=-0.031)])
    times = [round(0.1 * k, 1) for k in range(2000)] + [1e-3, 999.0]
    got = traffic_at(s, times)
    want = np.array([s.rows(t) for t in times], dtype=float)
    assert got.shape == (len(times), 3, 5) and got.tobytes() == want.tobytes()
    assert traffic_at(MovingObstacleSet([]), times).shape == (len(times), 0, 5)
    assert traffic_at(s, []).shape == (0, 3, 5)
