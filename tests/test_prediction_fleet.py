"""Fleet-batched collision prediction: stacked track motions, closed-form closest approaches, one
call for many vessels — the same numbers as the per-track, per-vessel forms."""

from dataclasses import replace

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from mjasc.avoidance.prediction import (CollisionPredictionConfig, PredictionQuery, TrackMotions, predict_conflicts,
                                        predict_fleet)
from mjasc.avoidance.prediction.cpa import closest_approaches, segment_cpa
from mjasc.avoidance.prediction.motion import intention_positions
from mjasc.cooperation.messages import TeamIntention
from mjasc.core.estimates import PlannedTrack, TrackEstimate
from mjasc.guidance.paths import Path


def _tracks(rng, n, t0=50.0, centre=(0.0, 0.0)):
    """A mix of static, straight, turning and plan tracks around ``centre``."""
    out = []
    for k in range(n):
        pos = np.asarray(centre) + rng.uniform(-80, 80, 2)
        kind = k % 5
        if kind == 0:
            out.append(TrackEstimate(k, t0, pos, 0.3, 1.0, 0.1, 2.0, is_static=True))
        elif kind == 1:
            out.append(TrackEstimate(k, t0 - 0.1, pos, rng.uniform(-3, 3), rng.uniform(0.2, 2), 0.0, 2.5))
        elif kind == 2:
            out.append(TrackEstimate(k, t0 - 0.2, pos, rng.uniform(-3, 3), rng.uniform(0.2, 2), rng.normal(0, 0.05),
                                     3.0))
        elif kind == 3:
            ts = t0 - 0.4 + np.arange(0.0, 30.0, 0.5)  # a plan along a turning course, knots every 0.5 s
            course = rng.uniform(-3, 3) + rng.normal(0, 0.04) * (ts - ts[0])
            pts = pos + np.cumsum(0.5 * rng.uniform(0.5, 2) * np.stack([np.cos(course), np.sin(course)], 1), axis=0)
            it = TeamIntention(f"m{k}", t0 - 0.4, pos, 0.0, rng.normal(0, 1, 2), 2.0, ts, pts)
            out.append(PlannedTrack(k, t0 - 0.4, pos, 0.0, 1.0, 0.0, 2.0, team_member=f"m{k}", intention=it))
        else:
            it = TeamIntention(f"m{k}", t0 - 0.4, pos, 0.0, rng.normal(0, 1, 2), 2.0)
            out.append(PlannedTrack(k, t0 - 0.4, pos, 0.0, 1.0, 0.0, 2.0, team_member=f"m{k}", intention=it))
    return out


def test_track_motions_equal_predict_positions_bit_for_bit():
    rng = np.random.default_rng(3)
    tracks = _tracks(rng, 25)
    motions = TrackMotions(tracks)
    times = np.linspace(40.0, 90.0, 101)
    np.testing.assert_array_equal(motions.grid(times), np.stack([tr.predict_positions(times) for tr in tracks]))
    rows = rng.integers(0, len(tracks), 200)
    per_row = rng.uniform(0.0, 120.0, (200, 3))  # before, inside and after the plans
    np.testing.assert_array_equal(motions.at(rows, per_row),
                                  np.stack([tracks[r].predict_positions(t) for r, t in zip(rows, per_row)]))
    its = [tr.intention for tr in tracks if isinstance(tr, PlannedTrack)]
    np.testing.assert_array_equal(intention_positions(its, times), np.stack([it.positions(times) for it in its]))
    # every receiver's copy of a team mate shares its message: stacked once, the same positions
    shared = tracks + [replace(tr, track_id=100 + k) for k, tr in enumerate(tracks) if isinstance(tr, PlannedTrack)]
    knots = np.concatenate([tr.intention.plan_times_s for tr in shared if isinstance(tr, PlannedTrack)])
    at_knots = np.broadcast_to(knots, (len(shared), knots.size))  # exactly on knots: np.interp's interval
    np.testing.assert_array_equal(TrackMotions(shared).at(np.arange(len(shared)), at_knots),
                                  np.stack([tr.predict_positions(knots) for tr in shared]))


def test_segment_cpa_closed_form():
    a = np.array([[-3.0, 2.0], [1.0, 1.0], [0.0, 5.0]])
    b = np.array([[3.0, 2.0], [2.0, 1.0], [0.0, 5.0]])  # crossing abeam; receding; degenerate
    s, d = segment_cpa(a, b)
    np.testing.assert_allclose(s, [0.5, 0.0, 0.0])
    np.testing.assert_allclose(d, [2.0, np.sqrt(2.0), 5.0])


