"""Missions (mjasc/missions, docs/missions.md): Dubins transits, go-to-formation, cooperative target
tracking, chained phases — checked against closed forms and the pass criteria the docs state —,
scenario errors, and the thesis's cooperative scenarios under 30 % packet loss."""

import math
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from mjasc.core.navigation import OwnNavigation
from mjasc.guidance.paths import Path as GPath
from mjasc.missions.dubins import dubins_length, dubins_path, dubins_words
from mjasc.missions.go_to_formation import bumped_transit, plan_transit, transit_length
from mjasc.missions.target_tracking import station
from mjasc.runs.runner import Runner
from mjasc.runs.scenario import ScenarioError, load_scenario, parse_scenario

TASKS = Path(__file__).resolve().parent.parent / "tasks"


def wrap(a):
    return (a + math.pi) % (2 * math.pi) - math.pi


# ---------------------------------------------------------------------- Dubins curves
def test_dubins_paths_join_the_poses_with_bounded_curvature():
    rng = np.random.default_rng(0)
    for _ in range(300):
        p0, p1 = rng.uniform(-60, 60, 2), rng.uniform(-60, 60, 2)
        a, b, r = rng.uniform(-math.pi, math.pi), rng.uniform(-math.pi, math.pi), rng.uniform(2, 20)
        path = dubins_path(p0, a, p1, b, r)
        assert np.allclose(path.point(0.0), p0, atol=1e-6) and np.allclose(path.point(path.length), p1, atol=1e-5)
        assert abs(wrap(path.tangent_angle(0.0) - a)) < 1e-6 and abs(wrap(path.tangent_angle(path.length) - b)) < 1e-6
        g = np.linspace(0.0, path.length, 64)
        assert np.all(np.abs(path.curvature(g)) <= 1.0 / r + 1e-9)
        lengths = [sum(s.length for s in w) for w in dubins_words(p0, a, p1, b, r).values()]
        assert path.length == pytest.approx(min(lengths))  # the shortest word
        assert path.length >= math.hypot(*(p1 - p0)) - 1e-9


def test_dubins_closed_forms():
    # straight ahead: the distance; a U-turn onto the reverse course 2R to the left: half a circle
    assert dubins_path([0, 0], 0.0, [100, 0], 0.0, 10.0).length == pytest.approx(100.0)
    assert dubins_path([0, 0], 0.0, [0, 20], math.pi, 10.0).length == pytest.approx(math.pi * 10.0)
    # a quarter turn to the left ending 10 m left and 10 m ahead: a quarter circle
    assert dubins_path([0, 0], 0.0, [10, 10], math.pi / 2, 10.0).length == pytest.approx(math.pi * 5.0)


def test_transit_ends_on_the_formation_pose_with_a_straight_lead_in():
    formation = GPath.line([60.0, 12.0], [260.0, 12.0])
    path = plan_transit([-20.0, 40.0], math.pi, formation, 10.0, 15.0)
    assert np.allclose(path.point(path.length), [60.0, 12.0], atol=1e-6)
    assert abs(wrap(path.tangent_angle(path.length))) < 1e-9
    assert np.all(path.curvature(np.linspace(path.length - 15.0, path.length, 10)) == 0.0)


def test_dubins_length_is_the_built_paths_length():
    rng = np.random.default_rng(7)
    for k in range(400):
        p0, p1 = rng.uniform(-60, 60, 2), rng.uniform(-60, 60, 2)
        if k % 4 == 0:  # near poses: the CCC words
            p1 = p0 + rng.uniform(-15, 15, 2)
        a, b, r = *rng.uniform(-4, 4, 2), rng.uniform(2.0, 20.0)
        assert dubins_length(p0, a, p1, b, r) == pytest.approx(dubins_path(p0, a, p1, b, r).length, abs=1e-9)
    assert dubins_length([0, 0], 0.0, [0, 20], math.pi, 10.0) == pytest.approx(math.pi * 10.0)
    # the radii dubins_path refuses: not a length (NaN read as "poses coincide", 0 as a straight line)
    for bad in (0.0, -5.0, math.nan, math.inf):
        with pytest.raises(ValueError, match="turn_radius_m"):
            dubins_length([0, 0], 0.0, [5, 5], 1.0, bad)


def test_a_vessel_already_on_its_lead_in_sails_on_instead_of_looping_back():
    """Deployed 0.5 m past its lead-in's entry (R = 10 m, lead-in 15 m), a vessel planned a Dubins loop
    back to the entry: 78 m for 14.5 m straight on. On its lead-in the transit now takes the longest
    lead-in that is still the shortest way: straight on here, an S-bend onto the line from 2 m off
    it; off the lead-in (behind its entry, or across the line) the lead-in is as configured."""
    from mjasc.missions.config import GoToFormationOptions
    from mjasc.missions.go_to_formation import GoToFormation, lead_in_for

    formation = GPath.line([100.0, 0.0], [300.0, 0.0])
    assert plan_transit([85.5, 0.0], 0.0, formation, 10.0, 15.0).length > 2 * math.pi * 10.0  # the loop
    assert lead_in_for([85.5, 0.0], 0.0, formation, 10.0, 15.0) == pytest.approx(14.5)
    ph = GoToFormation(0, GoToFormationOptions(turn_radius_m=10.0, lead_in_m=15.0), formation, 1.5)
    leg = ph.begin(0.0, _nav(85.5, 0.0, 0.0))
    assert leg.path.length == pytest.approx(14.5) and ph.own_arrival_s == pytest.approx(14.5 / 1.5)
    lead = lead_in_for([90.0, 2.0], 0.1, formation, 10.0, 15.0)
    bend = plan_transit([90.0, 2.0], 0.1, formation, 10.0, lead)
    assert bend.length < 11.0 and np.allclose(bend.point(bend.length), [100.0, 0.0], atol=1e-6)
    s = np.linspace(0.0, bend.length, 400)
    assert np.all(np.abs(bend.curvature(s)) <= 0.1 + 1e-9) and abs(wrap(bend.tangent_angle(bend.length))) < 1e-9
    for pose in (([40.0, 0.0], 0.0), ([-20.0, 40.0], math.pi), ([92.0, 0.0], 0.6 * math.pi), ([92.0, 30.0], 0.0)):
        assert lead_in_for(*pose, formation, 10.0, 15.0) == 15.0


