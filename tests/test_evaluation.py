"""mjasc.evaluation: COLREG roles and compliance on constructed encounters, GOSPA against closed
forms, identity switches and time to confirm."""

import math

import numpy as np
import pytest

from mjasc.evaluation.colreg import classify, judge_compliance, relative_bearing_deg
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


def test_identity_switches_and_time_to_confirm():
    s = TrackingScore(cutoff_m=5.0, sensor_range_m=100.0)
    s.add(0.0, [0, 0], ["boat"], [[50, 0]], [], np.zeros((0, 2)))     # in range, not yet tracked
    s.add(1.0, [0, 0], ["boat"], [[49, 0]], [7], [[49.5, 0]])          # confirmed after 1 s
    s.add(2.0, [0, 0], ["boat"], [[48, 0]], [9], [[48.2, 0]])          # a new id: one switch
    s.add(3.0, [0, 0], ["boat"], [[47, 0]], [9], [[47.1, 0]])
    out = s.summary()
    assert out["id_switches"] == 1 and out["time_to_confirm_s"] == {"boat": 1.0} and out["evaluations"] == 4


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