def _brent(path, gamma_now, t_now, speed, track, cfg):
    """The former temporal correlation (grid, then bounded Brent per local minimum): (t_c, d_c)."""
    n = int(np.ceil(cfg.window_s / cfg.time_step_s - 1e-9)) + 1
    times = np.linspace(t_now, t_now + cfg.window_s, n)

    def at(t):
        return path.point(np.clip(gamma_now + speed * (np.atleast_1d(t) - t_now), 0.0, path.length))

    d = np.hypot(*(at(times) - track.predict_positions(times)).T)
    left = np.concatenate([[True], d[1:] <= d[:-1]])
    right = np.concatenate([d[:-1] < d[1:], [True]])
    r_col = 2.5 + track.radius_m + cfg.safety_distance_m
    t_c = d_c = None
    for i in np.flatnonzero(left & right):
        res = minimize_scalar(lambda t: float(np.hypot(*(at(t)[0] - track.predict_positions(np.array([t]))[0]))),
                              bounds=(times[max(i - 1, 0)], times[min(i + 1, n - 1)]), method="bounded",
                              options={"xatol": 1e-7})
        tt, dd = (float(res.x), float(res.fun)) if res.fun <= d[i] else (float(times[i]), float(d[i]))
        if t_c is None:
            t_c, d_c = tt, dd
        if dd <= r_col:
            return tt, dd
    return t_c, d_c


def test_closed_form_minima_match_the_brent_search_on_curved_encounters():
    """Curved own path (rounded corners) and turning / plan tracks: the closed-form minima stay
    within the module's bound of the former Brent search (|Δd| ≤ 1e-6 m, |Δt_c| ≤ 2e-3 s)."""
    rng = np.random.default_rng(11)
    path = Path.from_waypoints([[0, 0], [60, 0], [90, 30], [90, 90], [20, 120]], turn_radius_m=15.0)
    cfg = CollisionPredictionConfig(window_s=30.0, time_step_s=0.5)
    tracks = _tracks(rng, 40, centre=path.point(10.0))
    got = {c.track_id: c for c in predict_conflicts(path, 10.0, 50.0, 1.5, 2.5, tracks, cfg, include_clear=True)}
    for tr in tracks:
        t_c, d_c = _brent(path, 10.0, 50.0, 1.5, tr, cfg)
        assert abs(got[tr.track_id].min_distance_m - d_c) <= 1e-6
        assert abs(got[tr.track_id].t_closest_s - t_c) <= 2e-3


def test_closed_form_minima_at_kinks_are_no_worse_than_the_brent_search():
    """Sharp path corners and team mates' plans with a kink at every knot: the zoom goes on until
    the last samples are straight; d_min is never more than 1e-7 m above Brent's (which converges
    slowly at a kink: it is often the larger one) and within 1e-5 m of it."""
    rng = np.random.default_rng(5)
    path = Path.from_waypoints([[0, 0], [60, 0], [90, 30], [90, 90], [20, 120]])  # sharp corners
    cfg = CollisionPredictionConfig(window_s=30.0, time_step_s=0.5)
    tracks = []
    for k in range(30):
        pos = path.point(40.0) + rng.uniform(-60, 60, 2)
        ts = 49.6 + np.arange(0.0, 30.0, 0.5)
        pts = pos + np.cumsum(rng.normal(0.0, 0.6, (ts.size, 2)), axis=0)
        it = TeamIntention(f"m{k}", 49.6, pos, 0.0, rng.normal(0, 1, 2), 2.0, ts, pts)
        tracks.append(PlannedTrack(k, 49.6, pos, 0.0, 1.0, 0.0, 2.0, team_member=f"m{k}", intention=it))
    got = {c.track_id: c for c in predict_conflicts(path, 40.0, 50.0, 1.5, 2.5, tracks, cfg, include_clear=True)}
    for tr in tracks:
        t_c, d_c = _brent(path, 40.0, 50.0, 1.5, tr, cfg)
        assert got[tr.track_id].min_distance_m <= d_c + 1e-7
        assert abs(got[tr.track_id].min_distance_m - d_c) <= 1e-5


def test_closest_approaches_choose_the_first_collision_over_padded_grids():
    times = np.array([[0.0, 1.0, 2.0, 3.0, 4.0], [0.0, 1.0, 2.0, np.nan, np.nan]])
    # pair 0: a near miss at t = 1 (d = 5), a collision at t = 3 (d = 1); pair 1: a grid shorter by two
    rel = np.array([[[0, 7], [0, 5], [0, 8], [0, 1], [0, 3]],
                    [[4, 0], [2, 0], [3, 0], [9, 9], [9, 9]]], dtype=float)
    t_c, d_c = closest_approaches(times, rel, np.array([2.0, 1.0]))
    np.testing.assert_allclose(t_c, [3.0, 1.0])
    np.testing.assert_allclose(d_c, [1.0, 2.0])
    t_c, d_c = closest_approaches(times, rel, np.array([2.0, 1.0]), stop_at_first=True)
    np.testing.assert_allclose(t_c, [1.0, 1.0])


