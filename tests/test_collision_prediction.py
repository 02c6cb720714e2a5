"""Tests for mjasc.avoidance.prediction against closed forms and the thesis's §6.1 numbers."""

import numpy as np
import pytest
from matplotlib.path import Path as MplPath
from scipy.optimize import brentq

from mjasc.avoidance.prediction import (
    CollisionPredictionConfig,
    Decision,
    gamma_of_time,
    predict_conflicts,
    prediction_window,
    swept_disc_polygon,
)
from mjasc.core.estimates import TrackEstimate
from mjasc.core.geometry import circle_polygon
from mjasc.core.geometry import polygon_signed_area as _signed_area
from mjasc.guidance.paths import Path


def _track(tid, t, pos, heading, speed, turn=0.0, radius=2.5, **kw):
    return TrackEstimate(tid, t, np.asarray(pos, float), heading, speed, turn, radius, **kw)


def _contains(poly, pts):
    return MplPath(np.vstack([poly, poly[:1]]), closed=True).contains_points(pts)


def _disc_points(centres, radius, n=24):
    return np.concatenate([circle_polygon(c, radius, n, circumscribed=False) for c in centres])


# ----------------------------------------------------------------------------- window
def test_prediction_window():
    assert prediction_window(1.0, 0.2, 5.0) == pytest.approx(10.0)  # δ = v/a + ζ
    assert prediction_window(1.0, 0.2, 5.0, fixed_s=30.0) == 30.0
    with pytest.raises(ValueError, match="brake_decel_m_s2"):
        prediction_window(1.0, 0.0, 5.0)
    with pytest.raises(ValueError, match="speed_m_s"):
        prediction_window(-1.0, 0.1, 5.0)


def test_dynamic_window_sets_grid_length():
    path = Path.line([0, 0], [500, 0])
    cfg = CollisionPredictionConfig(window_s=None, brake_decel_m_s2=0.1, margin_s=5.0)
    far = _track(1, 0.0, [400, 100], 0.0, 0.0)
    (c,) = predict_conflicts(path, 0.0, 0.0, 2.0, 2.5, [far], cfg, include_clear=True)
    assert c.times[-1] == pytest.approx(2.0 / 0.1 + 5.0)


# ----------------------------------------------------------------------------- temporal correlation
@pytest.mark.parametrize(
    "obst_pos, obst_heading, obst_speed, vessel_speed",
    [
        ([60.0, 0.0], np.pi, 1.0, 1.0),  # head-on
        ([60.0, 3.0], np.pi, 1.5, 1.0),  # head-on with a 3 m lateral offset
        ([40.0, -30.0], np.pi / 2, 1.0, 1.0),  # crossing from starboard
        ([10.0, -40.0], 1.1, 1.3, 0.8),  # oblique crossing
    ],
)
def test_closest_approach_matches_closed_form(obst_pos, obst_heading, obst_speed, vessel_speed):
    path = Path.line([0, 0], [300, 0])
    tr = _track(7, 0.0, obst_pos, obst_heading, obst_speed)
    cfg = CollisionPredictionConfig(window_s=80.0, time_step_s=0.5)
    (c,) = predict_conflicts(path, 0.0, 0.0, vessel_speed, 2.5, [tr], cfg, include_clear=True)
    # Relative motion r(t) = r0 + w t: t* = −r0·w/|w|², d* = |r0 + w t*|.
    r0 = np.asarray(obst_pos)
    w = obst_speed * np.array([np.cos(obst_heading), np.sin(obst_heading)]) - [vessel_speed, 0.0]
    t_star = -r0 @ w / (w @ w)
    d_star = np.hypot(*(r0 + w * t_star))
    assert c.t_closest_s == pytest.approx(t_star, abs=1e-4)
    assert c.min_distance_m == pytest.approx(d_star, abs=1e-6)
    assert c.collision == (d_star <= 6.0)
    assert c.collision_distance_m == pytest.approx(6.0)


