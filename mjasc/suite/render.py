"""Render one episode of any suite task to an MP4 video and a Rerun recording.

``render_episode("otter", "collision_avoidance", policy="baseline", out_dir="out", seed=0)`` runs
one seeded episode with a random policy, the task's classical baseline
(:mod:`mjasc.suite.baselines`) or a user's callable ``time_step → action``, and writes

* ``<domain>-<task>-<policy>-seed<seed>.mp4`` (``<domain>-<task>-<hull>-…`` when ``task_kwargs``
  name a ``vessel``): one frame per control step (10 fps, real time),
  MuJoCo's offscreen renderer (OSMesa unless ``MUJOCO_GL`` says otherwise) through
  :class:`mjasc.runs.video.VideoWriter`; the default ``top_down`` view is fitted to the task's area
  with the path / lanes / route drawn in, vessel arrows and trails; any model camera works too
  (``"basin"``, ``"otter/chase"``, ``"otter/follow"``, ``"overview"``). With ``hud`` (default) the
  scenario videos' heads-up display is drawn on each frame (:mod:`mjasc.suite.render_hud`): task
  and time, policy and seed, the step's reward and the return so far, per vessel its colour, name,
  speed and task error, the names by the hulls, scale, north, the current and the task's legend.
  It is drawn on the image only: the episode (observations, rewards, the recording) is the same;
* ``….rrd``: the same episode for Rerun (:class:`mjasc.runs.recording.Recorder`): vessel and traffic
  positions and headings, the task geometry, reward and propeller commands over ``sim_time``.

World ENU, SI units. Returns an :class:`EpisodeRender` with the paths, the return and the length.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import rerun as rr

from mjasc.core.geometry import circle_polygon
from mjasc.runs.recording import Recorder, vessel_colour
from mjasc.runs.video import VideoWriter
from mjasc.suite import load
from mjasc.suite.baselines import make_policy
from mjasc.suite.otter import CollisionAvoidance, PathFollowing, StationKeeping
from mjasc.suite.otter_team import Formation
from mjasc.suite.render_hud import hud_lines, task_legend, vessel_modes

__all__ = ["EpisodeRender", "render_episode"]



@dataclass(frozen=True)
class EpisodeRender:
    """What :func:`render_episode` wrote and how the episode went."""

    video_path: Path | None
    rerun_path: Path | None
    episode_return: float
    steps: int
    terminated: bool  # ended by the task (a collision), not by the time limit


def _task_lines(task, duration_s: float) -> list[np.ndarray]:
    """Polylines (k, 2) of the task's geometry for this episode: path, lanes, route, station."""
    if isinstance(task, PathFollowing):
        return [task.path.sub_path(0.0, min(task.path.length, 1.3 * task.speed_ref_m_s * duration_s + 20.0)).sample(1.0)]
    if isinstance(task, Formation):
        reach = task.speed_ref_m_s * duration_s + 20.0
        return [lane.sub_path(0.0, min(lane.length, 30.0 + reach)).sample(2.0) for lane in task.lanes]
    if isinstance(task, CollisionAvoidance):
        return [np.array([task.start_m, task.goal_m])]
    if isinstance(task, StationKeeping):
        return [circle_polygon(task.station_m, 1.0, 32, circumscribed=False, closed=True)]
    return []


def episode_blueprint(extent_m: float):
    """Rerun layout of a suite episode: the top-down world view on the left; the reward and the
    propeller commands over time and the event log on the right."""
    import rerun.blueprint as rrb

    top = rrb.Spatial3DView(
        origin="world", name="Top-down (ENU, y north up)",
        eye_controls=rrb.EyeControls3D(position=(0.0, -0.01 * extent_m, 1.6 * extent_m), look_target=(0.0, 0.0, 0.0),
                                        eye_up=(0.0, 1.0, 0.0)),
        line_grid=rrb.LineGrid3D(visible=True, spacing=10.0, plane=rr.components.Plane3D.XY))
    series = [rrb.TimeSeriesView(origin="plots/reward", name="reward"),
              rrb.TimeSeriesView(origin="plots/commands", name="propeller commands")]
    return rrb.Blueprint(rrb.Horizontal(top, rrb.Vertical(*series, rrb.TextLogView(origin="events", name="events")),
                                        column_shares=[3, 2]),
                         rrb.TimePanel(state="collapsed"), collapse_panels=False)


def _extent(lines, positions, margin_m: float = 10.0):
    pts = np.concatenate([*lines, positions]) if lines else positions
    return pts.min(axis=0) - margin_m, pts.max(axis=0) + margin_m


def _policy_name(policy) -> str:
    if isinstance(policy, str):
        return policy.replace(":", "_")
    return re.sub(r"[^A-Za-z0-9_]+", "_", getattr(policy, "__name__", "policy")).strip("_") or "policy"