def test_a_bump_lengthens_a_transit_inside_the_lead_ins_jump():
    """A vessel 60 m behind its formation pose, on its course: moving the lead-in's entry back adds
    no length until the entry passes behind the vessel, then a whole turn (> 2πR). 10 m more are
    made by a bump: the transit through a waypoint pushed sideways from its midpoint."""
    formation = GPath.line([100.0, 0.0], [300.0, 0.0])
    plain = plan_transit([40.0, 0.0], 0.0, formation, 10.0, 15.0)
    assert plain.length == pytest.approx(60.0)
    assert bumped_transit([40.0, 0.0], 0.0, formation, 10.0, 15.0, 0.0).length == pytest.approx(60.0)
    lengths = [bumped_transit([40.0, 0.0], 0.0, formation, 10.0, 15.0, h).length for h in np.linspace(0, 20, 41)]
    assert np.all(np.diff(lengths) > 0.0) and np.all(np.diff(lengths) < 1.0)  # grows, without a jump
    path = bumped_transit([40.0, 0.0], 0.0, formation, 10.0, 15.0, -12.0)
    assert transit_length([40.0, 0.0], 0.0, formation, 10.0, 15.0) == pytest.approx(60.0)
    # a feasible curve: joined without gaps or kinks, turns no tighter than R, the lead-in straight
    s = np.linspace(0.0, path.length, 2000)
    assert np.all(np.abs(path.curvature(s)) <= 1.0 / 10.0 + 1e-9)
    heading = np.unwrap([path.tangent_angle(x) for x in s])
    assert np.all(np.abs(np.diff(heading)) < 0.05)
    assert np.allclose(path.point(path.length), [100.0, 0.0], atol=1e-6)
    assert abs(wrap(path.tangent_angle(path.length))) < 1e-9
    assert np.all(path.curvature(np.linspace(path.length - 15.0, path.length, 10)) == 0.0)
    assert min(p[1] for p in (path.point(x) for x in s)) == pytest.approx(-12.0, abs=0.5)  # pushed to the right


def test_go_to_formation_arrives_at_cruise_speed_when_the_need_falls_in_the_jump():
    """The team needs 10 m more of this vessel than its shortest transit (within the lead-in's
    jump): before the bump it sailed slower (60 m at 1.36 m/s); now it sails 66 m at cruise."""
    from mjasc.missions.config import GoToFormationOptions
    from mjasc.missions.go_to_formation import GoToFormation
    from mjasc.missions.legs import MissionBroadcast, PhaseInputs

    formation = GPath.line([100.0, 0.0], [300.0, 0.0])
    ph = GoToFormation(0, GoToFormationOptions(), formation, 1.5, team_size=2)
    ph.begin(0.0, _nav(40.0, 0.0))
    leg, _ = ph.step(PhaseInputs(1.0, _nav(41.5, 0.0), 1.5, None, {"mate": MissionBroadcast(0, arrival_time_s=45.0)},
                                 True))
    assert leg.path.length == pytest.approx(1.5 * 44.0, abs=0.1) and leg.speed_m_s == pytest.approx(1.5, abs=0.01)
    assert ph.lead_in_m == 15.0 and 5.0 < abs(ph.bump_m) < 20.0
    assert np.allclose(leg.path.point(leg.path.length), [100.0, 0.0], atol=1e-6)


def test_a_transit_not_yet_sailed_reports_its_plan():
    """A run that ends before the arrival says when the team is due and what the vessel sails (its
    timeline entry held only phase, start and completed = false)."""
    from mjasc.missions.config import GoToFormationOptions
    from mjasc.missions.go_to_formation import GoToFormation
    from mjasc.missions.legs import MissionBroadcast, PhaseInputs

    formation = GPath.line([100.0, 0.0], [300.0, 0.0])
    ph = GoToFormation(0, GoToFormationOptions(), formation, 1.5, team_size=2)
    ph.begin(0.0, _nav(40.0, 0.0))
    ph.step(PhaseInputs(1.0, _nav(41.5, 0.0), 1.5, None, {"mate": MissionBroadcast(0, arrival_time_s=45.0)}, True))
    r = ph.result()
    assert r["completed"] is False and "arrival_time_s" not in r  # (the team's arrival spread ignores it)
    assert r["planned_arrival_s"] == 45.0 and r["transit_length_m"] == pytest.approx(66.0, abs=0.1)
    assert r["transit_speed_m_s"] == pytest.approx(1.5, abs=0.01) and r["lead_in_m"] == 15.0


def test_station_in_the_target_frame():
    # a target heading north: 30 m astern is 30 m south; 20 m to port is 20 m west
    assert np.allclose(station([100.0, 50.0], math.pi / 2, [-30.0, 0.0]), [100.0, 20.0])
    assert np.allclose(station([100.0, 50.0], math.pi / 2, [0.0, 20.0]), [80.0, 50.0])


# ---------------------------------------------------------------------- scenario errors
def _data(name):
    import tomllib

    return tomllib.loads((TASKS / f"{name}.toml").read_text())


@pytest.mark.parametrize("edit, message", [
    (lambda d: d["mission"].update(phases=["follow_path", "go_to_formation"]), "mission.phases: go_to_formation must"),
    (lambda d: d["mission"].update(phases=["fly"]), "mission.phases[0]: must be one of"),
    (lambda d: d["mission"].update(phases=[]), "mission.phases: must be a non-empty list"),
    (lambda d: d["mission"]["go_to_formation"].update(turn_radius_m=-1.0), "mission.go_to_formation.turn_radius_m"),
    # the Otter's tightest steady turn at 1.5 m/s is ~5.0 m (tests/test_steady_turn.py)
    (lambda d: d["mission"]["go_to_formation"].update(turn_radius_m=4.0),
     "mission.go_to_formation.turn_radius_m: vessels[0] 'alpha' (otter) turns no tighter than 5.01 m at its cruise"),
    (lambda d: d["vessels"][1]["controller"].update(speed_m_s=3.05),
     "mission.go_to_formation.turn_radius_m: vessels[1] 'bravo' (otter) sails no steady turn at its cruise speed 3.05"),
    (lambda d: d["mission"].update(phases=["go_to_formation", "track_target"]), "mission.track_target: missing"),
    (lambda d: d["vessels"][1].pop("comms"), "vessels[1].comms: missing"),
    (lambda d: d["vessels"][0].update(mission={"target_offset_m": [0.0, 1.0]}) or d.pop("mission"),
     "vessels[0].mission: the scenario has no [mission]"),
    # accepted silently until a review (2026-12-07): a station with no track_target phase to hold it, two leaders
    # (each keeps its own speed: the spread stayed at 20 m), a timeout every neighbour outlives between messages
    (lambda d: d["vessels"][0].update(mission={"target_offset_m": [0.0, 1.0]}),
     "vessels[0].mission.target_offset_m: the mission has no track_target phase (phases: go_to_formation, "
     "follow_path)"),
    (lambda d: [d["vessels"][k]["comms"].update(role="leader") for k in (0, 2)],
     "vessels[2].comms.role: a second leader (vessels[0] is one)"),
    (lambda d: d["vessels"][1]["comms"].update(neighbour_timeout_s=0.4),
     "vessels[1].comms.neighbour_timeout_s: must be > the comms period 1/rates.comms_hz"),
    # a column on one path without leads apart: the consensus put both on one point (contact at 26.8 s)
    (lambda d: (d["mission"].update(phases=["follow_path"]), d["mission"].pop("go_to_formation"),
                d["vessels"][2]["controller"].update(waypoints=d["vessels"][0]["controller"]["waypoints"])),
     "vessels[2].comms.formation_offset_m: 'charlie' sails the same path as vessels[0] (alpha) with leads 0 and 0 m"),
])
def test_bad_missions_are_one_line_errors(edit, message):
    d = _data("go_to_formation")
    edit(d)
    with pytest.raises(ScenarioError) as err:
        parse_scenario(d, "go_to_formation.toml")
    assert message in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize("vessel_type, speed", [("otter", 1.5), ("delfim", 1.0), ("delfim", 1.5)])
