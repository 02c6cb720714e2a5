"""mjasc.suite against the checks dm_control applies to its own suite (dm_control/suite/suite_test.py),
dm_env's EnvironmentTestMixin, offscreen rendering and the physics being mjasc's own step.

Short episodes (task_kwargs time_limit) keep the sweep over every task cheap.
"""

from __future__ import annotations

import dataclasses
import subprocess
import sys
import textwrap
from unittest import mock

import mujoco
import numpy as np
import pytest
from absl.testing import absltest
from dm_control.rl import control
from dm_env import test_utils

from mjasc import suite
from mjasc.currents import UniformCurrent
from mjasc.simulation import Simulation
from mjasc.suite import otter, otter_team
from mjasc.suite.common import VesselPhysics

ALL = [pytest.param(d, t, id=f"{d}-{t}") for d, t in suite.ALL_TASKS]
SHORT = {"time_limit": 3.0}


def uniform_random_policy(action_spec, random=None):
    rng = np.random.RandomState(random)
    return lambda time_step: rng.uniform(action_spec.minimum, action_spec.maximum)


def step_environment(env, policy, num_episodes=5, max_steps_per_episode=10):
    for _ in range(num_episodes):
        steps = 0
        time_step = env.reset()
        yield time_step
        while not time_step.last():
            time_step = env.step(policy(time_step))
            steps += 1
            yield time_step
            if steps >= max_steps_per_episode:
                break


def make_trajectory(domain, task, seed, time_limit=None, **kw):
    task_kwargs = {"random": seed} if time_limit is None else {"random": seed, "time_limit": time_limit}
    env = suite.load(domain, task, task_kwargs=task_kwargs)
    return env, step_environment(env, uniform_random_policy(env.action_spec(), random=seed), **kw)


def test_constants():
    assert len(suite.ALL_TASKS) == sum(len(t) for t in suite.TASKS_BY_DOMAIN.values())
    assert set(suite.TASKS_BY_DOMAIN) == {"otter", "otter_team", "delfim"}
    for task in ("path_following", "station_keeping", "collision_avoidance"):
        assert ("otter", task) in suite.BENCHMARKING and ("otter", task + "_hard") in suite.HARD
    assert set(suite.MULTI_AGENT) == {("otter_team", "formation"), ("otter_team", "formation_hard")}
    assert all(d == "delfim" for d, _ in suite.EXTRA)


def test_load_rejects_unknown_names():
    with pytest.raises(ValueError, match="domain_name"):
        suite.load("cartpole", "swingup")
    with pytest.raises(ValueError, match="task_name"):
        suite.load("otter", "swingup")


@pytest.mark.parametrize("domain,task", ALL)
def test_components_named_cameras_and_spec(domain, task):
    """Every model element named, ≥ 2 cameras, actions in [−1, 1], timesteps conform to the specs."""
    env = suite.load(domain, task, task_kwargs=SHORT)
    model = env.physics.model
    for obj, size in [("body", "nbody"), ("joint", "njnt"), ("geom", "ngeom"), ("site", "nsite"), ("camera", "ncam"),
                      ("light", "nlight"), ("mesh", "nmesh"), ("texture", "ntex"), ("material", "nmat"),
                      ("actuator", "nu"), ("sensor", "nsensor")]:
        for idx in range(getattr(model, size)):
            assert model.id2name(idx, obj) != "", f"unnamed {obj} {idx}"
    assert model.ncam >= 2
    spec = env.action_spec()
    np.testing.assert_array_equal(spec.minimum, -1.0)
    np.testing.assert_array_equal(spec.maximum, 1.0)
    assert spec.shape == (2 * env.physics.n_vessels,)
    obs_spec = env.observation_spec()
    for time_step in step_environment(env, uniform_random_policy(spec, 0), num_episodes=2):
        obs = dict(time_step.observation)
        for name, s in obs_spec.items():
            arr = obs.pop(name)
            assert arr.shape == s.shape and arr.dtype == s.dtype, name
            assert np.all(np.isfinite(arr)), name
        assert not obs
        if time_step.first():
            assert time_step.reward is None and time_step.discount is None
        else:
            assert isinstance(time_step.reward, float) and 0.0 <= time_step.reward <= 1.0
            assert isinstance(time_step.discount, float) and 0.0 <= time_step.discount <= 1.0
    env.close()


@pytest.mark.parametrize("domain,task", ALL)
def test_deterministic_per_seed(domain, task):
    """Same seed, same actions → bit-identical episodes (observations, rewards, discounts)."""
    _, a = make_trajectory(domain, task, seed=0)
    _, b = make_trajectory(domain, task, seed=0)
    n = 0
    for s1, s2 in zip(a, b):
        n += 1
        assert s1.step_type == s2.step_type and s1.reward == s2.reward and s1.discount == s2.discount
        for key in s1.observation:
            np.testing.assert_array_equal(s1.observation[key], s2.observation[key], err_msg=key)
    assert n == 55


