"""The hull's tightest steady turn (mjasc.physics.steady_turn) against MuJoCo: the closed-form steady
state sailed in the simulation from rest under the same constant commands, mirror symmetry, and that
no other commands at the same speed turn tighter."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mjasc.physics.simulation import Simulation
from mjasc.physics.steady_turn import steady_state, tightest_turn, tightest_turn_of_type
from mjasc.physics.trial_track import new_track
from mjasc.physics.vessels import load_vessel_type
from mjasc.physics.world import build_world


def _hull(name):
    sim = Simulation(build_world([("t", load_vessel_type(name))]))
    return sim.hydro, sim.thrusters


@pytest.mark.parametrize("name, speed", [("otter", 0.5), ("otter", 1.5), ("otter", 2.5), ("delfim", 1.0)])
def test_the_tightest_turn_is_the_turn_the_simulated_hull_settles_in(name, speed):
    turn = tightest_turn_of_type(load_vessel_type(name), speed)
    assert turn.speed_m_s == pytest.approx(speed, rel=1e-9)
    assert turn.yaw_rate_rad_s > 0 and turn.sway_m_s < 0  # to port, drifting out of the turn
    assert max(turn.commands) == 1.0 or min(turn.commands) == -1.0  # one propeller at its limit
    track = new_track(name)  # from rest, heading east, the same constant commands in MuJoCo
    track.command(*turn.commands)
    assert track.sail_until_steady()
    _, _, _, _, u, v, r = track.last
    radius = math.hypot(u, v) / r
    assert (u, v, r) == pytest.approx((turn.surge_m_s, turn.sway_m_s, turn.yaw_rate_rad_s), rel=3e-3)
    assert radius == pytest.approx(turn.radius_m, rel=3e-3)


def test_a_turn_to_starboard_is_the_mirror_image():
    hydro, thrusters = _hull("otter")
    port = steady_state(hydro, thrusters, (0.2, 1.0))
    starboard = steady_state(hydro, thrusters, (1.0, 0.2), port * [1.0, -1.0, -1.0])
    assert starboard == pytest.approx(port * [1.0, -1.0, -1.0], rel=1e-9, abs=1e-12)
    # and equal commands sail straight (from the straight run's guess)
    straight = steady_state(hydro, thrusters, (0.6, 0.6))
    assert straight[1] == pytest.approx(0.0, abs=1e-12) and straight[2] == pytest.approx(0.0, abs=1e-12)


def test_no_other_commands_at_the_same_speed_turn_tighter():
    """Along the outer propeller eased to 0.9 and 0.8 (the inner one swept up from full astern,
    each steady state solved from the last), the turn at the tightest turn's speed is wider."""
    hydro, thrusters = _hull("otter")
    best = tightest_turn(hydro, thrusters, 1.5)
    for outer in (0.9, 0.8):
        nu = steady_state(hydro, thrusters, (-1.0, outer))
        rows = []
        for inner in np.linspace(-1.0, outer, 80):
            nu = steady_state(hydro, thrusters, (inner, outer), nu)
            rows.append((math.hypot(nu[0], nu[1]), math.hypot(nu[0], nu[1]) / nu[2]))
        speeds, radii = np.array(rows).T
        k = int(np.argmax(speeds >= 1.5))
        assert speeds[k - 1] < 1.5 <= speeds[k]
        assert np.interp(1.5, speeds[k - 1:k + 1], radii[k - 1:k + 1]) > best.radius_m * 1.02


def test_faster_than_the_hull_turns_is_none_and_the_speed_is_checked():
    hydro, thrusters = _hull("otter")
    assert tightest_turn(hydro, thrusters, 3.05) is None  # the Otter's top speed (3.1 m/s) only straight
    for bad in (0.0, -1.0, math.nan):
        with pytest.raises(ValueError, match="speed_m_s: must be finite and > 0"):
            tightest_turn(hydro, thrusters, bad)


def test_a_heavier_hull_turns_wider():
    """The Otter with 25 kg of payload (examples/my_hull): more mass and inertia against the same
    propellers — a wider tightest turn at the same speed."""
    from pathlib import Path

    from mjasc.physics.vessels import resolve_vessel_type

    root = Path(__file__).resolve().parents[1]
    heavy = load_vessel_type(resolve_vessel_type("examples/my_hull/hulls/otter_payload", root))
    light = load_vessel_type("otter")
    assert tightest_turn_of_type(heavy, 1.5).radius_m > tightest_turn_of_type(light, 1.5).radius_m
