"""The gymnasium route (optional dependency group ``gym``): shimmy's dm_control wrapper on suite tasks."""

from __future__ import annotations

import warnings

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


@pytest.mark.parametrize("domain,task", [("otter", "collision_avoidance"), ("otter_team", "formation")])
def test_gymnasium_env_checker_passes(domain, task):
    """check_env passes; its only warnings are the infinite-bound ones, and exactly one per Box whose
    spec is unbounded (noisy velocities, positions): BoundedArray specs become finite Boxes."""
    env = make_gym_env(domain, task, task_kwargs=SHORT)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env, skip_render_check=True)
    messages = [str(w.message) for w in caught]
    spaces = env.observation_space.spaces
    unbounded_low = sum(bool(np.any(np.isneginf(b.low))) for b in spaces.values())
    unbounded_high = sum(bool(np.any(np.isposinf(b.high))) for b in spaces.values())
    assert sum("minimum value is -infinity" in m for m in messages) == unbounded_low
    assert sum("maximum value is infinity" in m for m in messages) == unbounded_high
    assert all("infinity" in m for m in messages), messages
    bounded = [k for k, b in spaces.items() if np.all(np.isfinite(b.low)) and np.all(np.isfinite(b.high))]
    expected = {"otter": {"shaft_speed", "goal_direction", "ranges"},
                "otter_team": {f"otter{i}_{k}" for i in range(3) for k in ("shaft_speed", "course_error")}}[domain]
    assert set(bounded) == expected
    if domain == "otter":
        np.testing.assert_array_equal(spaces["ranges"].low, 0.0)
        np.testing.assert_array_equal(spaces["ranges"].high, 1.0)
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