def test_the_turn_radius_the_error_names_is_accepted(vessel_type, speed):
    """The limit in the error is rounded up: writing it in the file passes the check (it printed
    the Delfim's 13.44 m at 1.5 m/s as 13.4 m, and 13.4 was refused)."""
    d = _data("go_to_formation")
    for v in d["vessels"]:
        v["type"], v["controller"]["speed_m_s"] = vessel_type, speed
    d["mission"]["go_to_formation"]["turn_radius_m"] = 1.0
    with pytest.raises(ScenarioError) as err:
        parse_scenario(d, "go_to_formation.toml")
    limit = float(re.search(r"turns no tighter than ([0-9.]+) m", str(err.value)).group(1))
    d["mission"]["go_to_formation"]["turn_radius_m"] = limit
    parse_scenario(d, "go_to_formation.toml")


@pytest.mark.parametrize("edit, message", [
    (lambda d: d["mission"]["track_target"].update(leader="zulu"), "mission.track_target.leader: no vessel"),
    (lambda d: (d["vessels"][0].pop("sensor"), d["vessels"][0].pop("avoidance"), d["vessels"][0].pop("tracking", None)),
     "mission.track_target.leader: 'alpha' has no [vessels.sensor]"),
    (lambda d: d["mission"]["track_target"].update(target="orca"), "mission.track_target.target: no moving obstacle"),
    (lambda d: d["mission"]["track_target"].pop("target_hint_m"), "mission.track_target.target_hint_m: missing"),
    (lambda d: d["vessels"][2].update(mission={"target_offset_m": [1.0]}), "vessels[2].mission.target_offset_m"),
    (lambda d: d.pop("mission"), "vessels[0].controller.waypoints: missing"),  # needed without a target-only mission
    # accepted until a review: two vessels on one station, one on the target, a follower that never hears the
    # leader (nothing relays its estimate: charlie's true station error was 76 m RMS)
    (lambda d: d["vessels"][2].update(mission={"target_offset_m": [-25.0, 20.0]}),
     "vessels[2].mission.target_offset_m: its station is 0.0 m from that of vessels[1] (bravo)"),
    (lambda d: d["vessels"][1].update(mission={"target_offset_m": [1.0, 0.0]}),
     "vessels[1].mission.target_offset_m: the station [1.0, 0.0] m is on the target"),
    (lambda d: d["comms"].update(topology="graph", links=[["alpha", "bravo"], ["bravo", "charlie"]]),
     "vessels[2].comms: 'charlie' does not hear the track_target leader 'alpha' on the link"),
])
def test_bad_target_tracking_is_a_one_line_error(edit, message):
    d = _data("target_tracking")
    edit(d)
    with pytest.raises(ScenarioError) as err:
        parse_scenario(d, "target_tracking.toml")
    assert message in str(err.value) and "\n" not in str(err.value)


# ---------------------------------------------------------------------- the primitives, run
def _run(name, **overrides):
    sc = load_scenario(TASKS / f"{name}.toml")
    if overrides:
        sc = sc.with_overrides(**overrides)
    return Runner(sc, None, progress=False).run().summary


def test_go_to_formation_arrives_together_on_the_formation_poses():
    s = _run("go_to_formation", duration_s=100.0)
    assert s["status"] == "completed" and not s["any_collision"]
    team = s["mission"]["go_to_formation"]
    # Pass criteria (docs/missions.md): arrival spread ≤ 1 s; on the pose within 1 m, on the
    # formation course (over ground) within 3°, at cruise speed within 0.3 m/s.
    assert team["arrival_spread_s"] <= 1.0
    assert team["max_position_error_m"] <= 1.0
    assert team["max_course_error_deg"] <= 3.0
    assert team["max_speed_error_m_s"] <= 0.3
    for name, v in s["vessels"].items():
        first = v["mission"]["phases"][0]
        assert first["phase"] == "go_to_formation" and first["completed"]
        assert v["mission"]["phases"][1]["phase"] == "follow_path"
        assert v["mission"]["phases"][1]["start_s"] == first["end_s"]
    # the transits differ in length by > 10 m, yet nobody arrived at the planned time ± the spread alone:
    lengths = [v["mission"]["phases"][0]["transit_length_m"] for v in s["vessels"].values()]
    assert max(lengths) - min(lengths) > 5.0 or len({v["mission"]["phases"][0]["lead_in_m"]
                                                     for v in s["vessels"].values()}) > 1


def test_go_to_formation_without_coordination_arrives_apart():
    """The consensus is what brings the team in together: with the link cut (every message lost)
    each vessel sails its own plan at its own speed and the arrivals spread."""
    sc = load_scenario(TASKS / "go_to_formation.toml").with_overrides(duration_s=100.0)
    sc = replace(sc, comms=replace(sc.comms, loss_probability=1.0))
    s = Runner(sc, None, progress=False).run().summary
    assert s["mission"]["go_to_formation"]["arrival_spread_s"] > 3.0


def test_go_to_formation_with_traffic_avoids_and_still_arrives_together():
    s = _run("go_to_formation_traffic", duration_s=110.0)
    assert s["status"] == "completed" and not s["any_collision"]
    acted = sum(sum(v["avoidance"]["actions"][k] for k in ("yield", "pass", "replan")) for v in s["vessels"].values())
    assert acted >= 1
    assert min(v["min_clearance_m"]["workboat"] for v in s["vessels"].values()) > 1.0
    assert s["mission"]["go_to_formation"]["arrival_spread_s"] <= 2.0


def _check_tracking(s, rms_m=6.0, max_m=15.0, standoff_tol_m=5.0):
    """Pass criteria (docs/missions.md): the target in track the whole phase (every vessel's
    estimate fresh from its first second), the true station error RMS ≤ 6 m and max ≤ 15 m after settling, the mean
    stand-off within 5 m of nominal, never closer than 20 m."""
    for name, v in s["vessels"].items():
        tt = next(p for p in v["mission"]["phases"] if p["phase"] == "track_target")
        # in track from the phase's first seconds (the fraction is of the whole phase: the time
        # before the first designation counts as out of track) and never lost after
        assert tt["completed"] and tt["in_track_fraction"] >= 0.99 and tt["longest_gap_s"] == 0.0, (name, tt)
        assert tt["target_acquired_s"] - tt["start_s"] <= 2.5, (name, tt)  # (a follower: the leader's first messages)
    truth = s["mission"]["track_target_truth"]
    assert set(truth) == set(s["vessels"])
    for name, t in truth.items():
        assert t["station_error_rms_m"] <= rms_m and t["station_error_max_m"] <= max_m, (name, t)
        # judged over the phase after settling, every record tick (10 Hz)
        assert t["judged_to_s"] - t["judged_from_s"] >= 60.0, (name, t)
        assert t["samples"] == round(10 * (t["judged_to_s"] - t["judged_from_s"])) + 1, (name, t)
        # no longer than the phase (a vessel still avoiding when it ended was judged on until it handed over)
        tt = next(p for p in s["vessels"][name]["mission"]["phases"] if p["phase"] == "track_target")
        assert tt["end_s"] is None or t["judged_to_s"] <= tt["end_s"], (name, t, tt)
        assert abs(t["standoff_mean_m"] - t["standoff_nominal_m"]) <= standoff_tol_m and t["standoff_min_m"] >= 20.0, (name, t)


