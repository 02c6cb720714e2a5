"""The compiled cell keys and row look-up of the static map store (mjasc.perception.cell_keys)
against the numpy form they replaced (kept here as the reference): points of several members and
cell sizes, on cell boundaries, negative, far out (the one-line error) and not finite."""

import numpy as np
import pytest

from mjasc.perception.cell_keys import IJ_BITS, IJ_HALF, MEMBER_SHIFT, create_rows, find_rows, point_keys
from mjasc.perception.static_map import StaticMapConfig, StaticMapStore


def _numpy_keys(member, points, cell_m):
    cells = np.floor(points / cell_m[member][:, None]).astype(np.int64)
    if cells.size and (cells.min() < -IJ_HALF or cells.max() >= IJ_HALF):
        raise ValueError("out of range")
    return ((member << MEMBER_SHIFT) | ((cells[:, 0] + IJ_HALF) << IJ_BITS)) | (cells[:, 1] + IJ_HALF)


def _numpy_find(keys, ks, key_rows):
    if ks.size == 0:
        return np.full(keys.shape, -1, dtype=np.int64)
    pos = np.minimum(np.searchsorted(ks, keys), ks.size - 1)
    return np.where(ks[pos] == keys, key_rows[pos], -1)


@pytest.mark.parametrize("seed", range(40))
def test_keys_and_rows_equal_the_numpy_form(seed):
    rng = np.random.default_rng(seed)
    M = int(rng.integers(1, 6))
    cell_m = rng.choice([0.25, 0.5, 1.0, 3.0], M)
    k = int(rng.integers(0, 300))
    member = rng.integers(0, M, k).astype(np.int64)
    points = rng.uniform(-500.0, 500.0, (k, 2)) * rng.choice([1e-3, 1.0], (k, 1))
    if k:
        points[: k // 4] = np.round(points[: k // 4])  # on cell boundaries
    keys, ok = point_keys(member, points, cell_m)
    assert ok
    want = _numpy_keys(member, points, cell_m)
    assert keys.dtype == want.dtype and keys.tobytes() == want.tobytes()
    ks = np.unique(want[rng.random(k) < 0.5])
    key_rows = rng.permutation(ks.size).astype(np.int64)
    probe = np.concatenate([want, want + 1, want - 1, ks[:3]]) if k else want
    got = find_rows(probe, ks, key_rows)
    assert got.tobytes() == _numpy_find(probe, ks, key_rows).tobytes()


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf, 1e300, float(IJ_HALF), -float(IJ_HALF) - 1.0])
def test_far_or_non_finite_points_give_the_one_line_error(bad):
    store = StaticMapStore()
    store.add_member(StaticMapConfig())
    pts = np.array([[1.0, 2.0], [bad, 3.0]])
    with np.errstate(invalid="ignore"), pytest.raises(ValueError, match="points_world: a cell index beyond"):
        store.add_points(np.zeros(2, dtype=np.int64), pts)
    _, ok = point_keys(np.zeros(2, dtype=np.int64), pts, np.ones(1))
    assert not ok
    edge = np.array([[float(IJ_HALF) - 1.0, -float(IJ_HALF)]])
    keys, ok = point_keys(np.zeros(1, dtype=np.int64), edge, np.ones(1))
    assert ok and keys.tobytes() == _numpy_keys(np.zeros(1, dtype=np.int64), edge, np.ones(1)).tobytes()


def _reference_create(new_keys, n, cells, member, score, sorted_keys, key_rows):
    """The numpy form StaticMapStore._create had: decode the new keys into rows n…, then np.insert
    the keys and their rows at np.searchsorted."""
    k = new_keys.size
    created = np.arange(n, n + k)
    cells[created] = np.stack([((new_keys >> IJ_BITS) & ((1 << IJ_BITS) - 1)) - IJ_HALF,
                               (new_keys & ((1 << IJ_BITS) - 1)) - IJ_HALF], axis=-1)
    member[created] = new_keys >> MEMBER_SHIFT
    score[created] = 0.0
    at = np.searchsorted(sorted_keys, new_keys)
    return np.insert(sorted_keys, at, new_keys), np.insert(key_rows, at, created)


@pytest.mark.parametrize("seed", range(6))
def test_create_rows_equals_the_numpy_form(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(0, 60))
    pool = np.unique((rng.integers(0, 4, 200) << MEMBER_SHIFT) | ((rng.integers(-40, 40, 200) + IJ_HALF) << IJ_BITS)
                     | (rng.integers(-40, 40, 200) + IJ_HALF))
    rng.shuffle(pool)
    old = np.sort(pool[:n])
    rows_old = rng.permutation(n).astype(np.int64)
    new = np.sort(pool[n:n + int(rng.integers(0, 30))])
    size = n + new.size + int(rng.integers(0, 5))
    tables = [(np.zeros((size, 2), dtype=np.int64), np.zeros(size, dtype=np.int64), np.full(size, 7.0)) for _ in range(2)]
    got = create_rows(new, n, *tables[0], old, rows_old)
    want = _reference_create(new, n, *tables[1], old, rows_old)
    for a, b in zip(got, want):
        assert a.dtype == b.dtype and np.array_equal(a, b)
    for a, b in zip(tables[0], tables[1]):
        assert a.tobytes() == b.tobytes()