def test_passing_wide_is_no_conflict():
    path = Path.line([0, 0], [300, 0])
    tr = _track(1, 0.0, [80, 20], np.pi, 1.0)  # parallel, 20 m abeam: d_min = 20 > 6
    cfg = CollisionPredictionConfig(window_s=60.0)
    assert predict_conflicts(path, 0.0, 0.0, 1.0, 2.5, [tr], cfg) == []
    (c,) = predict_conflicts(path, 0.0, 0.0, 1.0, 2.5, [tr], cfg, include_clear=True)
    assert not c.collision and c.decision is Decision.NONE and c.svo_polygon is None
    assert c.min_distance_m == pytest.approx(20.0)
    assert np.isnan(c.obstruction_s)


def _u_turn_path():
    """East 100 m along y = 0, a 90° turn north for 8 m, then west along y = 8."""
    return Path.from_waypoints([[0, 0], [100, 0], [100, 8], [0, 8]])


def test_first_local_minimum_is_taken_not_the_global_one():
    # Static obstacle at (50, 5): the first pass (y = 0) is 5 m away at t = 25 s, the second pass
    # (y = 8) only 3 m away at t = (100 + 8 + 50)/2 = 79 s. Both are collisions; t_c is the first.
    cfg = CollisionPredictionConfig(window_s=100.0)
    tr = _track(3, 0.0, [50, 5], 0.0, 0.0, is_static=True)
    (c,) = predict_conflicts(_u_turn_path(), 0.0, 0.0, 2.0, 2.5, [tr], cfg)
    assert c.t_closest_s == pytest.approx(25.0, abs=1e-4)
    assert c.min_distance_m == pytest.approx(5.0, abs=1e-6)
    assert c.min_distance_m > np.min(np.hypot(*(c.vessel_positions - [50, 5]).T)) + 1.0


def test_near_miss_first_then_collision_later():
    # Obstacle at (50, 12): the first pass misses (12 m at t = 25 s), the second pass hits
    # (4 m at t = 79 s).
    tr = _track(4, 0.0, [50, 12], 0.0, 0.0, is_static=True)
    cfg = CollisionPredictionConfig(window_s=100.0)
    (c,) = predict_conflicts(_u_turn_path(), 0.0, 0.0, 2.0, 2.5, [tr], cfg)
    assert c.collision and c.t_closest_s == pytest.approx(79.0, abs=1e-4)
    assert c.min_distance_m == pytest.approx(4.0, abs=1e-6)
    # The thesis's rule stops at the first minimum, a near miss: no collision predicted.
    thesis = CollisionPredictionConfig(window_s=100.0, stop_at_first_minimum=True)
    assert predict_conflicts(_u_turn_path(), 0.0, 0.0, 2.0, 2.5, [tr], thesis) == []
    (c1,) = predict_conflicts(_u_turn_path(), 0.0, 0.0, 2.0, 2.5, [tr], thesis, include_clear=True)
    assert c1.t_closest_s == pytest.approx(25.0, abs=1e-4) and not c1.collision


# ----------------------------------------------------------------------------- spatial correlation
@pytest.mark.parametrize("speed", [0.5, 1.0, 2.0])
def test_obstruction_interval_of_a_perpendicular_crossing(speed):
    # Straight path along y = 0; obstacle crossing it perpendicularly at x = 50 at t = 50 s.
    # The inflated disc (R = 2.5 + 2.5 + 1 = 6 m) meets the path while |y| ≤ R: Δt_o = 2R/V,
    # and covers the stretch [50 − R, 50 + R].
    R = 6.0
    path = Path.line([0, 0], [200, 0])
    tr = _track(1, 0.0, [50.0, -50.0 * speed], np.pi / 2, speed)
    cfg = CollisionPredictionConfig(window_s=60.0, obstruction_threshold_s=1e3)
    (c,) = predict_conflicts(path, 0.0, 0.0, 1.0, 2.5, [tr], cfg)
    assert c.t_closest_s == pytest.approx(50.0, abs=1e-4) and c.min_distance_m < 1e-6
    assert c.t_i == pytest.approx(50.0 - R / speed, abs=1e-5)
    assert c.t_f == pytest.approx(50.0 + R / speed, abs=1e-5)
    assert c.obstruction_s == pytest.approx(2 * R / speed, abs=1e-5)
    assert c.gamma_a == pytest.approx(50.0 - R, abs=1e-4)
    assert c.gamma_b == pytest.approx(50.0 + R, abs=1e-4)
    np.testing.assert_allclose(c.point_a, [50.0 - R, 0.0], atol=1e-4)
    np.testing.assert_allclose(c.point_b, [50.0 + R, 0.0], atol=1e-4)
    assert c.decision is Decision.VELOCITY_CORRECTION


