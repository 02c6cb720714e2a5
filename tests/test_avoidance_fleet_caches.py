"""What collision avoidance makes once for the fleet — a team mate's estimate per message, each
plan's knots in one table — and the columns of a fleet's prediction: the same numbers as the
readable forms (the dataclass constructors, one stacked table per call, one vessel at a time)."""

from dataclasses import replace

import numpy as np

from mjasc.avoidance.prediction import CollisionPredictionConfig, PredictionQuery, TrackMotions, predict_conflicts, \
    predict_fleet
from mjasc.avoidance.prediction import team_plans
from mjasc.avoidance.prediction.team_plans import _PlanTable, _StackedPlans, intention_positions
from mjasc.avoidance.team_mates import TeamMates
from mjasc.cooperation.messages import TeamIntention
from mjasc.core.estimates import PlannedTrack, TrackEstimate
from mjasc.guidance.paths import Path


def _intentions(rng, n, t0=50.0, plan=True):
    out = []
    for k in range(n):
        pos = rng.uniform(-50, 50, 2)
        if plan and k % 4:
            ts = t0 - 0.3 + np.arange(0.0, 20.0 + k % 3, 0.5)
            pts = pos + np.cumsum(rng.normal(0.0, 0.6, (ts.size, 2)), axis=0)
        else:  # no plan: the broadcast velocity
            ts, pts = np.zeros(0), np.zeros((0, 2))
        out.append(TeamIntention(f"m{k}", t0 - 0.3, pos, rng.uniform(-3, 3), rng.normal(0, 1, 2), 2.0, ts, pts))
    return out


def test_the_plan_table_gives_each_plans_positions_across_calls_and_restarts():
    """Rows looked up in a table filled over many calls (and started again when full) give the
    positions of a table stacked for the call alone, bit for bit."""
    rng = np.random.default_rng(2)
    table = _PlanTable()
    table._MAX_ROWS = 12  # restarts within the test
    pool = _intentions(rng, 20)
    times = np.linspace(40.0, 80.0, 37)
    for call in range(15):
        its = [pool[k] for k in rng.choice(len(pool), 7)]  # repeats included
        plans, rows = table.rows(its)
        got = plans.at(np.repeat(rows, times.size), np.tile(times, len(its))).reshape(len(its), -1, 2)
        ref = _StackedPlans(its).at(np.repeat(np.arange(len(its)), times.size),
                                    np.tile(times, len(its))).reshape(len(its), -1, 2)
        np.testing.assert_array_equal(got, ref)
        np.testing.assert_array_equal(got, np.stack([it.positions(times) for it in its]))
        assert plans.t_first.size <= 12 + 7


def test_the_plan_tables_rows_hold_the_numbers_of_stacked_plans():
    """Each row a table writes in one compiled pass (:func:`team_plans._stack_into`) holds, field for
    field, the numbers :class:`_StackedPlans` makes for its intention (knot offsets shifted to the
    table's columns): plans of 0, 1 and many knots, repeated and non-finite knot times, across
    batches, growth and restarts; intentions whose arrays are not float64 take the readable form."""
    rng = np.random.default_rng(6)
    pool = _intentions(rng, 24)
    for k in (3, 7):  # one knot: no plan
        pool[k] = replace(pool[k], plan_times_s=pool[k].plan_times_s[:1], plan_points_m=pool[k].plan_points_m[:1])
    for k in (5, 9):  # the last two knots at one time, a NaN knot time
        ts = pool[k].plan_times_s.copy()
        ts[-1] = ts[-2] if k == 5 else np.nan
        pool[k] = replace(pool[k], plan_times_s=ts)
    pool.append(replace(pool[1], plan_times_s=pool[1].plan_times_s.astype(np.float32)))  # (the readable form)
    table = _PlanTable()
    table._MAX_ROWS = 30
    checked = 0
    for call in range(25):
        its = [pool[k] for k in rng.choice(len(pool), int(rng.integers(1, 9)))]
        plans, rows = table.rows(its)
        for it, r in zip(its, rows.tolist()):
            ref = _StackedPlans([it])
            for name in ("start", "count", "t_first", "t_last", "anchor", "t_anchor", "vel", "p_last", "v_end"):
                want = getattr(ref, name)[0] + (plans.start[r] if name == "start" else 0)
                assert np.asarray(getattr(plans, name)[r]).tobytes() == np.asarray(want).astype(
                    getattr(plans, name).dtype).tobytes(), (name, call)
            a, c = plans.start[r], plans.count[r]
            for name in ("ts", "xs", "ys"):
                assert getattr(plans, name)[a:a + c].tobytes() == getattr(ref, name).astype(np.float64).tobytes()
            checked += 1
    assert checked > 80


