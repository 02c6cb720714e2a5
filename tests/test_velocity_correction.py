"""Tests for mjasc.avoidance.velocity_correction: the virtual-target law, its saturation, thesis §6.3."""

import numpy as np
import pytest

from mjasc.avoidance.prediction import Decision, PredictedConflict
from mjasc.avoidance.velocity_correction import VelocityCorrection, simulate_speed_tracking

# Thesis §6.3 (docs/thesis.md §5): the prediction module's output, Ts = 1 s, k = 2.
GAMMA_A, GAMMA_B = 340.3, 389.0
T_I, T_F = 167.0, 198.0
K = 2.0
# Assumed (the thesis does not state them): a Delfim-class ASC with speeds 0–2.5 m/s, sailing its
# mission at 1 m/s with γ(t) = t + 150 m (so γ = 290 m at t = 140 s and 280 m at t = 130 s;
# Fig. 6.5 shows the vehicle near γ ≈ 300 m at t ≈ 150 s). At the mission speed it would be in
# [γ_A, γ_B] from t = 190.3 s to t_f: a collision, hence the correction.
SPEED_MIN, SPEED_MAX = 0.0, 2.5
MISSION_SPEED = 1.0


def mission_gamma(t):
    return t + 150.0


def thesis_conflict():
    return PredictedConflict(
        track_id=1, t_closest_s=182.0, min_distance_m=0.0, collision=True,
        t_i=T_I, t_f=T_F, gamma_a=GAMMA_A, gamma_b=GAMMA_B,
        point_a=np.array([370.0, 100.6]), point_b=np.array([374.2, 114.46]),
        decision=Decision.VELOCITY_CORRECTION, svo_polygon=None,
        vessel_positions=np.zeros((0, 2)), obstacle_positions=np.zeros((0, 2)), times=np.zeros(0),
    )


def test_virtual_target_definition():
    vc = VelocityCorrection(10.0, 5.0, 70.0, 35.0, 0.5, 0.0, 3.0)
    assert vc.desired_speed == pytest.approx(2.0)  # (70 − 10)/(35 − 5)
    assert vc.gamma_desired(20.0) == pytest.approx(40.0)
    assert vc.command(40.0, 20.0) == pytest.approx(2.0)  # on the target: V_d
    assert vc.command(44.0, 20.0) == pytest.approx(0.0)  # 4 m ahead: 2 − 0.5·4
    assert vc.command(30.0, 20.0) == 3.0  # 10 m behind: 7 → saturated at 3
    assert vc.is_saturated(30.0, 20.0) and not vc.is_saturated(40.0, 20.0)
    assert vc.feasible
    assert not vc.finished(34.9) and vc.finished(35.0)


def test_error_decays_exponentially_with_rate_k():
    # Continuous law (small steps, instant speed response): e(t) = e0 exp(−k t).
    k, e0 = 0.5, 5.0
    vc = VelocityCorrection(0.0, 0.0, 100.0, 100.0, k, -10.0, 10.0)
    res = simulate_speed_tracking(vc, gamma0=e0, speed0=1.0, t0=0.0, t_end=10.0, dt=1e-3)
    err = res.gammas - vc.gamma_desired(res.times)
    np.testing.assert_allclose(err, e0 * np.exp(-k * res.times), rtol=2e-3, atol=1e-9)


@pytest.mark.parametrize("period", [0.25, 0.5, 1.0])
def test_sampled_law_error_ratio_is_one_minus_kT(period):
    # Command held for T: e_{n+1} = (1 − kT) e_n. kT = 2 (the thesis's k = 2, Ts = 1) does not decay.
    vc = VelocityCorrection(0.0, 0.0, 100.0, 100.0, K, -100.0, 100.0)
    res = simulate_speed_tracking(vc, 3.0, 1.0, 0.0, 4.0, dt=0.05, control_period_s=period)
    err = res.gammas - vc.gamma_desired(res.times)
    steps = np.arange(0.0, 3.0, period)
    idx = np.round(steps / 0.05).astype(int)
    np.testing.assert_allclose(err[idx], 3.0 * (1.0 - K * period) ** np.arange(steps.size), atol=1e-9)


def test_first_order_lag_integrates_exactly():
    # Constant command (k tiny, target far): v(t) = u + (v0 − u) e^(−t/τ), γ = ∫ v.
    vc = VelocityCorrection(0.0, 0.0, 2.0 * 1e4, 1e4, 1e-12, 0.0, 5.0)  # V_d = 2
    tau = 3.0
    res = simulate_speed_tracking(vc, 0.0, 0.5, 0.0, 9.0, dt=0.3, time_constant_s=tau)
    t = res.times
    np.testing.assert_allclose(res.speeds, 2.0 - 1.5 * np.exp(-t / tau), atol=1e-9)
    np.testing.assert_allclose(res.gammas, 2.0 * t - 1.5 * tau * (1 - np.exp(-t / tau)), atol=1e-9)


