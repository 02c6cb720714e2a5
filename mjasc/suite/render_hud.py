"""What the heads-up display of a suite episode's video says (:mod:`mjasc.suite.render`).

The frames are drawn by the scenario videos' own overlay (:mod:`mjasc.runs.video_hud`); this module
only supplies its text and legend, read from the physics and the task after each step (nothing
here changes the episode: the observations and rewards are those of a plain render):

- under the title ``<domain>/<task>  t = …`` the policy and the seed, then the step's reward
  and the return so far (:func:`hud_lines`; the font has no Σ);
- per vessel (in its palette colour, named as in the model) its speed over ground and what matters
  to the task (:func:`vessel_modes`): its cross-track error (path following), its distance to the
  station and its heading error (station keeping), its distance to the goal (collision
  avoidance), its distance to its slot (formation);
- the legend (:func:`task_legend`): the task's geometry as the frame draws it — the path, the
  route from start to goal, the station's 1 m circle or the lanes in the overlay's light blue,
  the target site (the goal, the station with its heading bar, the path's or the leader's end) —
  and the traffic and the basin's walls where the task has them.
"""

from __future__ import annotations

import numpy as np

from mjasc.core.frames import wrap_angle
from mjasc.runs.video_hud import STRUCTURE_SWATCH, TRAFFIC_RGBA
from mjasc.runs.video_scene import COLOURS
from mjasc.suite.otter import CollisionAvoidance, PathFollowing, StationKeeping
from mjasc.suite.otter_team import Formation

__all__ = ["hud_lines", "vessel_modes", "task_legend", "policy_label", "TARGET_RGBA"]

#: The target site's colour as rendered on the water from above (mjasc/suite/otter.xml, material
#: ``target``: 0.6 0.3 0.3, half transparent, lit), RGBA 0–1, for the legend's swatch.
TARGET_RGBA = (175 / 255, 102 / 255, 113 / 255, 1.0)


def policy_label(policy) -> str:
    """The policy as the HUD names it: its name (``baseline``, ``cas:vo`` …) or the callable's."""
    return policy if isinstance(policy, str) else getattr(policy, "__name__", type(policy).__name__)


def hud_lines(policy, seed: int, reward, episode_return: float) -> list[str]:
    """The rows under the title: the policy and seed, the step's reward and the return so far
    (before the first step: no reward yet, ``reward -``)."""
    r = "-" if reward is None else f"{float(reward):+.3f}"
    return [f"policy {policy_label(policy)} · seed {int(seed)}", f"reward {r} · return {float(episode_return):.2f}"]


def vessel_modes(task, physics) -> list[str]:
    """Per vessel: its speed over ground and its task error (see the module docstring)."""
    out = []
    for i in range(physics.n_vessels):
        p = physics.position(i)
        text = f"{float(np.hypot(*physics.world_velocity(i))):.2f} m/s"
        if isinstance(task, PathFollowing) and i == 0:
            _, e, _ = task.path_state(physics)  # cached for this state by the observation: no change
            text += f" · cross-track {e:+.2f} m"
        elif isinstance(task, StationKeeping) and i == 0:
            err = np.rad2deg(wrap_angle(physics.heading(i) - task.station_heading_rad))
            text += f" · {np.hypot(*(p - task.station_m)):.1f} m off station, heading {err:+.0f}°"
        elif isinstance(task, CollisionAvoidance) and i == 0:
            text += f" · goal {np.hypot(*(p - task.goal_m)):.1f} m"
        elif isinstance(task, Formation):
            text += f" · {np.hypot(*(p - task.slot_position(i, float(physics.data.time)))):.1f} m off slot"
        out.append(text)
    return out


def task_legend(task, physics, extent_xy=None) -> tuple:
    """The legend's rows (kind, RGBA 0–1, text) of the task's geometry as the frame draws it; the
    target site's row only where the site lies in ``extent_xy`` (lower-left, upper-right corners
    [m]; None: always) — a path's end is often far outside the framed view."""
    path = COLOURS["path"]
    if isinstance(task, PathFollowing):
        items = [("line", path, "path to follow"), ("target", TARGET_RGBA, "path's end")]
    elif isinstance(task, StationKeeping):
        items = [("line", path, "station: 1 m circle"), ("target", TARGET_RGBA, "station, heading to hold")]
    elif isinstance(task, CollisionAvoidance):
        items = [("line", path, "route, start to goal"), ("target", TARGET_RGBA, "goal")]
    elif isinstance(task, Formation):
        items = [("line", path, "formation lanes (slots move along)"),
                 ("target", TARGET_RGBA, "leader's path end")]
    else:
        items = []
    if extent_xy is not None:
        site = np.asarray(physics.named.model.site_pos["target"][:2], float)
        if not np.all((site >= extent_xy[0]) & (site <= extent_xy[1])):
            items = [it for it in items if it[0] != "target"]
    world = physics.world
    if len(world.moving_obstacles):
        items.append(("traffic", TRAFFIC_RGBA, "traffic (true hull, white bow)"))
    if len(world.static_obstacles):
        items.append(("outline", tuple(c / 255 for c in STRUCTURE_SWATCH) + (1.0,), "basin walls"))
    return tuple(items)
