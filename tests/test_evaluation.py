"""mjasc.evaluation: COLREG roles and compliance on constructed encounters, GOSPA against closed
forms, identity switches and time to confirm; the mission cost against the same mission without
traffic in closed form, a run against its own rerun (0 exactly), and a detour around a buoy."""

import math

import numpy as np
import pytest

from mjasc.evaluation.colreg import ColregConfig, classify, judge_compliance, relative_bearing_deg, role_from_geometry
from mjasc.evaluation.tracking_metrics import TrackingScore, gospa

EAST, NORTH, WEST, SOUTH = 0.0, math.pi / 2, math.pi, -math.pi / 2


def test_relative_bearing_is_clockwise_from_the_bow():
    assert relative_bearing_deg([0, 0], NORTH, [0, 10]) == pytest.approx(0.0)
    assert relative_bearing_deg([0, 0], NORTH, [10, 0]) == pytest.approx(90.0)  # starboard beam
    assert relative_bearing_deg([0, 0], NORTH, [0, -10]) == pytest.approx(180.0)
    assert relative_bearing_deg([0, 0], NORTH, [-10, 0]) == pytest.approx(270.0)  # port beam


@pytest.mark.parametrize("target, course, speed, role", [
    ([0, 100], SOUTH, 1.5, "head_on"),                    # dead ahead, reciprocal
    ([60, 60], WEST, 1.5, "crossing_give_way"),           # from starboard, crossing
    ([-60, 60], EAST, 1.5, "crossing_stand_on"),          # from port, crossing
    ([0, 40], NORTH, 0.5, "overtaking"),                  # slower, ahead, same course
    ([0, -40], NORTH, 2.5, "overtaken"),                  # faster, astern, same course
    ([0, -40], SOUTH, 1.5, "none"),                       # astern, opening
])
def test_roles_of_the_standard_encounters(target, course, speed, role):
    assert classify([0, 0], NORTH, 1.5, target, course, speed) == role


def test_no_role_for_a_wide_pass_risk_of_collision_needs_a_close_cpa():
    """Rule 7: risk of collision exists when the vessels would pass close, not whenever the range
    closes. A target 110 m ahead and 60 m to starboard on the reciprocal course passes 60 m off,
    starboard to starboard: no role (it was judged a crossing give-way, and a vessel holding its
    course non-compliant). The gate is the straight-line CPA distance against risk_cpa_m (20 m)."""
    assert classify([0, 0], NORTH, 1.5, [60, 110], SOUTH, 1.5) == "none"
    assert classify([0, 0], NORTH, 1.5, [60, 110], SOUTH, 1.5, ColregConfig(risk_cpa_m=61.0)) == "crossing_give_way"
    # the CPA distance, not the lateral offset: a crossing target whose straight lines pass 19 m / 21 m apart
    for offset, role in ((19.0, "crossing_give_way"), (21.0, "none")):
        # the target heads west from starboard and would meet the own vessel at (0, 60) at t = 40 s;
        # shifted across the relative motion (w = (−1.5, −1.5)) so that the CPA distance is `offset`
        target = np.array([60.0, 60.0]) + offset * np.array([1.0, -1.0]) / np.sqrt(2.0)
        assert classify([0, 0], NORTH, 1.5, target, WEST, 1.5) == role, offset
    j = judge_compliance(classify([0, 0], NORTH, 1.5, [60, 110], SOUTH, 1.5), np.arange(0.0, 40.0, 1.0),
                         np.column_stack([np.zeros(40), 1.5 * np.arange(40.0)]), np.full(40, NORTH),
                         np.tile([0.0, 1.5], (40, 1)),
                         np.column_stack([np.full(40, 60.0), 110 - 1.5 * np.arange(40.0)]),
                         np.tile([0.0, -1.5], (40, 1)))
    assert j.compliant  # holding course past a wide target is no fault


def test_overtaking_starts_more_than_22_5_degrees_abaft_the_beam():
    """Rule 13: 'more than 22.5 degrees abaft her beam' — a bearing of exactly 112.5° is not yet
    overtaking (the right-of-way rule of the CAS draws the same strict line)."""
    assert role_from_geometry(112.5, 0.0) == "crossing_give_way"
    assert role_from_geometry(112.5 + 1e-9, 0.0) == "overtaken"
    assert role_from_geometry(-112.5, 0.0) == "crossing_stand_on"


