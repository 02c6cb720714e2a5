"""The compiled polygon kernels (mjasc.core.polygon_kernels) against the vectorized numpy forms they
replaced (bit for bit) and against scipy's Qhull (the same hull vertices)."""

import math

import numpy as np
import pytest
from scipy.spatial import ConvexHull, QhullError

from mjasc.core.geometry import convex_hull, distance_to_polygon, point_in_polygon


def _numpy_distance(points, polygon):
    """The numpy form distance_to_polygon had: points × edges, closest point a + t (b − a)."""
    p = np.asarray(points, dtype=float).reshape(-1, 1, 2)
    a = np.asarray(polygon, dtype=float)
    ab = np.roll(a, -1, axis=0) - a
    t = np.clip(np.einsum("nkj,kj->nk", p - a, ab) / np.maximum(np.einsum("kj,kj->k", ab, ab), 1e-18), 0.0, 1.0)
    return np.min(np.linalg.norm(p - (a + t[..., None] * ab), axis=-1), axis=1)


def _numpy_inside(points, polygon):
    p = np.asarray(points, dtype=float).reshape(-1, 1, 2)
    a = np.asarray(polygon, dtype=float)
    b = np.roll(a, -1, axis=0)
    crosses = (a[:, 1] > p[..., 1]) != (b[:, 1] > p[..., 1])
    with np.errstate(divide="ignore", invalid="ignore"):
        x_int = a[:, 0] + (p[..., 1] - a[:, 1]) * (b[:, 0] - a[:, 0]) / (b[:, 1] - a[:, 1])
    return np.count_nonzero(crosses & (p[..., 0] < x_int), axis=1) % 2 == 1


def _qhull_canonical(points):
    """The Qhull form convex_hull had: rounded, de-duplicated, from the smallest point."""
    p = np.unique(np.round(np.asarray(points, dtype=float).reshape(-1, 2), 6), axis=0)
    if p.shape[0] <= 2:
        return p
    try:
        hull = p[ConvexHull(p).vertices]
    except QhullError:
        return p[[0, -1]]
    k = int(np.lexsort((hull[:, 1], hull[:, 0]))[0])
    return np.roll(hull, -k, axis=0)


def _polygons(rng):
    """Convex, star-shaped (non-convex) and degenerate-edged polygons."""
    out = []
    for _ in range(40):
        k = int(rng.integers(3, 24))
        ang = np.sort(rng.uniform(0, 2 * np.pi, k))
        r = rng.uniform(0.5, 30.0, k) if rng.random() < 0.7 else np.full(k, 10.0)
        poly = rng.normal(0, 50, 2) + np.stack([r * np.cos(ang), r * np.sin(ang)], axis=1)
        if rng.random() < 0.2:
            poly = np.insert(poly, 1, poly[1], axis=0)  # a zero-length edge
        out.append(poly)
    out.append(np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]]))  # axis-aligned: horizontal edges
    return out


def test_distance_and_containment_equal_the_numpy_forms_bit_for_bit():
    rng = np.random.default_rng(3)
    for poly in _polygons(rng):
        c = poly.mean(axis=0)
        pts = c + rng.normal(0, 25, (200, 2))
        pts[:10] = poly[rng.integers(0, len(poly), 10)]  # on vertices
        pts[10:20, 1] = poly[rng.integers(0, len(poly), 10), 1]  # at a vertex's height (ray through it)
        np.testing.assert_array_equal(distance_to_polygon(pts, poly), _numpy_distance(pts, poly))
        np.testing.assert_array_equal(point_in_polygon(pts, poly), _numpy_inside(pts, poly))
    # a single (2,) point; non-contiguous inputs
    sq = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]])
    assert distance_to_polygon(np.array([2.0, 1.0]), sq).tolist() == [1.0]
    assert point_in_polygon(np.array([2.0, 1.0]), sq).tolist() == [True]
    wide = np.zeros((5, 4))
    wide[:, ::2] = rng.normal(0, 3, (5, 2))
    np.testing.assert_array_equal(distance_to_polygon(wide[:, ::2], sq), _numpy_distance(wide[:, ::2], sq))


def test_distance_against_closed_form_and_nan():
    sq = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]])
    d = distance_to_polygon(np.array([[2.0, 1.0], [7.0, 8.0], [-3.0, 2.0], [np.nan, 1.0]]), sq)
    assert d[:3].tolist() == [1.0, 5.0, 3.0]
    assert np.isnan(d[3])  # a NaN point has no distance (as np.min)
    inside = point_in_polygon(np.array([[2.0, 2.0], [5.0, 2.0], [2.0, -1.0], [0.5, 3.9]]), sq)
    assert inside.tolist() == [True, False, False, True]


