"""A sharp turn's guard (mjasc.avoidance.control_tick.ControlTick._turn_closes_on_track): while a
detour's sharp turn runs, the hull sails off the planned path (the saturated turn advances it), so
the turn is held — all way off, the heading held — when the hull closes on a slow track (a team mate
stopped beside it included) within its collision distance plus one second of its speed. The
geometry is that of tests/cas_regressions/bottleneck_stressed_seed4.toml at 115 s: alpha (collision
radius 3.0 m) turning at 0.54 m/s, heading −134°, bravo stopped 5.0 m away to the south-west."""

import math
from types import SimpleNamespace

import numpy as np
import pytest

from mjasc.avoidance.control_tick import ControlTick
from mjasc.core.estimates import PerceptionReport, TrackEstimate
from mjasc.core.navigation import OwnNavigation

HERE = np.array([82.7, 1.5])
BRAVO = np.array([78.0, 0.0])


def _nav(speed_m_s=0.54, heading_deg=-134.0, position=HERE):
    psi = math.radians(heading_deg)
    v = speed_m_s * np.array([math.cos(psi), math.sin(psi)])
    return OwnNavigation(115.0, np.asarray(position, dtype=float), psi, v, np.array([speed_m_s, 0.0, 0.0]))


def _track(position=BRAVO, speed_m_s=0.0, static=True, radius_m=2.5, mate="bravo"):
    return TrackEstimate(track_id=166, time_s=115.0, position_m=np.asarray(position, dtype=float), heading_rad=0.0,
                         speed_m_s=speed_m_s, turn_rate_rad_s=0.0, radius_m=radius_m, is_static=static,
                         team_member=mate)


def _closes(nav, *tracks, radius_m=3.0):
    system = SimpleNamespace(_perceived=PerceptionReport(115.0, tuple(tracks)), radius_m=radius_m)
    return ControlTick._turn_closes_on_track(system, nav)


def test_a_turn_closing_on_a_stopped_team_mate_is_held():
    assert _closes(_nav(), _track())  # 4.93 m apart: 2.5 + 3.0 − 4.93 = 0.57 m inside, closing


@pytest.mark.parametrize("static, speed", [(False, 0.3), (True, 0.0)])
def test_slow_tracks_count_whether_or_not_static(static, speed):
    assert _closes(_nav(), _track(static=static, speed_m_s=speed))


def test_a_fast_track_is_left_to_the_predictions():
    assert not _closes(_nav(), _track(static=False, speed_m_s=1.5))


def test_a_turn_opening_from_the_track_goes_on():
    assert not _closes(_nav(heading_deg=46.0), _track())  # sailing away from bravo


def test_a_turn_beyond_one_second_of_its_speed_goes_on():
    far = BRAVO + 7.0 * (HERE - BRAVO) / np.linalg.norm(HERE - BRAVO)  # 7 m: 1.5 m clear, 0.54 m/s
    assert not _closes(_nav(position=far), _track())
    assert _closes(_nav(speed_m_s=2.0, position=far), _track())  # 2 m/s reaches it within the second


def test_a_hull_making_no_way_is_not_held():
    assert not _closes(_nav(speed_m_s=0.01), _track())


def test_without_tracks_nothing_holds_the_turn():
    assert not _closes(_nav())
    system = SimpleNamespace(_perceived=None, radius_m=3.0)
    assert not ControlTick._turn_closes_on_track(system, _nav())


def _turning_system(tracks):
    """The state a detour's sharp turn reads (``ControlTick._sharp_turn_speed``): a detour running
    east from alpha (134° off its heading: a sharp turn), its perceived tracks, the default config."""
    from mjasc.avoidance.config import AvoidanceConfig
    from mjasc.guidance.paths import Path
    from mjasc.guidance.state import GuidanceState

    system = SimpleNamespace(
        _guidance=GuidanceState(path=Path.line(HERE, HERE + [60.0, 0.0]), gamma_m=0.0, mission_speed_m_s=1.0),
        config=AvoidanceConfig(), _sharp_turn=("turn", 0), stats={"sharp_turn": 0, "turn_away": 0, "turn_held": 0},
        _perceived=PerceptionReport(115.0, tuple(tracks)), radius_m=3.0, _event=lambda t, text: None)
    system._turn_closes_on_track = lambda nav: ControlTick._turn_closes_on_track(system, nav)
    return system


def test_a_held_turn_goes_on_in_place_once_the_way_is_off():
    """Held beside bravo (all way off, the heading held), the hull makes no way: the rest of the turn
    is turned in place — no speed asked, so the allocation keeps the propellers' differential within
    the reverse thrust and nothing pushes the hull ahead (tests/test_path_following.py) — not sailed
    at the turn speed, which took the hull ahead again and again into the hold (with the
    allocation's limit alone, §6.2 dock seeds 65, 67 and 88 crept that way into the moored boat). A
    turn never held is sailed at the turn speed, as before."""
    system = _turning_system([_track()])
    speed, course = ControlTick._sharp_turn_speed(system, 115.0, _nav(), None)
    assert (speed, course) == (0.0, _nav().heading_rad) and system._sharp_turn[0] == "held"
    speed, course = ControlTick._sharp_turn_speed(system, 117.0, _nav(speed_m_s=0.01), None)
    assert speed == 0.0 and system._sharp_turn[0] == "held"  # turning in place (the detour's course)
    free = _turning_system([])
    assert ControlTick._sharp_turn_speed(free, 115.0, _nav(speed_m_s=0.01), None)[0] == free.config.sharp_turn_speed_m_s


def test_a_held_turn_in_place_steers_at_the_aim_point_and_ends_there():
    """Held, the hull turns in place towards the detour's point 5 m ahead, not along the path's LOS
    course: with no way on γ stands still, and where the detour bends within those 5 m the LOS
    course (the first leg's) would leave the hull more than ``sharp_turn_deg`` off the aim point
    for good, stopped. Once the heading is on the aim point the sharp turn is over."""
    from mjasc.guidance.paths import Path

    bend = math.radians(130.0)  # a detour bending 130° left 2 m ahead of the hull (heading east)
    points = HERE + np.array([[0.0, 0.0], [2.0, 0.0], [2.0 + 8.0 * math.cos(bend), 8.0 * math.sin(bend)]])
    system = _turning_system([])
    system._guidance = system._guidance.__class__(path=Path.from_points(points), gamma_m=0.0, mission_speed_m_s=1.0)
    system._sharp_turn = ("held", 0)
    aim = system._guidance.path.at(5.0)
    bearing = math.atan2(aim[1] - HERE[1], aim[0] - HERE[0])
    speed, course = ControlTick._sharp_turn_speed(system, 120.0, _nav(speed_m_s=0.0, heading_deg=0.0), None)
    assert speed == 0.0 and course == pytest.approx(bearing) and math.degrees(bearing) > 60.0
    on_aim = _nav(speed_m_s=0.0, heading_deg=math.degrees(bearing))
    assert ControlTick._sharp_turn_speed(system, 130.0, on_aim, None) == (None, None)  # over: the detour goes on
    assert system._sharp_turn is None
