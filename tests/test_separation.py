"""Two team mates stopped inside each other's collision distance move apart
(mjasc/avoidance/separation.py) on closed-form geometry; the deployment it was made for end to end
is in tests/test_cas_regressions.py (go_to_formation_deployment_5: the mission now completes)."""

import math
from dataclasses import replace

import numpy as np
import pytest

from mjasc.avoidance.config import AvoidanceConfig
from mjasc.avoidance.prediction import PredictionQuery, predict_fleet
from mjasc.avoidance.separation import STOPPED_M_S, separation_detour, separation_turn, stuck_with
from mjasc.core.estimates import TrackEstimate
from mjasc.guidance.paths import Path

MISSION = Path.line((0.0, 0.0), (100.0, 0.0))


def _mate(x, y, speed=0.0, team_member="bravo", track_id=3):
    return TrackEstimate(track_id=track_id, time_s=10.0, position_m=np.array([x, y]), heading_rad=0.0,
                         speed_m_s=speed, turn_rate_rad_s=0.0, radius_m=1.1, team_member=team_member)


def _conflict(track, planned_speed_m_s=0.0):
    """The own vessel at (0, 0) on MISSION at 10 s, its plan at ``planned_speed_m_s``, against ``track``."""
    query = PredictionQuery(MISSION, 0.0, 10.0, planned_speed_m_s, 1.1, [track], AvoidanceConfig().prediction,
                            include_clear=True)
    return predict_fleet([query])[0][0]


def test_a_stopped_team_mate_inside_the_collision_distance_is_a_deadlock_kept_since_it_began():
    mate = _mate(-1.5, 2.0)
    c = _conflict(mate)
    assert c.collision and c.collision_distance_m > 2.5  # its centre 2.5 m away, inside
    since = stuck_with(10.0, (0.0, 0.0), 0.02, [c], {3: mate}, {})
    assert since == {3: 10.0}
    assert stuck_with(14.0, (0.0, 0.0), 0.02, [c], {3: mate}, since) == {3: 10.0}  # carried on
    # not a deadlock: the own vessel moving, the team mate moving, a stranger, a team mate still outside
    assert stuck_with(10.0, (0.0, 0.0), STOPPED_M_S + 0.05, [c], {3: mate}, {}) == {}
    assert stuck_with(10.0, (0.0, 0.0), 0.0, [c], {3: replace(mate, speed_m_s=0.5)}, {}) == {}
    assert stuck_with(10.0, (0.0, 0.0), 0.0, [c], {3: replace(mate, team_member=None)}, {}) == {}
    ahead = _mate(12.0, 0.5)
    c_ahead = _conflict(ahead, planned_speed_m_s=1.5)
    assert c_ahead.collision  # a collision ahead, the team mate not yet inside the collision distance
    assert stuck_with(10.0, (0.0, 0.0), 0.0, [c_ahead], {3: ahead}, {3: 5.0}) == {}  # (and the old entry dropped)


def test_a_team_mates_broadcast_velocity_says_whether_it_is_stopped():
    class Intention:
        velocity_m_s = np.array([0.3, 0.4])

    class Planned:  # a PlannedTrack's speed_m_s is its plan's largest; its broadcast velocity is what it does
        team_member, speed_m_s, intention, position_m = "bravo", 1.5, Intention(), np.array([-1.5, 2.0])

    c = _conflict(_mate(-1.5, 2.0))
    assert stuck_with(10.0, (0.0, 0.0), 0.0, [c], {3: Planned()}, {}) == {}
    Intention.velocity_m_s = np.array([0.0, 0.05])
    assert stuck_with(10.0, (0.0, 0.0), 0.0, [c], {3: Planned()}, {}) == {3: 10.0}


def test_the_way_out_leads_straight_away_from_the_team_mate_to_the_reach():
    d = separation_detour(20.0, (0.0, 0.0), (-2.0, 0.0), 6.0, 12.5, [], 1.5)
    assert not isinstance(d, str)
    assert np.allclose(d.path.start_point, [0.0, 0.0]) and np.allclose(d.path.end_point, [4.0, 0.0])
    assert d.detour_length_m == pytest.approx(4.0) and d.field is None and d.time_s == 20.0
    # the vessel's mission γ stays where it left the path while it sails the leg, and it goes back there
    assert d.mission_gamma(0.0) == d.mission_gamma(4.0) == 12.5


def test_one_of_the_two_moves_first():
    assert separation_turn("alpha", ["charlie"]) == 1 and separation_turn("charlie", ["alpha"]) == 2
    assert separation_turn("bravo", ["charlie", "alpha"]) == 2  # (three stuck together: alpha first)
    assert separation_turn("Charlie", ["alpha"]) == 1  # (Python's string order: capitals first)


def test_the_way_out_turns_off_a_static_obstacle_and_says_when_there_is_none():
    wall_east = np.array([[7.5, -1.0], [12.0, -1.0], [12.0, 1.0], [7.5, 1.0]])  # by the straight way out
    d = separation_detour(0.0, (0.0, 0.0), (-2.0, 0.0), 7.0, 0.0, [wall_east], 3.0)
    assert not isinstance(d, str)
    end = d.path.end_point
    assert math.degrees(abs(math.atan2(end[1], end[0] + 2.0))) == pytest.approx(30.0)  # the first turn that clears
    assert np.hypot(end[0] + 2.0, end[1]) == pytest.approx(7.0)
    ring = [np.array([[-30.0, y0], [30.0, y0], [30.0, y0 + 1.0], [-30.0, y0 + 1.0]]) for y0 in (7.2, -8.2)] + \
        [np.array([[x0, -30.0], [x0 + 1.0, -30.0], [x0 + 1.0, 30.0], [x0, 30.0]]) for x0 in (7.2,)]
    out = separation_detour(0.0, (0.0, 0.0), (-2.0, 0.0), 7.0, 0.0, ring, 3.2)  # (each wall 7.2 m off)
    assert out == "every way out meets a mapped static obstacle"


def test_the_way_out_does_not_end_nearer_another_team_mate():
    # a third vessel 3 m east, inside the collision distance (4 m): the straight way out (east) would end
    # 2 m from it; the first turn whose end is no nearer than the 3 m it is now is taken (30°: 3.66 m)
    d = separation_detour(0.0, (0.0, 0.0), (-2.0, 0.0), 7.0, 0.0, [], 1.0, [np.array([3.0, 0.0])], 4.0)
    assert not isinstance(d, str)
    end = d.path.end_point
    assert np.hypot(end[0] - 3.0, end[1]) >= 3.0
    assert math.degrees(abs(math.atan2(end[1], end[0] + 2.0))) == pytest.approx(30.0)
    # team mates all round: no way out
    ring = [np.array([7.0 * math.cos(a), 7.0 * math.sin(a)]) - np.array([2.0, 0.0])
            for a in np.radians([0.0, 30.0, -30.0, 60.0, -60.0, 90.0, -90.0])]
    out = separation_detour(0.0, (0.0, 0.0), (-2.0, 0.0), 7.0, 0.0, [], 1.0, ring, 4.0)
    assert out == "every way out meets a mapped static obstacle or another team mate"
