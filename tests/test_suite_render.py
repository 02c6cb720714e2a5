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


def test_the_hud_lines_name_the_policy_the_reward_and_the_return():
    from mjasc.suite.render_hud import hud_lines

    def full_ahead(time_step):
        return np.ones(2)

    assert hud_lines("baseline", 0, None, 0.0) == ["policy baseline · seed 0", "reward - · return 0.00"]
    assert hud_lines(full_ahead, 3, 0.5, 1.254) == ["policy full_ahead · seed 3", "reward +0.500 · return 1.25"]


def _recording_policy(log):
    def steady(time_step):
        log.append((time_step.reward, {k: np.array(v) for k, v in time_step.observation.items()}))
        return np.array([0.8, 0.6])
    return steady


def test_the_hud_is_drawn_on_the_frames_only_and_says_the_task_s_state(tmp_path, monkeypatch):
    """Path following (its HUD reads the task's cross-track error): the frames with the HUD show its
    dark top-left box where the plain frames show water, name the vessel, its policy, reward and
    return and the task's legend, and the episode is bit-identical; the same seed gives the same
    video bytes."""
    import mjasc.runs.video as video

    shown = []
    draw = video.draw_hud

    def spy(image, view, *a, **k):
        shown.append((view.lines, [v.name for v in view.vessels], [v.mode for v in view.vessels], view.legend))
        return draw(image, view, *a, **k)

    monkeypatch.setattr(video, "draw_hud", spy)
    runs = {}
    for name, hud in (("plain", False), ("hud", True), ("again", True)):
        log = []
        out = render_episode("otter", "path_following", policy=_recording_policy(log), out_dir=tmp_path / name,
                             seed=2, task_kwargs={"time_limit": 0.3}, width=320, height=240, rerun=False, hud=hud)
        runs[name] = (out, log, iio.imread(out.video_path).astype(int))
    (plain, plain_log, plain_frames), (out, log, frames) = runs["plain"], runs["hud"]
    assert (out.episode_return, out.steps) == (plain.episode_return, plain.steps)
    for (r0, o0), (r1, o1) in zip(plain_log, log, strict=True):
        assert r0 == r1 and o0.keys() == o1.keys() and all(np.array_equal(o0[k], o1[k]) for k in o0)
    assert out.video_path.read_bytes() == runs["again"][0].video_path.read_bytes()
    # The title box (top left, black at 55 % over the water) darkens the plain frame's water there,
    # and its white text shows in it.
    box = np.s_[:, 8:40, 8:120]
    assert np.median(frames[box]) < np.median(plain_frames[box]) - 25
    assert (frames[box].min(axis=-1) > 200).mean() > 0.02 and (plain_frames[box].min(axis=-1) > 200).mean() == 0
    assert len(shown) == 2 * (out.steps + 1)  # the HUD runs' frames only, not the plain one's
    lines, names, modes, legend = shown[out.steps]  # the first HUD run's last frame
    assert lines[0] == "policy steady · seed 2"
    assert lines[1].startswith("reward +") and lines[1].endswith(f" · return {out.episode_return:.2f}")
    assert shown[0][0][1] == "reward - · return 0.00"  # the reset frame: no reward yet
    assert names == ["otter"] and "m/s · cross-track" in modes[0]
    assert [text for _, _, text in legend][0] == "path to follow"


def test_a_policy_that_fails_midway_leaves_no_video_or_recording(tmp_path):
    """Nothing half-written: the episode's files are written under temporary names and removed
    when the episode does not finish (the exception goes on); a finished episode renames them."""
    steps = []

    def breaks_at_step_5(time_step):
        steps.append(1)
        if len(steps) == 5:
            raise RuntimeError("policy broke")
        return np.ones(2)

    with pytest.raises(RuntimeError, match="policy broke"):
        render_episode("otter", "station_keeping", policy=breaks_at_step_5, out_dir=tmp_path, seed=3,
                       task_kwargs={"time_limit": 1.0}, width=96, height=64)
    assert len(steps) == 5 and sorted(p.name for p in tmp_path.iterdir()) == []
