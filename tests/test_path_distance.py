"""The spatial correlation's distances to the path ahead with far segments skipped
(mjasc.avoidance.prediction.path_distance) against Path.closest_points, bit for bit: on every gap
of real runs (detours with many segments) and on random paths of lines and arcs."""

from dataclasses import replace
from pathlib import Path as FilePath

import numpy as np

from mjasc.avoidance.prediction import path_distance, spatial
from mjasc.guidance.paths import Path
from mjasc.runs.runner import Runner
from mjasc.runs.scenario import load_scenario

TASKS = FilePath(__file__).resolve().parents[1] / "tasks"


def _same(path, pts, gamma_min):
    got = path_distance.path_distances(path, pts, gamma_min)
    want = path.closest_points(pts, gamma_min, path.length)[1]
    assert got.tobytes() == want.tobytes()


def test_the_gaps_of_real_runs_are_closest_points_distances(monkeypatch):
    seen = []
    fast = path_distance.path_distances

    def both(path, pts, gamma_min):
        got = fast(path, pts, gamma_min)
        assert got.tobytes() == path.closest_points(pts, gamma_min, path.length)[1].tobytes()
        seen.append(path.table.shape[1])
        return got

    monkeypatch.setattr(spatial, "path_distances", both)
    sc = load_scenario(TASKS / "thesis_6_4_bottleneck.toml").with_overrides(duration_s=120.0)
    Runner(replace(sc, outputs=replace(sc.outputs, recording=False, video=False)), None, progress=False).run()
    assert len(seen) > 20 and max(seen) > 2 * path_distance._FEW_SEGMENTS  # (detours: the skipping path)


def test_random_paths_of_lines_and_arcs():
    rng = np.random.default_rng(5)
    for trial in range(60):
        n = int(rng.integers(2, 60))
        pts = np.cumsum(rng.normal(0.0, 15.0, (n, 2)), axis=0)
        radius = None if trial % 3 == 0 else float(rng.uniform(0.2, 2.0))
        try:
            path = Path.from_waypoints(pts, turn_radius_m=radius or 0.0)
        except ValueError:
            continue
        q = rng.uniform(pts.min(axis=0) - 20.0, pts.max(axis=0) + 20.0, (int(rng.integers(1, 40)), 2))
        for g in (0.0, float(rng.uniform(0.0, path.length))):
            _same(path, q, g)