def _encounter(own_turn_deg=0.0, turn_at_s=5.0, target_from_starboard=True, speed_factor=1.0):
    """Own vessel north at 1.5 m/s from the origin; a target crossing west (from starboard) or east
    (from port) so that both reach (0, 60) at t = 40 s. The own vessel may turn at ``turn_at_s``."""
    t = np.arange(0.0, 60.0, 0.5)
    h = np.where(t < turn_at_s, NORTH, NORTH + math.radians(own_turn_deg))
    v = 1.5 * speed_factor * np.column_stack([np.cos(h), np.sin(h)])
    v[t < turn_at_s] = [0.0, 1.5]
    p = np.vstack([[0.0, 0.0], np.cumsum(v[:-1] * 0.5, axis=0)])
    sgn = 1.0 if target_from_starboard else -1.0
    w = np.tile([-sgn * 1.5, 0.0], (t.size, 1))
    q = np.column_stack([sgn * 60.0 - sgn * 1.5 * t, np.full(t.size, 60.0)])
    return t, p, h, v, q, w


def test_give_way_vessel_turning_early_to_starboard_and_passing_astern_complies():
    t, p, h, v, q, w = _encounter(own_turn_deg=-60.0, turn_at_s=5.0)
    c = judge_compliance("crossing_give_way", t, p, h, v, q, w)
    assert c.acted and c.early and c.to_starboard and not c.crossed_ahead and c.compliant, c.reasons


def test_give_way_vessel_turning_to_port_fails():
    t, p, h, v, q, w = _encounter(own_turn_deg=+60.0, turn_at_s=5.0)
    c = judge_compliance("crossing_give_way", t, p, h, v, q, w)
    assert not c.to_starboard and not c.compliant and "altered course to port" in c.reasons


def test_give_way_vessel_that_does_nothing_fails_and_one_that_acts_late_fails():
    t, p, h, v, q, w = _encounter()
    assert judge_compliance("crossing_give_way", t, p, h, v, q, w).reasons[0] == "did not act"
    t, p, h, v, q, w = _encounter(own_turn_deg=-60.0, turn_at_s=38.0)
    c = judge_compliance("crossing_give_way", t, p, h, v, q, w)
    assert c.acted and not c.early and not c.compliant


def test_give_way_vessel_that_speeds_across_ahead_is_flagged():
    t, p, h, v, q, w = _encounter(speed_factor=2.0, turn_at_s=2.0)  # doubles its speed: crosses first
    c = judge_compliance("crossing_give_way", t, p, h, v, q, w)
    assert c.crossed_ahead and "crossed ahead of the stand-on vessel" in c.reasons


def test_stand_on_vessel_keeps_course_and_speed():
    t, p, h, v, q, w = _encounter(target_from_starboard=False)
    assert judge_compliance("crossing_stand_on", t, p, h, v, q, w).compliant
    t, p, h, v, q, w = _encounter(own_turn_deg=-40.0, turn_at_s=5.0, target_from_starboard=False)
    c = judge_compliance("crossing_stand_on", t, p, h, v, q, w)
    assert c.kept_course_and_speed is False and not c.compliant


def _crabbing(slow_to_m_s=None, drift_east_m_s=0.0, crab_from_deg=9.5, crab_to_deg=9.5, target_from_starboard=True):
    """The crossing of :func:`_encounter` in a current setting east: the own vessel holds its track north
    (course over ground north) with its bow crabbed ``crab_from_deg`` → ``crab_to_deg`` to port into the
    current from t = 5 s; ``slow_to_m_s``: it also slows to that speed over ground, set ``drift_east_m_s``
    off its track."""
    t, p, h, v, q, w = _encounter(target_from_starboard=target_from_starboard)
    after = t >= 5.0
    h = np.where(after, NORTH + math.radians(crab_to_deg), NORTH + math.radians(crab_from_deg))
    if slow_to_m_s is not None:
        v[after] = [drift_east_m_s, slow_to_m_s]
        p = np.vstack([[0.0, 0.0], np.cumsum(v[:-1] * 0.5, axis=0)])
    return t, p, h, v, q, w