def test_target_tracking_keeps_stations_from_the_leaders_shared_estimate():
    s = _run("target_tracking")
    assert s["status"] == "completed" and not s["any_collision"] and s["mission"]["mission_completed"]
    _check_tracking(s)
    phases = {n: v["mission"]["phases"][0] for n, v in s["vessels"].items()}
    assert phases["alpha"]["role"] == "leader"
    assert all(phases[n]["role"] == "follower" and phases[n]["target_acquired_s"] > phases["alpha"]["target_acquired_s"]
               for n in ("bravo", "charlie"))  # the followers' estimate came over the link


def test_target_tracking_with_traffic_gives_way_and_resumes():
    s = _run("target_tracking_traffic")
    assert s["status"] == "completed" and not s["any_collision"] and s["mission"]["mission_completed"]
    acted = sum(sum(v["avoidance"]["actions"][k] for k in ("yield", "pass", "replan")) for v in s["vessels"].values())
    assert acted >= 1
    assert s["vessels"]["bravo"]["avoidance"]["mode_time_s"]["avoidance:yield"] >= 10.0  # a real give-way
    # every vessel keeps the safety distance its own avoidance is set to from the ferry (bounding
    # circles; 1.5 m in the file). Since an occluded detection grows a track's radius bravo yields,
    # then changes lane round the ferry and passes it at 2.5 m (it was 6.4 m; docs/missions.md).
    sc = load_scenario(TASKS / "target_tracking_traffic.toml")
    for v in sc.vessels:
        safety = v.options["avoidance"].options.prediction.safety_distance_m
        assert safety >= 1.0 and s["vessels"][v.name]["min_clearance_m"]["ferry"] > safety, v.name
    _check_tracking(s, rms_m=12.0, max_m=30.0, standoff_tol_m=8.0)  # the yield takes one vessel off its station for a while


def test_a_target_phase_shorter_than_its_settling_is_judged_on_no_samples():
    """A track_target phase that ends before settle_s leaves nothing to judge: every vessel's
    truth entry says so (samples 0, no numbers) instead of dropping out of the summary."""
    d = _data("target_tracking")
    d["mission"]["track_target"]["duration_s"] = 30.0
    d["duration_s"] = 45.0
    s = Runner(parse_scenario(d, "target_tracking.toml"), None, progress=False).run().summary
    truth = s["mission"]["track_target_truth"]
    assert set(truth) == set(s["vessels"])
    assert all(t["samples"] == 0 and t["station_error_rms_m"] is None and t["judged_from_s"] is None
               for t in truth.values()), truth


def test_a_target_phase_without_a_judged_target_runs_unjudged():
    """``[mission.track_target] target`` is optional (docs/missions.md: for judging only): a
    scenario without it loads and runs, and the summary has no truth entry (it used to fail to load
    with "target: must be a non-empty string, got ''")."""
    d = _data("target_tracking")
    d["mission"]["track_target"].pop("target")
    d["duration_s"] = 5.0
    sc = parse_scenario(d, "target_tracking.toml")
    assert sc.mission.track_target.target is None
    s = Runner(sc, None, progress=False).run().summary
    assert s["status"] == "completed" and "track_target_truth" not in s.get("mission", {})


def _false_alarm(withdraw: bool):
    """The target-tracking mission with the ferry 30–50 m north of the stations, on seed 8:
    charlie's tracker starts a track on the ferry (track 236) whose first estimates predict a
    0.9 m pass at 96.6 s; the next estimates clear it. (Seed 1 gave such a case until the
    stations' turn feed-forward moved charlie, 2026-12-06; seeds 1–15 give two, 8 and 10.)"""
    d = _data("target_tracking_traffic")
    d["duration_s"] = 130.0
    d["seed"] = 8
    d["moving_obstacles"][0]["position_m"] = [330.0, 60.0]
    for v in d["vessels"]:
        v["avoidance"]["withdraw_false_alarms"] = withdraw
    return Runner(parse_scenario(d, "target_tracking_traffic.toml"), None, progress=False).run().summary


def test_a_yield_on_a_new_tracks_false_alarm_is_withdrawn():
    """With ``withdraw_false_alarms`` a yield whose track, predicted again at the mission speed,
    passes well clear for 3 s is withdrawn; by default the vessel holds it to its goal, 27.1 s, as
    the thesis's velocity correction does."""
    s = _false_alarm(True)
    a = s["vessels"]["charlie"]["avoidance"]
    assert [c["track_id"] for c in a["conflicts"]] == [236] and a["actions"]["yield"] == 1
    assert a["actions"]["withdrawn"] == 1 and a["mode_time_s"]["avoidance:yield"] <= 6.0  # (4.5 s: clear for 3 s)
    held = _false_alarm(False)["vessels"]["charlie"]["avoidance"]
    assert held["actions"]["yield"] == 1 and held["actions"]["withdrawn"] == 0
    assert held["mode_time_s"]["avoidance:yield"] >= 25.0


@pytest.mark.slow
def test_chained_mission_completes_every_phase_in_order(tmp_path):
    sc = load_scenario(TASKS / "chain_formation_path_target.toml")
    s = Runner(sc, tmp_path, progress=False).run().summary
    assert s["status"] == "completed" and not s["any_collision"]
    assert s["mission"]["mission_completed"]
    for name, v in s["vessels"].items():
        phases = v["mission"]["phases"]
        assert [p["phase"] for p in phases] == ["go_to_formation", "follow_path", "track_target"]
        assert all(p["completed"] for p in phases) and v["mission"]["mission_completed"]
        for a, b in zip(phases, phases[1:]):
            assert a["end_s"] <= b["start_s"]
    assert s["mission"]["go_to_formation"]["arrival_spread_s"] <= 1.0
    _check_tracking(s)
    assert any(v["avoidance"]["actions"]["yield"] for v in s["vessels"].values())  # the ferry, in follow_path
    # the cross-track statistics leave the approach onto the target-tracking lines out (the error
    # jumps to 9, 27 and 45 m at that phase change) and count the path following, yields included,
    # and how far each vessel lags its station's moving line (5.6–6.8 m at most)
    for name, v in s["vessels"].items():
        assert 0.5 < v["max_cross_track_m"] < 8.0 and v["mean_cross_track_m"] < 1.5, name
    # the recording shows the phases as a lane per vessel
    import rerun as rr

    states = {}
    for chunk in rr.chunk.RrdReader(tmp_path / "recording.rrd").store().stream():
        if chunk.entity_path.startswith("/missions/"):
            tb = chunk.to_record_batch()
            col = [c for c in tb.schema.names if c.endswith("StateChange:state")]
            if col:
                states.setdefault(chunk.entity_path, []).extend(tb.column(col[0]).to_pylist())
    flat = {e: [x for row in v for x in (row if isinstance(row, list) else [row])] for e, v in states.items()}
    assert flat.get("/missions/alpha", [])[:4] == ["go_to_formation", "follow_path", "track_target", "done"]


