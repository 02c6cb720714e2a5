"""Tests for mjasc.guidance.paths: lengths, continuity, curvature, projection, cross-track sign, editing."""

import numpy as np
import pytest

from mjasc.guidance.paths import ArcSegment, LineSegment, Path


def _random_path(rng):
    """A zig-zag of 6 waypoints with rounded corners (radius 5 m)."""
    pts = np.cumsum(rng.uniform(20.0, 40.0, size=(6, 2)) * [1.0, 1.0], axis=0)
    pts[:, 1] *= rng.choice([-1.0, 1.0], size=6)
    return Path.from_waypoints(pts, turn_radius_m=5.0)


def test_line_length_point_and_tangent():
    p = Path.line([1.0, 2.0], [4.0, 6.0])
    assert p.length == pytest.approx(5.0)
    np.testing.assert_allclose(p.point(2.5), [2.5, 4.0])
    assert p.tangent_angle(1.0) == pytest.approx(np.arctan2(4.0, 3.0))
    assert p.curvature(1.0) == 0.0
    # clamping
    np.testing.assert_allclose(p.point([-3.0, 99.0]), [[1.0, 2.0], [4.0, 6.0]])


def test_arc_length_curvature_and_geometry():
    # CCW quarter circle of radius 10 centred at the origin, from (10, 0) to (0, 10).
    p = Path.from_segments([ArcSegment([0.0, 0.0], 10.0, 0.0, np.pi / 2)])
    assert p.length == pytest.approx(5.0 * np.pi)
    assert p.curvature(3.0) == pytest.approx(0.1)
    g = np.linspace(0.0, p.length, 17)
    np.testing.assert_allclose(np.hypot(*p.point(g).T), 10.0)
    np.testing.assert_allclose(p.point(p.length), [0.0, 10.0], atol=1e-12)
    assert p.tangent_angle(0.0) == pytest.approx(np.pi / 2)
    # CW arc: negative curvature
    q = Path.from_segments([ArcSegment([0.0, 0.0], 4.0, np.pi / 2, -np.pi)])
    assert q.curvature(1.0) == pytest.approx(-0.25)
    np.testing.assert_allclose(q.point(q.length), [0.0, -4.0], atol=1e-12)
    assert q.tangent_angle(0.0) == pytest.approx(0.0)


@pytest.mark.parametrize("radius", [0.0, 5.0, 20.0])
def test_l_shape_length(radius):
    a, b = 100.0, 60.0
    p = Path.from_waypoints([[0, 0], [a, 0], [a, b]], turn_radius_m=radius)
    assert p.length == pytest.approx(a + b - 2 * radius + np.pi * radius / 2)
    if radius > 0:
        # middle of the corner arc is at distance R(√2 − 1) from the corner, inside the turn
        mid = p.point(a - radius + np.pi * radius / 4)
        centre = np.array([a - radius, radius])
        assert np.hypot(*(mid - centre)) == pytest.approx(radius)
        assert p.curvature(a - radius + 1e-3) == pytest.approx(1.0 / radius)


def test_right_turn_corner_has_negative_curvature():
    p = Path.from_waypoints([[0, 0], [50, 0], [50, -50]], turn_radius_m=10.0)
    assert p.curvature(45.0) == pytest.approx(-0.1)
    assert p.length == pytest.approx(100 - 20 + 5 * np.pi)


def test_continuity_of_point_and_tangent_at_joints():
    rng = np.random.default_rng(0)
    p = _random_path(rng)
    eps = 1e-7
    for g in p.segment_starts[1:]:
        np.testing.assert_allclose(p.point(g - eps), p.point(g + eps), atol=1e-6)
        d = np.angle(np.exp(1j * (p.tangent_angle(g + eps) - p.tangent_angle(g - eps))))
        assert abs(d) < 1e-5
    # finite-difference tangent agrees with tangent_angle everywhere
    g = np.linspace(0.01, p.length - 0.01, 400)
    h = 1e-5
    d = p.point(g + h) - p.point(g - h)
    fd = np.arctan2(d[:, 1], d[:, 0])
    np.testing.assert_allclose(np.angle(np.exp(1j * (fd - p.tangent_angle(g)))), 0.0, atol=1e-6)
    # and unit speed: |dp/dγ| = 1
    np.testing.assert_allclose(np.hypot(*d.T) / (2 * h), 1.0, atol=1e-6)


def test_curvature_matches_finite_difference_of_tangent():
    p = _random_path(np.random.default_rng(1))
    g = np.linspace(0.5, p.length - 0.5, 300)
    h = 1e-4
    dth = np.angle(np.exp(1j * (p.tangent_angle(g + h) - p.tangent_angle(g - h)))) / (2 * h)
    near_joint = np.min(np.abs(g[:, None] - p.segment_starts[None, :]), axis=1) < 2 * h
    np.testing.assert_allclose(dth[~near_joint], p.curvature(g)[~near_joint], atol=1e-6)