def test_the_walk_along_a_plans_rising_times_gives_the_bisections_positions():
    """:func:`team_plans._plan_positions` walks on from the last knot interval within a run of one
    plan's rising times; every item's position is :func:`team_plans.plan_position`'s (a bisection
    per item), bit for bit: runs of rising, falling, repeated and NaN times, times before, inside
    and after the knots, knots unsorted, repeated or NaN, plans without knots, and items whose plans
    alternate."""
    rng = np.random.default_rng(11)
    pool = _intentions(rng, 12)
    shuffled = pool[2].plan_times_s.copy()
    rng.shuffle(shuffled)
    pool[2] = replace(pool[2], plan_times_s=shuffled)  # unsorted knots: the bisection's answer all the same
    ts = pool[5].plan_times_s.copy()
    ts[4:7] = ts[4]  # repeated knot times
    pool[5] = replace(pool[5], plan_times_s=ts)
    ts = pool[6].plan_times_s.copy()
    ts[-3] = np.nan
    pool[6] = replace(pool[6], plan_times_s=ts)
    stacked = _StackedPlans(pool)
    fields = [getattr(stacked, f) for f in team_plans.PLAN_FIELDS]
    walked = 0
    for case in range(40):
        k = int(rng.integers(1, len(pool) + 1))
        plans = rng.choice(len(pool), k)
        n = int(rng.integers(1, 60))
        if case % 3 == 0:  # runs of rising times (a track's samples), some long steps, some on knots
            knots = stacked.ts[np.isfinite(stacked.ts)]
            times = np.sort(np.r_[rng.uniform(40.0, 80.0, n), rng.choice(knots, n)])
            n = times.size
            items, t = np.repeat(plans, n), np.tile(times, k)
            walked += k * n
        elif case % 3 == 1:  # anything: falling, repeated and NaN times, plans alternating
            items, t = rng.choice(len(pool), n), rng.choice(np.r_[rng.uniform(40.0, 80.0, 8), np.nan], n)
            t[::5] = t[0]
        else:  # a run that rises, falls back and rises again
            times = np.r_[np.linspace(45.0, 70.0, n), np.linspace(50.0, 75.0, n)]
            items, t = np.full(times.size, plans[0]), times
        items = np.ascontiguousarray(items, dtype=np.intp)
        t = np.ascontiguousarray(t, dtype=float)
        got = np.empty((items.size, 2))
        team_plans._plan_positions(items, t, *fields, got)
        want = np.array([team_plans.plan_position(int(p), float(x), *fields) for p, x in zip(items, t)]).reshape(-1, 2)
        assert got.tobytes() == want.tobytes(), case
    assert walked > 1000


def test_track_motions_and_intention_positions_read_the_shared_table():
    rng = np.random.default_rng(4)
    its = _intentions(rng, 9)
    tracks = [PlannedTrack(k, it.sent_time_s, it.position_m, 0.0, 1.0, 0.0, 1.5 + k, team_member=it.name,
                           intention=it) for k, it in enumerate(its)]
    tracks += [TrackEstimate(100, 49.0, np.array([3.0, 4.0]), 0.4, 1.2, 0.02, 2.5),
               TrackEstimate(101, 49.0, np.array([-3.0, 4.0]), 0.4, 0.0, 0.0, 0.5, is_static=True)]
    times = np.linspace(30.0, 90.0, 61)
    for _ in range(2):  # first stacked, then looked up
        m = TrackMotions(tracks)
        np.testing.assert_array_equal(m.grid(times), np.stack([tr.predict_positions(times) for tr in tracks]))
        np.testing.assert_array_equal(m.radius_m, [tr.radius_m for tr in tracks])
        np.testing.assert_array_equal(intention_positions(its, times), np.stack([it.positions(times) for it in its]))
        for k in range(1, 5):  # a few, as in a small team: the table too
            np.testing.assert_array_equal(intention_positions(its[:k], times),
                                          np.stack([it.positions(times) for it in its[:k]]))
        assert intention_positions([], times).shape == (0, times.size, 2)
    assert team_plans._PLANS.rows(its)[1].tolist() == team_plans._PLANS.rows(list(reversed(its)))[1].tolist()[::-1]