# ---------------------------------------------------------------------- coordination within a phase
def test_coordination_ignores_team_mates_in_another_phase():
    from mjasc.cooperation.comms import CommsNetwork, NetworkConfig
    from mjasc.cooperation.coordination import Coordination
    from mjasc.missions.legs import MissionBroadcast, MissionLeg

    net = CommsNetwork(["a", "b"], NetworkConfig(base_delay_s=0.0, jitter_s=0.0, loss_probability=0.0),
                       np.random.default_rng(0))
    path = GPath.line([0.0, 0.0], [100.0, 0.0])
    a = Coordination("a", net, mission_path=path, mission_speed_m_s=1.0)
    b = Coordination("b", net, mission_path=path, mission_speed_m_s=1.0)

    def nav(x):
        return OwnNavigation(0.0, np.array([x, 0.0]), 0.0, np.array([1.0, 0.0]), np.array([1.0, 0.0, 0.0]))

    b.exchange(0.0, nav(50.0), 50.0, mission=MissionBroadcast(0))
    assert a.speed_correction(0.5, nav(10.0), 10.0) > 1.1  # b is ahead in the same phase: a speeds up
    b.set_mission(0.0, MissionLeg("follow_path", 1, path, 0.0, 1.0))
    b.exchange(1.0, nav(50.0), 50.0, mission=MissionBroadcast(1))
    assert a.speed_correction(1.5, nav(10.0), 10.0) == pytest.approx(1.0)  # b is in the next phase: not a peer


# ---------------------------------------------------------------------- the thesis's cooperative scenarios, lossy
@pytest.mark.parametrize("name, duration", [("thesis_6_4_crossing", 150.0),
                                            pytest.param("thesis_6_4_head_on", 200.0, marks=pytest.mark.slow),
                                            pytest.param("thesis_6_4_bottleneck", 200.0, marks=pytest.mark.slow)])
def test_thesis_cooperative_scenarios_pass_with_30_percent_packet_loss(name, duration):
    sc = load_scenario(TASKS / f"{name}.toml").with_overrides(duration_s=duration)
    sc = replace(sc, comms=replace(sc.comms, loss_probability=0.3))
    s = Runner(sc, None, progress=False).run().summary
    assert s["status"] == "completed" and not s["any_collision"], s["collisions"]
    for v in s["vessels"].values():
        assert v["min_clearance_to_any_m"] > 0.5
        assert v["coordination"]["loss_rate"] > 0.2  # the loss really applied


# ---------------------------------------------------------------------- the phases' logic, without a run
def _nav(x, y, heading=0.0, speed=1.0, t=0.0):
    return OwnNavigation(t, np.array([x, y]), heading, np.array([speed * math.cos(heading), speed * math.sin(heading)]),
                         np.array([speed, 0.0, 0.0]))


def test_go_to_formation_agrees_on_the_slowest_arrival_and_lengthens_the_early_transit():
    from mjasc.missions.config import GoToFormationOptions
    from mjasc.missions.go_to_formation import GoToFormation
    from mjasc.missions.legs import MissionBroadcast, PhaseInputs

    formation = GPath.line([100.0, 0.0], [300.0, 0.0])
    ph = GoToFormation(0, GoToFormationOptions(), formation, 1.5, team_size=2)
    leg = ph.begin(0.0, _nav(40.0, 0.0))  # 60 m straight ahead of its pose: earliest arrival 40 s
    assert leg.path.length == pytest.approx(60.0) and ph.broadcast().arrival_time_s == pytest.approx(40.0)
    late = {"mate": MissionBroadcast(0, arrival_time_s=100.0)}  # the mate needs 100 s
    leg, arrived = ph.step(PhaseInputs(1.0, _nav(41.5, 0.0), 1.5, None, late, True))
    assert not arrived and leg is not None and leg.new_path
    # re-planned to arrive at 100 s at cruise speed: 1.5 m/s × 99 s of path
    assert leg.path.length == pytest.approx(1.5 * 99.0, abs=1.0) and leg.speed_m_s == pytest.approx(1.5, abs=0.02)
    assert np.allclose(leg.path.point(leg.path.length), [100.0, 0.0], atol=1e-6)
    assert ph.broadcast().arrival_time_s == pytest.approx(100.0)
    # a mate in another phase is not heard; a later arrival heard afterwards slows the vessel
    leg, _ = ph.step(PhaseInputs(2.0, _nav(43.0, 0.0), 1.5, None, {"m": MissionBroadcast(1, arrival_time_s=500.0)}, True))
    assert leg is None
    leg, _ = ph.step(PhaseInputs(2.0, _nav(43.0, 0.0), 1.5, None, {"m": MissionBroadcast(0, arrival_time_s=130.0)}, True))
    assert leg is not None and not leg.new_path and leg.speed_m_s < 1.5
    # at the pose: arrived, with its figures
    _, arrived = ph.step(PhaseInputs(130.0, _nav(99.5, 0.0, speed=1.5, t=130.0), ph.path.length - 0.5, None, {}, True))
    assert arrived and ph.result()["completed"] and abs(ph.result()["course_error_deg"]) < 1e-6


def _track(track_id, x, y, heading=0.0, speed=1.0, team=None, static=False, t=0.0):
    from mjasc.core.estimates import TrackEstimate

    return TrackEstimate(track_id, t, np.array([x, y]), heading, speed, 0.0, 2.5, is_static=static, team_member=team)


def test_a_bump_keeps_clear_of_a_team_mates_plan():
    """The bump goes to the side away from a team mate whose broadcast plan runs alongside 14 m to
    one side (a bump of ~12 m toward it would meet it); with no plan, both sides are equal and the
    left wins."""
    from mjasc.missions.config import GoToFormationOptions
    from mjasc.missions.go_to_formation import GoToFormation
    from mjasc.missions.legs import MissionBroadcast, PhaseInputs

    formation = GPath.line([100.0, 0.0], [300.0, 0.0])
    times = np.arange(1.0, 62.0, 1.0)
    pushes = {}
    for side in (14.0, -14.0, None):
        ph = GoToFormation(0, GoToFormationOptions(), formation, 1.5, team_size=2)
        ph.begin(0.0, _nav(40.0, 0.0))
        plans = {} if side is None else {"mate": (times, np.column_stack([41.5 + 1.5 * (times - 1.0),
                                                                          np.full(times.size, side)]))}
        ph.step(PhaseInputs(1.0, _nav(41.5, 0.0), 1.5, None, {"mate": MissionBroadcast(0, arrival_time_s=45.0)}, True,
                            plans))
        assert ph.speed_m_s == pytest.approx(1.5, abs=0.01)
        pushes[side] = ph.bump_m
    assert pushes[14.0] < -5.0 and pushes[-14.0] > 5.0 and pushes[None] > 5.0


