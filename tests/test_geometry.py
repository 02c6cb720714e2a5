"""core.geometry against closed forms and a reference (Andrew's monotone chain, written out here)."""

import numpy as np
import pytest

from mjasc.core.geometry import (
    circle_polygon,
    clean_polygon,
    convex_hull,
    counter_clockwise,
    disc_hull,
    distance_to_polygon,
    inflate_polygon,
    point_in_polygon,
    polygon_signed_area,
    segments_intersect,
    self_intersections,
    signed_distance_to_polygon,
)

SQUARE = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]])  # CCW, side 2, area 4


def _andrew(p):
    p = np.unique(np.round(np.asarray(p, dtype=float), 6), axis=0)
    if p.shape[0] <= 2:
        return p

    def half(q):
        out = []
        for pt in q:
            while len(out) >= 2 and ((out[-1][0] - out[-2][0]) * (pt[1] - out[-2][1])
                                     - (out[-1][1] - out[-2][1]) * (pt[0] - out[-2][0])) <= 0:
                out.pop()
            out.append(pt)
        return out

    lower, upper = half(p), half(p[::-1])
    return np.array(lower[:-1] + upper[:-1])


def test_convex_hull_matches_monotone_chain_including_degenerate_sets():
    rng = np.random.default_rng(0)
    for n in (3, 4, 7, 40):
        for _ in range(100):
            p = rng.normal(size=(n, 2)) * rng.uniform(0.1, 10)
            if rng.random() < 0.3:
                p = np.round(p)  # duplicates and collinear points
            assert np.allclose(convex_hull(p), _andrew(p))
    assert np.allclose(convex_hull([[0, 0], [1, 1], [2, 2]]), [[0, 0], [2, 2]])


def test_convex_hull_of_a_square_with_inner_points_is_its_corners_ccw():
    sq = np.array([[0, 0], [2, 0], [2, 2], [0, 2], [1, 1], [1, 0]], dtype=float)
    h = convex_hull(sq)
    assert np.allclose(h, [[0, 0], [2, 0], [2, 2], [0, 2]])
    assert polygon_signed_area(h) == pytest.approx(4.0)  # counter-clockwise


def test_convex_hull_exact_mode_is_the_same_hull_in_qhull_order():
    rng = np.random.default_rng(1)
    p = rng.normal(size=(50, 2)) * 7.3
    exact = convex_hull(p, canonical=False)
    assert polygon_signed_area(exact) > 0
    k = int(np.lexsort((exact[:, 1], exact[:, 0]))[0])
    assert np.allclose(np.roll(exact, -k, axis=0), convex_hull(p), atol=1e-6)
    assert all(np.any(np.all(p == v, axis=1)) for v in exact)  # exact input coordinates


# ------------------------------------------------------------------ distances and containment
def test_distance_to_a_square_in_closed_form():
    pts = np.array([[3.0, 1.0], [3.0, 3.0], [-1.0, -2.0], [1.0, 1.0], [1.0, 0.5], [0.0, 1.0], [2.0, 2.0]])
    expected = np.array([1.0, np.sqrt(2.0), np.sqrt(5.0), 1.0, 0.5, 0.0, 0.0])
    np.testing.assert_allclose(distance_to_polygon(pts, SQUARE), expected, atol=1e-15)
    inside = np.array([False, False, False, True, True])
    assert np.array_equal(point_in_polygon(pts[:5], SQUARE), inside)
    np.testing.assert_allclose(signed_distance_to_polygon(pts[:5], SQUARE), np.where(inside, -1, 1) * expected[:5],
                               atol=1e-15)
    # one point as a (2,) array, and a clockwise polygon, give the same
    assert distance_to_polygon(np.array([3.0, 1.0]), SQUARE[::-1]).shape == (1,)
    assert signed_distance_to_polygon(np.array([1.0, 0.5]), SQUARE[::-1])[0] == pytest.approx(-0.5)


def test_signed_distance_inside_a_concave_polygon_and_both_forms_agree():
    ell = np.array([[0, 0], [4, 0], [4, 1], [1, 1], [1, 4], [0, 4]], dtype=float)  # an L, width 1
    assert point_in_polygon(np.array([[0.5, 3.0], [3.0, 0.5]]), ell).all()
    assert not point_in_polygon(np.array([[2.0, 2.0]]), ell)[0]  # in the notch
    assert signed_distance_to_polygon(np.array([[0.5, 3.0]]), ell)[0] == pytest.approx(-0.5)
    assert signed_distance_to_polygon(np.array([[2.0, 2.0]]), ell)[0] == pytest.approx(1.0)
    rng = np.random.default_rng(2)
    pts = rng.uniform(-2, 6, size=(400, 2))
    d = distance_to_polygon(pts, ell)
    np.testing.assert_allclose(np.abs(signed_distance_to_polygon(pts, ell)), d, rtol=0, atol=1e-12)
    assert np.array_equal(signed_distance_to_polygon(pts, ell) < 0, point_in_polygon(pts, ell))


def test_zero_length_edges_are_measured_to_their_vertex():
    dup = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]])
    pts = np.array([[3.0, -1.0], [1.0, 1.0]])
    np.testing.assert_allclose(distance_to_polygon(pts, dup), [np.sqrt(2.0), 1.0])
    np.testing.assert_allclose(signed_distance_to_polygon(pts, dup), [np.sqrt(2.0), -1.0])


