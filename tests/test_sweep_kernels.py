"""The compiled distance to a swept trajectory (mjasc.avoidance.prediction.sweep_kernels) against
the numpy form it replaced, bit for bit."""

import numpy as np
import pytest

from mjasc.avoidance.prediction.sweep_kernels import polyline_distances


def _numpy_form(p, q):
    """The former numpy form of spatial.obstructed_stretch's min_dist (k ≥ 2)."""
    a, ab = q[:-1], np.diff(q, axis=0)
    ab2 = np.maximum(np.sum(ab**2, axis=1), 1e-300)
    rel = p[:, None, :] - a[None, :, :]
    u = np.clip(np.sum(rel * ab, axis=-1) / ab2, 0.0, 1.0)
    return np.sqrt(np.min(np.sum((rel - u[..., None] * ab) ** 2, axis=-1), axis=1))


@pytest.mark.parametrize("seed", range(6))
def test_polyline_distances_bit_identical(seed):
    rng = np.random.default_rng(seed)
    k = int(rng.integers(2, 400))
    if seed % 2:  # a turning track sampled finely (the obstructed stretch's case)
        th = 0.3 + 0.05 * np.linspace(0.0, 20.0, k)
        q = np.column_stack([100.0 + 30.0 * np.sin(th), -50.0 - 30.0 * np.cos(th)])
    else:
        q = rng.normal(0.0, 50.0, (k, 2))
    p = rng.normal(0.0, 60.0, (int(rng.integers(1, 300)), 2))
    p[0] = q[k // 2]  # a point on the trajectory
    got = polyline_distances(p, q)
    ref = _numpy_form(p, q)
    assert got.tobytes() == ref.tobytes()


def test_polyline_distances_degenerate_segments():
    q = np.array([[1.0, 2.0], [1.0, 2.0], [3.0, 2.0], [3.0, 2.0]])
    p = np.array([[0.0, 0.0], [2.0, 5.0], [1.0, 2.0], [-0.0, -0.0]])
    assert polyline_distances(p, q).tobytes() == _numpy_form(p, q).tobytes()
    assert polyline_distances(np.zeros((0, 2)), q).shape == (0,)