@pytest.mark.parametrize("tau", [0.0, 1.0])
def test_thesis_6_3_slowing_down_at_140s_avoids_the_region(tau):
    """Thesis §6.3, Fig. 6.5: triggered at t = 140 s with goal (γ_A, t_f) the vessel stays out of
    [γ_A, γ_B] during [t_i, t_f]. V_d = (340.3 − 290)/(198 − 140) = 0.867 m/s, within range."""
    t0 = 140.0
    assert mission_gamma(T_F) > GAMMA_A  # at the mission speed it would be inside at t_f
    vc = VelocityCorrection.yield_to(thesis_conflict(), mission_gamma(t0), t0, K, SPEED_MIN, SPEED_MAX)
    assert vc.desired_speed == pytest.approx(50.3 / 58.0)
    assert vc.feasible
    res = simulate_speed_tracking(vc, mission_gamma(t0), MISSION_SPEED, t0, T_F, dt=0.05, time_constant_s=tau)
    during = (res.times >= T_I) & (res.times <= T_F)
    assert np.all(res.gammas[during] <= GAMMA_A + 1e-6)  # arrives at P_A at t_f at the latest
    assert res.gamma_at(T_F) == pytest.approx(GAMMA_A, abs=1e-3)
    assert vc.saturated_fraction == 0.0 and not vc.saturated_now
    assert vc.finished(T_F)


@pytest.mark.parametrize("tau", [0.0, 1.0])
def test_thesis_6_3_speeding_up_at_130s_saturates_and_fails(tau):
    """Thesis §6.3, Fig. 6.6: triggered at t = 130 s with goal (γ_B, t_i) the command saturates
    (V_d = (389 − 280)/(167 − 130) = 2.95 m/s > 2.5 m/s), the position error grows, and the vessel
    is still inside [γ_A, γ_B] at t_i: passing first fails."""
    t0 = 130.0
    vc = VelocityCorrection.pass_first(thesis_conflict(), mission_gamma(t0), t0, K, SPEED_MIN, SPEED_MAX)
    assert vc.desired_speed == pytest.approx(109.0 / 37.0)
    assert not vc.feasible
    res = simulate_speed_tracking(vc, mission_gamma(t0), MISSION_SPEED, t0, T_I, dt=0.05, time_constant_s=tau)
    err = res.gammas - vc.gamma_desired(res.times)
    assert err[-1] < err[len(err) // 2] < 0.0  # falls further and further behind the target
    assert GAMMA_A <= res.gamma_at(T_I) < GAMMA_B  # inside the obstructed stretch at t_i
    assert vc.saturated_now and vc.saturated_fraction > 0.95


def test_yield_with_margin_stays_strictly_out():
    t0 = 140.0
    vc = VelocityCorrection.yield_to(thesis_conflict(), mission_gamma(t0), t0, K, 0.0, 2.5, margin_m=5.0)
    res = simulate_speed_tracking(vc, mission_gamma(t0), 1.0, t0, T_F, time_constant_s=1.0)
    assert res.gamma_at(T_F) == pytest.approx(GAMMA_A - 5.0, abs=1e-3)


def test_validation():
    with pytest.raises(ValueError, match="t_goal"):
        VelocityCorrection(0, 10, 5, 10, 1, 0, 2)
    with pytest.raises(ValueError, match="gain_k"):
        VelocityCorrection(0, 0, 5, 10, 0, 0, 2)
    with pytest.raises(ValueError, match="speed_max"):
        VelocityCorrection(0, 0, 5, 10, 1, 2, 2)
    with pytest.raises(ValueError, match="conflict.gamma_a"):
        VelocityCorrection.yield_to(thesis_conflict(), 350.0, 160.0, K, 0, 2.5)
    with pytest.raises(ValueError, match="conflict.t_i"):
        VelocityCorrection.pass_first(thesis_conflict(), 300.0, 170.0, K, 0, 2.5)
    static = PredictedConflict(**{**thesis_conflict().__dict__, "t_f": np.inf})
    with pytest.raises(ValueError, match="conflict.t_f"):
        VelocityCorrection.yield_to(static, 290.0, 140.0, K, 0, 2.5)


def test_command_in_plain_floats_equals_the_law_and_numpy_clip():
    """``command`` (plain floats) gives ``float(np.clip(unsaturated_command(γ, t), v_min, v_max))``
    bit for bit, saturated or not, and keeps the same saturation record."""
    rng = np.random.default_rng(4)
    for _ in range(200):
        g0, t0 = rng.uniform(0, 100), rng.uniform(0, 100)
        vc = VelocityCorrection(g0, t0, g0 + rng.uniform(1, 60), t0 + rng.uniform(1, 40), rng.uniform(0.05, 2.0),
                                0.0, rng.uniform(0.5, 3.0))
        last_sat, sat_time = False, 0.0
        t = t0
        for _ in range(20):
            t_prev, t = t, t + rng.uniform(0.0, 1.0)
            gamma = g0 + rng.normal(0.0, 20.0)
            u = vc.unsaturated_command(gamma, t)
            want = float(np.clip(u, vc.speed_min, vc.speed_max))
            if last_sat and t > t_prev:
                sat_time += t - t_prev
            got = vc.command(gamma, t)
            assert got == want and np.copysign(1.0, got) == np.copysign(1.0, want)
            last_sat = want != u
            assert vc.saturated_now == last_sat
        assert vc.saturated_time_s == sat_time
