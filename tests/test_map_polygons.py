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


def test_maps_of_one_store_share_their_memo():
    """The maps of one fleet's store with the same settings share one memo (a part split for one
    vessel's map is not split again for another's); each map's polygons are those of a map of its
    own, bit for bit and in the same order."""
    from mjasc.perception.static_map import StaticMap, StaticMapStore

    rng = np.random.default_rng(7)
    store = StaticMapStore()
    a, b = StaticMap(1.0, 1, store=store), StaticMap(1.0, 1, store=store)
    other = StaticMap(1.0, 1, min_fill=0.6, store=store)  # other settings: a memo of its own
    assert a._polys._pieces is b._polys._pieces and a._polys._pieces is not other._polys._pieces
    wall = np.array([[x, 0.5 * x + 3.0] for x in np.arange(0.0, 60.0, 0.3)])
    blobs = rng.uniform(-20, 80, size=(40, 2))
    for m, pts in ((a, wall), (b, wall[20:]), (b, blobs), (other, wall), (a, blobs[:10])):
        m.add_scan(pts)
        alone = StaticMap(1.0, 1, min_fill=m.min_fill)
        alone.add_scan(m.occupied_cells() + 0.5)
        _same(m.polygons(), alone.polygons())
    assert len(a._polys._pieces) > 0