def render_episode(domain: str, task: str, policy="random", out_dir="out", seed: int = 0, *, task_kwargs=None,
                   camera: str = "top_down", width: int = 640, height: int = 360, video: bool = True,
                   rerun: bool = True, hud: bool = True, progress=None) -> EpisodeRender:
    """Run and render one episode of ``domain``/``task`` (see the module docstring).

    ``policy``: ``"random"``, ``"baseline"`` or a callable ``time_step → action`` (a dm_env
    TimeStep in, an action array of the action spec's shape out). ``task_kwargs`` are passed to
    :func:`mjasc.suite.load` (``random`` is set from ``seed``; ``time_limit`` shortens episodes;
    ``vessel`` sails another hull, whose name then joins the files' names and the title).
    ``progress``: called as ``progress(steps_done, step_limit)`` after every tenth of the episode.
    ``hud``: draw the heads-up display on the video's frames (False: the plain scene).
    """
    if not (video or rerun):
        raise ValueError("video/rerun: at least one output must be enabled")
    if width <= 0 or height <= 0 or width % 2 or height % 2:
        raise ValueError(f"width/height: must be positive and even (H.264), got {width}×{height}")
    time_limit = (task_kwargs or {}).get("time_limit")
    if time_limit is not None and time_limit == float("inf"):  # (it overflowed midway, leaving a broken video)
        raise ValueError(f"task_kwargs: time_limit must be finite to render an episode, got {time_limit!r}")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    kwargs = dict(task_kwargs or {})
    kwargs["random"] = int(seed)
    env = load(domain, task, task_kwargs=kwargs)
    hull = f"-{env.task.vessel.name}" if kwargs.get("vessel") is not None else ""
    stem = f"{domain}-{task}{hull}-{_policy_name(policy)}-seed{seed}"
    writer = recorder = None
    try:
        act = make_policy(env, policy, seed=int(seed))
        time_step = env.reset()
        physics, task_obj = env.physics, env.task
        n = physics.n_vessels
        duration = float(env.step_limit) * env.control_timestep()
        lines = _task_lines(task_obj, duration)
        positions = np.array([physics.position(i) for i in range(n)])
        lo, hi = _extent(lines, positions)
        colours = [tuple(c / 255 for c in vessel_colour(i)) + (1.0,) for i in range(n)]
        if video:
            writer = VideoWriter(out_dir / f"{stem}.mp4", physics.model.ptr, width, height,
                                 fps=1.0 / env.control_timestep(), camera=camera, extent_xy=(lo, hi), overlays=lines,
                                 title=f"{domain}/{task}" + (f" ({env.task.vessel.name})" if hull else ""),
                                 chase_title="{vessel}: chase view",
                                 vessel_colours=[(name, vessel_colour(i)) for i, name in
                                                 enumerate(physics.world.vessel_names)])
        if rerun:
            extent = float(np.max(hi - lo))
            recorder = Recorder(out_dir / f"{stem}.rrd", stem, int(seed),
                                blueprint=episode_blueprint(extent))
            for k, line in enumerate(lines):
                recorder.static(f"world/task/line{k}", rr.LineStrips3D([np.column_stack([line, np.zeros(len(line))])],
                                                                       colors=[(255, 255, 255)]))
            recorder.series_style("plots/reward/reward", "reward", (44, 160, 44))
        trails = [[p] for p in positions]
        legend = task_legend(task_obj, physics, (lo, hi))
        centre = (0.5 * (lo + hi))[None, :]  # the current at the framed view's centre
        total, steps = 0.0, 0

        def record(time_step, action):
            t = float(physics.data.time)
            pos = np.array([physics.position(i) for i in range(n)])
            heads = np.array([physics.heading(i) for i in range(n)])
            for i in range(n):
                trails[i].append(pos[i])
            if writer is not None:
                shown = dict(names=physics.world.vessel_names, modes=vessel_modes(task_obj, physics),
                             lines=hud_lines(policy, seed, time_step.reward, total), legend=legend,
                             current_m_s=physics.current_field.velocity(centre, t)[0]) if hud else {}
                writer.add_frame(physics.data.ptr,
                                 markers=[(pos[i], heads[i], colours[i]) for i in range(n)],
                                 trails=[(np.array(trails[i][-300:]), colours[i]) for i in range(n)], hud=hud,
                                 **shown)
            if recorder is not None:
                names = physics.world.vessel_names
                for i, name in enumerate(names):
                    recorder.points(f"world/vessels/{name}", t, pos[i:i + 1])
                    recorder.arrows(f"world/vessels/{name}/heading", t, pos[i:i + 1],
                                    3.0 * np.array([[np.cos(heads[i]), np.sin(heads[i])]]))
                    if action is not None:
                        recorder.scalar(f"plots/commands/{name}_port", t, action[2 * i])
                        recorder.scalar(f"plots/commands/{name}_starboard", t, action[2 * i + 1])
                if len(physics.world.moving_obstacles):
                    recorder.points("world/traffic", t, physics.traffic_positions())
                if time_step.reward is not None:
                    recorder.scalar("plots/reward/reward", t, time_step.reward)

        record(time_step, None)
        limit = int(env.step_limit)
        every = max(limit // 10, 1)
        while not time_step.last():
            action = np.asarray(act(time_step), dtype=float)
            time_step = env.step(action)
            total += time_step.reward
            steps += 1
            record(time_step, action)
            if progress is not None and steps % every == 0 and steps < limit:
                progress(steps, limit)
        terminated = time_step.discount == 0.0
        if recorder is not None:
            recorder.event(float(physics.data.time), f"episode end: return {total:.2f} over {steps} steps"
                           + (" (collision)" if terminated else ""), level="WARN" if terminated else "INFO")
    except BaseException:  # (a policy that raises, Ctrl-C: no half an episode under the final names)
        if writer is not None:
            writer.discard()
        if recorder is not None:
            recorder.discard()
        raise
    else:
        if writer is not None:
            writer.close()
        if recorder is not None:
            recorder.close()
    finally:
        env.close()
    return EpisodeRender(writer.path if writer is not None else None, recorder.path if recorder is not None else None,
                         float(total), steps, bool(terminated))
