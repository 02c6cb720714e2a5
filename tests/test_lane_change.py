"""Lane change (mjasc/avoidance/lane_change.py) on closed-form geometry: a straight mission path
along +x, a threat coming up from astern on (nearly) the same line."""

import numpy as np
import pytest

from mjasc.avoidance.config import AvoidanceConfig
from mjasc.avoidance.lane_change import lane_offsets, plan_lane_change
from mjasc.avoidance.prediction import PredictionQuery, predict_fleet
from mjasc.core.estimates import TrackEstimate
from mjasc.guidance.paths import Path


def test_lane_offsets_keep_the_clearance_on_either_side():
    port, starboard = lane_offsets(np.array([-2.0, -1.0, -1.5]), 4.0)
    assert port == pytest.approx(3.0) and starboard == pytest.approx(-6.0)
    assert lane_offsets(np.array([10.0]), 4.0) == (pytest.approx(14.0), 0.0)  # already clear to starboard
    assert lane_offsets(np.zeros(0), 4.0) == (0.0, 0.0)


def _overtaking_case(lateral_m):
    """Own at (0, 0) sailing east at 1.5 m/s on y = 0; a 2 m target 40 m astern at y = lateral_m,
    3 m/s east: it reaches the own vessel after about 27 s."""
    cfg = AvoidanceConfig()
    mission = Path.line((0.0, 0.0), (300.0, 0.0))
    track = TrackEstimate(track_id=7, time_s=0.0, position_m=np.array([-40.0, lateral_m]), heading_rad=0.0,
                          speed_m_s=3.0, turn_rate_rad_s=0.0, radius_m=2.0)
    query = PredictionQuery(mission, 0.0, 0.0, 1.5, 1.0, [track], cfg.prediction, include_clear=True)
    conflict = predict_fleet([query])[0][0]
    return cfg, mission, track, conflict


@pytest.mark.parametrize("lateral_m, side", [(-1.0, +1), (1.0, -1), (0.0, -1)])
def test_a_vessel_overtaken_on_its_line_steps_aside_and_the_prediction_then_clears(lateral_m, side):
    cfg, mission, track, c = _overtaking_case(lateral_m)
    assert c.collision
    d = plan_lane_change(0.0, (0.0, 0.0), mission, 0.0, 1.5, [c], [], cfg, 2.0)
    assert not isinstance(d, str), d
    assert d.field is None and d.mission_gamma_start_m == 0.0
    # away from the threat's line (starboard = −y on a tie), far enough: the clearance plus margins
    y = d.streamline[:, 1]
    held = y[np.argmax(np.abs(y))]
    assert np.sign(held) == side
    assert abs(held - lateral_m) >= c.collision_distance_m + cfg.replan_margin_m + cfg.correction_margin_m - 1e-6
    # it starts at the vessel and ends back on the mission path, which the detour path continues
    assert np.allclose(d.streamline[0], [0.0, 0.0]) and abs(d.streamline[-1, 1]) < 1e-9
    assert d.path.length == pytest.approx(d.detour_length_m + mission.length - d.mission_gamma_goal_m, abs=1e-6)
    # sailing the lane at the planned speed, the prediction finds no collision any more
    again = predict_fleet([PredictionQuery(d.path, 0.0, 0.0, 1.5, 1.0, [track], cfg.prediction,
                                           include_clear=True)])[0][0]
    assert not again.collision and again.min_distance_m > c.collision_distance_m


def test_a_lane_blocked_by_a_static_obstacle_is_refused_and_the_other_side_taken():
    cfg, mission, track, c = _overtaking_case(0.0)
    quay = np.array([[0.0, -12.0], [200.0, -12.0], [200.0, -4.0], [0.0, -4.0]])  # south: starboard blocked
    d = plan_lane_change(0.0, (0.0, 0.0), mission, 0.0, 1.5, [c], [quay], cfg, 1.0)
    assert not isinstance(d, str), d
    assert d.streamline[:, 1].max() > 4.0 and d.streamline[:, 1].min() > -1e-9
    both = [quay, quay * np.array([1.0, -1.0])]
    out = plan_lane_change(0.0, (0.0, 0.0), mission, 0.0, 1.5, [c], both, cfg, 1.0)
    assert isinstance(out, str) and "static obstacle" in out