@pytest.mark.parametrize("domain,task", ALL)
def test_flat_observation_and_no_aliasing(domain, task):
    env = suite.load(domain, task, task_kwargs=SHORT, environment_kwargs={"flat_observation": True})
    assert set(env.observation_spec()) == {control.FLAT_OBSERVATION_KEY}
    env = suite.load(domain, task, task_kwargs=SHORT)
    first = env.reset()
    second = env.step(np.zeros(env.action_spec().shape))
    for name, arr in first.observation.items():
        assert not np.may_share_memory(arr, second.observation[name]), name


def _noise_free(env):
    d = env.task.difficulty
    env.task.difficulty = dataclasses.replace(d, velocity_noise_m_s=0.0, position_noise_m=0.0,
                                              heading_noise_rad=0.0, range_noise_m=0.0)


@pytest.mark.parametrize("domain,task", ALL)
def test_no_constant_observation_elements(domain, task):
    """As dm_control's check, and with the observation noise switched off: every element of
    every observation (range rays included: the basin walls are always in range) varies."""
    env, trajectory = make_trajectory(domain, task, seed=0, time_limit=6.0, num_episodes=2, max_steps_per_episode=1000)
    _noise_free(env)
    observations = {name: [] for name in env.observation_spec()}
    for time_step in trajectory:
        for name, arr in time_step.observation.items():
            observations[name].append(arr)
    constant = {n: np.flatnonzero(np.all(np.array(a) == a[0], axis=0)) for n, a in observations.items()}
    assert not any(c.size for c in constant.values()), constant


@pytest.mark.parametrize("domain,task", ALL)
def test_initial_state_is_randomized(domain, task):
    env = suite.load(domain, task, task_kwargs={"random": 42, **SHORT})
    _noise_free(env)
    obs1, obs2 = env.reset().observation, env.reset().observation
    assert not all(np.all(obs1[k] == obs2[k]) for k in obs1)


@pytest.mark.parametrize("domain,task", [pytest.param(d, t, id=f"{d}-{t}") for d, t in suite.REWARD_VIZ[:3]])
def test_visualize_reward_colours(domain, task):
    env = suite.load(domain, task, task_kwargs=SHORT, visualize_reward=True)
    colors = env.physics.named.model.mat_rgba
    with mock.patch.object(env.task, "get_reward") as get_reward:
        for value, expected in ((0.5, 0.5), (2.0, 1.0)):
            get_reward.return_value = value
            env.reset() if value == 0.5 else env.step(np.zeros(env.action_spec().shape))
            blend = expected**4
            np.testing.assert_allclose(colors["self"], blend * colors["self_highlight"] + (1 - blend) * colors["self_default"])


# --------------------------------------------------------------------------- the physics is mjasc's
def test_step_is_mjasc_simulation_step():
    """The suite's physics step equals Simulation.step on an identical world, bit for bit, and
    the Simulation's MjData views are the live data of the physics (also after reset and copy)."""
    env = suite.load("otter", "path_following_hard", task_kwargs={"random": 3})
    env.reset()
    physics = env.physics
    assert isinstance(physics, VesselPhysics)
    sim = physics.simulation
    assert sim.data is physics.data.ptr
    assert np.shares_memory(sim._qpos3, physics.data.qpos)  # views, not copies
    world2 = otter.compose_world([("otter", "otter")], domain_xml=otter.XML_PATH)
    twin = Simulation(world2, physics.current_field)
    twin.data.qpos[:] = physics.data.qpos
    twin.data.qvel[:] = physics.data.qvel
    twin.data.act[:] = physics.data.act
    twin.data.time = physics.data.time
    rng = np.random.default_rng(0)
    for _ in range(20):
        action = rng.uniform(-1, 1, 2)
        env.step(action)
        twin.set_commands(action[None, :])
        twin.step(5)
        np.testing.assert_array_equal(physics.data.qpos, twin.data.qpos)
        np.testing.assert_array_equal(physics.data.qvel, twin.data.qvel)
    state = physics.get_state()
    with physics.reset_context():
        physics.set_state(state)
    assert np.shares_memory(physics.simulation._qpos3, physics.data.qpos)
    clone = physics.copy()
    assert clone.simulation.data is clone.data.ptr and clone.simulation.data is not physics.data.ptr
    clone.step(3)
    physics.step(3)
    np.testing.assert_array_equal(clone.data.qpos, physics.data.qpos)


def test_hydrodynamics_act_in_the_suite():
    """Full ahead in still water: the Otter accelerates toward its top speed (3.1 m/s) and no further
    (the linear surge damping X_u balances the bollard pull at U_max, hydrodynamics.toml)."""
    env = suite.load("otter", "station_keeping", task_kwargs={"random": 0, "time_limit": 40.0})
    env.reset()
    env.physics.configure_episode(UniformCurrent((0.0, 0.0)))
    for _ in range(400):
        env.step(np.ones(2))
    u = env.physics.body_velocity(0)[0]
    assert 2.9 < u < 3.15


