"""The part of the world a run's views frame: the overview and top-down views of the recording's
blueprint, and the video's top-down camera."""

from __future__ import annotations

import numpy as np

from mjasc.physics.obstacles import MovingObstacleSet

__all__ = ["scene_extent"]


def scene_extent(scenario, margin_m: float = 10.0) -> tuple[np.ndarray, np.ndarray]:
    """The (lower-left, upper-right) corners [m, ENU world] around everything ``scenario`` (a
    :class:`~mjasc.runs.scenario.Scenario`) places or sends somewhere: the vessels' starts and paths,
    the structures' vertices (a circle's centre), the traffic's starts and — a target a mission
    follows — where it goes during the run (sampled at 100 times, the team goes after it), with
    ``margin_m`` [m] around."""
    sc = scenario
    pts = [v.position_m for v in sc.vessels]
    for v in sc.vessels:
        if v.path is not None:
            pts.extend(v.path.sample(max(v.path.length / 50, 1.0)))
    for o in sc.static_obstacles:
        pts.extend(getattr(o, "vertices", [getattr(o, "centre", np.zeros(2))]))
    pts.extend(o.position_m for o in sc.moving_obstacles)
    tt = sc.mission.track_target if sc.mission is not None else None
    followed = [o for o in sc.moving_obstacles if tt is not None and o.name == getattr(tt, "target", None)]
    if followed:
        traffic = MovingObstacleSet(followed)
        pts.extend(p for t in np.linspace(0.0, sc.duration_s, 100) for p in traffic.state(float(t))[0])
    p = np.array(pts)
    return p.min(axis=0) - margin_m, p.max(axis=0) + margin_m