def test_project_matches_brute_force():
    rng = np.random.default_rng(2)
    p = _random_path(rng)
    dense_g = np.linspace(0.0, p.length, 200001)
    dense = p.point(dense_g)
    lo, hi = dense.min(axis=0) - 20, dense.max(axis=0) + 20
    for q in rng.uniform(lo, hi, size=(60, 2)):
        g = p.project(q)
        d_brute = np.min(np.hypot(*(dense - q).T))
        d_proj = np.hypot(*(p.point(g) - q))
        assert d_proj <= d_brute + 1e-9
        assert d_proj == pytest.approx(d_brute, abs=1e-3)


def test_project_exact_on_line_and_arc():
    p = Path.from_waypoints([[0, 0], [100, 0], [100, 100]], turn_radius_m=20.0)
    assert p.project([30.0, -7.0]) == pytest.approx(30.0)
    # point on the bisector of the corner → middle of the arc
    centre = np.array([80.0, 20.0])
    q = centre + 5.0 * np.array([np.cos(-np.pi / 4), np.sin(-np.pi / 4)])
    assert p.project(q) == pytest.approx(80.0 + np.pi * 20.0 / 4)
    # beyond the ends: clamps
    assert p.project([-10.0, 3.0]) == 0.0
    assert p.project([100.0, 150.0]) == pytest.approx(p.length)


def test_project_with_hint_keeps_continuity_on_self_crossing_path():
    # A figure-eight-ish path that passes the point (50, 0) twice.
    p = Path.from_waypoints([[0, 0], [100, 0], [100, 40], [50, 40], [50, -40]], turn_radius_m=0.0)
    q = [50.5, 0.2]  # 0.2 m from the first pass, 0.5 m from the second
    assert p.project(q) == pytest.approx(50.5)  # global: the nearer, first pass
    g_second = 100 + 40 + 50 + 40 - 0.2  # on the last leg going south (y = 0.2)
    assert p.project(q, gamma_hint=g_second - 2.0, search_window_m=10.0) == pytest.approx(g_second)
    with pytest.raises(ValueError, match="gamma_hint"):
        p.project(q, gamma_hint=3.0)


def test_cross_track_sign():
    p = Path.line([0, 0], [10, 0])  # going east: north is left
    assert p.cross_track_error([5, 2], 5.0) == pytest.approx(2.0)
    assert p.cross_track_error([5, -3], 5.0) == pytest.approx(-3.0)
    q = Path.line([0, 0], [0, 10])  # going north: west is left
    assert q.cross_track_error([-1, 5], 5.0) == pytest.approx(1.0)


def test_split_concatenate_round_trip():
    p = _random_path(np.random.default_rng(3))
    g_cut = 0.37 * p.length
    a, b = p.split(g_cut)
    assert a.length == pytest.approx(g_cut)
    assert a.length + b.length == pytest.approx(p.length)
    joined = a.concatenate(b)
    g = np.linspace(0, p.length, 1001)
    np.testing.assert_allclose(joined.point(g), p.point(g), atol=1e-9)
    np.testing.assert_allclose(joined.curvature(g[1:-1]), p.curvature(g[1:-1]))
    sub = p.sub_path(10.0, 60.0)
    assert sub.length == pytest.approx(50.0)
    np.testing.assert_allclose(sub.point([0.0, 25.0, 50.0]), p.point([10.0, 35.0, 60.0]), atol=1e-9)


def test_splice_detour():
    p = Path.line([0, 0], [100, 0])
    before, rest = p.split(40.0)
    _, after = rest.split(20.0)
    detour = Path.from_waypoints([[40, 0], [45, 10], [55, 10], [60, 0]])
    new = before.concatenate(detour).concatenate(after)
    assert new.length == pytest.approx(40 + 2 * np.hypot(5, 10) + 10 + 40)
    np.testing.assert_allclose(new.end_point, [100, 0])


def test_from_points_dense_polyline():
    t = np.linspace(0, np.pi, 2001)
    pts = np.stack([50 * np.cos(t), 50 * np.sin(t)], axis=1)
    pts = np.insert(pts, 10, pts[10], axis=0)  # a stagnation-point duplicate is dropped
    p = Path.from_points(pts)
    assert p.length == pytest.approx(50 * np.pi, rel=1e-6)
    assert len(p.segments) == 2000
    assert p.project([0.0, 60.0]) == pytest.approx(25 * np.pi, rel=1e-6)


def _same_arrays(a: Path, b: Path) -> bool:
    """Bit for bit the same path arrays (table, γ at the joints, the scalar queries' rows)."""
    return (np.array_equal(a.table, b.table) and np.array_equal(a.segment_starts, b.segment_starts)
            and a.length == b.length and a._rows == b._rows)