# ------------------------------------------------------------------ orientation
def test_orientation_by_signed_area():
    assert polygon_signed_area(SQUARE) == 4.0
    assert polygon_signed_area(SQUARE[::-1]) == -4.0
    assert counter_clockwise(SQUARE) is SQUARE
    cw = SQUARE[::-1].copy()
    out = counter_clockwise(cw)
    assert np.array_equal(out, SQUARE) and out is not cw
    tri = np.array([[0.0, 0.0], [3.0, 0.0], [0.0, 4.0]])
    assert polygon_signed_area(tri) == pytest.approx(6.0)


# ------------------------------------------------------------------ circles
@pytest.mark.parametrize("n", [8, 12, 16, 32, 128])
def test_circle_polygon_areas_bracket_pi_r_squared(n):
    r, c = 2.5, np.array([3.0, -1.0])
    outer = circle_polygon(c, r, n)
    inner = circle_polygon(c, r, n, circumscribed=False)
    assert outer.shape == inner.shape == (n, 2)
    assert polygon_signed_area(outer) == pytest.approx(n * r**2 * np.tan(np.pi / n), rel=1e-12)  # CCW
    assert polygon_signed_area(inner) == pytest.approx(0.5 * n * r**2 * np.sin(2 * np.pi / n), rel=1e-12)
    assert polygon_signed_area(inner) < np.pi * r**2 < polygon_signed_area(outer)
    assert polygon_signed_area(outer) / (np.pi * r**2) - 1 < 1.1 * (np.pi / n) ** 2 / 3  # tan x / x − 1 ≈ x²/3
    np.testing.assert_allclose(np.hypot(*(inner - c).T), r)
    np.testing.assert_allclose(np.hypot(*(outer - c).T), r / np.cos(np.pi / n))
    # the circumscribed polygon's edges touch the circle: the disc lies inside it
    assert distance_to_polygon(c, outer)[0] == pytest.approx(r, rel=1e-12)
    np.testing.assert_allclose(outer[0], c + [r / np.cos(np.pi / n), 0.0])  # starts at angle 0


def test_closed_circle_repeats_its_first_point():
    ring = circle_polygon([0.0, 0.0], 1.0, 16, circumscribed=False, closed=True)
    assert ring.shape == (17, 2)
    np.testing.assert_allclose(ring[-1], ring[0], atol=1e-15)
    assert np.array_equal(ring[:16], circle_polygon([0.0, 0.0], 1.0, 16, circumscribed=False))


def test_disc_hull_contains_every_disc():
    centres = np.array([[0.0, 0.0], [5.0, 1.0], [9.0, -2.0], [4.0, 3.0]])
    hull = disc_hull(centres, 1.5)
    assert polygon_signed_area(hull) > 0
    assert point_in_polygon(centres, hull).all()
    assert (distance_to_polygon(centres, hull) >= 1.5 - 1e-12).all()


# ------------------------------------------------------------------ clean-up and inflation
def test_clean_polygon_drops_repeats_merges_collinear_and_orients_ccw():
    ring = np.vstack([SQUARE[::-1], SQUARE[-1:]])  # clockwise, closed explicitly
    with_mid = np.insert(ring, 4, [[0.0, 1.0]], axis=0)  # a collinear vertex on the edge (0, 0)–(0, 2)
    out = clean_polygon(with_mid)
    assert len(out) == 4 and polygon_signed_area(out) == pytest.approx(4.0)
    with pytest.raises(ValueError, match="quay: polygon is self-intersecting"):
        clean_polygon(np.array([[0.0, 0.0], [2.0, 2.0], [2.0, 0.0], [0.0, 2.0]]), "quay")


def test_inflated_square_is_the_square_grown_by_the_margin():
    d = 0.5
    out = inflate_polygon(SQUARE, d)
    assert polygon_signed_area(out) == pytest.approx((2.0 + 2 * d) ** 2)  # right-angle corners: miters
    assert (signed_distance_to_polygon(SQUARE, out) <= -d * (1 - 1e-12)).all()


def test_segment_intersections():
    o, x, y, xy = np.array([0.0, 0.0]), np.array([2.0, 0.0]), np.array([0.0, 2.0]), np.array([2.0, 2.0])
    assert segments_intersect(o, xy, x, y, 1e-9)  # an X
    assert segments_intersect(o, x, np.array([1.0, 0.0]), np.array([1.0, 1.0]), 1e-9)  # a T touches
    assert not segments_intersect(o, x, y, xy, 1e-9)  # parallel
    bowtie = np.array([[0.0, 0.0], [2.0, 2.0], [2.0, 0.0], [0.0, 2.0]])
    assert self_intersections(bowtie, 1e-9) == [(0, 2)]
    assert self_intersections(SQUARE, 1e-9) == []


def test_points_near_polygon_is_inside_or_within_the_margin():
    from mjasc.core.geometry import points_near_polygon

    square = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]])
    assert points_near_polygon(np.array([[1.0, 1.0]]), square, 0.1)  # inside, whatever the margin
    assert points_near_polygon(np.array([[5.0, 5.0], [2.5, 1.0]]), square, 0.6)  # one point 0.5 m off
    assert not points_near_polygon(np.array([[5.0, 5.0], [2.5, 1.0]]), square, 0.5)  # (strictly closer)
    assert not points_near_polygon(np.array([[-3.0, 1.0]]), square, 2.9)