def test_a_team_mates_estimate_is_made_once_per_message_for_every_receiver():
    """Two receivers of the same messages: their team-mate tracks equal the dataclass forms, and
    the part made of the message alone is one object for both."""
    rng = np.random.default_rng(7)
    its = _intentions(rng, 4)

    class Picture:
        def __init__(self, intentions):
            self.intentions = {it.name: it for it in intentions}

        def fresh(self, t, max_age):
            return {n: it for n, it in self.intentions.items() if t - it.sent_time_s <= max_age}

    team = {it.name for it in its}
    a = TeamMates("a", team, 1.0, 3.0, 2.0, 30.0)
    b = TeamMates("b", team, 1.0, 3.0, 2.0, 30.0)
    pic = Picture(its)
    own = [TrackEstimate(7, 49.9, its[1].position_m + 0.3, 0.1, 1.0, 0.03, 2.2, np.eye(2) * 0.4,
                         team_member=its[1].name)]
    got_a = a.tracks(own, 50.0, pic, lambda *_: None)
    got_b = b.tracks(own, 50.0, pic, lambda *_: None)
    assert len(got_a) == len(its)
    for x, y in zip(got_a, got_b):
        assert type(x) is type(y) and x.__dict__.keys() == y.__dict__.keys()
        assert x.track_id == y.track_id and x.team_member == y.team_member
    order = sorted(team)
    for tr in got_a:
        it = next(i for i in its if i.name == tr.team_member)
        direction, speed = it.velocity_polar()
        course = direction if speed > 0.05 else it.heading_rad
        matched = tr.team_member == its[1].name
        radius, cov = (2.2, own[0].position_covariance) if matched else (2.0, np.zeros((2, 2)))
        track_id = 7 if matched else -1 - order.index(it.name)
        if it.has_plan:
            ref = PlannedTrack(track_id, it.sent_time_s, np.asarray(it.position_m, float), course,
                               max(it.max_speed_m_s(), 1e-3), 0.0, radius, cov, False, it.name, None, None, it)
        else:
            ref = TrackEstimate(track_id, it.sent_time_s, np.asarray(it.position_m, float), course, speed, 0.0,
                                radius, cov, False, it.name, None, None)
        assert type(tr) is type(ref)
        assert tr.__dict__.keys() == ref.__dict__.keys()
        for k, v in ref.__dict__.items():
            if isinstance(v, np.ndarray):
                np.testing.assert_array_equal(tr.__dict__[k], v)
            else:
                assert tr.__dict__[k] is v or tr.__dict__[k] == v, k
    again = a.tracks(own, 50.1, pic, lambda *_: None)  # a second prediction on the same messages
    assert [t.track_id for t in again] == [t.track_id for t in got_a]


