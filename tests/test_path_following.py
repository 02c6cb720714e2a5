"""Path following: cross-track error converges, also in current (integral LOS)."""

import numpy as np
import pytest

from mjasc.guidance.path_following import PathFollower, PathFollowingConfig
from mjasc.guidance.paths import Path
from tests.helpers import make_sim


def follow(vessel, path, current, speed, duration_s, start=(0.0, 0.0, 0.0), start_speed=0.5):
    sim = make_sim(vessel, current=current)
    sim.reset([list(start)], [[start_speed, 0, 0]])
    f = PathFollower(path, sim.world.vessel_types[0], sim.hydro.total_mass[0], sim.world.propeller_lateral_m[0, 0])
    log = []
    for _ in range(int(duration_s / 0.1)):
        st = sim.states()
        cmd, status = f.command(st.position_m[0], st.heading_rad[0], st.velocity_m_s[0], st.body_velocity[0], speed, 0.1)
        sim.set_commands(cmd[None])
        sim.step(5)
        log.append((st.time_s, status.cross_track_m, st.body_velocity[0, 0], status.gamma_m))
    return np.array(log)


@pytest.mark.parametrize("vessel,speed", [("otter", 1.5), ("delfim", 1.0)])
@pytest.mark.parametrize("current", [(0.0, 0.0), (0.0, 0.3), (-0.2, 0.25)])
def test_cross_track_error_converges_on_a_straight_line(vessel, speed, current):
    """From 10 m off the path, the error decays to centimetres, cross current included."""
    log = follow(vessel, Path.line([0, 0], [2000, 0]), current, speed, 150, start=(0.0, 10.0, 0.0))
    assert abs(log[0, 1]) == pytest.approx(10.0, abs=0.1)
    late = log[log[:, 0] > 100]
    assert np.max(np.abs(late[:, 1])) < 0.05
    assert np.mean(late[:, 2]) == pytest.approx(speed, abs=0.05)  # surge speed over ground tracks the reference


def test_l_shaped_path_in_current_stays_close():
    path = Path.from_waypoints([[0, 0], [150, 0], [150, 150]], turn_radius_m=20.0)
    log = follow("otter", path, (0.0, 0.3), 1.5, 230)
    assert log[-1, 3] > path.length - 10  # reached the end
    assert np.max(np.abs(log[log[:, 0] > 20, 1])) < 1.5
    assert np.mean(np.abs(log[:, 1])) < 0.3


def test_config_validation_names_the_field():
    with pytest.raises(ValueError, match="heading_bandwidth_rad_s"):
        PathFollowingConfig(heading_bandwidth_rad_s=0)


def test_command_for_thrust_in_floats_equals_the_array_form():
    """The float inverse propeller curve (small fleets) gives the array form's bits, saturation,
    both signs, zeros and NaN included."""
    from mjasc.physics.thrusters import PropellerCoefficients, command_for_thrust_scalar

    props = PropellerCoefficients(k_forward=0.0111, k_reverse=0.0071, n_max_rad_s=993.0 / 9.55,
                                  n_min_rad_s=-972.0 / 9.55, time_constant_s=0.1)
    rng = np.random.default_rng(3)
    t = np.concatenate([rng.uniform(-300.0, 300.0, 4000), rng.normal(0.0, 1.0, 1000),
                        [0.0, -0.0, 1e-300, -1e-300, 1e9, -1e9, np.nan]])
    want = props.command_for_thrust(t)
    got = np.array([command_for_thrust_scalar(v, props.k_forward, props.k_reverse, props.n_max_rad_s,
                                              props.n_min_rad_s) for v in t.tolist()])
    np.testing.assert_array_equal(got, want)
    assert np.array_equal(np.signbit(got), np.signbit(want))


def _turning(vessel: str, speed_ref: float, start_speed: float, duration_s: float = 40.0):
    """A vessel at ``start_speed`` told ``speed_ref`` and a course 150° off its heading at once (a
    collision-avoidance stop or a detour's sharp turn): (time, surge u [m/s], net thrust [N], port
    and starboard commands) per tick."""
    sim = make_sim(vessel)
    sim.reset([[0.0, 0.0, 0.0]], [[start_speed, 0, 0]])
    f = PathFollower(Path.line([0, 0], [2000, 0]), sim.world.vessel_types[0], sim.hydro.total_mass[0],
                     sim.world.propeller_lateral_m[0, 0])
    log = []
    for _ in range(int(duration_s / 0.1)):
        st = sim.states()
        cmd, _ = f.command(st.position_m[0], st.heading_rad[0], st.velocity_m_s[0], st.body_velocity[0], speed_ref,
                           0.1, course_override_rad=np.radians(150.0))
        sim.set_commands(cmd[None])
        sim.step(5)
        log.append((st.time_s, st.body_velocity[0, 0], float(np.sum(st.thrust_n[0])), cmd[0], cmd[1]))
    return np.array(log)


@pytest.mark.parametrize("vessel", ["otter", "delfim"])
def test_a_hull_faster_than_asked_is_not_pushed_ahead_by_its_turn(vessel):
    """Yaw has priority in the allocation, but while the hull is faster than its speed reference
    the differential stays within the reverse thrust's range: a full differential (T_max ahead on
    one propeller, T_min astern on the other) pushes ahead by T_max − T_min, and a hull told to stop
    while it turned hard kept ~0.5 m/s through the turn. Now the way comes off (a stop), a sharp
    turn at a slow turning speed stays near it, and from below the reference the turn still gets
    the whole differential: full astern on one side, full ahead on the other."""
    stop = _turning(vessel, 0.0, 1.5)
    assert np.max(np.abs(stop[stop[:, 0] > 8.0, 1])) < 0.05  # way off in seconds (and no sternway)
    ahead = stop[(stop[:, 0] > 1.0) & (stop[:, 1] > 0.01)]
    assert np.all(ahead[:, 2] <= 1e-6)  # while it moves ahead the propellers never add thrust ahead
    slow = _turning(vessel, 0.3, 1.5)  # (the CAS's sharp turn: 0.3 m/s)
    settled = slow[slow[:, 0] > 8.0]
    assert np.max(settled[:, 1]) < 0.36  # (the full differential held it at 0.5–0.7 m/s)
    from_rest = _turning(vessel, 1.0, 0.0)
    assert from_rest[1, 3] == pytest.approx(-1.0) and from_rest[1, 4] == pytest.approx(1.0)  # turning left