def test_a_give_way_vessel_slowing_down_in_a_cross_current_has_not_altered_course_to_port():
    # Slowing from 1.5 to 0.4 m/s on its track in a 0.25 m/s cross current turns the bow from 9.5° to
    # 32° into the current (to port): no course alteration. It was judged "altered course to port".
    t, p, h, v, q, w = _crabbing(slow_to_m_s=0.4, crab_to_deg=32.0)
    c = judge_compliance("crossing_give_way", t, p, h, v, q, w)
    assert c.acted and c.early and c.to_starboard is None and c.compliant, c.reasons
    # all but stopped and set off its track by the current: a drift, not a course (to either side)
    t, p, h, v, q, w = _crabbing(slow_to_m_s=0.3, drift_east_m_s=0.25, crab_to_deg=60.0)
    c = judge_compliance("crossing_give_way", t, p, h, v, q, w)
    assert c.acted and c.to_starboard is None and c.compliant, c.reasons
    # a real turn to port in the current is still one
    t, p, h, v, q, w = _encounter(own_turn_deg=+60.0, turn_at_s=5.0)
    c = judge_compliance("crossing_give_way", t, p, h + math.radians(9.5), v, q, w)
    assert c.to_starboard is False and "altered course to port" in c.reasons


def test_a_stand_on_vessel_whose_bow_swings_in_a_current_gradient_keeps_its_course():
    # Across an eddy's edge the crab grows from 0° to 15° while the track over ground stays north.
    t, p, h, v, q, w = _crabbing(crab_from_deg=0.0, crab_to_deg=15.0, target_from_starboard=False)
    c = judge_compliance("crossing_stand_on", t, p, h, v, q, w)
    assert c.kept_course_and_speed and c.compliant, c.reasons


# ------------------------------------------------------------------ GOSPA
def test_gospa_closed_forms():
    c, p = 10.0, 2.0
    assert gospa([[0, 0]], [[0, 0]], c, p).distance == 0.0
    assert gospa([[0, 0]], [[3, 4]], c, p).distance == pytest.approx(5.0)          # one assigned pair
    assert gospa([[0, 0]], [], c, p).distance == pytest.approx((c ** p / 2) ** (1 / p))  # one missed
    assert gospa([], [[1, 1]], c, p).distance == pytest.approx((c ** p / 2) ** (1 / p))  # one false
    far = gospa([[0, 0]], [[30, 0]], c, p)  # beyond the cut-off: one missed and one false
    assert far.n_missed == 1 and far.n_false == 1 and far.distance == pytest.approx(c)
    g = gospa([[0, 0], [10, 0], [50, 50]], [[1, 0], [10, 2]], c, p)
    assert g.localization == pytest.approx(1 + 4) and g.n_missed == 1 and g.n_false == 0
    assert g.distance ** p == pytest.approx(g.localization + g.missed + g.false)