def test_predict_fleet_with_constant_and_planned_speeds_equals_one_call_per_vessel():
    """The zoom's γ(t) of the vessels at a constant speed in one array operation, the others by
    their own γ(t): the same numbers as each vessel predicted alone."""
    rng = np.random.default_rng(9)
    queries = []
    for v in range(4):
        o = np.array([50.0 * v, 5.0 * v])
        path = Path.from_waypoints(o + [[0, 0], [70, 0], [70, 50]], turn_radius_m=8.0)
        cfg = CollisionPredictionConfig(window_s=25.0, time_step_s=0.5)
        if v % 2:
            def profile(t, g0=3.0, v_d=0.4 + 0.1 * v):  # a slow-down until t = 60 s, then 1.5 m/s
                t = np.asarray(t, dtype=float)
                return g0 + v_d * np.clip(t - 50.0, 0.0, 10.0) + 1.5 * np.maximum(t - 60.0, 0.0)
        else:
            profile = 1.0 + 0.3 * v
        its = _intentions(rng, 6)
        tracks = [PlannedTrack(k, it.sent_time_s, it.position_m + path.point(5.0), 0.0, 1.0, 0.0, 2.0,
                               team_member=it.name,
                               intention=replace(it, position_m=it.position_m + path.point(5.0),
                                                 plan_points_m=it.plan_points_m + path.point(5.0)))
                  for k, it in enumerate(its)]
        tracks.append(TrackEstimate(50, 49.8, path.point(30.0) + [0.0, -20.0], np.pi / 2, 1.0, 0.01, 2.5))
        queries.append(PredictionQuery(path, 3.0, 50.0, profile, 2.0, tracks, cfg, include_clear=True))
    fleet = predict_fleet(queries)
    for q, got in zip(queries, fleet):
        one = predict_conflicts(q.vessel_path, q.gamma_now, q.t_now, q.speed_profile, q.vessel_radius_m, q.tracks,
                                q.config, include_clear=True)
        assert [c.track_id for c in got] == [c.track_id for c in one]
        for a, b in zip(got, one):
            assert (a.t_closest_s, a.min_distance_m, a.collision, a.collision_distance_m, a.is_static) == \
                (b.t_closest_s, b.min_distance_m, b.collision, b.collision_distance_m, b.is_static)
            assert (a.t_i, a.t_f, a.gamma_a, a.gamma_b) == (b.t_i, b.t_f, b.gamma_a, b.gamma_b) or \
                (np.isnan(a.t_i) and np.isnan(b.t_i))


def test_distinct_rows_find_each_vessels_shared_brackets():
    from mjasc.avoidance.prediction.conflicts import _distinct_rows

    rng = np.random.default_rng(1)
    brackets = rng.uniform(0.0, 10.0, (3, 2))
    pick = rng.integers(0, 3, 40)
    v = rng.integers(0, 2, 40)
    t = brackets[pick, :1] + (brackets[pick, 1:] - brackets[pick, :1]) * np.linspace(0.0, 1.0, 17)
    u, inv = _distinct_rows(v, t)
    assert u is not None and u.size == len(set(zip(v.tolist(), pick.tolist())))
    np.testing.assert_array_equal(t[u][inv], t)
    np.testing.assert_array_equal(v[u][inv], v)
    assert _distinct_rows(np.arange(40), t) == (None, None)  # every row its own: nothing to share


def test_the_zoom_evaluates_shared_brackets_once_with_the_same_numbers(monkeypatch):
    """Team mates sailing away (their first minimum at the window's start: one bracket for all of a
    vessel's pairs): the prediction with the vessel's positions evaluated once per distinct
    bracket equals the one evaluating them per pair, bit for bit."""
    from mjasc.avoidance.prediction import conflicts
    from mjasc.avoidance.prediction.zoom_motion import ZoomMotion

    rng = np.random.default_rng(3)
    queries = []
    for v in range(3):
        path = Path.from_waypoints(np.array([60.0 * v, 0.0]) + [[0, 0], [80, 0], [80, 60]], turn_radius_m=8.0)
        tracks = []
        for k, it in enumerate(_intentions(rng, 12)):
            off = path.point(3.0) + it.position_m
            away = replace(it, position_m=off, plan_points_m=off + np.outer(it.plan_times_s - 49.7, [0.0, 1.5])
                           if it.has_plan else it.plan_points_m, velocity_m_s=np.array([0.0, 1.5]))
            tracks.append(PlannedTrack(k, away.sent_time_s, off, 0.0, 1.5, 0.0, 2.0, team_member=away.name,
                                       intention=away))
        queries.append(PredictionQuery(path, 3.0, 50.0, 1.0 + 0.2 * v, 2.0, tracks,
                                       CollisionPredictionConfig(window_s=25.0, time_step_s=0.5), include_clear=True))
    compiled = predict_fleet(queries)  # (the zoom's levels in compiled passes: zoom_motion)
    # The readable rel_at (the compiled levels' reference) is where brackets are shared: the zoom through it.
    monkeypatch.setattr(ZoomMotion, "level", None)
    calls = []
    orig = conflicts._distinct_rows

    def counted(v, t):
        out = orig(v, t)
        calls.append(out[0] is not None)
        return out

    monkeypatch.setattr(conflicts, "_distinct_rows", counted)
    shared = predict_fleet(queries)
    assert any(calls)
    monkeypatch.setattr(conflicts, "_distinct_rows", lambda v, t: (None, None))
    per_pair = predict_fleet(queries)
    for got, ref, fast in zip(shared, per_pair, compiled):
        assert [(c.track_id, c.t_closest_s, c.min_distance_m, c.collision) for c in got] == \
            [(c.track_id, c.t_closest_s, c.min_distance_m, c.collision) for c in ref] == \
            [(c.track_id, c.t_closest_s, c.min_distance_m, c.collision) for c in fast]