def test_obstructed_stretch_of_an_oblique_crossing():
    # Crossing at angle α: the disc touches the path while |y| ≤ R, i.e. for 2R/(V sin α);
    # the union of the discs covers the path within R of the straight track: half-width R/sin α.
    R, V, alpha = 6.0, 1.5, np.radians(40)
    path = Path.line([0, 0], [300, 0])
    t_x = 60.0
    start = np.array([120.0, 0.0]) - V * t_x * np.array([np.cos(alpha), np.sin(alpha)])
    tr = _track(2, 0.0, start, alpha, V)
    cfg = CollisionPredictionConfig(window_s=90.0, obstruction_threshold_s=1e3)
    (c,) = predict_conflicts(path, 0.0, 0.0, 2.0, 2.5, [tr], cfg)
    assert c.obstruction_s == pytest.approx(2 * R / (V * np.sin(alpha)), abs=1e-5)
    assert c.gamma_a == pytest.approx(120.0 - R / np.sin(alpha), abs=1e-3)
    assert c.gamma_b == pytest.approx(120.0 + R / np.sin(alpha), abs=1e-3)


@pytest.mark.parametrize("threshold, expected", [(11.9, Decision.REPLAN), (12.1, Decision.VELOCITY_CORRECTION)])
def test_decision_switches_at_the_threshold(threshold, expected):
    path = Path.line([0, 0], [200, 0])
    tr = _track(1, 0.0, [50.0, -50.0], np.pi / 2, 1.0)  # Δt_o = 12 s
    cfg = CollisionPredictionConfig(window_s=60.0, obstruction_threshold_s=threshold)
    (c,) = predict_conflicts(path, 0.0, 0.0, 1.0, 2.5, [tr], cfg)
    assert c.obstruction_s == pytest.approx(12.0, abs=1e-5)
    assert c.decision is expected
    if expected is Decision.REPLAN:
        poly = c.svo_polygon
        assert poly.ndim == 2 and poly.shape[1] == 2 and _signed_area(poly) > 0  # CCW
        swept = tr.predict_positions(np.linspace(c.t_i, c.t_f, 50))
        assert _contains(poly, _disc_points(swept, 6.0 - 1e-6)).all()
        # not grossly larger than the swept area (stadium 12 m wide, 12 m long + caps)
        assert _signed_area(poly) < 1.15 * (12 * 12 + np.pi * 36)
    else:
        assert c.svo_polygon is None


def test_static_obstacle_always_replans():
    path = Path.line([0, 0], [200, 0])
    tr = _track(9, 0.0, [80, 3], 0.0, 0.0, radius=4.0, is_static=True)
    cfg = CollisionPredictionConfig(window_s=100.0, obstruction_threshold_s=1e6)
    (c,) = predict_conflicts(path, 10.0, 0.0, 1.0, 2.5, [tr], cfg)
    assert c.decision is Decision.REPLAN and c.t_f == np.inf and c.t_i == 0.0
    assert c.t_closest_s == pytest.approx(70.0, abs=1e-4) and c.min_distance_m == pytest.approx(3.0)
    r = 4.0 + 2.5 + 1.0
    half = np.sqrt(r**2 - 3.0**2)
    assert c.gamma_a == pytest.approx(80 - half, abs=1e-4) and c.gamma_b == pytest.approx(80 + half, abs=1e-4)
    assert _signed_area(c.svo_polygon) > 0
    assert _contains(c.svo_polygon, _disc_points([[80, 3]], r - 1e-6)).all()
    # with an outline: the SVO is the outline inflated by R_vh + safety
    outline = np.array([[76, 0], [84, 0], [84, 6], [76, 6]], float)
    tr2 = _track(10, 0.0, [80, 3], 0.0, 0.0, radius=5.0, is_static=True, outline_m=outline)
    (c2,) = predict_conflicts(path, 10.0, 0.0, 1.0, 2.5, [tr2], cfg)
    assert _contains(c2.svo_polygon, _disc_points(outline, 3.5 - 1e-6)).all()
    assert _signed_area(c2.svo_polygon) > 0