def test_collision_terminates_episode():
    env = suite.load("otter", "collision_avoidance", task_kwargs={"random": 1})
    env.reset()
    physics = env.physics
    # Aim at the nearest wall point from 6 m away, full ahead: the hull must hit it.
    physics.set_pose(0, 33.0, 0.0, 0.0, surge_m_s=2.0)
    physics.after_reset()
    for _ in range(100):
        time_step = env.step(np.ones(2))
        if time_step.last():
            break
    assert time_step.last() and time_step.discount == 0.0
    assert physics.position(0)[0] < 40.0


def test_range_fan_sees_the_walls_and_traffic():
    env = suite.load("otter", "collision_avoidance", task_kwargs={"random": 5})
    env.reset()
    physics, task = env.physics, env.task
    physics.set_pose(0, 0.0, 0.0, 0.0)
    physics.after_reset()
    mocap = physics.world.mocap_id
    physics.data.mocap_pos[mocap, :2] = 1000.0  # all traffic far outside the basin
    mujoco.mj_kinematics(physics.model.ptr, physics.data.ptr)
    ranges = task.ranges(physics)
    # From the centre of the 80 m basin every ray hits a wall: 40 m ahead (the walls lie outside
    # the basin polygon), 40·√2 m toward a corner (ray 4 of 32 is at 45°).
    assert ranges.shape == (otter.RANGE_RAYS,)
    assert ranges[0] == pytest.approx(40.0, abs=1e-6)
    assert ranges[4] == pytest.approx(40.0 * np.sqrt(2), abs=0.6)
    assert np.all(ranges < otter.RANGE_MAX_M)
    # A traffic boat 10 m dead ahead: the bow ray reads 10 m − its radius.
    physics.data.mocap_pos[mocap[0], :2] = [10.0, 0.0]
    mujoco.mj_kinematics(physics.model.ptr, physics.data.ptr)
    task._cache = {}
    assert task.ranges(physics)[0] == pytest.approx(10.0 - otter.TRAFFIC_RADIUS_M, abs=1e-6)
    assert physics.traffic_positions().shape == (len(physics.world.moving_obstacles), 2)


def test_formation_layout_and_joint_policy():
    env = suite.load("otter_team", "formation", task_kwargs={"random": 0, **SHORT})
    time_step = env.reset()
    assert env.action_spec().shape == (6,)
    a0 = otter_team.agent_observation(time_step.observation, 0)
    assert set(a0) == {"body_velocity", "shaft_speed", "current_body", "slot_error", "leader_velocity",
                       "course_error", "mates"}
    assert a0["mates"].shape == (4,)
    seen = []
    policy = otter_team.joint_policy([lambda o, k=k: (seen.append(k), np.full(2, 0.1 * k))[1] for k in range(3)])
    action = policy(time_step)
    np.testing.assert_allclose(action, [0, 0, 0.1, 0.1, 0.2, 0.2])
    assert seen == [0, 1, 2]
    time_step = env.step(action)
    rewards = env.task.vessel_rewards(env.physics)
    assert rewards.shape == (3,) and time_step.reward == pytest.approx(float(np.mean(rewards)))


# --------------------------------------------------------------------------- dm_env contract
class OtterPathFollowingContract(test_utils.EnvironmentTestMixin, absltest.TestCase):
    def make_object_under_test(self):
        return suite.load("otter", "path_following", task_kwargs={"random": 0, **SHORT})


class OtterCollisionAvoidanceContract(test_utils.EnvironmentTestMixin, absltest.TestCase):
    def make_object_under_test(self):
        return suite.load("otter", "collision_avoidance_hard", task_kwargs={"random": 0, **SHORT})


class FormationContract(test_utils.EnvironmentTestMixin, absltest.TestCase):
    def make_object_under_test(self):
        return suite.load("otter_team", "formation", task_kwargs={"random": 0, **SHORT})


# --------------------------------------------------------------------------- rendering
def test_render_offscreen_and_quiet_exit():
    """physics.render() works offscreen (OSMesa unless MUJOCO_GL says otherwise) from every
    named camera kind, and close() releases the GL context: nothing is printed at exit."""
    script = textwrap.dedent("""
        import mjasc, numpy as np
        from mjasc import suite
        env = suite.load("otter", "collision_avoidance", task_kwargs={"random": 0})
        env.reset()
        env.step(np.zeros(2))
        frames = [env.physics.render(48, 64, camera_id=c) for c in ("basin", "otter/chase", "otter/follow")]
        assert all(f.shape == (48, 64, 3) and f.std() > 0 for f in frames)
        env.close()
        env.close()
        print("ok")
    """)
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "ok"
    assert out.stderr.strip() == "", out.stderr


def test_quiet_exit_without_close():
    """A user who renders and never closes the environment gets a silent exit too (the physics
    frees its GL context from an exit hook that runs before dm_control's render thread stops)."""
    script = textwrap.dedent("""
        import mjasc
        from mjasc import suite
        env = suite.load("otter", "station_keeping", task_kwargs={"random": 0})
        env.reset()
        assert env.physics.render(32, 32, camera_id="basin").shape == (32, 32, 3)
    """)
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and out.stderr.strip() == "", out.stderr