def test_gospa_with_optional_objects_closed_forms_and_brute_force():
    """A static track may stand for a truth object (a boat that stopped) but is never false; a truth
    object the sensor cannot see may be tracked but is never missed: such a pair is assigned only
    when d^p + k·c^p/2 < c^p (k optional members); checked against every partial assignment
    enumerated (orders 1–3, cut-offs 1–10 m)."""
    import itertools

    c, p = 10.0, 2.0
    half = c ** p / 2
    assert gospa([[0, 0]], [[0.1, 0]], c, p, [True]).distance == pytest.approx(0.1)  # a stopped boat, tracked
    assert gospa([], [[1, 1]], c, p, [True]).distance == 0.0                          # a buoy: not false
    g = gospa([[0, 0]], [[8, 0]], c, p, [True])  # 64 > 50: leaving both unassigned is cheaper
    assert g.assignment == {} and g.n_missed == 1 and g.n_false == 0 and g.distance ** p == pytest.approx(half)
    g = gospa([[0, 0]], [[6, 0], [9, 0]], c, p, [True, False])  # the moving track is nearer the threshold
    assert g.assignment == {0: 1} and g.n_false == 0 and g.distance ** p == pytest.approx(81)
    # a track of an object just out of the sensor's range: neither false nor missed, its error counts
    g = gospa([[0, 0]], [[0.5, 0]], c, p, None, [True])
    assert g.assignment == {0: 0} and (g.n_missed, g.n_false) == (0, 0) and g.distance == pytest.approx(0.5)
    assert gospa([[0, 0]], [], c, p, None, [True]).distance == 0.0
    assert gospa([[0, 0]], [[0.5, 0]], c, p, [True], [True]).assignment == {}  # both optional: nothing to gain

    def brute(x, y, opt, x_opt, c, p):
        best = math.inf
        for k in range(min(len(x), len(y)) + 1):
            for rows in itertools.combinations(range(len(x)), k):
                for cols in itertools.permutations(range(len(y)), k):
                    d = [math.dist(x[r], y[q]) for r, q in zip(rows, cols)]
                    if all(v < c for v in d):
                        false = sum(1 for q in range(len(y)) if q not in cols and not opt[q])
                        missed = sum(1 for r in range(len(x)) if r not in rows and not x_opt[r])
                        best = min(best, sum(v ** p for v in d) + c ** p / 2 * (missed + false))
        return best ** (1 / p)

    rng = np.random.default_rng(3)
    for _ in range(400):
        x, y = rng.uniform(0, 15, (rng.integers(0, 4), 2)), rng.uniform(0, 15, (rng.integers(0, 5), 2))
        opt, x_opt = rng.random(len(y)) < 0.5, rng.random(len(x)) < 0.3
        c, p = float(rng.choice([1.0, 5.0, 10.0])), float(rng.choice([1.0, 2.0, 3.0]))
        g = gospa(x, y, c, p, opt, x_opt)
        assert g.distance == pytest.approx(brute(x, y, opt, x_opt, c, p), abs=1e-9)
        assert g.n_missed == sum(1 for r in range(len(x)) if r not in g.assignment and not x_opt[r])
        assert g.distance ** p == pytest.approx(g.localization + g.missed + g.false)
        assert g.n_false == sum(1 for q in range(len(y)) if q not in g.assignment.values() and not opt[q])


def test_a_stopped_target_tracked_as_static_is_not_missed():
    """A moving obstacle at rest (speed 0) in range of a vessel: its track is flagged static after
    ``static_min_age_s`` and must still count as the target's track (it used to be left out of the
    estimates, the target scored as missed, c²/2 per evaluation, for the rest of the run)."""
    from mjasc.evaluation.run_evaluation import RunEvaluator
    from mjasc.runs.runner import Runner
    from mjasc.runs.scenario import parse_scenario

    doc = {"name": "still_target", "duration_s": 25.0, "seed": 1,
           "vessels": [{"name": "asc", "type": "delfim", "position_m": [0.0, 0.0], "heading_deg": 90.0,
                        "controller": {"type": "path_following", "waypoints": [[0.0, 0.0], [0.0, 10.0]],
                                       "speed_m_s": 0.3},
                        "sensor": {"max_range_m": 80.0}, "tracking": {}}],
           "moving_obstacles": [{"name": "still", "radius_m": 1.5, "position_m": [-30.0, 40.0], "speed_m_s": 0.0}]}
    runner = Runner(parse_scenario(doc), None, progress=False)
    ev = RunEvaluator(runner)
    runner.observe("record", ev)
    runner.run()
    assert runner.agents[0].perception.tracks()[0].is_static  # the case: flagged static
    tr = ev.summary()["tracking"]["asc"]
    assert tr["time_to_confirm_s"]["still"] < 2.0 and tr["id_switches"] == 0
    # missed only until the track is confirmed (< 2 s of 25 s), never after it is flagged static
    assert tr["gospa_missed_mean"] < 50.0 * 2.0 / 25.0 and tr["gospa_false_mean"] == 0.0
    assert tr["gospa_mean_m"] < 1.0


