"""A stand-on vessel at its last resort never slows down for a give-way team mate coming up from
abaft its beam — slowing would let the mate run into it (COLREG rule 13) — but only when the mate
does come up: it moves toward the vessel faster than ``static_speed_m_s``
(mjasc.avoidance.triage.closing_from_astern). A mate stopped or creeping abaft the beam is answered
as any give-way conflict: there it is the vessel that closes on the mate (seen in the stressed
§6.4.3 bottleneck: a vessel keeping its speed at the last resort for a mate stopped on its
quarter)."""

import math

import numpy as np
import pytest

from mjasc.avoidance.triage import closing_from_astern
from mjasc.core.estimates import TrackEstimate
from mjasc.core.navigation import OwnNavigation

OWN = OwnNavigation(50.0, np.array([0.0, 0.0]), 0.0, np.array([1.0, 0.0]), np.array([1.0, 0.0, 0.0]))


def _mate(position, heading_deg, speed_m_s):
    return TrackEstimate(track_id=3, time_s=50.0, position_m=np.array(position, dtype=float),
                         heading_rad=math.radians(heading_deg), speed_m_s=speed_m_s, turn_rate_rad_s=0.0,
                         radius_m=2.0, team_member="bravo")


@pytest.mark.parametrize("position, heading_deg, speed_m_s, closing", [
    ((-8.0, -3.0), 20.0, 1.2, True),     # coming up on the quarter
    ((-8.0, 0.0), 0.0, 0.5, True),       # dead astern, faster than the static speed
    ((-8.0, -3.0), 20.0, 0.0, False),    # stopped on the quarter
    ((-8.0, -3.0), 20.0, 0.1, False),    # creeping: under static_speed_m_s (0.15)
    ((-8.0, -3.0), 200.0, 1.2, False),   # opening
    ((-8.0, 0.0), 90.0, 1.5, False),     # crossing astern at right angles
])
def test_a_mate_abaft_the_beam_closes_only_when_it_moves_toward_the_vessel(position, heading_deg, speed_m_s,
                                                                           closing):
    assert closing_from_astern(OWN, _mate(position, heading_deg, speed_m_s), 50.0, 0.15) is closing


def test_the_last_resort_keeps_the_speed_only_for_a_closing_mate():
    """The triage end to end: at the last resort (t_c − t = 4 s < 10 s) a stand-on vessel keeps its
    speed for a mate coming up from astern, and yields (or passes) for one stopped there."""
    from mjasc.avoidance.config import AvoidanceConfig
    from mjasc.avoidance.prediction import Decision, PredictedConflict
    from mjasc.avoidance.triage import triage

    cfg = AvoidanceConfig()
    roles = {}
    for name, mate in (("closing", _mate((-6.0, -4.0), 30.0, 1.5)), ("stopped", _mate((-6.0, -4.0), 30.0, 0.0))):
        c = PredictedConflict(track_id=3, t_closest_s=54.0, min_distance_m=1.0, collision=True, t_i=51.0,
                              t_f=58.0, gamma_a=2.0, gamma_b=9.0, point_a=np.array([2.0, 0.0]),
                              point_b=np.array([9.0, 0.0]), decision=Decision.VELOCITY_CORRECTION,
                              svo_polygon=None, vessel_positions=np.zeros((0, 2)),
                              obstacle_positions=np.zeros((0, 2)), times=np.zeros(0), collision_distance_m=5.5)
        tri = triage(50.0, OWN, 0.0, [c], [], {3: mate}, {"bravo"}, cfg, 2.5, None,
                     mates_giving_way=frozenset({"bravo"}), own_name="alpha", path_end_m=100.0)
        roles[name] = tri.roles[3]
    assert roles["closing"].startswith("team right of way: stand-on, last resort")
    assert "last resort" not in roles["stopped"]


@pytest.mark.parametrize("resume_s, closing", [(20.0, False), (0.0, True)])
def test_a_mate_predicted_from_its_plan_closes_as_its_plan_moves_now(resume_s, closing):
    """A team mate predicted from its broadcast plan (a ``PlannedTrack``, whose ``speed_m_s`` is the
    plan's largest speed): stopped on the quarter with its plan resuming at 1.5 m/s in 20 s, it is
    not coming up; moving on at once, it is."""
    from mjasc.avoidance.team_mates import _message_estimate
    from mjasc.cooperation.messages import TeamIntention
    from mjasc.core.estimates import PlannedTrack, estimate_as_track

    times = np.arange(50.0, 111.0)
    along = 1.5 * np.clip(times - 50.0 - resume_s, 0.0, None)
    course = np.array([math.cos(math.radians(30.0)), math.sin(math.radians(30.0))])
    it = TeamIntention("bravo", 50.0, np.array([-6.0, -4.0]), math.radians(30.0), np.zeros(2), 1.5,
                       plan_times_s=times, plan_points_m=np.array([-6.0, -4.0]) + along[:, None] * course)
    track = estimate_as_track(_message_estimate(it, 0.0), 3, 1.5, None)
    assert isinstance(track, PlannedTrack) and track.speed_m_s == pytest.approx(1.5)
    assert closing_from_astern(OWN, track, 50.0, 0.15) is closing


def test_a_mate_stopped_ahead_is_given_way_to_whatever_its_broadcast_says():
    """A team mate whose fresh broadcast says it gives way makes the vessel stand on (rule order in
    mjasc.avoidance.triage) — but not when that mate is stopped forward of the vessel's beam: its
    give-way, all way off, keeps it where it is, and a vessel standing on toward it sailed into it
    (thesis §6.4.3 under 30 % dropout and packet loss, seeds 70 and 234: a mate stopped 4–5 m
    ahead). The vessel gives way as the geometry says; a moving mate there, or a stopped one
    abaft the beam, leaves the broadcast's word standing."""
    from mjasc.avoidance.config import AvoidanceConfig
    from mjasc.avoidance.prediction import Decision, PredictedConflict
    from mjasc.avoidance.triage import stopped_ahead, triage

    cfg = AvoidanceConfig()

    def answer(mate):
        c = PredictedConflict(track_id=3, t_closest_s=70.0, min_distance_m=1.0, collision=True, t_i=60.0,
                              t_f=80.0, gamma_a=8.0, gamma_b=20.0, point_a=np.array([8.0, 0.0]),
                              point_b=np.array([20.0, 0.0]), decision=Decision.VELOCITY_CORRECTION,
                              svo_polygon=None, vessel_positions=np.zeros((0, 2)),
                              obstacle_positions=np.zeros((0, 2)), times=np.zeros(0), collision_distance_m=5.5)
        return triage(50.0, OWN, 0.0, [c], [], {3: mate}, {"bravo"}, cfg, 2.5, None,
                      mates_giving_way=frozenset({"bravo"}), own_name="alpha", path_end_m=100.0)

    stopped = answer(_mate((6.0, -2.0), 90.0, 0.0))  # on the starboard bow, all way off
    assert stopped_ahead(OWN, _mate((6.0, -2.0), 90.0, 0.0))
    assert stopped.give_way_mates == {3} and stopped.roles[3].startswith("team right of way: give-way")
    assert [stat for stat, _ in stopped.notes if stat] == ["stopped_mate_ahead"]
    moving = answer(_mate((6.0, -2.0), 90.0, 1.0))  # the same place, under way: its word stands
    assert moving.give_way_mates == set() and moving.roles[3] == "team right of way: stand-on, keeps its speed"
    assert not stopped_ahead(OWN, _mate((-6.0, -2.0), 90.0, 0.0))  # abaft the beam
