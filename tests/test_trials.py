"""Manoeuvring trials against closed forms, symmetry and the ordering physics demands.

Straight-line surge of both vessels is exactly linear (X_uu = 0 and, with v = r = 0, every
Coriolis term vanishes), so the speed trial has closed forms: the steady speed balances thrust and
linear damping, and the rise from rest is a first-order lag τ = M_11/|X_u| driven by the thrust of a
first-order shaft lag T_n. Figures come from the vessel folders, masses from the compiled model.
"""

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest
from scipy.optimize import brentq

from mjasc.physics.trials import DEFAULT_COMMANDS, TRIAL_KINDS, run_trial
from mjasc.physics.vessels import load_vessel_type
from tests.helpers import make_sim

REPO = Path(__file__).resolve().parent.parent


def surge_time_constant(vessel: str) -> float:
    """τ = M_11 / |X_u| with M_11 from the vessel's total (rigid + added) mass matrix."""
    sim = make_sim(vessel)
    return float(sim.hydro.total_mass[0, 0, 0]) / abs(load_vessel_type(vessel).hydro.X_u)


def t63_with_shaft_lag(tau: float, t_n: float) -> float:
    """Exact time to 1 − 1/e of the steady speed for τ u̇ + u = U f(t), f = (1 − e^(−t/T_n))²: thrust
    ∝ n|n| follows the square of the lagged shaft speed. Each exponential input e^(−t/a) gives
    a/(a − τ) (e^(−t/a) − e^(−t/τ))."""

    def response(t):
        c1 = t_n / (t_n - tau)
        c2 = (t_n / 2) / (t_n / 2 - tau)
        return ((1 - math.exp(-t / tau)) - 2 * c1 * (math.exp(-t / t_n) - math.exp(-t / tau))
                + c2 * (math.exp(-2 * t / t_n) - math.exp(-t / tau)))

    return brentq(lambda t: response(t) - (1 - math.exp(-1)), 1e-3, 20 * tau)


# ---------------------------------------------------------------------- speed
@pytest.mark.parametrize("vessel,command", [("otter", 0.25), ("otter", 0.5), ("otter", 1.0), ("otter", -0.5),
                                            ("delfim", 0.6)])
def test_speed_trial_steady_speed_and_t63_match_linear_surge(vessel, command):
    """steady_speed = 2 k n²/|X_u| (k, n_max for ahead; k_r, |n_min| astern) within 1 %, and t63
    equals the closed form of a first-order surge driven through the shaft lag within one physics
    step (the explicit Euler step shifts it by O(dt))."""
    vt = load_vessel_type(vessel)
    pr = vt.propellers
    k, n = (pr.k_forward, command * pr.n_max_rad_s) if command > 0 else (pr.k_reverse, command * pr.n_min_rad_s)
    expected = 2 * k * n * n / abs(vt.hydro.X_u)
    res = run_trial("speed", vessel, port=command, starboard=command)
    assert res["steady_state_reached"]
    assert res["steady_speed"] == pytest.approx(expected, rel=0.01)
    assert math.copysign(1, res["steady_surge"]) == math.copysign(1, command)
    assert res["steady_yaw_rate"] == 0.0  # equal commands sail dead straight
    tau = surge_time_constant(vessel)
    assert res["t63"] == pytest.approx(t63_with_shaft_lag(tau, pr.time_constant_s), abs=res["timestep_s"])


def test_speed_trial_otter_t63_is_the_surge_time_constant_plus_the_shaft_lag():
    """t63 ≈ M_11/|X_u| ≈ 1.10 s. The thrust rises as (1 − e^(−t/T_n))², whose mean delay is
    ∫(1 − f) dt = 2T_n − T_n/2 = 1.5 T_n = 0.15 s for T_n = 0.1 s, so t63 ∈ (τ, τ + 2 T_n]."""
    tau = surge_time_constant("otter")
    assert tau == pytest.approx(85.5 / 77.55, rel=1e-3)
    res = run_trial("speed", "otter")
    assert res["port"] == res["starboard"] == 1.0
    assert res["steady_speed"] == pytest.approx(3.09, abs=0.01)  # Fossen: top speed ≈ 3.1 m/s
    assert tau < res["t63"] <= tau + 2 * 0.1


def test_delfim_top_speed_is_the_published_figure():
    assert run_trial("speed", "delfim")["steady_speed"] == pytest.approx(2.5, abs=0.01)


# ---------------------------------------------------------------------- turning circle
@pytest.fixture(scope="module")
def otter_turns():
    return (run_trial("turning-circle", "otter"), run_trial("turning-circle", "otter", port=0.2, starboard=1.0))


