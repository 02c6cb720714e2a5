"""The suite's settings as an RL user passes them: environment_kwargs and task_kwargs values that
dm_control accepted silently (and broke the episode) or rejected with an error naming no key."""

from __future__ import annotations

import numpy as np
import pytest

from mjasc import suite
from mjasc.suite import otter_team


@pytest.mark.parametrize("environment_kwargs,match", [
    # n_sub_steps = 0 divided by zero; -1 ran episodes whose time never advanced; 2.5 / "5" / True
    # were a TypeError deep in dm_control or a silent 1-step control period.
    ({"n_sub_steps": 0}, r"environment_kwargs: n_sub_steps must be an integer >= 1, got 0"),
    ({"n_sub_steps": -1}, r"n_sub_steps must be an integer >= 1, got -1"),
    ({"n_sub_steps": 2.5}, r"n_sub_steps must be an integer >= 1, got 2.5"),
    ({"n_sub_steps": "5"}, r"n_sub_steps must be an integer >= 1, got '5'"),
    ({"n_sub_steps": True}, r"n_sub_steps must be an integer >= 1, got True"),
    ({"control_timestep": "0.1"}, r"environment_kwargs: control_timestep must be a multiple of the physics step"),
    ({"control_timestep": float("nan")}, r"control_timestep must be a multiple of the physics step \(0.02 s\)"),
    ({"control_timestep": 0.0}, r"control_timestep must be a multiple of the physics step \(0.02 s\).*got 0.0"),
    ({"control_timestep": 0.05}, r"control_timestep must be a multiple of the physics step \(0.02 s\).*got 0.05"),
    ({"control_timestep": 0.1, "n_sub_steps": 5}, r"environment_kwargs: give control_timestep or n_sub_steps"),
    ({"flat_observation": "yes"}, r"environment_kwargs: flat_observation must be True or False, got 'yes'"),
    ({"legacy_step": 1}, r"environment_kwargs: legacy_step must be True or False, got 1"),
])
def test_bad_environment_kwargs_are_one_line_errors_naming_the_key(environment_kwargs, match):
    with pytest.raises(ValueError, match=match) as info:
        suite.load("otter", "station_keeping", task_kwargs={"random": 0}, environment_kwargs=environment_kwargs)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("key", ["control_timestep", "n_sub_steps"])
def test_none_control_step_keeps_the_default(key):
    """``control_timestep: null`` (a config file's "not set") used to give dm_control's own default,
    one physics step (0.02 s, 5x the steps per episode), instead of the suite's 0.1 s."""
    env = suite.load("otter", "station_keeping", task_kwargs={"random": 0}, environment_kwargs={key: None})
    assert env.control_timestep() == pytest.approx(0.1) and env.step_limit == pytest.approx(400.0)


def test_good_environment_kwargs_still_work():
    env = suite.load("otter", "station_keeping", task_kwargs={"random": 0, "time_limit": 1.0},
                     environment_kwargs={"n_sub_steps": np.int64(10), "flat_observation": np.True_,
                                         "legacy_step": True})
    assert env.control_timestep() == pytest.approx(0.2) and env.step_limit == pytest.approx(5.0)
    env = suite.load("otter", "station_keeping", environment_kwargs={"control_timestep": 0.04})
    assert env.control_timestep() == pytest.approx(0.04)


@pytest.mark.parametrize("seed", [-1, 2 ** 32])
def test_out_of_range_seed_names_the_key(seed):
    """numpy's "Seed must be between 0 and 2**32 - 1" named neither the key nor the value."""
    with pytest.raises(ValueError, match=rf"task_kwargs: random must be .* in \[0, 2\*\*32 - 1\], got {seed}"):
        suite.load("otter", "station_keeping", task_kwargs={"random": seed})


def test_joint_policy_takes_a_gymnasium_observation():
    """A gymnasium user has observation dicts, not dm_env TimeSteps: joint_policy takes either."""
    env = suite.load("otter_team", "formation", task_kwargs={"random": 0})
    time_step = env.reset()
    policy = otter_team.joint_policy([lambda o, k=k: np.full(2, 0.1 * k) for k in range(3)])
    expected = np.repeat([0.0, 0.1, 0.2], 2)
    np.testing.assert_allclose(policy(time_step), expected)
    np.testing.assert_allclose(policy(dict(sorted(time_step.observation.items()))), expected)