def test_go_to_formation_never_plans_a_transit_that_arrives_late():
    """Where the lead-in's jump leaves no length near the need (a 30 m turn radius), the searches
    took the closest length even beyond the jump: 51 m (and 3 m) longer than the need, sailed at
    cruise speed 34 s (2 s) after the agreed time, with the consensus holding the team back. A
    shorter transit sailed slower arrives on time: no transit is longer than the need (1 m)."""
    from mjasc.missions.config import GoToFormationOptions
    from mjasc.missions.go_to_formation import GoToFormation
    from mjasc.missions.legs import MissionBroadcast, PhaseInputs

    formation = GPath.line([100.0, 0.0], [300.0, 0.0])
    for x, y, heading, extra in ((-24.4, -45.0, -0.80, 70.0), (14.8, -30.8, -1.29, 10.0)):
        ph = GoToFormation(0, GoToFormationOptions(turn_radius_m=30.0, lead_in_m=0.0), formation, 1.5, team_size=2)
        ph.begin(0.0, _nav(x, y, heading))
        need = ph.path.length + extra
        leg, _ = ph.step(PhaseInputs(0.0, _nav(x, y, heading), 0.0, None,
                                     {"mate": MissionBroadcast(0, arrival_time_s=need / 1.5)}, True))
        assert ph.path.length <= need + 1.0
        assert ph.path.length / leg.speed_m_s == pytest.approx(need / 1.5, abs=0.7)  # on time
        s = np.linspace(0.0, ph.path.length, 1500)
        assert np.all(np.abs(ph.path.curvature(s)) <= 1.0 / 30.0 + 1e-9)
        assert ph.bump_m == 0.0  # no bump gives the length here (see below)


def test_a_bump_that_cannot_give_the_length_is_not_sailed():
    """70 m more than the shortest transit, with a 30 m turn radius: the lead-in's jump (> 2πR)
    and the bumps (whose curves loop once pushed a little) give no length near the need. A bump
    33.5 m to the side, still 42 m short, was taken because it came closer: a detour sailed
    slower all the same. The vessel now sails its lead-in transit, slower, with no bump."""
    from mjasc.missions.config import GoToFormationOptions
    from mjasc.missions.go_to_formation import GoToFormation
    from mjasc.missions.legs import MissionBroadcast, PhaseInputs

    formation = GPath.line([100.0, 0.0], [300.0, 0.0])
    for x, y, heading, lead_in in ((-24.4, -45.0, -0.80, 0.0), (-19.5, -3.0, 0.52, 15.0)):
        opts = GoToFormationOptions(turn_radius_m=30.0, lead_in_m=lead_in)
        ph = GoToFormation(0, opts, formation, 1.5, team_size=2)
        ph.begin(0.0, _nav(x, y, heading))
        need = ph.path.length + 70.0
        leg, _ = ph.step(PhaseInputs(0.0, _nav(x, y, heading), 0.0, None,
                                     {"mate": MissionBroadcast(0, arrival_time_s=need / 1.5)}, True))
        assert ph.bump_m == 0.0 and ph.path.length < need - 30.0
        assert leg.speed_m_s == pytest.approx(ph.path.length / (need / 1.5))  # slower, on time
        # the transit is the lead-in's: Dubins to the (moved) entry, then straight on the course
        assert leg.path.length == pytest.approx(plan_transit([x, y], heading, formation, 30.0, ph.lead_in_m).length)


def test_a_bump_that_gives_the_length_wins_over_a_clearer_one_that_does_not():
    """Bumped right, this vessel's transit cannot reach the need (the push turns the first curve's
    word into a loop); bumped left it can, and stays 12 m clear of a team mate's plan 25 m to the
    left. The side was chosen by clearance first: right (25 m clear), 66 m at 1.40 m/s instead of
    71 m at cruise. A side that gives the length now comes first, then the clearer one."""
    from mjasc.missions.config import GoToFormationOptions
    from mjasc.missions.go_to_formation import GoToFormation, _separation
    from mjasc.missions.legs import MissionBroadcast, PhaseInputs

    formation = GPath.line([100.0, 0.0], [300.0, 0.0])
    ph = GoToFormation(0, GoToFormationOptions(), formation, 1.5, team_size=2)
    ph.begin(0.0, _nav(41.9, -4.2, 0.45))
    base = ph.path
    need = base.length + 12.5
    t = np.arange(0.0, 60.0, 1.0)
    plans = {"mate": (t, np.array([base.point(min(x * 1.5, base.length)) for x in t]) + [0.0, 25.0])}
    leg, _ = ph.step(PhaseInputs(0.0, _nav(41.9, -4.2, 0.45), 0.0, None,
                                 {"mate": MissionBroadcast(0, arrival_time_s=need / 1.5)}, True, plans))
    assert leg.path.length == pytest.approx(need, abs=0.1) and leg.speed_m_s == pytest.approx(1.5, abs=0.01)
    assert ph.bump_m > 5.0 and _separation(leg.path, 0.0, 1.5, plans) > 10.0


def test_the_length_search_refines_a_steep_crossing_and_skips_a_jump():
    """A bump's length grows like √push where it starts: from 11.7 m short at no push to 0.9 m
    over one grid step on. The search refined only sign changes no steeper than 2 m/m (+1 m), took
    this one for a jump and kept the grid's point 11.7 m short (the bump was refused). It now lets
    brentq refine every neighbouring sign change and keeps its point when it comes closer: a steep
    crossing is met, a jump (where brentq ends on the jump) still is not."""
    from mjasc.missions.go_to_formation import _solve_length

    x, length = _solve_length(lambda h: 100.0 + 30.0 * math.sqrt(h), 50.0, 110.0)
    assert length == pytest.approx(110.0, abs=0.1) and x == pytest.approx(1.0 / 9.0, abs=0.02)
    x, length = _solve_length(lambda h: 100.0 if h < 10.0 else 190.0 + h, 50.0, 150.0)
    assert length == 100.0 and x < 10.0  # the closest length not beyond the need, no "root" on the jump


def test_go_to_formation_ignores_a_mates_non_finite_arrival_time():
    """A mate's arrival time of inf (or NaN) is no time to arrive at: before, inf became the team's
    arrival, the length searches ran over [0, inf] and the bump built an arc of NaN sweep
    (ValueError, the run aborted). It is ignored like an unheard mate: the vessel agrees after
    ``agree_s`` on its own time and sails its shortest transit at cruise speed."""
    from mjasc.missions.config import GoToFormationOptions
    from mjasc.missions.go_to_formation import GoToFormation
    from mjasc.missions.legs import MissionBroadcast, PhaseInputs

    formation = GPath.line([100.0, 0.0], [300.0, 0.0])
    for bad in (math.inf, math.nan):
        ph = GoToFormation(0, GoToFormationOptions(), formation, 1.5, team_size=2)
        ph.begin(0.0, _nav(40.0, 0.0))
        mates = {"mate": MissionBroadcast(0, arrival_time_s=bad)}
        leg, _ = ph.step(PhaseInputs(1.0, _nav(41.5, 0.0), 1.5, None, mates, True))
        assert leg is None and not ph.agreed  # the mate is not heard
        leg, _ = ph.step(PhaseInputs(3.5, _nav(45.25, 0.0), 5.25, None, mates, True))
        assert ph.agreed and math.isfinite(ph.team_arrival_s) and ph.team_arrival_s == pytest.approx(40.0)
        assert leg.speed_m_s == pytest.approx(1.5) and ph.bump_m == 0.0 and math.isfinite(leg.path.length)


