"""The gymnasium route (optional dependency group ``gym``): shimmy's dm_control wrapper on suite tasks."""

from __future__ import annotations

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")
pytest.importorskip("shimmy")

from gymnasium.utils.env_checker import check_env  # noqa: E402

from mjasc.suite.gym_compat import gym_id, make_gym_env, register_gym_envs  # noqa: E402

SHORT = {"time_limit": 2.0}


def rollout(env, seed, steps=15):
    obs, _ = env.reset(seed=seed)
    out = [obs]
    env.action_space.seed(seed)
    for _ in range(steps):
        obs, reward, terminated, truncated, _ = env.step(env.action_space.sample())
        out.append(obs)
        assert 0.0 <= reward <= 1.0
        if terminated or truncated:
            break
    return out


@pytest.mark.filterwarnings("ignore:.*Box observation space (minimum|maximum) value is:UserWarning")
@pytest.mark.parametrize("domain,task", [("otter", "collision_avoidance"), ("otter_team", "formation")])
def test_gymnasium_env_checker_passes(domain, task):
    env = make_gym_env(domain, task, task_kwargs=SHORT)
    check_env(env, skip_render_check=True)
    env.close()


def test_seeding_reproduces_episodes():
    env = make_gym_env("otter", "path_following_hard", task_kwargs=SHORT)
    a, b, c = rollout(env, 7), rollout(env, 7), rollout(env, 8)
    for oa, ob in zip(a, b):
        for key in oa:
            np.testing.assert_array_equal(oa[key], ob[key])
    assert not np.array_equal(a[0]["path_error"], c[0]["path_error"])
    env.close()


def test_time_limit_truncates_and_flatten_wrapper():
    env = gymnasium.wrappers.FlattenObservation(make_gym_env("otter", "station_keeping", task_kwargs=SHORT))
    obs, _ = env.reset(seed=0)
    assert obs.shape == env.observation_space.shape == (11,)
    for k in range(100):
        obs, _, terminated, truncated, _ = env.step(np.zeros(2))
        if terminated or truncated:
            break
    assert truncated and not terminated and k == 19  # 2 s at 0.1 s per step
    env.close()


def test_registered_ids_and_rgb_render():
    ids = register_gym_envs()
    assert gym_id("otter", "path_following") in ids and register_gym_envs() == ids
    env = gymnasium.make(gym_id("otter", "path_following"), task_kwargs=SHORT, render_mode="rgb_array",
                         render_kwargs={"camera_id": "otter/chase", "height": 48, "width": 64})
    env.reset(seed=0)
    frame = env.render()
    assert frame.shape == (48, 64, 3) and frame.dtype == np.uint8
    env.close()