def test_swept_polygon_of_a_turning_obstacle_contains_the_swept_discs():
    tr = _track(1, 0.0, [0, 0], 0.3, 1.5, turn=0.05)
    for t_b, R in [(20.0, 6.0), (50.0, 6.0), (90.0, 6.0), (20.0, 40.0)]:  # the last two: hull fallback
        poly = swept_disc_polygon(tr, 0.0, t_b, R, 32)
        assert _signed_area(poly) > 0
        centres = tr.predict_positions(np.linspace(0.0, t_b, 200))
        assert _contains(poly, _disc_points(centres, R - 1e-6, 36)).all()


def test_thesis_6_1_obstruction_longer_than_threshold_gives_svo():
    """Thesis §6.1: a target at 1.5 m/s turning at 0.03 rad/s, estimated V = 1.5723 m/s,
    ω = 0.0312 rad/s; 30 s window, 15 s threshold, 2.5 m circles + 1 m safety (6 m); predicted
    obstruction t_i = 115.2 s, t_f = 130.4 s (15.2 s) → SVO.

    The thesis does not give the geometry; this one is consistent with every number above. The
    vessel sails east along y = 0 at 1 m/s (Delfim cruise speed, assumed). The target, propagated
    with the *estimated* V and ω, crosses the path turning left (CCW); for a constant-turn crossing
    at course ψ the time its 6 m disc touches the line is
    (arccos(cos ψ − k) − arccos(cos ψ + k))/ω with k = 6ω/V, which is 15.2 s for ψ ≈ 33.1° (and
    for 146.9°, but then the target runs back along the path and leaves the path *ahead of the
    vessel* at 128.9 s). So the target converges from the vessel's starboard quarter, 8 m abeam,
    and turns into its path. The crossing point x = 150 m and the crossing time are set so that
    t_i = 115.2 s and the vessel is at the crossing at the same time (a collision). Prediction runs
    at t = 101 s, the target 14 m away (the thesis checks only within 20 m); the window
    [101, 131] s contains t_f.
    """
    V, w, R = 1.5723, 0.0312, 6.0
    k = R * w / V
    duration = lambda c: (np.arccos(c - k) - np.arccos(c + k)) / w  # noqa: E731
    cos_psi = brentq(lambda c: duration(c) - 15.2, 0.0, 1 - k - 1e-9)
    psi = np.arccos(cos_psi)
    tau_in = (np.arccos(cos_psi + k) - psi) / w  # < 0: entry relative to the crossing
    t_x = 115.2 - tau_in
    at_crossing = _track(5, t_x, [150.0, 0.0], psi, V, turn=w)
    t_now = 101.0
    track = _track(5, t_now, at_crossing.predict_positions(np.array([t_now]))[0], psi - w * (t_x - t_now), V, turn=w)
    path = Path.line([0, 0], [400, 0])
    gamma_now = 150.0 - (t_x - t_now)
    cfg = CollisionPredictionConfig(window_s=30.0, obstruction_threshold_s=15.0, safety_distance_m=1.0, max_range_m=20.0)
    (c,) = predict_conflicts(path, gamma_now, t_now, 1.0, 2.5, [track], cfg)
    assert c.collision and c.min_distance_m < 6.0
    assert c.t_i == pytest.approx(115.2, abs=1e-4)
    assert c.t_f == pytest.approx(130.4, abs=1e-4)
    assert c.decision is Decision.REPLAN and _signed_area(c.svo_polygon) > 0
    swept = track.predict_positions(np.linspace(c.t_i, c.t_f, 100))
    assert _contains(c.svo_polygon, _disc_points(swept, R - 1e-6)).all()
    assert np.hypot(*(track.position_m - path.point(gamma_now))) == pytest.approx(13.9, abs=0.1)
    # With a 10 m check range the target is not checked at all.
    short = CollisionPredictionConfig(window_s=30.0, obstruction_threshold_s=15.0, max_range_m=10.0)
    assert predict_conflicts(path, gamma_now, t_now, 1.0, 2.5, [track], short) == []