def test_target_designation_keeps_its_track_and_reacquires_within_the_gate():
    from mjasc.core.estimates import PerceptionReport
    from mjasc.missions.target_tracking import designate_target

    rep = PerceptionReport(0.0, [_track(1, 50, 0), _track(2, 10, 0, team="bravo"), _track(3, 20, 5, static=True),
                                 _track(4, 80, 0)], [])
    assert designate_target(rep, [15.0, 0.0]).track_id == 1  # nearest non-team, non-static track
    assert designate_target(rep, [15.0, 0.0], keep_id=4).track_id == 4  # its own track, wherever
    assert designate_target(rep, [60.0, 0.0], gate_m=15.0, keep_id=9).track_id == 1  # lost: nearest within the gate
    assert designate_target(rep, [65.0, 30.0], gate_m=15.0, keep_id=9) is None


def test_followers_hold_stations_from_the_leaders_broadcast_and_count_stale_estimates():
    from mjasc.missions.config import TrackTargetOptions
    from mjasc.missions.legs import MissionBroadcast, PhaseInputs, TargetEstimate
    from mjasc.missions.target_tracking import TrackTarget

    opts = TrackTargetOptions(leader="alpha", target_hint_m=np.array([100.0, 0.0]), duration_s=100.0, settle_s=0.0)
    ph = TrackTarget(0, opts, "bravo", [-30.0, 10.0], 1.5, 3.0)
    ph.begin(0.0, _nav(0.0, 0.0))
    est = TargetEstimate(0.0, np.array([100.0, 0.0]), np.array([1.0, 0.0]), 7, "alpha")
    leg, done = ph.step(PhaseInputs(0.1, _nav(60.0, 10.0), 0.0, None, {"alpha": MissionBroadcast(0, target=est)}, True))
    # the station is 30 m astern and 10 m to port of the extrapolated target: (70.1, 10)
    assert leg.new_path and not leg.coordinated and not done
    assert abs(leg.path.cross_track_error(np.array([70.1, 10.0]), leg.path.project([70.1, 10.0]))) < 1e-6
    assert abs(math.atan2(*(leg.path.end_point - leg.path.start_point)[::-1])) < 1e-9  # along the target's course
    assert leg.speed_m_s == pytest.approx(1.0 + opts.speed_gain_1_s * 10.1, abs=1e-6)  # behind: faster than it
    for t in np.arange(0.2, 10.0, 0.1):  # the leader falls silent: the estimate ages out after 5 s
        ph.step(PhaseInputs(float(t), _nav(60.0, 10.0), 0.0, None, {}, True))
    r = ph.result()
    assert r["role"] == "follower" and r["longest_gap_s"] > 4.0 and r["in_track_fraction"] < 0.6


@pytest.mark.slow
def test_a_mission_campaign_reports_completion_and_arrival_spread(tmp_path):
    """The shipped deployment campaign, cut to 3 runs: every run completes its mission and
    the report shows the mission table (completion with its Wilson interval, arrival spread)."""
    from mjasc.campaigns.engine import run_campaign
    from mjasc.campaigns.report import format_report, report_data
    from mjasc.campaigns.spec import load_campaign_spec

    text = (TASKS / "campaigns" / "go_to_formation_deployments.toml").read_text()
    text = text.replace('scenario = "../go_to_formation.toml"', f'scenario = "{TASKS / "go_to_formation.toml"}"')
    text = text.replace("runs = 40", "runs = 3")
    (tmp_path / "c.toml").write_text(text)
    run_campaign(load_campaign_spec(tmp_path / "c.toml"), tmp_path / "out", workers=0, progress=False)
    data = report_data(tmp_path / "out")
    m = data["mission"]
    assert m["completed"]["count"] == 3 and m["completed"]["n"] == 3
    assert m["arrival_spread_s"]["p100"] <= 2.0
    text = format_report(data)
    assert "mission completed [Wilson 95 %]" in text and "arrival spread [s]" in text


def test_the_leader_designates_only_near_the_hint():
    from mjasc.core.estimates import PerceptionReport
    from mjasc.missions.config import TrackTargetOptions
    from mjasc.missions.legs import PhaseInputs
    from mjasc.missions.target_tracking import TrackTarget

    opts = TrackTargetOptions(leader="alpha", target_hint_m=np.array([100.0, 0.0]), duration_s=100.0)
    ph = TrackTarget(0, opts, "alpha", [-30.0, 0.0], 1.5, 3.0)
    ph.begin(0.0, _nav(0.0, 0.0))
    far = PerceptionReport(0.5, [_track(3, 100.0, 90.0, t=0.5)], [])  # a boat 90 m from the hint
    leg, _ = ph.step(PhaseInputs(0.5, _nav(0.5, 0.0), 0.5, far, {}, True))
    assert leg is None and ph.estimate is None and ph.broadcast().target is None
    near = PerceptionReport(1.0, [_track(3, 100.0, 90.0, t=1.0), _track(5, 104.0, 3.0, t=1.0)], [])
    leg, _ = ph.step(PhaseInputs(1.0, _nav(1.0, 0.0), 1.0, near, {}, True))
    assert ph.estimate.track_id == 5 and ph.broadcast().target.track_id == 5 and leg is not None


def test_the_mission_report_says_how_many_runs_the_arrival_figures_rest_on(tmp_path):
    """Runs whose team never reached its formation poses have no arrival spread: the report's
    mission table says the figures rest on 1 of 3 runs (it showed them as if over all three)."""
    from mjasc.campaigns.report import format_report, report_data
    from mjasc.campaigns.store import CampaignStore

    gtf = {"arrival_spread_s": 0.13, "max_position_error_m": 0.14}
    with CampaignStore(tmp_path, "abc", name="c", runs_defined=3) as s:
        for k in range(3):
            mission = {"phases": ["go_to_formation"], "mission_completed": k == 0, **({"go_to_formation": gtf}
                                                                                      if k == 0 else {})}
            s.record(k, family="perturbation", parameters={}, seed=k, scenario="", status="completed",
                     metrics={"mission": mission, "vessels": {}})
    text = format_report(report_data(tmp_path))
    assert "| 0.13 / 0.13 / 0.13 (1 of 3 runs) | 0.14 / 0.14 / 0.14 (1 of 3 runs) |" in text