def test_a_lane_off_a_short_line_that_ends_in_the_threats_track_is_held_beside_its_end():
    """A station-keeping leg's short line (``hold_past_end``: its end is no destination; 30 m along
    +x, the vessel 8 m from its end at 0.5 m/s)
    with a 4 m ferry coming down it head-on, 2 m to port, at 1.7 m/s: the obstruction outlasts
    the line. The lane runs on past the line's end, straight, for the whole hold, keeps the
    clearance from the ferry's centres alongside it and beyond its end, does not step back, and is
    not left before t_f (tests/cas_regressions/target_tracking_current_16.toml)."""
    cfg = AvoidanceConfig()
    mission = Path.line((0.0, 0.0), (30.0, 0.0))
    ferry = TrackEstimate(track_id=3, time_s=0.0, position_m=np.array([60.0, 2.0]), heading_rad=np.pi,
                          speed_m_s=1.7, turn_rate_rad_s=0.0, radius_m=4.0)
    query = PredictionQuery(mission, 22.0, 0.0, 0.5, 1.0, [ferry], cfg.prediction, include_clear=True)
    c = predict_fleet([query])[0][0]
    assert c.collision and c.gamma_b == pytest.approx(mission.length)
    plain = plan_lane_change(0.0, (22.0, 0.0), mission, 22.0, 0.5, [c], [], cfg, 2.0)
    assert isinstance(plain, str) or plain.hold_until_s == -np.inf  # a goal's path end: no hold past it
    d = plan_lane_change(0.0, (22.0, 0.0), mission, 22.0, 0.5, [c], [], cfg, 2.0, hold_past_end=True)
    assert not isinstance(d, str), d
    assert d.hold_until_s == pytest.approx(c.t_f)  # not left before the ferry has passed
    assert d.mission_gamma_goal_m == pytest.approx(mission.length) and d.path is not None
    end = d.path.point(d.path.length)
    # the line continued straight for the whole hold: to the planned γ at t_f plus the goal margin
    assert end[0] == pytest.approx(22.0 + 0.5 * c.t_f + cfg.goal_margin_m, abs=0.5) and end[0] > mission.length
    clear = c.collision_distance_m + cfg.replan_margin_m + cfg.correction_margin_m
    assert 2.0 - end[1] >= clear - 1e-6  # to starboard, off the ferry's track by the clearance
    # sailing the lane at 0.5 m/s and waiting at its end, the prediction finds no collision
    again = predict_fleet([PredictionQuery(d.path, 0.0, 0.0, 0.5, 1.0, [ferry], cfg.prediction,
                                           include_clear=True)])[0][0]
    assert not again.collision


@pytest.mark.parametrize("course_deg, crossing", [(180.0, False), (150.0, False), (-140.0, False), (-90.0, True),
                                                  (-60.0, True), (120.0, True)])
def test_no_lane_leaves_the_track_of_a_threat_crossing_the_path(course_deg, crossing):
    """A threat on a course more than 45° off the path's line sweeps across every parallel lane: no
    lane is planned for it (shared_perception_occluded without sharing: a starboard lane raced a
    ship crossing 12 m ahead down its own track). One moving along the line, either way, still gets
    its lane: the own vessel sails east at 1.5 m/s, the 2 m target meets it ~20 s ahead."""
    cfg = AvoidanceConfig()
    mission = Path.line((0.0, 0.0), (300.0, 0.0))
    course = np.radians(course_deg)
    meet = np.array([30.0, 0.0])  # where the own vessel is at t = 20 s
    start = meet - 20.0 * 1.2 * np.array([np.cos(course), np.sin(course)])
    track = TrackEstimate(track_id=3, time_s=0.0, position_m=start, heading_rad=course, speed_m_s=1.2,
                          turn_rate_rad_s=0.0, radius_m=2.0)
    c = predict_fleet([PredictionQuery(mission, 0.0, 0.0, 1.5, 1.0, [track], cfg.prediction,
                                       include_clear=True)])[0][0]
    assert c.collision
    out = plan_lane_change(0.0, (0.0, 0.0), mission, 0.0, 1.5, [c], [], cfg, 2.0)
    if crossing:
        off = abs((course_deg + 180.0) % 360.0 - 180.0)  # (the course's angle to the path's direction, east)
        assert out == f"track 3 crosses the path ({off:.0f}° off its line): no lane leaves its track", out
    else:
        assert not isinstance(out, str), out
    # A team mate's predicted centres follow its broadcast plan: it never counts as crossing (two team mates
    # deployed across each other's transits both refused the lane and drifted together on the current; the
    # go-to-formation deployments' run 5). The rule is only the crossing test: a lane still may not exist.
    team = plan_lane_change(0.0, (0.0, 0.0), mission, 0.0, 1.5, [c], [], cfg, 2.0, team_ids=frozenset({3}))
    assert not (isinstance(team, str) and "crosses the path" in team), team
