"""The own vessel after a pass first: the plan steps from V_d down to the mission speed at the goal
time, the hull sheds the difference over metres (mjasc.avoidance.speed_plan). Prediction puts the
vessel where the hull will be — (V_d − v_m)² / (2 a) further along — so that a slower vessel just
past the pass's goal is seen (tasks/fleet_50.toml, seed 1: v009 passed a crossing boat at 2.9 m/s
and ended 4.0 m (predicted, centre to centre; collision distance 3.4 m) behind v001 sailing at
0.9 m/s; the hull ran 1.2 m past the plan and the bounding circles closed to 0.19 m; docs/avoidance.md, "Hardening")."""

from types import SimpleNamespace

import numpy as np
import pytest

from mjasc.avoidance.config import AvoidanceConfig, parse_avoidance_options
from mjasc.avoidance.prediction import PredictionQuery, gamma_of_time, predict_fleet
from mjasc.avoidance.speed_plan import correction_profile
from mjasc.core.estimates import TrackEstimate
from mjasc.guidance.paths import Path


def _correction(t_goal, v_d):
    return SimpleNamespace(law=SimpleNamespace(t_goal=t_goal, desired_speed=v_d))


def test_a_pass_sheds_its_extra_speed_at_the_deceleration_after_its_goal():
    pas = _correction(10.0, 2.9)
    step = correction_profile(pas, 0.0, 5.0, 0.9)
    lag = correction_profile(pas, 0.0, 5.0, 0.9, decel_m_s2=1.0)
    before = np.linspace(0.0, 10.0, 21)
    assert np.array_equal(step(before), lag(before))  # the plan itself, up to the goal
    tau = (2.9 - 0.9) / 1.0
    after = np.array([10.0 + tau, 30.0])
    assert lag(after) - step(after) == pytest.approx([2.0 ** 2 / 2.0] * 2)  # (V_d − v_m)² / (2 a), then kept
    dt = 1e-4  # the speed falls from V_d to v_m: continuous, slope −a
    v = lambda f, t: (f(t + dt) - f(t)) / dt  # noqa: E731
    assert v(lag, 10.0) == pytest.approx(2.9, abs=1e-3) and v(lag, 11.0) == pytest.approx(1.9, abs=1e-3)
    assert v(lag, 10.0 + tau + 0.1) == pytest.approx(0.9, abs=1e-3)


@pytest.mark.parametrize("correction, speed",
                         [(None, 0.9), (_correction(10.0, 0.4), 0.9), (_correction(10.0, 2.9), 2.9)])
def test_yields_plain_speeds_and_no_excess_keep_the_plan(correction, speed):
    t = np.linspace(0.0, 40.0, 81)
    step = gamma_of_time(correction_profile(correction, 0.0, 0.0, speed), 0.0, 0.0)(t)
    lag = gamma_of_time(correction_profile(correction, 0.0, 0.0, speed, decel_m_s2=1.0), 0.0, 0.0)(t)
    assert np.array_equal(step, lag)


def test_the_deceleration_is_declared_and_zero_keeps_the_step():
    assert AvoidanceConfig().slow_down_decel_m_s2 == 1.0
    assert parse_avoidance_options({"slow_down_decel_m_s2": 0}).slow_down_decel_m_s2 == 0.0
    with pytest.raises(ValueError, match="slow_down_decel_m_s2"):
        parse_avoidance_options({"slow_down_decel_m_s2": -1.0})
    pas = _correction(10.0, 2.9)
    t = np.linspace(0.0, 40.0, 81)
    assert np.array_equal(correction_profile(pas, 0.0, 0.0, 0.9)(t),
                          correction_profile(pas, 0.0, 0.0, 0.9, decel_m_s2=0.0)(t))


def test_a_slower_vessel_just_past_the_pass_goal_is_a_conflict_only_with_the_hulls_lag():
    """Own at γ = 0 on a line east passing first at 2.9 m/s until t = 10 s, then 0.9 m/s; a vessel
    ahead in the same lane at 0.9 m/s, 4.2 m beyond the pass's goal at t = 10 s (centre to centre;
    radii 0.95 m each, safety 1.5 m: a collision distance of 3.4 m). Predicted as planned it stays
    4.2 m ahead; with the hull's 2 m of lag it is 2.2 m ahead: a collision."""
    cfg = parse_avoidance_options({"window_s": 40.0, "safety_distance_m": 1.5})  # (the fleet's)
    line = Path.line((0.0, 0.0), (300.0, 0.0))
    ahead = TrackEstimate(track_id=3, time_s=0.0, position_m=np.array([29.0 + 4.2 - 9.0, 0.0]), heading_rad=0.0,
                          speed_m_s=0.9, turn_rate_rad_s=0.0, radius_m=0.95)
    pas = _correction(10.0, 2.9)

    def predicted(decel):
        q = PredictionQuery(line, 0.0, 0.0, correction_profile(pas, 0.0, 0.0, 0.9, decel), 0.95, [ahead],
                            cfg.prediction, include_clear=True)
        return predict_fleet([q])[0][0]

    planned, lagging = predicted(0.0), predicted(cfg.slow_down_decel_m_s2)
    assert lagging.collision_distance_m == pytest.approx(3.4)
    assert not planned.collision and planned.min_distance_m == pytest.approx(4.2, abs=0.05)
    assert lagging.collision and lagging.min_distance_m == pytest.approx(2.2, abs=0.1)


def test_predicted_from_after_the_goal_continues_the_same_slow_down():
    """Predicted again 0.7 s after the pass's goal (the hull part way through shedding its extra
    speed), γ(t) is the earlier prediction's curve from that point: only what is left is shed."""
    pas = _correction(10.0, 2.9)
    t = np.linspace(10.7, 30.0, 60)
    early = correction_profile(pas, 0.0, 0.0, 0.9, decel_m_s2=1.0)
    g1 = float(early(np.array([10.7]))[0])
    late = correction_profile(pas, 10.7, g1, 0.9, decel_m_s2=1.0)
    assert np.allclose(late(t), early(t), rtol=0.0, atol=1e-9)


def test_the_prediction_keeps_a_pass_that_ended_at_its_goal_until_its_extra_speed_is_shed():
    """The control tick clears a correction at its goal and predicts at once ("check it before it is
    sailed"): that prediction still sheds the pass's extra speed (2 s at 1 m/s² from 2.9 to 0.9 m/s),
    and a prediction after the shedding is the plain mission speed again."""
    from types import SimpleNamespace

    from mjasc.avoidance.prediction_step import PredictionStep

    pas = _correction(10.0, 2.9)
    own = SimpleNamespace(correction=None, ended_correction=pas, config=AvoidanceConfig())
    at_goal = PredictionStep.predicted_gamma(own, 10.0, 0.0, 0.9)
    t = np.array([10.0, 11.0, 12.0, 20.0])
    assert np.allclose(at_goal(t), [0.0, 2.4, 3.8, 11.0])  # 2.9 → 0.9 m/s over 2 s: 2 m ahead of the step
    assert own.ended_correction is pas
    later = PredictionStep.predicted_gamma(own, 12.5, 0.0, 0.9)
    assert later == 0.9 and own.ended_correction is None  # (the constant profile: the mission speed)
