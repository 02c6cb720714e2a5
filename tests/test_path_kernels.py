"""A path's points at many γ in one compiled pass (mjasc.guidance.path_kernels, Path.point on
arrays) against the numpy form it replaced, bit for bit: random paths of lines only and of lines
and arcs, γ inside, outside, on the joints and NaN, arrays of any shape, and every array query of
a real run."""

from dataclasses import replace
from pathlib import Path as FilePath

import numpy as np

from mjasc.guidance.paths import Path
from mjasc.guidance.segment_geometry import COS0, K, SIN0, X0, Y0, eval_points
from mjasc.runs.runner import Runner
from mjasc.runs.scenario import load_scenario

TASKS = FilePath(__file__).resolve().parents[1] / "tasks"


def _reference_points(path, gamma):
    """Path.point's numpy form for an array of γ (the form the kernel replaced)."""
    _, idx, s = path._locate(gamma)
    table = path._table
    if not np.any(table[K] != 0.0):  # (lines only)
        out = np.empty(np.shape(s) + (2,))
        np.add(table[X0][idx], s * table[COS0][idx], out=out[..., 0])
        np.add(table[Y0][idx], s * table[SIN0][idx], out=out[..., 1])
        return out
    return np.stack(eval_points(table[:, idx], s), axis=-1)


def _same(path, gamma):
    got, want = path.point(gamma), _reference_points(path, gamma)
    assert got.shape == want.shape and got.tobytes() == want.tobytes()


def test_points_on_random_paths():
    rng = np.random.default_rng(11)
    n_paths = 0
    for trial in range(120):
        n = int(rng.integers(2, 40))
        pts = np.cumsum(rng.normal(0.0, 20.0, (n, 2)), axis=0)
        radius = 0.0 if trial % 3 == 0 else float(rng.uniform(0.2, 6.0))
        try:
            path = Path.from_waypoints(pts, turn_radius_m=radius)
        except ValueError:
            continue
        n_paths += 1
        L = path.length
        joints = path._cum
        g = np.concatenate([rng.uniform(-5.0, L + 5.0, 200), joints, np.nextafter(joints, -np.inf),
                            np.nextafter(joints, np.inf), [0.0, -0.0, L, np.nan, np.inf, -np.inf]])
        _same(path, g)
        _same(path, g[:9])
        _same(path, rng.uniform(0.0, L, (7, 13)))
        _same(path, np.array(rng.uniform(0.0, L)))
        _same(path, rng.uniform(0.0, L, 40)[::3])  # (not contiguous)
        _same(path, rng.integers(0, int(L) + 1, 30))  # (integers)
    assert n_paths > 40


def test_every_array_query_of_a_run(monkeypatch):
    point, seen = Path.point, []

    def checked(self, gamma):
        got = point(self, gamma)
        if type(gamma) is np.ndarray and not (gamma.ndim == 1 and gamma.size <= 8):
            want = _reference_points(self, gamma)
            assert got.shape == want.shape and got.tobytes() == want.tobytes()
            seen.append(gamma.size)
        return got

    monkeypatch.setattr(Path, "point", checked)
    sc = load_scenario(TASKS / "thesis_6_2_dock.toml")
    Runner(replace(sc, outputs=replace(sc.outputs, recording=False, video=False)), None, progress=False).run()
    assert len(seen) > 50