def test_the_lazy_results_are_predict_fleets_lists():
    """predict_fleet_lazy: the same conflicts in the same order as predict_fleet, the clear ones made
    on first read; its collisions and distances are those of the list."""
    from mjasc.avoidance.prediction.conflicts import ConflictList, predict_fleet_lazy

    rng = np.random.default_rng(12)
    queries = []
    for v in range(3):
        path = Path.from_waypoints(np.array([40.0 * v, 0.0]) + [[0, 0], [80, 0], [80, 60]], turn_radius_m=8.0)
        tracks = [TrackEstimate(k, 49.8, path.point(10.0 + 7 * k) + rng.normal(0, 6, 2), rng.uniform(-3, 3),
                                rng.uniform(0.0, 2.0), rng.normal(0, 0.03), 2.0 + k % 3) for k in range(9)]
        queries.append(PredictionQuery(path, 3.0, 50.0, 1.2, 2.0, tracks,
                                       CollisionPredictionConfig(window_s=25.0), include_clear=v != 1))
    lists = predict_fleet(queries)
    lazy = predict_fleet_lazy(queries)
    assert any(c.collision for res in lists for c in res) and any(not c.collision for res in lists for c in res)
    for ref, got in zip(lists, lazy):
        assert isinstance(got, ConflictList) and len(got) == len(ref)
        assert got.collisions == [got[i] for i in range(len(got)) if got[i].collision]
        assert got.min_distances == [c.min_distance_m for c in ref]
        for a, b in zip(got, ref):
            assert a.__dict__.keys() == b.__dict__.keys()
            for k, x in b.__dict__.items():
                if isinstance(x, np.ndarray):
                    np.testing.assert_array_equal(a.__dict__[k], x)
                else:
                    assert a.__dict__[k] == x or (x != x and a.__dict__[k] != a.__dict__[k]), k
        assert got[-1:] == [got[len(got) - 1]] if len(got) else True


def test_a_few_intentions_positions_in_the_compiled_pass_equal_their_own_positions():
    """A small team's intentions (k ≤ 4, one compiled pass each) at times before, on and between
    the knots, on the last knot and after it: ``TeamIntention.positions`` bit for bit (plans of
    2 and more knots, uneven spans, no plan)."""
    rng = np.random.default_rng(11)
    its = _intentions(rng, 8)
    its.append(TeamIntention("two", 49.7, np.array([1.0, 2.0]), 0.3, np.array([0.5, -0.2]), 2.0,
                             np.array([50.0, 50.0 + 1e-12]), np.array([[1.0, 2.0], [1.5, 2.5]])))
    its.append(TeamIntention("uneven", 49.7, np.array([1.0, 2.0]), 0.3, np.array([0.5, -0.2]), 2.0,
                             np.array([49.0, 49.3, 51.0, 55.5]), rng.normal(0.0, 10.0, (4, 2))))
    for it in its:
        knots = it.plan_times_s
        times = np.sort(np.concatenate([knots, np.linspace(20.0, 100.0, 33), knots + 1e-9, rng.uniform(40, 80, 9)]))
        for k in range(1, 5):
            group = ([it] + its[:k - 1])[:k]
            np.testing.assert_array_equal(intention_positions(group, times),
                                          np.stack([g.positions(times) for g in group]))