def test_a_target_outside_the_field_of_view_is_not_missed():
    """A 90° sensor looking north: a boat astern within range cannot be seen, so it is neither missed
    nor waiting to be confirmed (it used to be scored missed, c²/2 at every evaluation); the boat
    ahead is tracked. A disc straddling the edge of the fan counts (its half-width added)."""
    from mjasc.evaluation.run_evaluation import RunEvaluator
    from mjasc.runs.runner import Runner
    from mjasc.runs.scenario import parse_scenario

    doc = {"name": "fov", "duration_s": 12.0, "seed": 1,
           "vessels": [{"name": "asc", "type": "delfim", "position_m": [0.0, 0.0], "heading_deg": 90.0,
                        "controller": {"type": "path_following", "waypoints": [[0.0, 0.0], [0.0, 20.0]],
                                       "speed_m_s": 0.3},
                        "sensor": {"max_range_m": 80.0, "fov_deg": 90.0}, "tracking": {}}],
           "moving_obstacles": [{"name": "ahead", "radius_m": 1.5, "position_m": [10.0, 50.0], "speed_m_s": 0.5},
                                {"name": "astern", "radius_m": 1.5, "position_m": [0.0, -40.0], "speed_m_s": 0.5}]}
    runner = Runner(parse_scenario(doc), None, progress=False)
    ev = RunEvaluator(runner)
    runner.observe("record", ev)
    runner.run()
    tr = ev.summary()["tracking"]["asc"]
    assert set(tr["time_to_confirm_s"]) == {"ahead"} and tr["time_to_confirm_s"]["ahead"] < 2.0
    assert tr["gospa_missed_mean"] < 50.0 * 2.0 / 12.0  # the boat ahead until confirmed, never the one astern
    s = TrackingScore(sensor_range_m=100.0, sensor_fov_rad=math.radians(90.0))
    s.add(0.0, [0, 0], ["edge", "out"], [[30, 29], [30, 20]], [], np.zeros((0, 2)), [2.0, 2.0], own_heading_rad=NORTH)
    assert list(s.summary()["time_to_confirm_s"]) == ["edge"]  # 45.9° off the bow, 2 m disc: its edge is in
    with pytest.raises(ValueError, match="own_heading_rad"):
        s.add(0.0, [0, 0], ["a"], [[0, 10]], [], np.zeros((0, 2)))


def test_a_track_kept_briefly_after_its_target_left_the_range_is_not_false():
    """A target leaving the sensor's range (100 m) with its track still held, 0.3 m off: the track
    is neither false nor the target missed (it used to cost c²/2 as a false track); the target's
    time to confirm counts only while in range."""
    s = TrackingScore(cutoff_m=10.0, sensor_range_m=100.0)
    s.add(0.0, [0, 0], ["boat"], [[99, 0]], [3], [[99.2, 0]])
    s.add(1.0, [0, 0], ["boat"], [[101, 0]], [3], [[101.3, 0]])   # out of range, track kept
    s.add(2.0, [0, 0], ["boat"], [[103, 0]], [], np.zeros((0, 2)))  # track dropped: nothing missed
    out = s.summary()
    assert out["gospa_false_mean"] == 0.0 and out["gospa_missed_mean"] == 0.0
    assert out["gospa_mean_m"] == pytest.approx((0.2 + 0.3 + 0.0) / 3, abs=1e-4) and out["id_switches"] == 0
    far = TrackingScore(cutoff_m=10.0, sensor_range_m=100.0)
    far.add(0.0, [0, 0], ["boat"], [[150, 0]], [4], [[150.1, 0]])  # a shared track of an unseen boat
    assert far.summary()["time_to_confirm_s"] == {} and far.summary()["gospa_false_mean"] == 0.0


def test_identity_switches_and_time_to_confirm():
    s = TrackingScore(cutoff_m=5.0, sensor_range_m=100.0)
    s.add(0.0, [0, 0], ["boat"], [[50, 0]], [], np.zeros((0, 2)))     # in range, not yet tracked
    s.add(1.0, [0, 0], ["boat"], [[49, 0]], [7], [[49.5, 0]])          # confirmed after 1 s
    s.add(2.0, [0, 0], ["boat"], [[48, 0]], [9], [[48.2, 0]])          # a new id: one switch
    s.add(3.0, [0, 0], ["boat"], [[47, 0]], [9], [[47.1, 0]])
    out = s.summary()
    assert out["id_switches"] == 1 and out["time_to_confirm_s"] == {"boat": 1.0} and out["evaluations"] == 4
    # position RMSE over the assigned pairs (0.5, 0.2, 0.1 m), whatever GOSPA's order
    assert out["position_rmse_m"] == pytest.approx(math.sqrt((0.25 + 0.04 + 0.01) / 3), abs=1e-4)
    cubic = TrackingScore(cutoff_m=5.0, order=3.0)
    cubic.add(0.0, [0, 0], ["a", "b"], [[0, 0], [20, 0]], [1, 2], [[3, 3.9], [20, 1]])
    assert cubic.summary()["position_rmse_m"] == pytest.approx(math.sqrt((9 + 3.9 ** 2 + 1) / 2), abs=1e-4)
    assert TrackingScore().summary()["position_rmse_m"] is None


