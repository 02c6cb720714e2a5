"""The spatial correlation's bisections compiled (mjasc.avoidance.prediction.spatial_kernels)
against ``spatial._bisect`` of the numpy gaps, bit for bit: on every bisection of a real run (the
dock's detours and corrections) and on random paths of lines and arcs, tracks straight, turning
and static, swept polylines."""

from dataclasses import replace
from pathlib import Path as FilePath

import numpy as np

from mjasc.avoidance.prediction import spatial, spatial_kernels
from mjasc.avoidance.prediction.path_distance import path_distances
from mjasc.avoidance.prediction.sweep_kernels import polyline_distances
from mjasc.core.compiled import clip_float
from mjasc.core.estimates import TrackEstimate
from mjasc.guidance.paths import Path
from mjasc.runs.runner import Runner
from mjasc.runs.scenario import load_scenario

TASKS = FilePath(__file__).resolve().parents[1] / "tasks"


def _stretch_reference(path, q, r_col, g_in, g_out):
    return spatial._bisect(lambda g: polyline_distances(path.point(g), q) - r_col, g_in, g_out, tol=1e-6)


def _interval_reference(path, gamma_now, track, r_col, t_in, t_out):
    return spatial._bisect(lambda t: path_distances(path, track.predict_positions(t), gamma_now) - r_col, t_in, t_out)


def _motion(track):
    return np.array([float(track.position_m[0]), float(track.position_m[1]), track.time_s, track.speed_m_s,
                     track.heading_rad, track.turn_rate_rad_s, 1.0 if track.is_static else 0.0])


def _random_path(rng, trial):
    while True:
        n = int(rng.integers(2, 30))
        pts = np.cumsum(rng.normal(0.0, 15.0, (n, 2)), axis=0)
        radius = None if trial % 3 == 0 else float(rng.uniform(0.2, 4.0))
        try:
            return Path.from_waypoints(pts, turn_radius_m=radius or 0.0)
        except ValueError:
            continue


def _brackets(values, grid):
    """(inside, outside) pairs of neighbouring grid points where ``values`` changes sign (≤ 0 / > 0)."""
    out = []
    for k in range(grid.size - 1):
        a, b = values[k] <= 0.0, values[k + 1] <= 0.0
        if a != b:
            out.append((grid[k], grid[k + 1]) if a else (grid[k + 1], grid[k]))
    return out


def test_stretch_ends_on_random_paths_and_polylines():
    rng = np.random.default_rng(8)
    checked = 0
    for trial in range(80):
        path = _random_path(rng, trial)
        q = np.cumsum(rng.normal(0.0, 3.0, (int(rng.integers(2, 40)), 2)), axis=0) + path.point(
            float(rng.uniform(0.0, path.length)))
        r_col = float(rng.uniform(0.5, 8.0))
        gs = np.linspace(0.0, path.length, 200)
        f = polyline_distances(path.point(gs), q) - r_col
        for g_in, g_out in _brackets(f, gs):
            got = spatial_kernels.stretch_end(path._table, path._cum, path._length, q, r_col, float(g_in),
                                              float(g_out), 1e-6)
            assert np.float64(got).tobytes() == np.float64(_stretch_reference(path, q, r_col, g_in, g_out)).tobytes()
            checked += 1
        for g_in, g_out in ((0.0, path.length), (-1.0, path.length + 2.0), (path.length, 0.0)):  # whole, beyond
            got = spatial_kernels.stretch_end(path._table, path._cum, path._length, q, r_col, g_in, g_out, 1e-6)
            assert np.float64(got).tobytes() == np.float64(_stretch_reference(path, q, r_col, g_in, g_out)).tobytes()
    assert checked > 80


def test_interval_ends_on_random_paths_and_tracks():
    rng = np.random.default_rng(9)
    checked = 0
    for trial in range(80):
        path = _random_path(rng, trial)
        gamma_now = float(rng.uniform(0.0, 0.5 * path.length)) if trial % 4 else 0.0
        start = path.point(float(rng.uniform(0.0, path.length))) + rng.normal(0.0, 10.0, 2)
        w = float(rng.choice([0.0, 1e-10, 0.05, -0.2, 0.5]))
        track = TrackEstimate(1, 10.0, start, float(rng.uniform(-np.pi, np.pi)), float(rng.choice([0.0, 0.7, 2.5])),
                              w, 2.0, is_static=bool(trial % 9 == 8))
        r_col = float(rng.uniform(0.5, 8.0))
        ts = np.linspace(10.0, 60.0, 120)
        f = path_distances(path, track.predict_positions(ts), gamma_now) - r_col
        g_lo = clip_float(gamma_now, 0.0, path.length)
        for t_in, t_out in _brackets(f, ts) + [(10.0, 60.0), (60.0, 10.0)]:
            done, got = spatial_kernels.interval_end(path.table, g_lo, path.length, _motion(track), r_col,
                                                     float(t_in), float(t_out), 1e-6)
            assert done
            want = _interval_reference(path, gamma_now, track, r_col, t_in, t_out)
            assert np.float64(got).tobytes() == np.float64(want).tobytes()
            checked += 1
    assert checked > 160


def test_the_bisections_of_a_real_run_equal_the_numpy_form(monkeypatch):
    """Every bisection of the dock's run (detours, velocity corrections) gives ``_bisect``'s end of
    the numpy gap, bit for bit."""
    stretch, interval, seen = spatial_kernels.stretch_end, spatial_kernels.interval_end, []

    def stretch_checked(table, cum, length, q, r_col, g_in, g_out, tol):
        got = stretch(table, cum, length, q, r_col, g_in, g_out, tol)
        path = next(p for p in paths if p._table is table)
        assert np.float64(got).tobytes() == np.float64(_stretch_reference(path, q, r_col, g_in, g_out)).tobytes()
        seen.append("stretch")
        return got

    def interval_checked(table, g_lo, length, motion, r_col, t_in, t_out, tol):
        done, got = interval(table, g_lo, length, motion, r_col, t_in, t_out, tol)
        path = next(p for p in paths if p.table is table)
        track = TrackEstimate(0, motion[2], motion[:2].copy(), motion[4], motion[3], motion[5], 1.0,
                              is_static=bool(motion[6]))
        assert done
        assert np.float64(got).tobytes() == np.float64(
            _interval_reference(path, g_lo, track, r_col, t_in, t_out)).tobytes()
        seen.append("interval")
        return done, got

    paths = []
    point = Path.point

    def noting_point(self, gamma):  # (the paths the run evaluates: the kernels see their tables)
        if not any(p is self for p in paths):
            paths.append(self)
        return point(self, gamma)

    monkeypatch.setattr(Path, "point", noting_point)
    monkeypatch.setattr(spatial, "stretch_end", stretch_checked)
    monkeypatch.setattr(spatial, "interval_end", interval_checked)
    sc = load_scenario(TASKS / "thesis_6_2_dock.toml")
    Runner(replace(sc, outputs=replace(sc.outputs, recording=False, video=False)), None, progress=False).run()
    assert seen.count("stretch") >= 4 and seen.count("interval") >= 4