def test_plans_changed_on_the_thesis_crossing_compares_the_plans_positions():
    """On the thesis crossing (3 vessels, plans broadcast over a lossy link) every plan comparison's
    positions equal ``TeamIntention.positions``, bit for bit."""
    import mjasc
    from mjasc.avoidance import plan_deviation, team_mates
    from mjasc.runs.runner import Runner

    seen = []

    def checked(intentions, times):
        got = intention_positions(intentions, times)
        np.testing.assert_array_equal(got, np.stack([it.positions(times) for it in intentions]))
        seen.append(len(intentions))
        return got

    # (the comparison's readable form, plan_deviation.plans_deviate_reference, reads intention_positions)
    original, original_deviate = plan_deviation.intention_positions, team_mates.plans_deviate
    plan_deviation.intention_positions, team_mates.plans_deviate = checked, plan_deviation.plans_deviate_reference
    try:
        sc = mjasc.load_scenario("tasks/thesis_6_4_crossing.toml").with_overrides(duration_s=30.0, video=False)
        Runner(replace(sc, outputs=replace(sc.outputs, recording=False))).run()
    finally:
        plan_deviation.intention_positions, team_mates.plans_deviate = original, original_deviate
    assert len(seen) > 20 and max(seen) <= 4


def _farther_reference(motions, rows, times, pos, limit):
    pred = motions.at(np.array(rows), np.array(times, dtype=float)[:, None])[:, 0]
    pos = np.array(pos, dtype=float)
    return bool((np.hypot(pred[:, 0] - pos[:, 0], pred[:, 1] - pos[:, 1]) > limit).any())


def test_farther_than_equals_the_distance_of_at_for_straight_turning_static_and_planned_tracks():
    """``TrackMotions.farther_than`` (straight and static tracks in one compiled pass, else through
    ``at``) answers as ``np.hypot`` of ``at``'s positions, on limits placed at the distances
    themselves (the comparison's edge)."""
    rng = np.random.default_rng(21)
    its = _intentions(rng, 3)
    tracks = [TrackEstimate(k, 49.0 + 0.1 * k, rng.uniform(-40, 40, 2), rng.uniform(-3, 3), rng.uniform(0, 3),
                            float(rng.choice([0.0, 0.0, 0.03, -0.02])), 2.0, is_static=bool(k % 5 == 4))
              for k in range(12)]
    tracks += [PlannedTrack(20 + k, it.sent_time_s, it.position_m, 0.0, 1.0, 0.0, 1.5, team_member=it.name,
                            intention=it) for k, it in enumerate(its)]
    straight = [k for k, tr in enumerate(tracks) if isinstance(tr, TrackEstimate) and not isinstance(tr, PlannedTrack)
                and (tr.is_static or tr.speed_m_s == 0.0 or abs(tr.turn_rate_rad_s) < 1e-9)]
    assert len(straight) >= 4
    for m in (TrackMotions(tracks), TrackMotions([tracks[k] for k in straight])):
        n = m.n
        for trial in range(200):
            rows = rng.choice(n, size=int(rng.integers(1, 6)))
            times = 50.0 + rng.uniform(0.0, 3.0, rows.size)
            pos = m.at(rows, times[:, None])[:, 0] + rng.normal(0.0, 1.0, (rows.size, 2))
            d = np.hypot(*(m.at(rows, times[:, None])[:, 0] - pos).T)
            for limit in (0.5, 2.0, float(d.max()), float(np.nextafter(d.max(), -np.inf)), float(d.min())):
                assert m.farther_than(tuple(rows.tolist()), tuple(times.tolist()), tuple(pos), limit) == \
                    _farther_reference(m, rows, times, pos, limit)


def _farther_by_id_reference(motions, row_ids, ids, times, pos, limit):
    """The control tick's selection (an id → row mapping filled in row order, unknown ids skipped),
    then :func:`_farther_reference` of the known rows."""
    row = {i: k for k, i in enumerate(row_ids)}
    sel = [(row[i], k) for k, i in enumerate(ids) if i in row]
    if not sel:
        return False
    rows, ks = zip(*sel)
    return _farther_reference(motions, list(rows), [times[k] for k in ks], [pos[k] for k in ks], limit)


