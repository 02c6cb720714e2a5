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


def _state_arrays(s: MovingObstacleSet, t: float):
    """The vectorized numpy form :meth:`MovingObstacleSet.rows` replaced (per obstacle, plain floats)."""
    m = len(s.obstacles)
    pos, head, vel = np.zeros((m, 2)), np.zeros(m), np.zeros((m, 2))
    th = s._th0 + s._w * t
    c, sn = np.cos(th), np.sin(th)
    vt = s._v * t
    dx = np.where(s._small, vt * s._c0, s._vw * (sn - s._s0))
    dy = np.where(s._small, vt * s._s0, s._nvw * (c - s._c0))
    pos[s._ct_idx] = s._p0 + np.stack([dx, dy], axis=-1)
    head[s._ct_idx], vel[s._ct_idx] = th, np.stack([s._v * c, s._v * sn], axis=-1)
    rows = np.arange(len(s._path_idx))
    g = np.minimum(s._g0 + s._pv * t, s._plen)
    i0 = np.minimum((g / s.PATH_SAMPLE_M).astype(int), s._samples.shape[1] - 2)
    g_a = s._sample_g[rows, i0]
    span = s._sample_g[rows, i0 + 1] - g_a
    f = np.divide(g - g_a, span, out=np.zeros_like(g), where=span > 0)[:, None]
    a, b = s._samples[rows, i0], s._samples[rows, i0 + 1]
    pos[s._path_idx] = a + f * (b - a)
    h = s._sample_headings[rows, i0]
    head[s._path_idx] = h
    vel[s._path_idx] = np.where(g < s._plen, s._pv, 0.0)[:, None] * np.stack([np.cos(h), np.sin(h)], axis=-1)
    return pos, head, vel


def test_plain_float_state_has_the_bits_of_the_array_form():
    """The per-step traffic update runs on plain floats (math.sin/cos): the same bits as numpy."""
    bend = Path.from_waypoints([[0, 0], [50, 0], [50, 50]], turn_radius_m=10.0)
    s = MovingObstacleSet([MovingObstacle("a", 2.0, position_m=(3.0, -4.0), heading_rad=2.1, speed_m_s=1.7),
                           MovingObstacle("b", 3.0, speed_m_s=0.8, path=bend, start_gamma_m=3.3),
                           MovingObstacle("c", 1.0, position_m=(-7, 9), heading_rad=-0.4, speed_m_s=2.2,
                                          turn_rate_rad_s=-0.031)])
    for t in np.concatenate([np.arange(0.0, 150.0, 0.02), [1e-3, 999.0]]):
        for got, want in zip(s.state(float(t)), _state_arrays(s, float(t))):
            assert got.tobytes() == want.tobytes()


def test_obstacle_validation_names_the_field():
    with pytest.raises(ValueError, match="radius_m"):
        MovingObstacle("x", 0.0)
    with pytest.raises(ValueError, match="vertices"):
        PolygonObstacle("p", [[0, 0], [1, 1]])
    with pytest.raises(ValueError, match="radius_m"):
        CircleObstacle("c", (0, 0), -1.0)
    cw = PolygonObstacle("p", [[0, 0], [0, 1], [1, 1], [1, 0]])
    assert cw.vertices[1].tolist() == [1.0, 1.0] or cw.vertices[1].tolist() == [1.0, 0.0]  # stored CCW
