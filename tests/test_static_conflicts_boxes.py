"""Static conflicts: the polygons' bounding boxes tested all at once give the conflicts of the
polygons tested one by one (the readable form: one call per polygon), field by field."""

from dataclasses import fields

import numpy as np

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