def test_turning_circle_steady_diameter_is_kinematically_consistent(otter_turns):
    """The diameter fitted to the track over a steady revolution equals 2U/|r| (a steady turn)."""
    res, _ = otter_turns
    assert res["steady_state_reached"]
    assert res["steady_diameter"] == pytest.approx(2 * res["steady_speed"] / res["steady_yaw_rate"], rel=2e-3)


def test_turning_circle_geometry_is_ordered_like_a_ship(otter_turns):
    """Default (1.0, 0.2) turns to starboard; the approach at equal total thrust loses speed in the
    turn (drift, cross-flow drag), so the turn tightens: tactical diameter > steady diameter;
    the transfer at 90° is under the tactical diameter and the advance positive; drift is outward."""
    res, _ = otter_turns
    assert res["turn_direction"] == "starboard"
    assert res["steady_speed"] < res["approach_speed"]
    assert res["steady_diameter"] < res["tactical_diameter"] < 1.2 * res["steady_diameter"]
    assert 0 < res["transfer"] < res["tactical_diameter"]
    assert res["advance"] > res["transfer"] > 0
    assert 0 < res["steady_drift_angle_deg"] < 30
    assert 0 < res["time_to_90_deg"] < res["time_to_180_deg"]


def test_turning_circle_is_mirror_symmetric(otter_turns):
    """Swapping port and starboard flips the turn and leaves every distance the same (the hull,
    CG and propellers are symmetric about the centreline)."""
    a, b = otter_turns
    assert b["turn_direction"] == "port"
    for key in ("advance", "transfer", "tactical_diameter", "steady_diameter", "steady_speed", "steady_yaw_rate"):
        assert b[key] == pytest.approx(a[key], rel=1e-3, abs=1e-4), key


def test_turning_circle_bigger_differential_turns_tighter():
    wide = run_trial("turning-circle", "otter", port=0.8, starboard=0.6)
    tight = run_trial("turning-circle", "otter", port=0.8, starboard=0.0)
    assert tight["steady_diameter"] < wide["steady_diameter"]
    assert tight["tactical_diameter"] < wide["tactical_diameter"]


# ---------------------------------------------------------------------- zigzag
@pytest.mark.parametrize("vessel", ["otter", "delfim"])
def test_zigzag_overshoots_are_positive_and_finite(vessel):
    res = run_trial("zigzag", vessel)
    assert res["first_turn"] == "starboard"
    for key in ("overshoot_1_deg", "overshoot_2_deg"):
        assert 0 < res[key] < 20, key
    assert 0 < res["initial_turning_time"] < res["time_to_third_execute"]
    assert "differential" in res["definition"]


def test_zigzag_smaller_angle_smaller_overshoot_and_mirror():
    """A 10°/10° check reverses at a lower yaw rate (less time to build it up): smaller overshoot.
    The mirrored command starts to port with the same overshoots."""
    twenty = run_trial("zigzag", "otter")
    ten = run_trial("zigzag", "otter", zigzag_angle_deg=10.0)
    assert 0 < ten["overshoot_1_deg"] < twenty["overshoot_1_deg"]
    mirror = run_trial("zigzag", "otter", port=0.2, starboard=1.0)
    assert mirror["first_turn"] == "port"
    assert mirror["overshoot_1_deg"] == pytest.approx(twenty["overshoot_1_deg"], abs=0.02)
    assert mirror["overshoot_2_deg"] == pytest.approx(twenty["overshoot_2_deg"], abs=0.02)


# ---------------------------------------------------------------------- stopping
def test_crash_stop_against_closed_form_and_coasting():
    """Full astern from full ahead: with linear damping d = |X_u| and reverse thrust T_r on both
    shafts, M u̇ = −T_r − d u gives t = τ ln((d U + T_r)/(d u_stop + T_r)) (plus ~the shaft reversal
    lag). Coasting (shafts stopped) takes τ ln(U/u_stop), longer, and sails further."""
    vt = load_vessel_type("otter")
    pr = vt.propellers
    crash = run_trial("stopping", "otter")
    coast = run_trial("stopping", "otter", port=0.0, starboard=0.0)
    assert crash["port"] == crash["starboard"] == -1.0
    assert crash["stopping_distance"] > 0 and crash["lateral_deviation"] == 0.0
    assert crash["stopping_distance"] == pytest.approx(crash["head_reach"], rel=1e-6)
    tau, d = surge_time_constant("otter"), abs(vt.hydro.X_u)
    t_r = 2 * pr.k_reverse * pr.n_min_rad_s**2
    u0 = crash["approach_speed"]
    ideal = tau * math.log((d * u0 + t_r) / (d * 0.05 + t_r))
    assert ideal < crash["stopping_time"] < ideal + 2 * pr.time_constant_s
    assert coast["stopping_time"] == pytest.approx(tau * math.log(u0 / 0.05), abs=0.05)
    assert coast["stopping_time"] > crash["stopping_time"]
    assert coast["stopping_distance"] > crash["stopping_distance"]


