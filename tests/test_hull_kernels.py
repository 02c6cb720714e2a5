"""mjasc.perception.hull_kernels.hull_area2 against scipy's qhull, the map's polygon split that
uses it (mjasc.perception.map_polygons.split_component) against the qhull-only form it replaced,
bit for bit, on walls, docks, blobs and single cells, and map_polygons.hull_2d (qhull without
ConvexHull's facet arrays) against ConvexHull on those and on a run's pieces."""

import numpy as np
import pytest
from scipy.spatial import ConvexHull, QhullError

from mjasc.perception.hull_kernels import centred, halves, hull_area2, median
from mjasc.perception import map_polygons
from mjasc.perception.map_polygons import hull_2d, split_component

_CORNERS = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])


def reference_split(comp, cell_m, min_fill, max_depth, depth, out):
    """The qhull-only form of split_component (every piece's fill from qhull's area)."""
    corners = (comp[:, None, :] + _CORNERS[None, :, :]).reshape(-1, 2) * cell_m
    try:
        hull = ConvexHull(corners)
    except QhullError:
        return
    fill = comp.shape[0] * cell_m**2 / hull.volume
    if fill >= min_fill or comp.shape[0] <= 4 or depth >= max_depth:
        out.append(corners[hull.vertices])
        return
    c = comp - comp.mean(axis=0)
    _, vec = np.linalg.eigh(c.T @ c)
    proj = c @ vec[:, -1]
    cut = np.median(proj)
    left = proj <= cut
    if left.all() or not left.any():
        out.append(corners[hull.vertices])
        return
    reference_split(comp[left], cell_m, min_fill, max_depth, depth + 1, out)
    reference_split(comp[~left], cell_m, min_fill, max_depth, depth + 1, out)


def _shapes(rng):
    """Components as a map makes them (row-major int64 cells): walls at any angle, L and U docks,
    blobs, single cells, far from the origin or near it."""
    out = []
    for _ in range(60):
        kind = int(rng.integers(0, 4))
        if kind == 0:  # a wall: cells along a segment, one or two thick
            a, L = rng.uniform(0, np.pi), rng.uniform(3, 60)
            t = np.linspace(0, L, int(L * 2) + 2)
            p = np.stack([t * np.cos(a), t * np.sin(a)], axis=-1)
            p = np.concatenate([p, p + rng.uniform(-1, 1, 2)]) if rng.random() < 0.5 else p
            cells = np.floor(p).astype(np.int64)
        elif kind == 1:  # an L or a U
            w, h = int(rng.integers(4, 30)), int(rng.integers(4, 30))
            cells = [(i, 0) for i in range(w)] + [(0, j) for j in range(h)]
            if rng.random() < 0.5:
                cells += [(w - 1, j) for j in range(h)]
            cells = np.array(cells, dtype=np.int64)
        elif kind == 2:  # a blob
            cells = rng.integers(0, int(rng.integers(2, 12)), (int(rng.integers(1, 50)), 2))
        else:
            cells = rng.integers(0, 3, (int(rng.integers(1, 4)), 2))
        cells = np.unique(cells + rng.integers(-200000, 200000, 2) * int(rng.random() < 0.3), axis=0)
        out.append(cells.astype(np.int64))
    return out


@pytest.mark.parametrize("seed", range(4))
def test_hull_area_is_qhulls_area(seed):
    rng = np.random.default_rng(seed)
    for cells in _shapes(rng):
        cm = float(rng.choice([0.5, 1.0, 1.5, 2.0]))
        corners = (cells[:, None, :] + _CORNERS[None, :, :]).reshape(-1, 2) * cm
        a2 = hull_area2(cells)
        assert a2 % 1 == 0 and a2 >= 2
        assert abs(ConvexHull(corners).volume / cm**2 - 0.5 * a2) <= 1e-10 * a2
    assert hull_area2(np.zeros((0, 2), dtype=np.int64)) == 0
    assert hull_area2(np.array([[3, -7]], dtype=np.int64)) == 2
    assert hull_area2(np.array([[0, 0], [2, 2]], dtype=np.int64)) == 10  # a 3 × 3 box less two corners of 2 cells²


@pytest.mark.parametrize("seed", range(4))
def test_split_equals_the_qhull_only_form(seed):
    rng = np.random.default_rng(10 + seed)
    n_pieces = 0
    for cells in _shapes(rng):
        cm = float(rng.choice([0.5, 1.0, 2.0]))
        fill = float(rng.choice([0.4, 0.5, 0.25, 0.0, 1.0]))
        depth = int(rng.choice([0, 2, 6]))
        got, want = [], []
        split_component(cells, cm, fill, depth, 0, got)
        reference_split(cells, cm, fill, depth, 0, want)
        assert len(got) == len(want)
        for a, b in zip(got, want):
            assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
        n_pieces += len(got)
    assert n_pieces > 50


def test_median_is_numpys():
    rng = np.random.default_rng(5)
    for n in list(range(1, 12)) + [50, 51, 200]:
        for _ in range(30):
            v = rng.normal(0, 3, n)
            if rng.random() < 0.3:
                v = np.round(v)  # ties
            want = np.median(v)
            got = median(v)
            # the same number (a zero's sign may differ: the order among equal values is the sort's);
            # what the split takes from it, ``proj <= cut``, is the same
            assert got == want and np.array_equal(v <= got, v <= want)
            if want != 0.0:
                assert np.float64(got).tobytes() == np.float64(want).tobytes()
    v = np.array([1.0, np.nan, 3.0])
    assert np.isnan(median(v)) and np.isnan(np.median(v))


def test_centred_is_numpys():
    rng = np.random.default_rng(6)
    for cells in _shapes(rng):
        want = cells - cells.mean(axis=0)
        got = centred(cells)
        assert got.dtype == want.dtype and got.shape == want.shape and got.tobytes() == want.tobytes()