def test_polylines_and_joined_paths_hold_their_segments_arrays_bit_for_bit():
    """A path from points (its arrays computed for all segments at once) and a path joined from
    others (its table from theirs) are bit for bit the paths built segment by segment; their
    segments, made only when asked for, are those segments; editing them gives the same paths."""
    rng = np.random.default_rng(11)
    for trial in range(300):
        n = int(rng.integers(2, 200))
        pts = np.cumsum(rng.normal(size=(n, 2)) * rng.uniform(0.01, 50.0), axis=0) + rng.uniform(-1e4, 1e4, 2)
        if trial % 5 == 0:
            pts[1::4] = pts[0::4][:len(pts[1::4])]  # consecutive duplicates, dropped
        try:
            fast = Path.from_points(pts)
        except ValueError:  # (all points one)
            continue
        assert fast._segments is None  # (not made yet)
        keep = np.concatenate([[True], np.hypot(*np.diff(pts, axis=0).T) > 1e-9])
        q = pts[keep]
        slow = Path([LineSegment(q[i], q[i + 1]) for i in range(len(q) - 1)])
        assert _same_arrays(fast, slow)
        np.testing.assert_array_equal(fast.start_point, q[0])
        np.testing.assert_array_equal(fast.end_point, q[-1])
        end = fast.end_point
        arc = Path.from_waypoints([end + [10.0, 3.0], end + [40.0, 50.0], end + [90.0, 10.0]], turn_radius_m=8.0)
        link = Path.line(end, end + [10.0, 3.0])
        joined = fast.concatenate(link).concatenate(arc)
        assert fast._segments is None and joined._segments is None  # (joining makes no segment)
        np.testing.assert_array_equal(joined.end_point, arc.end_point)
        whole = Path([*slow.segments, *link.segments, *arc.segments])
        assert _same_arrays(joined, whole)
        assert all(type(a) is LineSegment and np.array_equal(a.start, b.start) and np.array_equal(a.end, b.end)
                   for a, b in zip(fast.segments, slow.segments, strict=True))
        assert all(a is b for a, b in zip(joined.segments, [*fast.segments, *link.segments, *arc.segments],
                                          strict=True))
        cut = float(rng.uniform(0.1, 0.9)) * joined.length
        for x, y in zip(joined.split(cut), whole.split(cut)):
            assert _same_arrays(x, y)
    pts = np.array([[0.0, 0.0], [3.0, 4.0]])
    p = Path.from_points(pts)
    pts[1] = [9.0, 9.0]  # the path holds its own copy
    np.testing.assert_array_equal(p.end_point, [3.0, 4.0])


def test_sample_spacing():
    p = Path.from_waypoints([[0, 0], [10, 0], [10, 10]], turn_radius_m=2.0)
    s = p.sample(0.5)
    steps = np.hypot(*np.diff(s, axis=0).T)
    assert steps.max() <= 0.5 + 1e-9
    np.testing.assert_allclose(s[0], [0, 0])
    np.testing.assert_allclose(s[-1], [10, 10])


def test_validation_errors_name_the_field():
    with pytest.raises(ValueError, match=r"waypoints\[2\]: repeats the previous point"):
        Path.from_waypoints([[0, 0], [1, 0], [1, 0], [2, 2]])
    with pytest.raises(ValueError, match="waypoints: expected shape"):
        Path.from_waypoints([[0, 0]])
    with pytest.raises(ValueError, match=r"turn_radius_m: .*waypoints\[1\]"):
        Path.from_waypoints([[0, 0], [5, 0], [5, 5]], turn_radius_m=10.0)
    with pytest.raises(ValueError, match=r"waypoints\[1\]: the path reverses"):
        Path.from_waypoints([[0, 0], [5, 0], [0, 0]], turn_radius_m=1.0)
    with pytest.raises(ValueError, match=r"segments\[1\]: starts"):
        Path.from_segments([LineSegment([0, 0], [1, 0]), LineSegment([2, 0], [3, 0])])
    with pytest.raises(ValueError, match="ArcSegment.radius"):
        ArcSegment([0, 0], -1.0, 0.0, 1.0)
    with pytest.raises(ValueError, match="ArcSegment.sweep"):
        ArcSegment([0, 0], 1.0, 0.0, 0.0)
    with pytest.raises(ValueError, match="LineSegment.end"):
        LineSegment([0, 0], [0, 0])
    with pytest.raises(ValueError, match="gamma"):
        Path.line([0, 0], [1, 0]).split(1.0)
    with pytest.raises(ValueError, match="other: starts"):
        Path.line([0, 0], [1, 0]).concatenate(Path.line([5, 0], [6, 0]))
    with pytest.raises(ValueError, match="spacing_m"):
        Path.line([0, 0], [1, 0]).sample(0.0)


def test_closest_points_vectorized_matches_project_and_respects_stretch():
    rng = np.random.default_rng(4)
    p = _random_path(rng)
    q = rng.uniform(-20, 150, size=(50, 2))
    g, d = p.closest_points(q)
    np.testing.assert_allclose(g, [p.project(x) for x in q], atol=1e-9)
    np.testing.assert_allclose(d, np.hypot(*(p.point(g) - q).T), atol=1e-9)
    g2, d2 = p.closest_points(q, gamma_min=30.0, gamma_max=60.0)
    assert np.all((g2 >= 30.0 - 1e-9) & (g2 <= 60.0 + 1e-9))
    assert np.all(d2 >= d - 1e-12)