@pytest.mark.parametrize("seed", [0, 1])
def test_predict_fleet_equals_one_call_per_vessel(seed):
    rng = np.random.default_rng(seed)
    queries = []
    for v in range(5):
        o = np.array([70.0 * v, 10.0 * v])
        path = Path.from_waypoints(o + [[0, 0], [80, 0], [80, 60]], turn_radius_m=10.0)
        cfg = CollisionPredictionConfig(window_s=None if v == 2 else 20.0 + 5 * v, time_step_s=0.5 if v != 3 else 0.7,
                                        max_range_m=60.0 if v == 4 else None, stop_at_first_minimum=v == 1)
        tracks = _tracks(rng, 3 + 2 * v, centre=path.point(5.0))
        queries.append(PredictionQuery(path, 5.0, 50.0, 1.0 + 0.2 * v, 2.5, tracks, cfg, include_clear=v != 0))
    fleet = predict_fleet(queries)
    for q, got in zip(queries, fleet):
        one = predict_conflicts(q.vessel_path, q.gamma_now, q.t_now, q.speed_profile, q.vessel_radius_m, q.tracks,
                                q.config, include_clear=q.include_clear)
        assert [c.track_id for c in got] == [c.track_id for c in one]
        for a, b in zip(got, one):
            assert (a.t_closest_s, a.min_distance_m, a.collision, a.decision, a.t_i, a.t_f) == \
                (b.t_closest_s, b.min_distance_m, b.collision, b.decision, b.t_i, b.t_f) or \
                (np.isnan(a.t_i) and np.isnan(b.t_i) and a.t_closest_s == b.t_closest_s)
            np.testing.assert_array_equal(a.obstacle_positions, b.obstacle_positions)


def _fleet(n, duration_s):
    """n Otters in a block 15 m apart, all sensing, tracking, avoiding and talking, sailing east
    through a ferry crossing their lanes."""
    from mjasc.runs.scenario import parse_scenario

    cols = int(np.ceil(np.sqrt(n)))
    vessels = []
    for i in range(n):
        r, c = divmod(i, cols)
        x0, y0 = -15.0 * r, 15.0 * c
        vessels.append({"name": f"v{i}", "type": "otter", "position_m": [x0, y0], "speed_m_s": 1.0,
                        "controller": {"type": "path_following", "waypoints": [[x0, y0], [x0 + 300.0, y0]],
                                       "speed_m_s": 1.5},
                        "sensor": {"beams": 180, "max_range_m": 100.0}, "tracking": {},
                        "avoidance": {"window_s": 30.0}, "comms": {"max_speed_correction": 0.4}})
    ferry = {"name": "ferry", "radius_m": 4.0, "position_m": [40.0, -40.0], "heading_deg": 90.0, "speed_m_s": 1.2}
    return parse_scenario({"name": f"fleet_{n}", "duration_s": duration_s, "seed": 1, "vessels": vessels,
                           "moving_obstacles": [ferry], "comms": {"preset": "radio"},
                           "outputs": {"video": False}})


def test_prediction_slot_for_the_fleet_gives_the_same_run(monkeypatch):
    """The runner's prediction slot (runs.tick: every vessel's pairs in one predict_slot call) gives
    the same run — tracks, decisions, commands — as each vessel predicting on its own."""
    import mjasc.runs.runner as runner
    from mjasc.campaigns.engine import without_timing

    def run(batched):
        orig = runner.run_onboard_slot

        def slot(name, agents, navs, dt):
            if name != "prediction" or batched:
                return orig(name, agents, navs, dt)
            for a, n in zip(agents, navs):  # the per-vessel reference
                a.on_prediction(n)
            return None

        monkeypatch.setattr(runner, "run_onboard_slot", slot)
        return runner.run_scenario(_fleet(4, duration_s=10.0), None, progress=False).summary

    batched = run(True)
    assert sum(v["avoidance"]["predictions"] for v in batched["vessels"].values()) >= 8  # it did predict
    assert without_timing(batched) == without_timing(run(False))


def test_control_slot_for_the_fleet_gives_the_same_run(monkeypatch):
    """The control slot asks the thesis method for every vessel at once (control_slot: the
    predictions the tick triggers in one predict_fleet call); the run is the same — tracks,
    decisions, commands — as each vessel's control tick on its own (the method's base class
    default, vessel by vessel)."""
    from mjasc.avoidance.system import CollisionAvoidance
    from mjasc.campaigns.engine import without_timing
    from mjasc.plugins.stages import AvoidanceMethod
    from mjasc.runs.runner import run_scenario

    def run(batched):
        if not batched:
            monkeypatch.setattr(CollisionAvoidance, "control_many", AvoidanceMethod.__dict__["control_many"])
        return run_scenario(_fleet(4, duration_s=10.0), None, progress=False).summary

    batched = run(True)
    assert sum(v["avoidance"]["predictions"] for v in batched["vessels"].values()) >= 8  # it did predict
    assert without_timing(batched) == without_timing(run(False))