def test_farther_by_id_equals_the_selection_then_the_distance_of_at():
    """``TrackMotions.farther_by_id`` (the id look-ups and the distances in one compiled pass)
    answers as the control tick's id → row selection then ``np.hypot`` of ``at``, with ids unknown,
    repeated on rows, and limits at the distances themselves; None when a known row is a plan."""
    rng = np.random.default_rng(22)
    its = _intentions(rng, 3)
    tracks = [TrackEstimate(k, 49.0 + 0.1 * k, rng.uniform(-40, 40, 2), rng.uniform(-3, 3), rng.uniform(0, 3),
                            float(rng.choice([0.0, 0.0, 0.03, -0.02])), 2.0, is_static=bool(k % 5 == 4))
              for k in range(12)]
    planned = [PlannedTrack(20 + k, it.sent_time_s, it.position_m, 0.0, 1.0, 0.0, 1.5, team_member=it.name,
                            intention=it) for k, it in enumerate(its)]
    m = TrackMotions(tracks + planned)
    row_ids = [3 * k - 7 for k in range(12)] + [40, 41, 42]
    row_ids[5] = row_ids[9]  # an id on two rows: the later one answers
    known = np.array(row_ids, dtype=np.int64)
    n_checked = 0
    for trial in range(300):
        ids = rng.choice(np.array(row_ids[:12] + [-100, 1000, 2]), size=int(rng.integers(1, 7)))
        times = 50.0 + rng.uniform(0.0, 3.0, ids.size)
        rows = [max(k for k, i in enumerate(row_ids) if i == j) if j in row_ids else 0 for j in ids.tolist()]
        pos = m.at(np.array(rows), times[:, None])[:, 0] + rng.normal(0.0, 1.0, (ids.size, 2))
        d = np.hypot(*(m.at(np.array(rows), times[:, None])[:, 0] - pos).T)
        for limit in (0.5, 2.0, float(d.max()), float(np.nextafter(d.max(), -np.inf)), float(d.min())):
            got = m.farther_by_id(known, ids, times, pos, limit)
            assert got == _farther_by_id_reference(m, row_ids, ids.tolist(), times.tolist(), list(pos), limit)
            n_checked += 1
    for j in (40, 41, 42):  # a known row on a plan: None (the caller takes the mapping's way)
        assert m.farther_by_id(known, np.array([0, j]), np.array([50.0, 50.5]), np.zeros((2, 2)), 1.0) is None
    assert m.farther_by_id(known, np.array([1000]), np.array([50.0]), np.zeros((1, 2)), 1.0) is False
    assert n_checked == 1500


def test_deviation_checks_on_the_demo_equal_the_reference_form(monkeypatch):
    """Every deviation check of the demo's control ticks (60 s) answers as ``np.hypot`` of ``at``
    (by id: after the id → row selection)."""
    import mjasc
    from mjasc.runs.runner import Runner

    farther, by_id, seen = TrackMotions.farther_than, TrackMotions.farther_by_id, []

    def checked(self, rows, times, pos, limit):
        got = farther(self, rows, times, pos, limit)
        assert got == _farther_reference(self, rows, times, pos, limit)
        seen.append(got)
        return got

    def checked_by_id(self, row_ids, ids, times, pos, limit):
        got = by_id(self, row_ids, ids, times, pos, limit)
        if got is not None:
            assert got == _farther_by_id_reference(self, row_ids.tolist(), ids.tolist(), times.tolist(), list(pos),
                                                   limit)
            seen.append(got)
        return got

    monkeypatch.setattr(TrackMotions, "farther_than", checked)
    monkeypatch.setattr(TrackMotions, "farther_by_id", checked_by_id)
    sc = mjasc.load_scenario("demo").with_overrides(duration_s=60.0, video=False)
    Runner(replace(sc, outputs=replace(sc.outputs, recording=False))).run()
    assert len(seen) > 100