def test_heavier_delfim_stops_later_relative_to_its_speed():
    """Delfim τ ≈ 2.1 s vs Otter 1.1 s: it needs longer, also per unit of approach speed."""
    otter, delfim = run_trial("stopping", "otter"), run_trial("stopping", "delfim")
    assert delfim["stopping_time"] > otter["stopping_time"]
    assert delfim["stopping_distance"] / delfim["approach_speed"] > otter["stopping_distance"] / otter["approach_speed"]


def test_tightest_turn_trial_sails_the_closed_form_turn():
    """The solved commands held from rest settle in the turn the steady-state solve predicts, and it
    is tighter than the turning circle at the same speed with a smaller differential."""
    res = run_trial("tightest-turn", "otter")  # the Otter's cruise speed, 1.5 m/s
    assert res["speed"] == 1.5 and res["starboard"] == 1.0 and -1.0 <= res["port"] < 1.0
    assert res["steady_state_reached"]
    assert res["steady_diameter"] == pytest.approx(res["closed_form_diameter"], rel=3e-3)
    assert res["steady_speed"] == pytest.approx(1.5, rel=3e-3)
    assert res["steady_diameter"] == pytest.approx(2 * res["steady_speed"] / res["steady_yaw_rate"], rel=3e-3)
    # the radius the go-to-formation check's error names (rounded up: 5.003 m → 5.01 m)
    assert res["min_mission_turn_radius"] == 5.01
    slower = run_trial("tightest-turn", "otter", speed_m_s=1.0)
    assert slower["closed_form_diameter"] < res["closed_form_diameter"]  # slower, tighter


def test_tightest_turn_trial_input():
    with pytest.raises(ValueError, match="^--port/--starboard: the tightest turn's commands are solved for"):
        run_trial("tightest-turn", "otter", port=1.0)
    with pytest.raises(ValueError, match="^--speed: only the tightest-turn trial takes a speed"):
        run_trial("speed", "otter", speed_m_s=1.0)
    with pytest.raises(ValueError, match="^--speed: the hull sails no steady turn at 3.05 m/s"):
        run_trial("tightest-turn", "otter", speed_m_s=3.05)
    for bad in (0.0, float("nan")):
        with pytest.raises(ValueError, match="^--speed"):
            run_trial("tightest-turn", "otter", speed_m_s=bad)


# ---------------------------------------------------------------------- input and CLI
def test_every_kind_returns_its_identity_and_commands():
    for kind in TRIAL_KINDS:
        assert kind in DEFAULT_COMMANDS
    res = run_trial("speed", "otter", port=0.5, starboard=0.5)
    assert (res["kind"], res["vessel"], res["port"], res["starboard"]) == ("speed", "otter", 0.5, 0.5)


@pytest.mark.parametrize("kwargs,needle", [
    (dict(port=1.5), "--port"),
    (dict(starboard=-1.01), "--starboard"),
    (dict(port=float("nan")), "--port"),
    (dict(port="fast"), "--port"),
])
def test_bad_commands_name_the_flag(kwargs, needle):
    with pytest.raises(ValueError, match=needle):
        run_trial("speed", "otter", **kwargs)


def test_bad_trial_specific_input():
    with pytest.raises(ValueError, match="--port.*differ"):
        run_trial("turning-circle", "otter", port=0.5, starboard=0.5)
    with pytest.raises(ValueError, match="--starboard.*≤ 0"):
        run_trial("stopping", "otter", port=-1.0, starboard=0.3)
    with pytest.raises(ValueError, match="kind"):
        run_trial("spiral", "otter")


def test_unknown_vessel_lists_the_available_ones():
    with pytest.raises(ValueError, match="^--vessel: must be one of delfim, otter or a vessel folder's path"):
        run_trial("speed", "titanic")


def test_cli_prints_one_json_object():
    out = subprocess.run(
        [sys.executable, "-m", "mjasc", "trial", "speed", "--vessel", "otter", "--port", "0.5", "--starboard", "0.5",
         "--json"], cwd=REPO, capture_output=True, text=True, timeout=120, check=True).stdout
    res = json.loads(out)
    assert {"kind", "vessel", "port", "starboard", "steady_speed", "t63"} <= res.keys()
    assert res["steady_speed"] == pytest.approx(2 * 0.01108 * (0.5 * 103.9) ** 2 / 77.55, rel=0.01)


def test_cli_bad_port_exits_2_naming_the_flag():
    proc = subprocess.run([sys.executable, "-m", "mjasc", "trial", "speed", "--vessel", "otter", "--port", "1.5"],
                          cwd=REPO, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and "--port" in proc.stderr
