"""Static conflicts: the polygons' bounding boxes tested all at once give the conflicts of the
polygons tested one by one (the readable form: one call per polygon), field by field."""

from dataclasses import fields

import numpy as np
import pytest

import mjasc.avoidance.static_conflicts as static_conflicts_module
from mjasc.avoidance.prediction import CollisionPredictionConfig
from mjasc.avoidance.static_conflicts import static_conflicts
from mjasc.guidance.paths import Path


def _same(a, b):
    assert len(a) == len(b)
    for x, y in zip(a, b):
        for f in fields(x):
            np.testing.assert_array_equal(getattr(x, f.name), getattr(y, f.name))


def test_all_boxes_at_once_equal_one_polygon_at_a_time():
    rng = np.random.default_rng(5)
    cfg = CollisionPredictionConfig()
    path = Path.from_waypoints(np.array([[0.0, 0.0], [60.0, 0.0], [60.0, 50.0], [120.0, 60.0]]), turn_radius_m=6.0)
    found = 0
    for trial in range(60):
        polys = []
        for _ in range(int(rng.integers(2, 9))):
            centre = rng.uniform([-10.0, -30.0], [130.0, 80.0])
            k = int(rng.integers(3, 9))
            ang = np.sort(rng.uniform(0.0, 2 * np.pi, k))
            polys.append(centre + rng.uniform(1.0, 8.0) * np.column_stack([np.cos(ang), np.sin(ang)]))
        gamma = float(rng.uniform(0.0, path.length - 5.0))
        speed = float(rng.uniform(0.3, 2.5))
        got = static_conflicts(100.0, path, gamma, speed, polys, 2.0, cfg)
        ref = [c for p in polys for c in static_conflicts(100.0, path, gamma, speed, [p], 2.0, cfg)]
        _same(got, ref)
        found += len(got)
    assert found > 10


def _reference(t, path, gamma, speed, polygons, radius_m, cfg):
    """The readable form: every path sample ahead (to the path's end) against each polygon."""
    from mjasc.avoidance.prediction import gamma_of_time, prediction_window
    from mjasc.avoidance.static_conflicts import StaticConflict
    from mjasc.core.geometry import distance_to_polygon, point_in_polygon

    gfn = gamma_of_time(speed, gamma, t)
    v_now = max(0.0, float(gfn(t + 1e-3) - gfn(t)) / 1e-3)
    delta = prediction_window(max(v_now, 1e-3), cfg.brake_decel_m_s2, max(cfg.margin_s, 1.0), cfg.window_s)
    g_end = min(path.length, max(float(gfn(t + delta)), gamma) + radius_m)
    if g_end - gamma < 0.25:
        return []
    limit = radius_m + cfg.safety_distance_m
    gs = np.arange(gamma, path.length + 1e-9, 0.25)
    pts = path.point(gs)
    out = []
    for poly in polygons:
        d = distance_to_polygon(pts, poly)
        blocked = (d < limit) | point_in_polygon(pts, poly)
        ahead = blocked & (gs <= g_end)
        if not ahead.any():
            continue
        a = b = int(np.argmax(ahead))
        while b + 1 < gs.size and blocked[b + 1]:
            b += 1
        t_i = float(t + (gs[a] - gamma) / max(v_now, 1e-3))
        out.append(StaticConflict(float(gs[a]), float(gs[b]), pts[a], pts[b], poly, t_i, float(d[a:b + 1].min())))
    return out


@pytest.mark.parametrize("beyond", [None, 1])
def test_the_path_ahead_sampled_only_as_far_as_needed_gives_the_whole_paths_conflicts(beyond, monkeypatch):
    """Samples up to the window's end (and the whole path when a stretch goes on past them): the
    conflicts of the whole path's samples, bit for bit — long walls along the path included (and
    with 1 sample beyond the window: the whole path needed often)."""
    if beyond is not None:
        monkeypatch.setattr(static_conflicts_module, "_BEYOND", beyond)
    rng = np.random.default_rng(11)
    cfg = CollisionPredictionConfig()
    path = Path.from_waypoints(np.array([[0.0, 0.0], [300.0, 0.0], [300.0, 250.0], [600.0, 300.0], [620.0, 340.0]]),
                               turn_radius_m=15.0)
    found = long = 0
    for trial in range(150):
        polys = []
        for _ in range(int(rng.integers(1, 6))):
            g = float(rng.uniform(0.0, path.length))
            c = path.point(g) + rng.uniform(-8.0, 8.0, 2)
            if rng.random() < 0.4:  # a wall along the path, up to 200 m long
                ang = float(path.tangent_angle(g))
                half = float(rng.uniform(20.0, 100.0))
                u, n = np.array([np.cos(ang), np.sin(ang)]), np.array([-np.sin(ang), np.cos(ang)])
                polys.append(np.array([c - half * u - 2 * n, c + half * u - 2 * n, c + half * u + 2 * n,
                                       c - half * u + 2 * n]))
            else:
                k = int(rng.integers(3, 9))
                ang = np.sort(rng.uniform(0.0, 2 * np.pi, k))
                polys.append(c + rng.uniform(1.0, 8.0) * np.column_stack([np.cos(ang), np.sin(ang)]))
        gamma = float(rng.uniform(0.0, path.length - 1.0))
        speed = float(rng.uniform(0.3, 3.0))
        got = static_conflicts(50.0, path, gamma, speed, polys, 2.0, cfg)
        _same(got, _reference(50.0, path, gamma, speed, polys, 2.0, cfg))
        found += len(got)
        long += sum(c.gamma_b - c.gamma_a > 30.0 for c in got)
    assert found > 25 and long > 5


def test_indexed_conflicts_are_each_polygons_own():
    """static_conflicts_of: each conflict with its polygon's index, the one that polygon has alone
    (the avoidance checks its mapped polygons and its static tracks' outlines in one call)."""
    from mjasc.avoidance.static_conflicts import static_conflicts_of

    rng = np.random.default_rng(9)
    cfg = CollisionPredictionConfig()
    path = Path.from_waypoints(np.array([[0.0, 0.0], [60.0, 0.0], [60.0, 50.0], [120.0, 60.0]]), turn_radius_m=6.0)
    found = 0
    for trial in range(200):
        polys = []
        for _ in range(int(rng.integers(1, 7))):
            centre = rng.uniform([-10.0, -30.0], [130.0, 80.0])
            k = int(rng.integers(3, 9))
            ang = np.sort(rng.uniform(0.0, 2 * np.pi, k))
            polys.append(centre + rng.uniform(2.0, 12.0) * np.column_stack([np.cos(ang), np.sin(ang)]))
        gamma = float(rng.uniform(0.0, path.length - 5.0))
        speed = float(rng.uniform(0.3, 2.5))
        got = static_conflicts_of(100.0, path, gamma, speed, polys, 2.0, cfg)
        ref = [(k, c) for k, p in enumerate(polys) for c in static_conflicts(100.0, path, gamma, speed, [p], 2.0, cfg)]
        assert [k for k, _ in got] == [k for k, _ in ref]
        _same([c for _, c in got], [c for _, c in ref])
        found += len(got)
    assert found > 10