# ----------------------------------------------------------------------------- plan and API
def test_speed_profile_knots_integrate_exactly():
    # at rest until t = 10 s, then a constant acceleration 0.1 m/s² to 2 m/s at t = 30 s, then 2 m/s
    g = gamma_of_time(np.array([[10.0, 0.0], [30.0, 2.0]]), 5.0, 0.0)
    t = np.array([0.0, 5.0, 10.0, 20.0, 30.0, 40.0])
    expected = 5.0 + np.array([0, 0, 0, 0.05 * 100, 0.05 * 400, 20 + 20.0])
    np.testing.assert_allclose(g(t), expected)
    assert gamma_of_time(lambda t: 3.0 * t, 0.0, 0.0)(np.array([2.0]))[0] == 6.0
    with pytest.raises(ValueError, match="speed_profile"):
        gamma_of_time(np.array([[1.0, 1.0], [0.5, 1.0]]), 0.0, 0.0)


def test_conflicts_sorted_by_time_and_vessel_stops_at_path_end():
    path = Path.line([0, 0], [100, 0])
    late = _track(1, 0.0, [60, -60], np.pi / 2, 1.0)  # meets the vessel at x = 60 at t = 60
    early = _track(2, 0.0, [20, 20], -np.pi / 2, 1.0)  # meets the vessel at x = 20 at t = 20
    cfg = CollisionPredictionConfig(window_s=80.0, obstruction_threshold_s=100.0)
    out = predict_conflicts(path, 0.0, 0.0, 1.0, 2.5, [late, early], cfg)
    assert [c.track_id for c in out] == [2, 1]
    # at 3 m/s the vessel reaches the end (100 m) at t ≈ 33 s and stays there
    (c,) = predict_conflicts(path, 0.0, 0.0, 3.0, 2.5, [early], cfg, include_clear=True)
    np.testing.assert_allclose(c.vessel_positions[-1], [100.0, 0.0])


def test_validation_errors_name_the_field():
    path = Path.line([0, 0], [100, 0])
    with pytest.raises(ValueError, match="gamma_now"):
        predict_conflicts(path, 150.0, 0.0, 1.0, 2.5, [])
    with pytest.raises(ValueError, match="vessel_radius_m"):
        predict_conflicts(path, 0.0, 0.0, 1.0, -1.0, [])
    with pytest.raises(ValueError, match=r"tracks\[0\]"):
        predict_conflicts(path, 0.0, 0.0, 1.0, 2.5, ["boat"])
    with pytest.raises(ValueError, match="obstruction_threshold_s"):
        CollisionPredictionConfig(obstruction_threshold_s=0.0)
    with pytest.raises(ValueError, match="time_step_s"):
        CollisionPredictionConfig(time_step_s=-1.0)


def test_config_parameters_declared_once_read_from_a_table_name_its_path():
    from mjasc.core.config_tables import dataclass_from_table

    with pytest.raises(ValueError,
                       match=r"^vessels\[0\]\.avoidance\.window_s: must be finite, > 0 and ≤ 3600 s, got 0\.0$"):
        dataclass_from_table(CollisionPredictionConfig, {"window_s": 0}, "vessels[0].avoidance")
    with pytest.raises(ValueError, match=r"^av\.margin_s: must be finite and ≥ 0, got -1\.0$"):
        dataclass_from_table(CollisionPredictionConfig, {"margin_s": -1}, "av")
    with pytest.raises(ValueError, match=r'^av\.window_s: must be a number \[s\] or "dynamic", got \'fast\'$'):
        dataclass_from_table(CollisionPredictionConfig, {"window_s": "fast"}, "av")
    assert dataclass_from_table(CollisionPredictionConfig, {"window_s": "dynamic"}, "av").window_s is None
    # built in code, the config has no table: its errors name the field alone
    with pytest.raises(ValueError, match=r"^margin_s: must be finite and ≥ 0, got -1$"):
        CollisionPredictionConfig(margin_s=-1)
    with pytest.raises(ValueError, match=r"^svo_vertices: must be ≥ 8, got 4$"):
        CollisionPredictionConfig(svo_vertices=4)