def test_halves_are_the_masks_halves():
    rng = np.random.default_rng(7)
    n_cut = 0
    for cells in _shapes(rng) + [np.array([[0, 0], [0, 1], [0, 2]], dtype=np.int64)]:
        for proj in (rng.normal(0, 3, cells.shape[0]), np.round(rng.normal(0, 1, cells.shape[0])),
                     np.zeros(cells.shape[0])):
            left = proj <= np.median(proj)
            got_l, got_r = halves(cells, proj)
            if left.all() or not left.any():
                assert got_l.shape == (0, 2) and got_r.shape == (0, 2)
                continue
            n_cut += 1
            for got, want in ((got_l, cells[left]), (got_r, cells[~left])):
                assert got.dtype == want.dtype and got.shape == want.shape and got.tobytes() == want.tobytes()
    assert n_cut > 50
    proj = np.array([1.0, np.nan, 3.0])  # a NaN: no cut (proj <= NaN is false everywhere)
    assert halves(np.zeros((3, 2), dtype=np.int64), proj)[0].shape == (0, 2)


def _components_ndimage(cells):
    """The form map_polygons had: ndimage.label on the cells' grid, then lexsort and split."""
    from scipy import ndimage

    lo = cells.min(axis=0)
    rel = cells - lo
    grid = np.zeros(tuple(rel.max(axis=0) + 1), dtype=bool)
    grid[tuple(rel.T)] = True
    labels, n = ndimage.label(grid, structure=np.ones((3, 3)))
    lab = labels[tuple(rel.T)]
    order = np.lexsort((cells[:, 1], cells[:, 0], lab))
    return cells[order], np.bincount(lab, minlength=n + 1)[1:]


@pytest.mark.parametrize("seed", range(60))
def test_components_match_ndimage_label(seed):
    from mjasc.perception.hull_kernels import components

    rng = np.random.default_rng(seed)
    span = int(rng.integers(1, 40))
    c = int(rng.integers(1, 300))
    cells = rng.integers(-span, span + 1, size=(c, 2)) + rng.integers(-10**6, 10**6, size=2)
    if seed % 3 == 0:  # sparse: many components
        cells = rng.integers(-200, 201, size=(c, 2))
    cells = rng.permutation(np.unique(cells, axis=0))
    got, counts = components(cells)
    want, want_counts = _components_ndimage(cells)
    assert got.dtype == np.int64 and got.flags.c_contiguous
    assert got.tobytes() == want.tobytes() and counts.tolist() == want_counts.tolist()


@pytest.mark.parametrize("seed", range(20))
def test_corners_match_numpy_form(seed):
    from mjasc.perception.hull_kernels import corners

    rng = np.random.default_rng(seed)
    comp = rng.integers(-2**20, 2**20, size=(int(rng.integers(0, 50)), 2))
    comp[: comp.shape[0] // 3] = rng.integers(-3, 3, size=(comp.shape[0] // 3, 2))  # zeros and signs
    for cell_m in (1.0, 0.5, 0.3, 2.7, float(rng.uniform(0.1, 5.0))):
        want = (comp[:, None, :] + _CORNERS[None, :, :]).reshape(-1, 2) * cell_m
        got = corners(comp, cell_m)
        assert got.shape == want.shape and got.tobytes() == want.tobytes()


def _same_hull(points):
    hull = ConvexHull(points)
    vertices, area = hull_2d(points)
    assert vertices.dtype == hull.vertices.dtype and np.array_equal(vertices, hull.vertices)  # (order and start)
    assert np.float64(area).tobytes() == np.float64(hull.volume).tobytes()


@pytest.mark.parametrize("seed", range(2))
def test_hull_2d_is_convexhulls(seed):
    rng = np.random.default_rng(20 + seed)
    for cells in _shapes(rng):
        cm = float(rng.choice([0.5, 1.0, 1.5, 2.0]))
        _same_hull((cells[:, None, :] + _CORNERS[None, :, :]).reshape(-1, 2) * cm)
        _same_hull(rng.normal(0.0, 50.0, (int(rng.integers(3, 300)), 2)))  # (points in general position)
    for bad in (np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]]), np.zeros((2, 2))):  # collinear, too few
        with pytest.raises(QhullError):
            ConvexHull(bad)
        with pytest.raises(QhullError):
            hull_2d(bad)


def test_hull_2d_without_scipys_private_wrapper(monkeypatch):
    """A scipy without ``_Qhull`` gets ConvexHull's own result (the guarded import's route)."""
    rng = np.random.default_rng(7)
    points = [rng.normal(0.0, 20.0, (int(rng.integers(3, 80)), 2)) for _ in range(20)]
    fast = [hull_2d(p) for p in points]
    monkeypatch.setattr(map_polygons, "_Qhull", None)
    for p, (v, a) in zip(points, fast):
        v2, a2 = hull_2d(p)
        assert np.array_equal(v, v2) and np.float64(a).tobytes() == np.float64(a2).tobytes()


def test_hull_2d_is_convexhulls_on_a_runs_pieces(monkeypatch):
    """Every hull the demo's maps ask for in 60 s (recorded run's inputs: the pieces' corners)."""
    import mjasc
    from dataclasses import replace

    from mjasc.runs.runner import Runner

    seen = []

    def checked(points):
        _same_hull(points)
        seen.append(points.shape[0])
        return hull_2d(points)

    monkeypatch.setattr(map_polygons, "hull_2d", checked)
    sc = mjasc.load_scenario("demo").with_overrides(duration_s=60.0)
    Runner(replace(sc, outputs=replace(sc.outputs, recording=False, video=False)), out_dir=None).run()
    assert len(seen) > 50 and max(seen) > 40
