"""Moving obstacles: the closed-form constant-turn motion and the sampled path motion."""

import numpy as np
import pytest

from mjasc.guidance.paths import Path
from mjasc.physics.obstacles import CircleObstacle, MovingObstacle, MovingObstacleSet, PolygonObstacle


def test_constant_turn_matches_integrating_thesis_eq_3_2():
    o = MovingObstacle("t", 2.5, position_m=(10.0, -5.0), heading_rad=0.3, speed_m_s=1.5, turn_rate_rad_s=0.03)
    s = MovingObstacleSet([o])
    x, y, th, dt = 10.0, -5.0, 0.3, 1e-3
    for _ in range(int(60 / dt)):  # eq. 3.2 without noise, fine step
        x += dt * 1.5 * np.cos(th + 0.5 * dt * 0.03)
        y += dt * 1.5 * np.sin(th + 0.5 * dt * 0.03)
        th += dt * 0.03
    pos, head, vel = s.state(60.0)
    np.testing.assert_allclose(pos[0], [x, y], atol=1e-6)
    assert head[0] == pytest.approx(th)
    assert np.hypot(*vel[0]) == pytest.approx(1.5)


def test_path_obstacles_follow_their_paths_exactly_on_lines_and_closely_on_arcs():
    line = Path.line([0, 0], [100, 0])
    bend = Path.from_waypoints([[0, 0], [50, 0], [50, 50]], turn_radius_m=10.0)
    obstacles = [MovingObstacle("a", 2.0, speed_m_s=1.2, path=line, start_gamma_m=5.0),
                 MovingObstacle("b", 3.0, speed_m_s=0.8, path=bend),
                 MovingObstacle("c", 1.0, position_m=(0, 0), speed_m_s=1.0)]
    s = MovingObstacleSet(obstacles)
    for t in (0.0, 7.3, 50.0, 71.1, 500.0):
        pos, head, vel = s.state(t)
        for k, (path, g0, v) in enumerate(((line, 5.0, 1.2), (bend, 0.0, 0.8))):
            g = min(g0 + v * t, path.length)
            np.testing.assert_allclose(pos[k], path.point(g), atol=2e-3)  # chord error ds²/8R < 1 mm
            moving = g < path.length
            assert np.hypot(*vel[k]) == pytest.approx(v if moving else 0.0)
        np.testing.assert_allclose(pos[2], [t, 0.0])


def test_obstacle_validation_names_the_field():
    with pytest.raises(ValueError, match="radius_m"):
        MovingObstacle("x", 0.0)
    with pytest.raises(ValueError, match="vertices"):
        PolygonObstacle("p", [[0, 0], [1, 1]])
    with pytest.raises(ValueError, match="radius_m"):
        CircleObstacle("c", (0, 0), -1.0)
    cw = PolygonObstacle("p", [[0, 0], [0, 1], [1, 1], [1, 0]])
    assert cw.vertices[1].tolist() == [1.0, 1.0] or cw.vertices[1].tolist() == [1.0, 0.0]  # stored CCW
