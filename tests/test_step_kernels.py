"""The compiled physics step (mjasc.physics.step_kernels) gives the bits of the sequence it replaced:
the traffic poses of MovingObstacleSet.rows, and whole steps of the readable order — traffic, mj_step1,
hydrodynamic force, mj_step2 — on a scenario with traffic and a current."""

import math
from pathlib import Path

import mujoco
import numpy as np
import pytest

from mjasc.guidance.paths import Path as GuidancePath
from mjasc.physics.obstacles import MovingObstacle, MovingObstacleSet
from mjasc.physics.simulation import PhysicsDivergence
from mjasc.physics.step_kernels import traffic_poses, traffic_state_at, traffic_table
from mjasc.runs.runner import Runner
from mjasc.runs.scenario import load_scenario

TASKS = Path(__file__).resolve().parents[1] / "tasks"


def test_traffic_poses_have_the_bits_of_rows():
    bend = GuidancePath.from_waypoints([[0, 0], [50, 0], [50, 50]], turn_radius_m=10.0)
    s = MovingObstacleSet([MovingObstacle("a", 2.0, position_m=(3.0, -4.0), heading_rad=2.1, speed_m_s=1.7),
                           MovingObstacle("b", 3.0, speed_m_s=0.8, path=bend, start_gamma_m=3.3),
                           MovingObstacle("c", 1.0, position_m=(-7, 9), heading_rad=-0.4, speed_m_s=2.2,
                                          turn_rate_rad_s=-0.031),
                           MovingObstacle("d", 1.0, speed_m_s=1.1, path=bend)])
    mocap = [3, 0, 2, 1]
    table, samples = traffic_table(s.constants(), mocap, MovingObstacleSet.PATH_SAMPLE_M)
    pos, quat = np.full((4, 3), 7.0), np.full((4, 4), 7.0)
    for t in np.concatenate([np.arange(0.0, 150.0, 0.02), [1e-3, 999.0]]):
        traffic_poses(float(t), table, samples, pos, quat)
        for k, (x, y, h, _, _) in zip(mocap, s.rows(float(t))):
            want = np.array([x, y, 7.0, math.cos(0.5 * h), 0.0, 0.0, math.sin(0.5 * h)])
            assert np.concatenate([pos[k], quat[k]]).tobytes() == want.tobytes()


def test_traffic_state_at_has_the_bits_of_state():
    bend = GuidancePath.from_waypoints([[0, 0], [50, 0], [50, 50]], turn_radius_m=10.0)
    s = MovingObstacleSet([MovingObstacle("a", 2.0, position_m=(3.0, -4.0), heading_rad=2.1, speed_m_s=1.7),
                           MovingObstacle("b", 3.0, speed_m_s=0.8, path=bend, start_gamma_m=3.3),
                           MovingObstacle("c", 1.0, position_m=(-7, 9), heading_rad=-0.4, speed_m_s=2.2,
                                          turn_rate_rad_s=-0.031),
                           MovingObstacle("d", 1.0, speed_m_s=1.1, path=bend)])
    table, samples = traffic_table(s.constants(), [3, 0, 2, 1], MovingObstacleSet.PATH_SAMPLE_M)
    for t in np.concatenate([np.arange(0.0, 200.0, 0.02), [1e-3, 999.0]]):  # (past the paths' ends too)
        pv, heading = traffic_state_at(float(t), table, samples)
        got, want = (pv[0], heading, pv[1]), s.state(float(t))
        for a, b in zip(got, want):
            assert a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes() and a.flags.c_contiguous


def test_traffic_state_of_a_run_is_the_obstacle_sets():
    runner = Runner(load_scenario(TASKS / "demo.toml").with_overrides(duration_s=5.0), None, progress=False)
    sim = runner.sim
    assert len(sim.traffic)
    for _ in range(50):
        sim.step(5)
        for a, b in zip(sim.traffic_state(), sim.traffic.state(sim.time_s)):
            assert a.shape == b.shape and a.tobytes() == b.tobytes()


def _reference_steps(sim, n: int) -> None:
    """The physics step as it was written before the compiled one (no divergence checks)."""
    m, d = sim.model, sim.data
    vc = sim.current.velocity(sim._qpos3[:, :2], 0.0)
    for _ in range(n):
        sim._update_traffic()
        mujoco.mj_step1(m, d)
        sim.hydro.compute_bound(vc, None)
        mujoco.mj_step2(m, d)