def test_render_names_the_vessels_when_a_chase_camera_is_missing(tmp_path, capsys):
    """With --vessel the vessel is named after its hull: "chase:otter" then used to fail with
    "no camera 'otter/chase' in the model" and no word of the name to use instead."""
    from mjasc.cli import main
    out = tmp_path / "r"
    assert main(["render", "otter", "path_following", "--vessel", "delfim", "--camera", "chase:otter",
                 "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "no camera 'otter/chase' in the model (its vessels: delfim)" in err and not out.exists()


@pytest.mark.parametrize("domain,task,shape", [("otter", "station_keeping", (1,)), ("otter", "station_keeping", (1, 2)),
                                               ("otter", "station_keeping", ()), ("otter_team", "formation", (1, 6))])
def test_an_action_of_the_wrong_shape_is_an_error(domain, task, shape):
    """np.copyto broadcast these into ctrl: (1,) drove both propellers with one command, (1, 2) a
    batch of one passed unnoticed."""
    env = suite.load(domain, task, task_kwargs={"random": 0})
    env.reset()
    with pytest.raises(ValueError, match=rf"action: must have shape \({env.action_spec().shape[0]},\)"):
        env.step(np.full(shape, 0.5))
    env.step(np.full(env.action_spec().shape, 0.5))


def test_a_nan_action_is_an_error_before_the_step():
    """MuJoCo took a NaN control for 0, stepped, then raised its own "simulation is unstable" error:
    the episode lost a step's reward and ended 0.1 s late (a user's review). ±inf act as ±1."""
    env = suite.load("otter", "station_keeping", task_kwargs={"random": 0})
    env.reset()
    with pytest.raises(ValueError, match=r"^action: must not be NaN, got \[nan, 0\.0\]$"):
        env.step(np.array([np.nan, 0.0]))
    assert env.physics.data.time == 0.0
    inf = env.step(np.array([np.inf, -np.inf]))
    env2 = suite.load("otter", "station_keeping", task_kwargs={"random": 0})
    env2.reset()
    one = env2.step(np.array([1.0, -1.0]))
    assert inf.reward == one.reward and all(np.array_equal(inf.observation[k], one.observation[k])
                                            for k in one.observation)


def test_the_hard_station_is_held_bow_into_the_mean_current():
    """The Gauss-Markov current's value at t = 0 holds a fluctuation of σ = 0.08 m/s: the rewarded
    heading was up to 23° off "bow into the current" (a user's review). It is into the mean now."""
    from mjasc.core.frames import wrap_angle
    off = []
    for seed in range(8):
        env = suite.load("otter", "station_keeping_hard", task_kwargs={"random": seed})
        env.reset()
        mean = env.physics._current.mean_velocity_m_s
        into = np.arctan2(-mean[1], -mean[0])
        off.append(abs(float(wrap_angle(env.task.station_heading_rad - into))))
        assert not np.allclose(env.physics._current.velocity(np.zeros((1, 2)), 0.0)[0], mean)  # (it fluctuates)
    assert max(off) < 1e-12


@pytest.mark.parametrize("name", ["otter.v2", "my boat", "obstacle_boat"])
def test_a_hull_whose_name_cannot_name_a_vessel_is_a_vessel_key_error(tmp_path, name):
    """A folder that passed the contract but whose name the model rejects used to fail later with
    "vessels: invalid vessel name 'otter.v20'" (in otter_team: a name the user never wrote)."""
    from mjasc.physics.vessels import VESSELS_DIR
    from tests.test_own_hull import copy_vessel
    copy = copy_vessel(VESSELS_DIR / "otter", tmp_path / "hulls" / name)
    for domain, task in (("otter", "station_keeping"), ("otter_team", "formation")):
        with pytest.raises(ValueError, match=rf"^task_kwargs\.vessel: the hull's name '{name}' \(its folder's\) must "
                                             r"be letters, digits, '_' or '-'.*, got '.*hulls/"):
            suite.load(domain, task, task_kwargs={"vessel": str(copy)})


def test_mjasc_render_takes_the_pixel_cameras(tmp_path, monkeypatch, capsys):
    """render_episode renders the suite's basin, <vessel>/follow and <vessel>/heading_up views
    (docs/suite.md), but `mjasc render --camera basin` / `follow:otter` / `heading_up:otter` were
    refused as not a scenario camera."""
    import mjasc.suite.render as render
    from mjasc.cli import main

    seen = []

    def fake(domain, task, **kw):
        seen.append(kw["camera"])
        raise ValueError("stop here")
    monkeypatch.setattr(render, "render_episode", fake)
    for camera in ("basin", "follow:otter", "heading_up:otter", "chase:otter", "top_down"):
        assert main(["render", "otter", "station_keeping", "--camera", camera, "--out", str(tmp_path / "r")]) == 2
    assert seen == ["basin", "otter/follow", "otter/heading_up", "chase:otter", "top_down"]
    capsys.readouterr()
    assert main(["render", "otter", "station_keeping", "--camera", "side", "--out", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("mjasc: render --camera: must be top_down") and "basin, follow:<vessel>, heading_up" in err
    assert err.count("\n") == 1 and len(seen) == 5


def test_a_collision_on_the_last_step_ends_with_discount_zero():
    """dm_control's Environment gives discount 1 at the time limit without asking the task, so a
    vessel that hit the wall on the episode's last step was "truncated" (gymnasium: truncated,
    not terminated) and a learner bootstrapped through the crash. Full ahead in seed 1 of
    collision_avoidance touches at step 151: with a time limit of 15.1 s that is the last step."""
    def last(time_limit):
        env = suite.load("otter", "collision_avoidance", task_kwargs={"random": 1, "time_limit": time_limit})
        time_step, steps = env.reset(), 0
        while not time_step.last():
            time_step, steps = env.step(np.ones(2)), steps + 1
        return steps, time_step.discount
    assert last(80.0) == (151, 0.0)
    assert last(15.1) == (151, 0.0)
    assert last(15.0) == (150, 1.0)  # (the time limit one step before the contact: truncated)


def test_a_frame_larger_than_the_offscreen_buffer_is_a_one_line_error():
    """Enlarging the buffer after the first render (docs/suite.md: before it) used to render the
    frame black beyond the old width, silently; before any render the larger buffer works."""
    env = suite.load("otter", "station_keeping", task_kwargs={"random": 0})
    env.reset()
    with pytest.raises(ValueError, match=r"^render: 1400x84 is larger than the offscreen buffer, 1280x720; set "):
        env.physics.render(84, 1400, camera_id="basin")
    env.physics.render(84, 84, camera_id="basin")
    env.physics.model.vis.global_.offwidth = 1400
    with pytest.raises(ValueError, match=r"^render: 1400x84 is larger than the offscreen buffer, 1280x720;") as info:
        env.physics.render(height=84, width=1400, camera_id="basin")
    assert "\n" not in str(info.value)
    env.close()
    env = suite.load("otter", "station_keeping", task_kwargs={"random": 0})
    env.reset()
    env.physics.model.vis.global_.offwidth = 1400
    frame = env.physics.render(84, 1400, camera_id="basin")
    assert frame.shape == (84, 1400, 3) and frame[:, 1300:].mean() > 50  # (water, not black)
    env.close()


def test_agent_observation_has_the_spec_order_also_from_a_gymnasium_dict():
    """gymnasium's Dict sorts its keys, so agent_observation of a gymnasium observation came out
    alphabetically (body_velocity, course_error, current_body, ...): a per-vessel policy that
    concatenates the values got them in another order than on the dm_env route."""
    env = suite.load("otter_team", "formation", task_kwargs={"random": 0})
    observation = env.reset().observation
    shuffled = dict(sorted(observation.items()))
    for i in range(3):
        a, b = otter_team.agent_observation(observation, i), otter_team.agent_observation(shuffled, i)
        assert list(a) == list(b) == ["body_velocity", "shaft_speed", "current_body", "slot_error",
                                      "leader_velocity", "course_error", "mates"]
        assert all(a[k] is b[k] for k in a)


def test_render_episode_refuses_an_endless_episode_before_writing(tmp_path):
    """time_limit=inf used to stop with "OverflowError: cannot convert float infinity to integer"
    after the video file was opened, leaving a broken MP4 behind."""
    from mjasc.suite.render import render_episode
    with pytest.raises(ValueError, match=r"^task_kwargs: time_limit must be finite to render an episode, got inf$"):
        render_episode("otter", "station_keeping", out_dir=tmp_path / "r", task_kwargs={"time_limit": float("inf")})
    assert not list(tmp_path.rglob("*.mp4"))


def test_the_cas_baseline_keeps_its_perception_rate_with_a_shorter_control_step():
    """The CAS sensed and tracked at every control step: at 0.04 s (25 Hz) its map and tracks,
    tuned in scans, filled up and the vessel yielded and crawled (59 m from the goal after 20 s,
    against 43 m at the default 0.1 s step). Its perception now keeps 10 Hz."""
    from mjasc.suite.baselines import make_policy

    def goal_distance(environment_kwargs):
        env = suite.load("otter", "collision_avoidance", task_kwargs={"random": 0, "time_limit": 20.0},
                         environment_kwargs=environment_kwargs)
        policy, time_step = make_policy(env, "cas"), env.reset()
        while not time_step.last():
            time_step = env.step(policy(time_step))
        return float(time_step.observation["goal_distance"][0])
    assert goal_distance({"n_sub_steps": 2}) == pytest.approx(goal_distance(None), abs=2.0)


@pytest.mark.parametrize("domain, task, name", [("otter_team", "formation", "formation"),
                                                ("otter", "path_following_hard", "path_following"),
                                                ("delfim", "station_keeping", "station_keeping")])
def test_a_collision_avoidance_policy_on_another_task_names_the_task_as_the_suite_does(domain, task, name):
    """It said 'not Formation' / 'not PathFollowing' (the class names)."""
    from mjasc.suite.baselines import CASPolicy, goal_line_policy

    env = suite.load(domain, task, task_kwargs={"random": 0})
    with pytest.raises(ValueError, match=rf"^env: the CAS policy is for the collision_avoidance tasks, not {name}$"):
        CASPolicy(env)
    with pytest.raises(ValueError, match=rf"^env: the goal-line policy is for the collision_avoidance tasks, "
                                         rf"not {name}$"):
        goal_line_policy(env)
    env.close()
