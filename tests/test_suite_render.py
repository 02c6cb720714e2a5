"""render_episode: an MP4 with one frame per control step and a readable Rerun recording."""

from __future__ import annotations

import imageio.v3 as iio
import numpy as np
import pytest
import rerun as rr

from mjasc.suite.render import render_episode


def test_callable_policy_renders_video_and_recording(tmp_path):
    calls = []

    def full_ahead(time_step):
        calls.append(time_step.step_type)
        return np.ones(2)

    out = render_episode("otter", "station_keeping", policy=full_ahead, out_dir=tmp_path, seed=3,
                         task_kwargs={"time_limit": 1.0}, width=96, height=64)
    assert out.steps == 10 and len(calls) == 10 and not out.terminated
    assert out.video_path.name == "otter-station_keeping-full_ahead-seed3.mp4"
    frames = iio.imread(out.video_path)
    assert frames.shape == (11, 64, 96, 3)  # the reset frame + one per control step
    assert frames[-1].std() > 0
    store = rr.chunk.RrdReader(str(out.rerun_path)).store()
    paths = {str(p) for p in store.schema().entity_paths()}
    assert {"/world/vessels/otter", "/plots/reward/reward", "/plots/commands/otter_port"} <= paths


def test_baseline_team_episode_matches_its_return(tmp_path):
    from mjasc import suite
    from mjasc.suite.baselines import baseline_policy, episode_return

    calls = []
    out = render_episode("otter_team", "formation", policy="baseline", out_dir=tmp_path, seed=1,
                         task_kwargs={"time_limit": 1.0}, video=False, progress=lambda *a: calls.append(a))
    assert out.video_path is None and out.rerun_path.exists()
    limit = out.steps  # the episode runs to its limit: progress every tenth of it, not at the end
    every = max(limit // 10, 1)
    assert calls and calls == [(k, limit) for k in range(every, limit, every)]
    env = suite.load("otter_team", "formation", task_kwargs={"random": 1, "time_limit": 1.0})
    total, steps = episode_return(env, baseline_policy(env))
    assert (out.episode_return, out.steps) == (total, steps)


def test_bad_arguments(tmp_path):
    with pytest.raises(ValueError, match="policy"):
        render_episode("otter", "path_following", policy="greedy", out_dir=tmp_path, task_kwargs={"time_limit": 0.2})
    with pytest.raises(ValueError, match="width/height"):
        render_episode("otter", "path_following", out_dir=tmp_path, width=95)
