"""PolygonCache remembers the pieces of every part it split (mjasc.perception.map_polygons): over a
map growing and losing cells, its polygons are those of a cache that never split anything before,
bit for bit and in the same order."""

import numpy as np

import mjasc.perception.map_polygons as mp
from mjasc.perception.map_polygons import MEMO_PARTS, PolygonCache


def _same(got, want):
    assert len(got) == len(want)
    for a, b in zip(got, want):
        assert a.shape == b.shape and a.tobytes() == b.tobytes()


def test_memo_gives_the_pieces_of_a_fresh_split(monkeypatch):
    rng = np.random.default_rng(4)
    # an L-shaped quay, a U-shaped dock and scattered blobs, revealed a few cells at a time
    quay = [(i, 0) for i in range(40)] + [(39, j) for j in range(1, 30)]
    dock = [(60 + i, 40) for i in range(15)] + [(60, 40 + j) for j in range(1, 12)] + [(74, 40 + j) for j in range(1, 12)]
    blobs = [(int(x), int(y)) for x, y in rng.integers(-30, 100, size=(60, 2))]
    cells_all = quay + dock + blobs
    order = rng.permutation(len(cells_all))
    cache = PolygonCache(2.0, 0.5, 4)
    split = mp._split
    calls = [0, 0]  # parts split by the cache, by the fresh ones
    shown, fresh = [], [False]

    def counted(*args):
        calls[fresh[0]] += 1
        split(*args)

    monkeypatch.setattr(mp, "_split", counted)
    for step, k in enumerate(order.tolist()):
        shown.append(cells_all[k])
        if step % 9 == 5 and len(shown) > 3:  # a cell freed now and then
            shown.pop(int(rng.integers(0, len(shown))))
        cells = np.unique(np.array(shown, dtype=np.int64), axis=0)
        got = cache.polygons(cells)
        fresh[0] = True
        _same(got, PolygonCache(2.0, 0.5, 4).polygons(cells))
        fresh[0] = False
    assert len(cache._pieces) <= MEMO_PARTS + 64
    assert 0 < calls[0] < calls[1] / 5  # most parts were split before
    _same(cache.polygons(np.zeros((0, 2), dtype=np.int64)), [])


def test_hull_of_and_principal_axis_are_convexhull_and_eigh():
    """hull_of (qhull without ConvexHull's facet arrays) gives ConvexHull's vertices, in its order,
    and its area; principal_axis gives np.linalg.eigh's last eigenvector: bit for bit, on the
    corners of random cell sets (lines, blocks, scattered cells, other cell sizes, far from the origin)."""
    from scipy.spatial import ConvexHull

    from mjasc.perception.map_polygons import _CORNERS, hull_of, principal_axis

    rng = np.random.default_rng(11)
    for k in range(300):
        n = int(rng.integers(1, 60))
        spread = int(rng.integers(1, 30))
        cells = rng.integers(-spread, spread + 1, size=(n, 2)) + rng.integers(-10**5, 10**5, size=2) * (k % 3 == 0)
        if k % 7 == 0:
            cells[:, 1] = cells[0, 1]  # one row
        cells = np.unique(cells, axis=0)
        cell_m = (1.0, 0.5, 2.0, 0.7)[k % 4]
        corners = (cells[:, None, :] + _CORNERS[None, :, :]).reshape(-1, 2) * cell_m
        hull = ConvexHull(corners)
        vertices, area = hull_of(corners)
        assert vertices.tobytes() == hull.vertices.tobytes() and vertices.dtype == hull.vertices.dtype
        assert area == hull.volume
        c = cells - cells.mean(axis=0)
        m = c.T @ c
        assert principal_axis(m).tobytes() == np.linalg.eigh(m)[1][:, -1].tobytes()