@pytest.mark.parametrize("seed", range(6))
def test_convex_hull_equals_qhull(seed):
    rng = np.random.default_rng(seed)
    for _ in range(60):
        n = int(rng.integers(1, 60))
        pts = rng.normal(0, 20, (n, 2))
        if rng.random() < 0.3:  # repeated points and grid-aligned collinear boundary points
            pts = np.round(pts / 5.0) * 5.0
        if rng.random() < 0.2:
            pts = np.concatenate([pts, pts[: n // 2]])
        got = convex_hull(pts)
        np.testing.assert_array_equal(got, _qhull_canonical(pts))


def test_convex_hull_degenerate_sets():
    line = np.array([[0.0, 0.0], [2.0, 2.0], [1.0, 1.0], [3.0, 3.0]])
    np.testing.assert_array_equal(convex_hull(line), [[0.0, 0.0], [3.0, 3.0]])
    np.testing.assert_array_equal(convex_hull(np.array([[1.0, 2.0], [1.0, 2.0]])), [[1.0, 2.0]])
    square = np.array([[0, 0], [2, 0], [2, 2], [0, 2], [1, 0], [1, 1], [0, 1]], dtype=float)
    np.testing.assert_array_equal(convex_hull(square), [[0, 0], [2, 0], [2, 2], [0, 2]])  # CCW, collinear dropped


def _numpy_canonical_hull(points):
    """The numpy form convex_hull had before the compiled canonical_hull: round, lexsort, drop
    repeats, hull_indices."""
    from mjasc.core.polygon_kernels import hull_indices

    p = np.round(np.asarray(points, dtype=float).reshape(-1, 2), 6)
    p = p[np.lexsort((p[:, 1], p[:, 0]))]
    if p.shape[0] > 1:
        p = p[np.concatenate([[True], (p[1:] != p[:-1]).any(axis=1)])]
    if p.shape[0] <= 2:
        return p
    return p[hull_indices(p)]


@pytest.mark.parametrize("seed", range(4))
def test_canonical_hull_equals_the_numpy_form_bit_for_bit(seed):
    from mjasc.core.polygon_kernels import canonical_hull

    rng = np.random.default_rng(seed)
    for _ in range(300):
        n = int(rng.integers(0, 120))
        pts = rng.normal(0, 30, (n, 2)) + rng.normal(0, 1e4, 2)
        u = rng.random()
        if u < 0.2:  # half-micrometre ties of the rounding
            pts = (np.round(pts * 1e6) + 0.5) / 1e6
        elif u < 0.4:  # grid points: repeats, collinear boundaries, ±0.0 coordinates
            pts = np.round(pts / 5.0) * 5.0
            pts[rng.random(pts.shape) < 0.2] = -0.0
            pts[rng.random(pts.shape) < 0.2] = 0.0
        if rng.random() < 0.2:
            pts = np.concatenate([pts, pts[: n // 2]])
        want = _numpy_canonical_hull(pts)
        got = canonical_hull(np.ascontiguousarray(pts, dtype=float).reshape(-1, 2))
        assert got.shape == want.shape
        assert got.tobytes() == want.tobytes()  # bit for bit (signs of zeros included)
        assert convex_hull(pts).tobytes() == want.tobytes()


def _numpy_self_intersections(v, tol):
    """The numpy form self_intersections had: every edge pair through segments_intersect."""
    from mjasc.core.geometry import segments_intersect

    k = len(v)
    a, b = v, np.roll(v, -1, axis=0)
    hit = segments_intersect(a[:, None], b[:, None], a[None, :], b[None, :], tol)
    i, j = np.triu_indices(k, 1)
    sel = hit[i, j] & ~((j == i + 1) | ((i == 0) & (j == k - 1)))
    return list(zip(i[sel].tolist(), j[sel].tolist()))


@pytest.mark.parametrize("seed", range(3))
def test_self_intersections_equal_the_numpy_form(seed):
    """Random polygons (many crossing), on a coarse grid too (exact touches and collinear edges),
    tolerances from 0 to a metre, and inflated circles (the polygons re-planning cleans)."""
    from mjasc.core.geometry import circle_polygon, inflate_polygon, self_intersections

    rng = np.random.default_rng(seed)
    polys = []
    for _ in range(300):
        k = int(rng.integers(3, 14))
        v = rng.normal(0.0, 10.0, (k, 2))
        polys.append(np.round(v) if rng.random() < 0.4 else v)
    polys += [inflate_polygon(circle_polygon([3.0, -2.0], r, int(n)), m)
              for r, n, m in zip(rng.uniform(0.5, 5.0, 20), rng.integers(3, 40, 20), rng.uniform(0.0, 2.0, 20))]
    seen = 0
    for v in polys:
        for tol in (0.0, 1e-9, 0.5, 1.0):
            want = _numpy_self_intersections(v, tol)
            assert self_intersections(v, tol) == want
            seen += bool(want)
    assert seen > 100


def test_edges_cross_equals_the_numpy_form():
    """Whether two polygons' edges meet (the potential field's overlap check) as numpy's
    segments_intersect over every edge pair, on random and grid-snapped polygons."""
    from mjasc.core.geometry import segments_intersect
    from mjasc.core.polygon_kernels import edges_cross

    rng = np.random.default_rng(11)
    hits = 0
    for _ in range(2000):
        a = rng.normal(0.0, 5.0, (int(rng.integers(3, 10)), 2)) + rng.normal(0.0, 8.0, 2)
        b = rng.normal(0.0, 5.0, (int(rng.integers(3, 10)), 2)) + rng.normal(0.0, 8.0, 2)
        if rng.random() < 0.4:
            a, b = np.round(a), np.round(b)
        for tol in (0.0, 1e-9, 0.5):
            want = bool(np.any(segments_intersect(a[:, None], np.roll(a, -1, axis=0)[:, None], b[None],
                                                  np.roll(b, -1, axis=0)[None], tol)))
            assert edges_cross(a, b, tol) == want
            hits += want
    assert 500 < hits < 5500


def test_polygons_overlap_is_edges_or_containment():
    """polygons_overlap (the potential field's and the plausibility check's one test): edges meeting
    or one polygon inside the other, as the numpy forms both had — on crossing, nested, disjoint and
    touching squares, and on random polygons."""
    from mjasc.core.geometry import point_in_polygon, polygons_overlap, segments_intersect

    sq = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]])
    assert polygons_overlap(sq, sq + [2.0, 2.0])  # edges cross
    assert polygons_overlap(sq, 0.25 * sq + [1.0, 1.0]) and polygons_overlap(0.25 * sq + [1.0, 1.0], sq)  # nested
    assert not polygons_overlap(sq, sq + [10.0, 0.0])  # apart
    assert polygons_overlap(sq, sq + [4.0, 0.0])  # a shared edge touches
    assert not polygons_overlap(sq, sq + [4.0 + 1e-6, 0.0]) and polygons_overlap(sq, sq + [4.0 + 1e-6, 0.0], 1e-3)
    rng = np.random.default_rng(12)
    for _ in range(500):
        a = rng.normal(0.0, 5.0, (int(rng.integers(3, 8)), 2)) + rng.normal(0.0, 8.0, 2)
        b = rng.normal(0.0, 5.0, (int(rng.integers(3, 8)), 2)) + rng.normal(0.0, 8.0, 2)
        want = bool(np.any(segments_intersect(a[:, None], np.roll(a, -1, axis=0)[:, None], b[None],
                                              np.roll(b, -1, axis=0)[None], 0.0))
                    or point_in_polygon(a[:1], b)[0] or point_in_polygon(b[:1], a)[0])
        assert polygons_overlap(a, b) == want


def _numpy_clean_polygon(polygon, name="x"):
    """The numpy form clean_polygon had (its vertices' tests array by array)."""
    from mjasc.core.geometry import polygon_signed_area

    v = np.asarray(polygon, dtype=float)
    scale = float(np.max(np.ptp(v, axis=0))) if len(v) else 0.0
    tol = 1e-9 * max(scale, 1.0)
    keep = np.linalg.norm(v - np.roll(v, 1, axis=0), axis=1) > tol
    if not np.any(keep):
        raise ValueError(f"{name}: needs at least 3 distinct vertices, got 1")
    v = v[keep]
    if len(v) < 3:
        raise ValueError(f"{name}: needs at least 3 distinct vertices, got {len(v)}")
    changed = True
    while changed and len(v) >= 3:
        changed = False
        e_in = v - np.roll(v, 1, axis=0)
        e_out = np.roll(v, -1, axis=0) - v
        cross = e_in[:, 0] * e_out[:, 1] - e_in[:, 1] * e_out[:, 0]
        flat = np.abs(cross) <= 1e-9 * (np.linalg.norm(e_in, axis=1) * np.linalg.norm(e_out, axis=1))
        if np.any(flat):
            i = int(np.argmax(flat))
            if np.dot(e_in[i], e_out[i]) < 0:
                raise ValueError(f"{name}: boundary folds back on itself at vertex {v[i].tolist()} "
                                 "(degenerate, self-overlapping polygon)")
            v = np.delete(v, i, axis=0)
            changed = True
    if len(v) < 3:
        raise ValueError(f"{name}: fewer than 3 non-collinear vertices (polygon has no area)")
    crossings = _numpy_self_intersections(v, tol)
    if crossings:
        i, j = crossings[0]
        raise ValueError(f"{name}: polygon is self-intersecting (edges {i} and {j} cross); give a simple polygon")
    area = polygon_signed_area(v)
    if abs(area) <= 1e-12 * max(scale, 1.0) ** 2:
        raise ValueError(f"{name}: polygon has zero area")
    return v[::-1].copy() if area < 0 else v


def _outcome(fn, v):
    try:
        return fn(v, "x"), None
    except ValueError as err:
        return None, str(err)


def test_clean_polygon_equals_the_numpy_form():
    """The same vertices (bit for bit) or the same error, on random polygons, grid-snapped ones
    (repeated, collinear and folding vertices), explicitly closed rings, inserted midpoints,
    collinear triples, and regular polygons of three scales both ways round."""
    from mjasc.core.geometry import circle_polygon, clean_polygon

    rng = np.random.default_rng(4)
    cases = []
    for _ in range(3000):
        k = int(rng.integers(0, 12))
        v = rng.normal(0.0, 10.0, (k, 2))
        r = rng.random()
        if r < 0.3:
            v = np.round(v / 3.0)
        elif r < 0.5 and k >= 3:
            v = np.insert(v, 1, 0.5 * (v[0] + v[1]), axis=0)
            v = np.insert(v, 0, v[0], axis=0)
        elif r < 0.6 and k >= 1:
            v = np.vstack([v, v[:1]])
        cases.append(v)
    cases += [np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]), np.array([[1.0, 0.0], [2.0, 0.0], [0.0, 0.0]])]
    rings = [circle_polygon([1.0, -2.0], s, 8) for s in (1e-6, 1.0, 1e4)]
    cases += rings + [p[::-1] for p in rings]
    seen = set()
    for v in cases:
        got, err = _outcome(clean_polygon, v)
        want, want_err = _outcome(_numpy_clean_polygon, v)
        assert err == want_err
        assert (got is None and want is None) or (got.shape == want.shape and got.tobytes() == want.tobytes())
        seen.add(err.split(":")[1][:12] if err else "ok")
    assert len(seen) == 5  # kept, too few, folding, collinear only, crossing


def _numpy_offset(v, margin):
    """The numpy form of inflate_polygon's offset vertices (vertex by vertex on 2-vectors)."""
    edges = np.roll(v, -1, axis=0) - v
    t = edges / np.linalg.norm(edges, axis=1, keepdims=True)
    n = np.stack([t[:, 1], -t[:, 0]], axis=1)
    out = []
    for i in range(len(v)):
        t1, n1, t2, n2 = t[i - 1], n[i - 1], t[i], n[i]
        turn = t1[0] * t2[1] - t1[1] * t2[0]
        cos_phi = float(np.clip(n1 @ n2, -1.0, 1.0))
        if turn > 0 and cos_phi < 0.0:
            s = margin * np.tan(np.arccos(cos_phi) / 4.0)
            out.append(v[i] + margin * n1 + s * t1)
            out.append(v[i] + margin * n2 - s * t2)
        else:
            out.append(v[i] + margin * (n1 + n2) / (1.0 + cos_phi))
    return np.array(out)


def test_offset_vertices_equal_the_numpy_form():
    """inflate_polygon's offset vertices (miters and bevels) bit for bit, on random star-shaped
    polygons (convex and concave corners, sharp and blunt) and regular ones, margins 1 cm to 5 m;
    numpy's tan(arccos(·)) and 2-vector dot as math's and x·x' + y·y' on their own too."""
    from mjasc.core.geometry import circle_polygon, clean_polygon
    from mjasc.core.polygon_kernels import offset_vertices

    rng = np.random.default_rng(6)
    polys = [circle_polygon([0.0, 0.0], 3.0, int(k)) for k in (3, 4, 5, 12)]
    for _ in range(400):
        k = int(rng.integers(3, 12))
        th = np.sort(rng.uniform(0.0, 2.0 * np.pi, k))
        r = rng.uniform(0.5, 10.0, k)
        polys.append(np.column_stack([r * np.cos(th), r * np.sin(th)]) + rng.normal(0.0, 20.0, 2))
    bevels = 0
    for p in polys:
        try:
            v = clean_polygon(p)
        except ValueError:
            continue
        for margin in (0.01, 0.5, 1.5, 5.0):
            want = _numpy_offset(v, margin)
            out = np.empty((2 * len(v), 2))
            n = offset_vertices(v, margin, out)
            assert n == len(want) and out[:n].tobytes() == want.tobytes()
            bevels += n - len(v)
    assert bevels > 100
    c = rng.uniform(-1.0, 1.0, 200_000)
    a, b = rng.normal(size=(2000, 2)), rng.normal(size=(2000, 2))
    assert np.array_equal([x @ y for x, y in zip(a, b)], a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1])
    assert all(float(np.tan(np.arccos(x) / 4.0)) == math.tan(math.acos(x) / 4.0) for x in c[:20_000].tolist())