# ------------------------------------------------------------------ a whole run
def test_run_evaluator_on_the_velocity_correction_scenario():
    """§6.3: the ASC yields to a boat crossing from its starboard side — a crossing where it gives
    way; the evaluator finds that one encounter, its role, a clearance that matches the run's own
    metric, and tracks the boat with a small GOSPA."""
    import mjasc
    from mjasc.evaluation.run_evaluation import RunEvaluator
    from mjasc.runs.runner import Runner

    sc = mjasc.load_scenario("thesis_6_3_velocity_correction")
    runner = Runner(sc, None, progress=False)
    ev = RunEvaluator(runner)
    runner.observe("record", ev)
    summary = runner.run().summary
    out = ev.summary()
    assert len(out["encounters"]) == 1
    e = out["encounters"][0]
    vessel, other = e["vessel"], e["other"]
    assert e["separation_m"] == pytest.approx(summary["vessels"][vessel]["min_clearance_m"][other], abs=1e-3)
    assert e["role"] in ("crossing_give_way", "head_on") and e["acted"] and not e["collision"]
    tr = out["tracking"][vessel]
    assert tr["evaluations"] > 100 and tr["gospa_mean_m"] < 5.0


# ------------------------------------------------------------------ mission cost
def _trace(t, xy, gamma):
    from mjasc.evaluation.mission_cost import ProgressTrace

    return ProgressTrace.from_samples(["a"], t, np.asarray(xy)[:, None, :], np.asarray(gamma)[:, None])


def test_mission_cost_closed_forms():
    """Reference: straight east at 1 m/s, γ = t. A run that waits 3 s first is 3 s late on the same
    track length; one that sails at 45° to its path (|Δp| = √2 Δγ) is on time but sails √2 − 1 further;
    a reference that stopped at γ = 6 gives no time cost and says by how much it fell short."""
    from mjasc.evaluation.mission_cost import mission_cost

    t = np.arange(0.0, 20.01, 0.1)
    ref = _trace(t, np.column_stack([t, 0 * t]), t)
    late = np.maximum(t - 3.0, 0.0)
    c = mission_cost(_trace(t, np.column_stack([late, 0 * t]), late), ref, tolerance_m=0.5)["a"]
    assert c["time_cost_s"] == pytest.approx(3.0, abs=1e-9) and c["path_cost"] == pytest.approx(0.0, abs=1e-9)
    assert c["progress_m"] == pytest.approx(16.5) and c["reached_s"] == pytest.approx(19.5)
    assert c["progress_lost_m"] == pytest.approx(3.0)  # 3 s late at the end: 3 m less of the mission made
    c = mission_cost(_trace(t, np.column_stack([t, t]), t), ref, tolerance_m=0.5)["a"]
    assert c["path_cost"] == pytest.approx(math.sqrt(2) - 1, abs=1e-4)
    assert c["time_cost_s"] == pytest.approx(0.0, abs=1e-9)
    stop = np.minimum(t, 6.0)
    c = mission_cost(_trace(t, np.column_stack([t, 0 * t]), t), _trace(t, np.column_stack([stop, 0 * t]), stop),
                     tolerance_m=0.5)["a"]
    assert c["time_cost_s"] is None and c["progress_short_m"] == pytest.approx(14.0)
    assert c["path_cost"] == pytest.approx(0.0, abs=1e-9)  # the same distance per metre of progress
    assert c["progress_lost_m"] == 0.0
    # a run that stopped for good at γ = 6 (or was pushed back there): no path or time cost at its own
    # progress, but 14 m of the mission lost against the reference
    c = mission_cost(_trace(t, np.column_stack([stop, 0 * t]), stop), ref, tolerance_m=0.5)["a"]
    assert c["time_cost_s"] == pytest.approx(0.0, abs=1e-9) and c["path_cost"] == pytest.approx(0.0, abs=1e-9)
    assert c["progress_lost_m"] == pytest.approx(14.0)
    back = np.where(t < 6.0, t, np.maximum(6.0 - 2.0 * (t - 6.0), 2.0))  # pushed back from γ = 6 to 2
    c = mission_cost(_trace(t, np.column_stack([back, 0 * t]), back), ref, tolerance_m=0.5)["a"]
    assert c["progress_lost_m"] == pytest.approx(14.0)  # (progress counts as its running maximum, 6 m)
    still = _trace(t, np.zeros((len(t), 2)), 0 * t)  # no progress: no cost
    assert mission_cost(still, still)["a"]["path_cost"] is None