def test_compiled_steps_have_the_bits_of_the_readable_sequence():
    sc = load_scenario(TASKS / "demo.toml")
    ref, new = Runner(sc, None, progress=False), Runner(sc, None, progress=False)
    assert len(new.sim.traffic) and new.sim._bound and new.sim._current_uniform_steady
    rng = np.random.default_rng(3)
    for block in range(400):
        cmd = rng.uniform(-1.0, 1.0, (new.sim.n_vessels, 2))
        ref.sim.set_commands(cmd)
        new.sim.set_commands(cmd)
        _reference_steps(ref.sim, 5)
        new.sim.step(5)
        for field in ("qpos", "qvel", "qacc", "act", "qfrc_applied", "mocap_pos", "mocap_quat"):
            assert getattr(new.sim.data, field).tobytes() == getattr(ref.sim.data, field).tobytes(), (block, field)
        assert new.sim.data.time == ref.sim.data.time


def test_compiled_steps_have_the_bits_of_the_readable_sequence_in_contact():
    """The common case's step calls mj_step once (Euler: mj_step1's stages then mj_step2's): the
    same bits as the readable sequence while hulls touch (contacts found by mj_step1's collision)."""
    sc = load_scenario(TASKS / "demo.toml")
    ref, new = Runner(sc, None, progress=False), Runner(sc, None, progress=False)
    assert new.sim._euler
    for sim in (ref.sim, new.sim):  # vessels 1 and 2 pushed against vessel 0
        sim._qpos3[1, :2] = sim._qpos3[0, :2] + [1.0, 0.5]
        sim._qpos3[2, :2] = sim._qpos3[0, :2] + [-1.0, 0.8]
        mujoco.mj_forward(sim.model, sim.data)
    rng = np.random.default_rng(4)
    contacts = 0
    for block in range(200):
        cmd = rng.uniform(-1.0, 1.0, (new.sim.n_vessels, 2))
        ref.sim.set_commands(cmd)
        new.sim.set_commands(cmd)
        _reference_steps(ref.sim, 5)
        new.sim.step(5)
        contacts = max(contacts, new.sim.data.ncon)
        for field in ("qpos", "qvel", "qacc", "act", "qfrc_applied", "mocap_pos", "mocap_quat", "efc_force"):
            assert getattr(new.sim.data, field).tobytes() == getattr(ref.sim.data, field).tobytes(), (block, field)
        assert new.sim.data.time == ref.sim.data.time
    assert contacts > 0


def test_a_divergence_inside_a_block_is_still_caught_at_its_step():
    sc = load_scenario(TASKS / "demo.toml")
    runner = Runner(sc, None, progress=False)
    sim = runner.sim
    sim.step(5)
    t0 = sim.time_s
    sim.data.qvel[0] = 1e6  # diverged before the next block's first step
    with pytest.raises(PhysicsDivergence, match="speed") as err:
        sim.step(5)
    assert f"t = {t0 + 0.02:.3f} s: vessel 'alpha' speed" in str(err.value)  # the block's first step
    assert err.value.last_good_time_s == t0


def test_a_mujoco_warning_during_a_block_stops_the_run():
    runner = Runner(load_scenario(TASKS / "demo.toml"), None, progress=False)
    sim = runner.sim
    sim.step(5)
    t0 = sim.time_s
    sim.data.warning[int(mujoco.mjtWarning.mjWARN_BADQACC)].number = 1  # (as if MuJoCo had warned)
    with pytest.raises(PhysicsDivergence, match="MuJoCo warning mjWARN_BADQACC") as err:
        sim.step(5)
    assert err.value.last_good_time_s == t0


def test_write_commands_writes_numpys_clipped_commands_or_nothing():
    from mjasc.physics.step_kernels import write_commands

    rng = np.random.default_rng(3)
    adr = np.array([[4, 1], [0, 5], [2, 3]], dtype=np.intp)
    for _ in range(300):
        c = rng.uniform(-2.5, 2.5, (3, 2))
        c[rng.random((3, 2)) < 0.2] = rng.choice([-1.0, 1.0, 0.0, -0.0])
        ref, got = np.full(6, 9.0), np.full(6, 9.0)
        ref[adr] = np.minimum(np.maximum(c, -1.0), 1.0)
        assert write_commands(c, got, adr)
        assert got.tobytes() == ref.tobytes()
    for bad in (np.nan, np.inf, -np.inf):
        c = rng.uniform(-1, 1, (3, 2))
        c[1, 1] = bad
        got = np.full(6, 9.0)
        assert not write_commands(c, got, adr)
        assert (got == 9.0).all()


def test_fast_bounds_and_warning_checks():
    from mjasc.physics.step_kernels import any_nonzero, fast_bounds_ok

    v, a = np.array([1.0, -2.0, 0.5]), np.array([3.0, 0.0, -1.0])
    assert fast_bounds_ok(v, a, 5.25, 10.0)
    assert not fast_bounds_ok(v, a, 5.0, 10.0)
    assert not fast_bounds_ok(v, a, 5.25, 9.5)
    a[1] = np.nan
    assert not fast_bounds_ok(v, a, 5.25, np.inf)
    assert not any_nonzero(np.zeros(8, dtype=np.int32))
    assert any_nonzero(np.array([0, 0, 0, 2, 0], dtype=np.int32))
