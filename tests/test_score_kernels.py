"""score_kernels against the numpy form of StaticMapStore's updates they replaced (scores, occupied
counts and versions after hits; occupancy of points; distinct cell rows), bit for bit. The carving
(carve_cells) is checked through StaticMapStore.carve in tests/test_carve_kernels.py."""

from __future__ import annotations

import numpy as np
import pytest

from mjasc.perception.cell_keys import find_rows, point_keys
from mjasc.perception.score_kernels import add_hits, cell_rows, occupied_points, set_scores


def _numpy_set_scores(rows, new, score, member, min_hits, n_occupied, version):
    mem = member[rows]
    m = min_hits[mem]
    was = score[rows] >= m
    score[rows] = new
    now = new >= m
    flip = was != now
    if flip.any():
        nm = version.size
        n_occupied += np.bincount(mem[flip], np.where(now[flip], 1, -1), nm).astype(np.int64)
        version += np.bincount(mem[flip], minlength=nm) > 0


def _table(rng):
    M = int(rng.integers(1, 5))
    n = int(rng.integers(1, 60))
    member = rng.integers(0, M, n).astype(np.int64)
    min_hits = rng.integers(1, 4, M).astype(float)
    cap = min_hits + rng.integers(0, 6, M)
    score = np.minimum(rng.integers(0, 10, n).astype(float) * rng.choice([0.5, 1.0]), cap[member])
    n_occ = np.bincount(member, score >= min_hits[member], M).astype(np.int64)
    return member, min_hits, cap, score, n_occ, rng.integers(0, 9, M).astype(np.int64)


@pytest.mark.parametrize("seed", range(100))
def test_hits_and_set_scores_match_numpy_form(seed):
    rng = np.random.default_rng(seed)
    member, min_hits, cap, score, n_occ, version = _table(rng)
    rows = rng.permutation(score.size)[: int(rng.integers(0, score.size + 1))].astype(np.int64)
    a = [score.copy(), n_occ.copy(), version.copy()]
    _numpy_set_scores(rows, np.minimum(a[0][rows] + 1.0, cap[member[rows]]), a[0], member, min_hits, a[1], a[2])
    b = [score.copy(), n_occ.copy(), version.copy()]
    add_hits(rows, b[0], member, cap, min_hits, b[1], b[2])
    assert all(x.tobytes() == y.tobytes() for x, y in zip(a, b))
    new = np.maximum(score[rows] - rng.choice([0.25, 0.5, 1.0]), 0.0)
    a = [score.copy(), n_occ.copy(), version.copy()]
    _numpy_set_scores(rows, new, a[0], member, min_hits, a[1], a[2])
    b = [score.copy(), n_occ.copy(), version.copy()]
    set_scores(rows, new, b[0], member, min_hits, b[1], b[2])
    assert all(x.tobytes() == y.tobytes() for x, y in zip(a, b))


@pytest.mark.parametrize("seed", range(60))
def test_cell_rows_and_occupied_points_match_numpy_form(seed):
    rng = np.random.default_rng(seed)
    M = int(rng.integers(1, 4))
    cell_m = rng.choice([0.5, 1.0, 2.0], M)
    k = int(rng.integers(0, 80))
    pm = rng.integers(0, M, k).astype(np.int64)
    pts = rng.uniform(-20.0, 20.0, (k, 2))
    keys, ok = point_keys(pm, pts, cell_m)
    assert ok
    table = np.unique(np.concatenate([keys[: k // 2], keys[:3] + 7]))
    key_rows = rng.permutation(table.size).astype(np.int64)
    member = (np.zeros(table.size, dtype=np.int64) if table.size == 0 else
              np.empty(table.size, dtype=np.int64))
    member[key_rows] = table >> 48
    score = rng.integers(0, 6, table.size).astype(float)
    min_hits = rng.integers(1, 4, M).astype(float)
    u, rows, ok = cell_rows(pm, pts, cell_m, table, key_rows)
    want_u = np.unique(keys)
    assert ok and np.array_equal(u, want_u) and np.array_equal(rows, find_rows(want_u, table, key_rows))
    occ, ok = occupied_points(pm, pts, cell_m, table, key_rows, score, member, min_hits)
    r = find_rows(keys, table, key_rows)
    safe = np.maximum(r, 0)
    want = (r >= 0) & (score[safe] >= min_hits[member[safe]]) if table.size else np.zeros(k, dtype=bool)
    assert ok and np.array_equal(occ, want)


def test_out_of_range_points_report_not_ok():
    pm = np.zeros(1, dtype=np.int64)
    far = np.array([[1e12, 0.0]])
    z = np.zeros(0, dtype=np.int64)
    assert not cell_rows(pm, far, np.ones(1), z, z)[2]
    assert not occupied_points(pm, far, np.ones(1), z, z, np.zeros(0), z, np.ones(1))[1]
