"""The compiled point-in-disc loops (mjasc.perception.owned_discs, behind
mjasc.perception.fleet.inside_owned and tracked_returns.inside) against the numpy forms they replaced
(kept here as the reference): random owners with and without points or discs, points on a disc's
rim, NaN points."""

import numpy as np
import pytest

from mjasc.perception.fleet import _starts, inside_owned
from mjasc.perception.tracking.association import block_pairs


def _numpy_inside_owned(points, point_owner, centres, radii, disc_owner):
    k = points.shape[0]
    out = np.zeros(k, dtype=bool)
    if k == 0 or centres.shape[0] == 0:
        return out
    no = int(max(point_owner.max(), disc_owner.max())) + 1
    n_p, n_d = np.bincount(point_owner, minlength=no), np.bincount(disc_owner, minlength=no)
    q, i, j, _ = block_pairs(n_p, n_d)
    if q.size == 0:
        return out
    a, b = _starts(n_p)[q] + i, _starts(n_d)[q] + j
    d2 = ((points[a] - centres[b]) ** 2).sum(-1)
    out[a[d2 <= radii[b] ** 2]] = True
    return out


@pytest.mark.parametrize("seed", range(60))
def test_inside_owned_equals_the_numpy_form(seed):
    rng = np.random.default_rng(seed)
    no = int(rng.integers(1, 6))
    point_owner = np.sort(rng.integers(0, no, int(rng.integers(0, 200))))
    disc_owner = np.sort(rng.integers(0, no, int(rng.integers(0, 8))))
    points = rng.uniform(-30.0, 30.0, (point_owner.size, 2))
    centres = rng.uniform(-30.0, 30.0, (disc_owner.size, 2))
    radii = rng.uniform(0.0, 15.0, disc_owner.size)
    if points.shape[0] and centres.shape[0]:
        points[0] = centres[0] + (radii[0], 0.0)  # on a rim
        if rng.random() < 0.3:
            points[rng.integers(0, points.shape[0])] = np.nan
    want = _numpy_inside_owned(points, point_owner, centres, radii, disc_owner)
    got = inside_owned(points, point_owner, centres, radii, disc_owner)
    assert got.dtype == want.dtype and got.tobytes() == want.tobytes()


def _numpy_inside(p, centres, radii):
    """tracked_returns.inside's numpy form (one owner)."""
    if p.shape[0] == 0 or centres.shape[0] == 0:
        return np.zeros(p.shape[0], dtype=bool)
    d2 = ((p[:, None, :] - centres[None, :, :]) ** 2).sum(-1)
    return (d2 <= radii[None, :] ** 2).any(axis=1)


@pytest.mark.parametrize("seed", range(30))
def test_inside_discs_equals_the_numpy_form(seed):
    from mjasc.perception.tracked_returns import inside as _inside

    rng = np.random.default_rng(seed)
    points = rng.uniform(-30.0, 30.0, (int(rng.integers(0, 100)), 2))
    q = int(rng.integers(0, 6))
    centres, radii = rng.uniform(-30.0, 30.0, (q, 2)), rng.uniform(0.0, 15.0, q)
    if points.shape[0] and q:
        points[0] = centres[-1] - (0.0, radii[-1])  # on a rim
        points[-1] = np.nan
    got, want = _inside(points, centres, radii), _numpy_inside(points, centres, radii)
    assert got.dtype == want.dtype and got.tobytes() == want.tobytes()