def test_a_team_mates_old_track_coasting_on_is_not_designated():
    """The case a mixed Otter/Delfim team met: bravo stopped near the hint, its label passed from
    track 278 (coasting on at its old velocity) to a new track 915, and the leader designated 278 —
    bravo's own wake of a track — while the animal was 150 m away. A track once labelled a team
    mate (in any phase, seen by the sequencer) is never designated."""
    from mjasc.core.estimates import PerceptionReport
    from mjasc.missions.config import MissionConfig, TrackTargetOptions
    from mjasc.missions.sequencer import MissionSequencer

    opts = TrackTargetOptions(leader="alpha", target_hint_m=np.array([300.0, 40.0]), duration_s=100.0)
    seq = MissionSequencer(MissionConfig(phases=("track_target",), track_target=opts), "alpha",
                           GPath.line([250.0, 50.0], [260.0, 50.0]), 1.0, 3.0, team_size=2)
    seq.begin(0.0, _nav(250.0, 50.0))
    labelled = PerceptionReport(0.5, [_track(278, 270.4, 16.5, team="bravo")], [])
    seq.update(0.5, _nav(250.0, 50.0, t=0.5), 0.5, labelled, None, "mission")
    coasting = PerceptionReport(1.0, [_track(278, 277.4, 21.7), _track(915, 273.0, 18.5, team="bravo")], [])
    seq.update(1.0, _nav(250.0, 50.0, t=1.0), 1.0, coasting, None, "mission")
    assert seq.phase.estimate is None
    seal = PerceptionReport(1.5, [_track(278, 277.8, 22.0), _track(915, 273.0, 18.5, team="bravo"),
                                  _track(7, 310.0, 60.0, t=1.5)], [])
    seq.update(1.5, _nav(250.0, 50.0, t=1.5), 1.5, seal, None, "mission")
    assert seq.phase.estimate is not None and seq.phase.estimate.track_id == 7


def test_the_in_track_fraction_is_of_the_whole_phase():
    """A follower that heard the leader's estimate only halfway through the phase counted 100 % in
    track and the phase completed (the fraction ran from the first designation, against the docs:
    "in track … for at least min_in_track_fraction of it")."""
    from mjasc.missions.legs import MissionBroadcast, PhaseInputs, TargetEstimate
    from mjasc.missions.target_tracking import TrackTarget, TrackTargetOptions

    opts = TrackTargetOptions(leader="alpha", target_hint_m=np.array([100.0, 0.0]), duration_s=100.0, settle_s=0.0)
    ph = TrackTarget(0, opts, "bravo", [-30.0, 10.0], 1.5, 3.0)
    ph.begin(0.0, _nav(0.0, 0.0))
    for t in np.arange(0.1, 100.05, 0.1):
        est = TargetEstimate(float(t), np.array([100.0 + t, 0.0]), np.array([1.0, 0.0]), 7, "alpha")
        heard = {"alpha": MissionBroadcast(0, target=est)} if t >= 50.0 else {}
        ph.step(PhaseInputs(float(t), _nav(60.0, 10.0), 0.0, None, heard, True))
    r = ph.result()
    assert r["target_acquired_s"] == pytest.approx(50.0, abs=0.11)
    assert r["in_track_fraction"] == pytest.approx(0.5, abs=0.01) and not r["completed"]
    assert r["longest_gap_s"] == 0.0  # (no gap once in track)


@pytest.mark.parametrize("offset", [[-35.0, 0.0], [0.0, -20.0], [-30.0, 10.0]])
def test_a_station_s_speed_is_its_own_in_a_turn(offset):
    """The speed law's feed-forward is the station's own speed |ṡ|, ṡ = v_T + ω J R(χ) o: a
    station astern of a turning target swings sideways at ω o_ahead; with the along-course part
    alone (|v_T| − ω o_port) a station 35 m astern in a 0.8°/s turn lagged ~4 m for good."""
    from mjasc.missions.legs import MissionBroadcast, PhaseInputs, TargetEstimate
    from mjasc.missions.target_tracking import TrackTarget, TrackTargetOptions

    w, v = math.radians(0.8), 0.7
    opts = TrackTargetOptions(leader="alpha", target_hint_m=np.array([0.0, 0.0]), duration_s=100.0, settle_s=0.0)
    ph = TrackTarget(0, opts, "bravo", offset, 1.5, 3.0)
    ph.begin(0.0, _nav(0.0, 0.0))
    est = TargetEstimate(0.0, np.array([0.0, 0.0]), np.array([v, 0.0]), 7, "alpha", turn_rate_rad_s=w)
    s = station(est.position_at(0.1), 0.0, np.asarray(offset, dtype=float))
    # the vessel exactly on its station: no along-course error, the speed is the feed-forward alone
    leg, _ = ph.step(PhaseInputs(0.1, _nav(float(s[0]), float(s[1]), speed=v), 0.0, None,
                                 {"alpha": MissionBroadcast(0, target=est)}, True))
    ahead, port = offset
    assert leg.speed_m_s == pytest.approx(math.hypot(v - w * port, w * ahead), abs=0.02)
    # and it is the station's speed: the station's positions a small time apart
    h = 1e-4
    def st(t):
        th = w * t
        p_t = np.array([v / w * math.sin(th), v / w * (1.0 - math.cos(th))])
        return station(p_t, th, np.asarray(offset, dtype=float))
    assert math.hypot(v - w * port, w * ahead) == pytest.approx(float(np.hypot(*(st(h) - st(0.0)))) / h, rel=1e-3)


def test_a_formation_pose_two_hulls_cannot_share_is_refused():
    """A reviewer gave two vessels the same formation pose: the scenario loaded, alpha yielded for
    105 of 120 s and the mission stalled with only ``mission_completed: false`` to say so. (A
    ``settle_s`` longer than the phase stays allowed: the judgement then says it rests on no
    sample — test_a_target_phase_shorter_than_its_settling_is_judged_on_no_samples.)"""
    d = _data("go_to_formation")
    d["vessels"][1]["controller"]["waypoints"] = [list(map(float, w))
                                                  for w in d["vessels"][0]["controller"]["waypoints"]]
    with pytest.raises(ScenarioError, match=r"^vessels\[1\]\.controller\.waypoints: its formation pose \(the path's "
                                            r"start\) is 0\.0 m from that of vessels\[0\] \(alpha\), closer than "
                                            r"their hulls' radii \(\d+\.\d m\): both cannot hold it$"):
        parse_scenario(d)


def test_every_bundled_mission_scenario_still_loads():
    for name in ("go_to_formation", "go_to_formation_traffic", "target_tracking", "target_tracking_traffic",
                 "chain_formation_path_target"):
        assert parse_scenario(_data(name)).mission is not None, name


def test_a_column_on_one_path_without_go_to_formation_still_loads():
    """follow_path joins the path where each vessel is: two vessels on one path spaced along it by
    their formation offsets are a column, not two vessels on one pose (only go_to_formation sends
    every vessel to its path's start)."""
    d = _data("go_to_formation")
    d["mission"]["phases"] = ["follow_path"]
    d["mission"].pop("go_to_formation", None)
    d["vessels"][1]["controller"]["waypoints"] = [list(map(float, w))
                                                  for w in d["vessels"][0]["controller"]["waypoints"]]
    d["vessels"][1]["comms"]["formation_offset_m"] = -15.0  # (15 m astern: without a lead apart it is refused)
    assert parse_scenario(d).mission.phases == ("follow_path",)