STRAIGHT = """
name = "straight"
duration_s = 5.0
seed = 4
[[vessels]]
name = "a"
type = "otter"
position_m = [0.0, 1.0]
speed_m_s = 1.0
controller = { type = "path_following", waypoints = [[0.0, 0.0], [100.0, 0.0]], speed_m_s = 1.5 }
"""


def test_a_run_without_traffic_against_its_rerun_costs_exactly_nothing():
    """A run is a pure function of its text: rerun as the reference, its cost is 0 exactly — why a
    run without traffic is its own reference (no second run)."""
    import tomllib

    from mjasc.evaluation.mission_cost import ProgressTrace, mission_cost, reference_document
    from mjasc.evaluation.run_evaluation import RunEvaluator
    from mjasc.runs.runner import Runner
    from mjasc.runs.scenario import parse_scenario

    doc = tomllib.loads(STRAIGHT)
    assert reference_document(doc) is None
    runner = Runner(parse_scenario(doc), None, progress=False)
    ev = RunEvaluator(runner)
    runner.observe("record", ev)
    runner.run()
    again = Runner(parse_scenario(doc), None, progress=False)
    trace = ProgressTrace(again)
    again.observe("record", trace)
    again.run()
    cost = mission_cost(ev.progress, trace)["a"]
    assert cost["path_cost"] == 0.0 and cost["time_cost_s"] == 0.0 and cost["progress_m"] > 5.0
    assert ev.cost(None)["a"] == {**cost, "reference": "self"}


DETOUR = """
name = "detour"
duration_s = 30.0
seed = 3
[rates]
prediction_period_s = 2.0
[[vessels]]
name = "a"
type = "otter"
position_m = [0.0, 0.0]
speed_m_s = 1.5
controller = { type = "path_following", waypoints = [[0.0, 0.0], [200.0, 0.0]], speed_m_s = 1.5 }
avoidance = {}
sensor = { beams = 180, max_range_m = 100.0 }
tracking = {}
[[moving_obstacles]]
name = "buoy"
radius_m = 3.0
position_m = [35.0, 0.5]
heading_deg = 90.0
speed_m_s = 0.0
"""


def test_a_detour_around_a_buoy_costs_path_and_time():
    """A buoy (a stationary target) on the path: the vessel replans around it and sails further and
    later than the same mission without the buoy, whose vessel stays on its straight path (distance
    = progress)."""
    from mjasc.campaigns.executor import execute_in_process

    out = execute_in_process({"index": 0, "scenario_toml": DETOUR, "run_dir": None, "evaluate": True,
                              "reference": True})
    assert out["status"] == "completed", out["error"]
    ev = out["summary"]["evaluation"]
    assert ev["cost_reference"]["kind"] == "no_traffic" and ev["cost_reference"]["status"] == "completed"
    c = ev["cost"]["a"]
    assert out["summary"]["vessels"]["a"]["avoidance"]["actions"]["replan"] >= 1
    assert c["path_cost"] > 0.02 and c["time_cost_s"] > 0.5 and c["progress_short_m"] is None
    assert c["ref_distance_m"] == pytest.approx(c["progress_m"], abs=0.05)  # the reference sails its path
    assert c["distance_m"] <= out["summary"]["vessels"]["a"]["distance_m"] + 1e-6
    plain = execute_in_process({"index": 0, "scenario_toml": DETOUR, "run_dir": None, "evaluate": True})
    assert "cost" not in plain["summary"]["evaluation"]  # no reference unless asked
