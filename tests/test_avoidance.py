"""Collision avoidance per vessel (mjasc.avoidance.system): mode machine, yield vs pass, right of way
between team mates, detour splice and resumption, configuration. Synthetic tracks only (the
system is tested through the runner in test_avoidance_scenarios.py)."""

from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from mjasc.avoidance.config import AvoidanceConfig, parse_avoidance_options
from mjasc.avoidance.replanning import merge_overlapping
from mjasc.avoidance.system import CollisionAvoidance
from mjasc.avoidance.team_mates import PlannedTrack
from mjasc.cooperation.messages import TeamIntention, TeamPicture
from mjasc.core.estimates import PerceptionReport, TrackEstimate
from mjasc.core.geometry import distance_to_polygon, point_in_polygon
from mjasc.guidance.paths import Path
from mjasc.guidance.state import GuidanceState
from mjasc.physics.vessels import load_vessel_type

DELFIM = load_vessel_type("delfim")


class FakeFollower:
    """The part of PathFollower the avoidance uses: path, γ, set_path."""

    def __init__(self, path):
        self.path, self.gamma_m = path, 0.0

    def set_path(self, path, gamma0_m=0.0):
        self.path, self.gamma_m = path, float(gamma0_m)


class Driven:
    """The avoidance stage driven the way the vessel agent drives it: typed inputs each call (its
    guidance state from the fake follower, a perception report, a team picture from the fake
    coordination) and its requests applied to the fake follower. Other attributes are the
    system's own (correction, detour, stats, summary(), ...)."""

    def __init__(self, ca, agent):
        self.ca, self.agent = ca, agent

    def __getattr__(self, name):
        return getattr(self.ca, name)

    def mission_speed_now(self):
        return self.agent.mission_speed_m_s * getattr(getattr(self.agent, "coordination", None), "last_factor", 1.0)

    def _guidance(self, follower=None):
        f = follower or self.agent.follower
        return GuidanceState(f.path, f.gamma_m, self.mission_speed_now())

    def _team(self, t):
        coord = getattr(self.agent, "coordination", None)
        return None if coord is None else TeamPicture(t, coord.team_intentions(), coord.last_factor)

    def _report(self, t):
        p = self.agent.perception
        return None if p is None else PerceptionReport(t, tuple(p.tracks()), tuple(p.static_polygons()))

    def _apply(self, req):
        if req.path_switch is not None:
            self.agent.follower.set_path(req.path_switch.path, req.path_switch.gamma_m)
        return req

    def predict(self, t, nav, tracks, static_polygons=()):
        req = self.ca.predict(t, nav, self._guidance(), PerceptionReport(t, tuple(tracks), tuple(static_polygons)),
                              self._team(t))
        return list(self._apply(req).conflicts)

    def control_refs(self, t, nav):
        req = self._apply(self.ca.control(t, nav, self._guidance(), self._report(t), self._team(t)))
        return req.speed_override_m_s, req.mode

    def mission_gamma_m(self, follower):
        return self.ca.mission_gamma_m(self._guidance(follower))

    def planned_trajectory(self, t, nav, horizon_s, step_s):
        return self.ca.planned_trajectory(t, nav, self._guidance(), horizon_s, step_s)

    def _poll_team(self):
        self.ca.team_mates.poll(self._team(None))

    def _team_tracks(self, tracks, t):
        return self.ca.team_mates.tracks(tracks, t, self._team(t), self.ca._event)


def make(config=None, name="a", team=("a", "b"), path=None, perception=None):
    path = path or Path.from_waypoints(np.array([[0.0, 0.0], [200.0, 0.0]]))
    agent = SimpleNamespace(name=name, vessel=DELFIM, follower=FakeFollower(path), mission_speed_m_s=1.0,
                            perception=perception)
    ca = CollisionAvoidance(name, DELFIM, path, config or AvoidanceConfig(), list(team))
    return Driven(ca, agent), agent


def nav(x=0.0, y=0.0, heading=0.0, speed=0.0):
    """The own navigation (OwnNavigation's fields) at rest or sailing ``speed`` [m/s] on its heading."""
    return SimpleNamespace(position_m=np.array([x, y]), heading_rad=heading,
                           velocity_m_s=speed * np.array([np.cos(heading), np.sin(heading)]),
                           body_velocity=np.array([speed, 0.0, 0.0]))


def crossing(x_cross=30.0, t_cross=30.0, speed=1.0, radius=2.0, track_id=1, team_member=None, from_south=True):
    """A track crossing the x axis at x_cross at t_cross, moving north (or south)."""
    h = np.pi / 2 if from_south else -np.pi / 2
    y0 = -speed * t_cross if from_south else speed * t_cross
    return TrackEstimate(track_id, 0.0, np.array([x_cross, y0]), h, speed, 0.0, radius, team_member=team_member)


# ------------------------------------------------------------------------------------ config
def test_config_parsing_and_errors_name_the_field():
    cfg = parse_avoidance_options({"gain_k": 2, "window_s": "dynamic", "enabled": False}, "vessels[0].avoidance")
    assert cfg.gain_k == 2.0 and cfg.window_s is None and cfg.enabled is False
    assert cfg.prediction_config().window_s is None
    with pytest.raises(ValueError, match=r"^vessels\[0\]\.avoidance\.gain_k: must be"):
        parse_avoidance_options({"gain_k": -1}, "vessels[0].avoidance")
    with pytest.raises(ValueError, match=r"^vessels\[1\]\.avoidance\.wobble: unknown field"):
        parse_avoidance_options({"wobble": 1}, "vessels[1].avoidance")
    with pytest.raises(ValueError, match=r"avoidance\.safety_ratio: .*≤ 1"):
        parse_avoidance_options({"safety_ratio": 1.5}, "avoidance")
    with pytest.raises(ValueError, match=r"avoidance\.enabled: must be true or false"):
        parse_avoidance_options({"enabled": 1}, "avoidance")
    with pytest.raises(ValueError, match=r"avoidance\.speed_max_m_s: must exceed"):
        parse_avoidance_options({"speed_min_m_s": 1.0, "speed_max_m_s": 0.5}, "avoidance")
    # options of a mode the table does not choose (they were ignored)
    with pytest.raises(ValueError, match=r'^avoidance\.stand_on_s: only with traffic_rule = "colreg" \(the thesis'):
        parse_avoidance_options({"stand_on_s": 5.0}, "avoidance")
    assert parse_avoidance_options({"stand_on_s": 5.0, "traffic_rule": "colreg"}, "avoidance").stand_on_s == 5.0
    for key in ("brake_decel_m_s2", "margin_s"):
        with pytest.raises(ValueError, match=rf'^avoidance\.{key}: only with window_s = "dynamic" \(a fixed window of 30'):
            parse_avoidance_options({key: 0.5}, "avoidance")
        assert getattr(parse_avoidance_options({key: 0.5, "window_s": "dynamic"}, "avoidance"), key) == 0.5
    with pytest.raises(ValueError, match=r"^avoidance\.time_step_s: must not exceed the window \(10\.0 s\), got 20\.0$"):
        parse_avoidance_options({"window_s": 10.0, "time_step_s": 20.0}, "avoidance")


def test_scenario_loader_validates_the_avoidance_table():
    from mjasc.runs.scenario import ScenarioError, parse_scenario

    doc = {"duration_s": 10.0, "vessels": [{"name": "a", "type": "delfim", "avoidance": {"gain_k": 0.0},
                                            "sensor": {}, "controller": {"waypoints": [[0, 0], [10, 0]]}}]}
    with pytest.raises(ScenarioError, match=r"vessels\[0\]\.avoidance\.gain_k"):
        parse_scenario(doc)
    doc["vessels"][0]["avoidance"] = {"gain_k": 1.0}
    assert parse_scenario(doc).vessels[0].options["avoidance"].options.gain_k == 1.0


# ------------------------------------------------------------------------------------ mode machine
def test_crossing_obstacle_yield_then_resume_mission():
    ca, agent = make()
    conflicts = ca.predict(0.0, nav(), [crossing()], [])
    assert len(conflicts) == 1 and conflicts[0].decision.value == "velocity_correction"
    speed, mode = ca.control_refs(0.0, nav())
    assert mode == "avoidance:yield"
    law = ca.correction.law
    # Goal (γ_A − margin, t_f): the vessel is held out of the obstructed stretch until t_f.
    assert law.gamma_goal == pytest.approx(conflicts[0].gamma_a - ca.config.correction_margin_m)
    assert law.t_goal == pytest.approx(conflicts[0].t_f)
    assert 0.2 <= speed < agent.mission_speed_m_s
    # Kinematic vessel following the command: out of [γ_A, γ_B] during [t_i, t_f].
    t, g, dt = 0.0, 0.0, 0.1
    while t < law.t_goal + 1.0:
        speed, mode = ca.control_refs(t, nav(g))
        v = agent.mission_speed_m_s if speed is None else speed
        if conflicts[0].t_i <= t <= conflicts[0].t_f:
            assert g < conflicts[0].gamma_a
        g += v * dt
        agent.follower.gamma_m = g
        t += dt
    assert mode == "mission" and speed is None
    texts = [e[1] for e in ca.drain_events()]
    assert any("mode mission → avoidance:yield" in s for s in texts)
    assert any("complete: mission speed resumed" in s for s in texts)
    assert any("mode avoidance:yield → mission" in s for s in texts)
    s = ca.summary()
    assert s["actions"]["yield"] == 1 and s["predicted_conflicts"] == 1
    assert s["mode_time_s"]["avoidance:yield"] == pytest.approx(law.t_goal, abs=0.2)
    assert s["min_predicted_distance_m"] < 1.0


def test_repeated_prediction_of_the_same_conflict_keeps_the_slowed_plan():
    """Once yielding, the planned (slowed) motion clears the obstacle: a new prediction finds no
    collision and the correction continues unchanged (the thesis's 'until the manoeuvre is complete')."""
    ca, agent = make()
    tr = crossing()
    ca.predict(0.0, nav(), [tr], [])
    law = ca.correction.law
    agent.follower.gamma_m = law.gamma_desired(5.0)
    assert ca.predict(5.0, nav(agent.follower.gamma_m), [tr], []) == []
    assert ca.correction.law is law


def test_monitor_only_predicts_without_acting():
    ca, _ = make(AvoidanceConfig(enabled=False))
    assert len(ca.predict(0.0, nav(), [crossing()], [])) == 1
    assert ca.control_refs(0.0, nav()) == (None, "mission")
    assert ca.summary()["predicted_conflicts"] == 1 and ca.summary()["actions"]["yield"] == 0


def test_clear_track_is_no_conflict():
    ca, _ = make()
    far = crossing(x_cross=150.0, t_cross=30.0)  # the vessel is at x = 30 then
    assert ca.predict(0.0, nav(), [far], []) == []
    assert ca.control_refs(0.0, nav()) == (None, "mission")
    assert ca.summary()["min_predicted_distance_m"] > 50


# ------------------------------------------------------------------------------------ yield vs pass
def test_pass_first_when_yielding_needs_less_than_the_minimum_speed():
    """A vessel that must keep 0.8 m/s of steerage way: yielding to an obstacle crossing at
    t = 20 s would need V_d ≈ 0.5 m/s, so it speeds up and passes γ_B + margin before t_i."""
    ca, agent = make(AvoidanceConfig(speed_min_m_s=0.8))
    c = ca.predict(0.0, nav(), [crossing(x_cross=20.0, t_cross=20.0)], [])[0]
    assert (c.gamma_a - 2.0) / c.t_f < 0.8
    speed, mode = ca.control_refs(0.0, nav())
    assert mode == "avoidance:pass"
    law = ca.correction.law
    assert law.gamma_goal == pytest.approx(c.gamma_b + 2.0) and law.t_goal == pytest.approx(c.t_i)
    assert law.desired_speed > agent.mission_speed_m_s and law.feasible
    assert ca.summary()["actions"]["pass"] == 1


def test_no_pass_first_towards_a_goal_beyond_the_end_of_the_path():
    """The same crossing on a path that ends 2 m past it: passing first would aim at γ_B + margin,
    beyond the path's end, where the follower takes all way off inside the obstructed stretch
    (tests/cas_regressions/target_tracking_current_16.toml). No pass: the vessel goes around."""
    ca, _ = make(AvoidanceConfig(speed_min_m_s=0.8), path=Path.from_waypoints(np.array([[0.0, 0.0], [22.0, 0.0]])))
    c = ca.predict(0.0, nav(), [crossing(x_cross=20.0, t_cross=20.0)], [])[0]
    assert c.gamma_b + 2.0 > 22.0
    ca.control_refs(0.0, nav())
    assert ca.summary()["actions"]["pass"] == 0
    assert ca.correction is None or ca.correction.kind != "pass"


def test_neither_yield_nor_pass_falls_back_to_a_detour():
    ca, _ = make(AvoidanceConfig(allow_pass_first=False, speed_min_m_s=0.8))
    ca.predict(0.0, nav(), [crossing(x_cross=20.0, t_cross=20.0)], [])
    assert ca.detour is not None and ca.agent.follower.path is ca.detour.path
    assert ca.summary()["actions"]["replan"] == 1
    # Still grazing the swept area on the detour: slows down on it as well (emergency yield).
    assert ca.control_refs(0.0, nav())[1] in ("avoidance:detour", "avoidance:yield")


def test_an_emergency_slow_down_looks_again_every_second():
    """No manoeuvre clears the conflict on the detour: the vessel slows to speed_min (emergency)
    and predicts again one second later instead of at the next period (a detour or lane change
    may clear it by then: the head-on threat in the §6.2-stressed and §6.4.2 campaigns)."""
    ca, _ = make(AvoidanceConfig(allow_pass_first=False, speed_min_m_s=0.8))
    tr = crossing(x_cross=20.0, t_cross=20.0)
    report = PerceptionReport(0.0, (tr,), ())
    ca.predict(0.0, nav(), [tr], [])
    assert ca.correction.emergency and ca.summary()["actions"]["emergency"] == 1
    n = ca.stats["predictions"]
    ca.agent.perception = SimpleNamespace(report=lambda t: report)
    ca.ca.control(0.5, nav(), ca._guidance(), report, None)
    assert ca.stats["predictions"] == n  # not before a second has passed
    ca.ca.control(1.1, nav(), ca._guidance(), report, None)
    assert ca.stats["predictions"] > n


def test_a_track_inside_a_mapped_island_is_the_island_not_a_vessel():
    """A fragment of an island tracked as a 2 m/s target (under sensor dropout the §6.4.3 islands
    broke into such tracks): its centre lies inside a mapped static polygon, so it is taken as
    static (no vessel floats inside land) and yields no moving conflict; the same track in open
    water is a crossing conflict."""
    island = np.array([[25.0, -40.0], [45.0, -40.0], [45.0, -20.0], [25.0, -20.0]])
    inside = crossing(x_cross=30.0, t_cross=25.0, speed=1.2)  # starts at (30, −30): in the island
    assert inside.position_m[1] == pytest.approx(-30.0)
    ca, _ = make()
    assert [c for c in ca.predict(0.0, nav(), [inside], [island]) if not c.is_static] == []
    assert ca.summary()["actions"]["yield"] == 0
    ca, _ = make()
    water = crossing(x_cross=30.0, t_cross=25.0, speed=1.2, from_south=False)  # from (30, 30): open water
    assert [c.track_id for c in ca.predict(0.0, nav(), [water], [island])] == [1]


def test_a_fragment_centred_in_mapped_land_is_no_larger_than_the_land_around_it():
    """Under 30 % dropout an island's face broke into a 7.8 m track centred inside the 2 m sliver
    the map holds of the face (§6.4.3 seed 11). As a static disc of its bounding radius it closed
    the whole gap between the islands and bravo re-planned into the south island; no vessel floats
    inside land, so the track is static and no larger than the structure around its centre (here
    0.5 m): the path 9 m from the face keeps no conflict at all. A track deep inside a mapped
    footprint (a vessel whose own returns the map absorbed) keeps its radius."""
    face = np.array([[20.0, 9.0], [40.0, 9.0], [40.0, 10.0], [20.0, 10.0]])
    fragment = TrackEstimate(5, 0.0, np.array([30.0, 9.5]), -0.5 * np.pi, 0.3, 0.0, 7.8)
    ca, agent = make()
    assert ca.predict(0.0, nav(), [fragment], [face]) == []
    assert ca.detour is None and ca.summary()["actions"]["in_structure"] == 1
    assert ca.last_prediction.tracks[5].is_static and ca.last_prediction.tracks[5].radius_m == pytest.approx(0.5)
    footprint = np.array([[26.0, 6.0], [34.0, 6.0], [34.0, 14.0], [26.0, 14.0]])  # 4 m deep around (30, 10)
    boat = TrackEstimate(6, 0.0, np.array([30.0, 10.0]), 0.0, 1.0, 0.0, 3.5)
    ca, _ = make()
    ca.predict(0.0, nav(), [boat], [footprint])
    assert ca.last_prediction.tracks[6].is_static and ca.last_prediction.tracks[6].radius_m == pytest.approx(3.5)
    # The same track in open water is predicted (a 7.8 m target crossing the path as the vessel passes).
    ca, _ = make()
    assert [c.track_id for c in ca.predict(0.0, nav(), [fragment], [face + [0.0, 30.0]])] == [5]


def test_a_detour_that_runs_onto_mapped_structure_is_not_taken():
    """A detour around a moving track passing a mapped structure closer than R_vh + safety, and
    closer than the vessel is now, is refused (§6.4.3 seed 2: charlie's detour from the gap ran
    into the south island); one that keeps its distance, or moves away from a structure the vessel
    is already near, is taken."""
    from mjasc.avoidance.replanning import Detour
    from mjasc.avoidance.structure import detour_onto_structure
    cfg = AvoidanceConfig()
    land = np.array([[0.0, -20.0], [40.0, -20.0], [40.0, -6.0], [0.0, -6.0]])

    def refused(start, points):
        pts = np.array(points, dtype=float)
        path = Path.from_points(pts)
        d = Detour(path, path.length, 0.0, 40.0, pts, (), None, 0.0)
        return detour_onto_structure(0.0, start, d, [land], 1.0, DELFIM.radius_m, cfg.prediction,
                                     cfg.detour_structure_slack_m)

    assert "mapped structure" in refused([0.0, 0.0], [[0.0, 0.0], [5.0, -2.0], [10.0, -4.5], [20.0, -4.5],
                                                      [40.0, 0.0]])
    assert refused([0.0, 0.0], [[0.0, 0.0], [10.0, 1.0], [20.0, 1.0], [40.0, 0.0]]) is None
    # Starting 2 m from the land (inside R_vh + safety) and moving away from it.
    assert refused([0.0, -4.0], [[0.0, -4.0], [10.0, -2.0], [20.0, 0.0], [40.0, 0.0]]) is None


# ------------------------------------------------------------------------------------ right of way
def test_team_mates_split_by_the_starboard_rule():
    """b crosses a's path from a's starboard side (south, heading north): a has b on its
    starboard and gives way; b has a on its port side and stands on (keeps its speed)."""
    ca_a, _ = make(name="a")
    tr_b = crossing(team_member="b")
    ca_a.predict(0.0, nav(), [tr_b], [])
    assert ca_a.control_refs(0.0, nav())[1] == "avoidance:yield"
    # b's view: own path north along x = 30, a approaching from the west (b's port side).
    path_b = Path.from_waypoints(np.array([[30.0, -30.0], [30.0, 170.0]]))
    ca_b, _ = make(name="b", path=path_b)
    tr_a = TrackEstimate(7, 0.0, np.array([0.0, 0.0]), 0.0, 1.0, 0.0, 2.1, team_member="a")
    assert len(ca_b.predict(0.0, nav(30.0, -30.0, np.pi / 2), [tr_a], [])) == 1
    assert ca_b.control_refs(0.0, nav(30.0, -30.0, np.pi / 2)) == (None, "mission")
    assert ca_b.summary()["actions"]["stand_on"] == 1


def test_non_team_obstacle_on_port_is_still_yielded_to():
    ca, _ = make()
    ca.predict(0.0, nav(), [crossing(from_south=False)], [])  # from the north: on a's port side
    assert ca.control_refs(0.0, nav())[1] == "avoidance:yield"


# ------------------------------------------------------------------------------------ re-planning
def test_static_obstacle_detour_splice_and_resumption():
    ca, agent = make()
    mission = agent.follower.path
    poly = np.array([[20.0, -5.0], [30.0, -5.0], [30.0, 5.0], [20.0, 5.0]])
    conflicts = ca.predict(0.0, nav(), [], [poly])
    assert len(conflicts) == 1 and conflicts[0].decision.value == "replan"
    d = ca.detour
    assert d is not None and agent.follower.path is d.path
    # The detour starts at the vessel, ends on the mission path beyond the obstacle, then the
    # rest of the mission follows: same end point, lengths add up.
    assert np.allclose(d.path.start_point, [0.0, 0.0])
    assert np.allclose(d.path.point(d.detour_length_m), mission.point(d.mission_gamma_goal_m), atol=1e-6)
    assert np.allclose(d.path.end_point, mission.end_point)
    assert d.path.length == pytest.approx(d.detour_length_m + mission.length - d.mission_gamma_goal_m)
    assert d.mission_gamma_goal_m > 30.0
    # Clear of the obstacle by at least half the beam + safety distance.
    pts = d.path.sample(0.2)
    assert not point_in_polygon(pts, poly).any()
    assert distance_to_polygon(pts, poly).min() >= 0.5 * DELFIM.beam_m + 1.0 - 0.05
    # Mission γ during the detour: continuous and monotone from where the detour began.
    gs = np.linspace(0.0, d.path.length, 400)
    mg = np.array([d.mission_gamma(g) for g in gs])
    assert mg[0] == pytest.approx(0.0) and np.all(np.diff(mg) > 0)
    assert ca.mission_gamma_m(agent.follower) == pytest.approx(0.0)
    assert ca.control_refs(0.0, nav())[1] == "avoidance:detour"
    # End of the detour: the follower is switched back to the mission path at the matching γ.
    agent.follower.gamma_m = d.detour_length_m
    speed, mode = ca.control_refs(60.0, nav(*d.path.point(d.detour_length_m)))
    assert mode == "mission" and speed is None
    assert agent.follower.path is mission
    assert agent.follower.gamma_m == pytest.approx(d.mission_gamma_goal_m, abs=0.6)
    assert any("back on the mission path" in e[1] for e in ca.drain_events())


def test_slow_head_on_obstacle_is_replanned_around_its_swept_area():
    ca, agent = make()
    tr = TrackEstimate(1, 0.0, np.array([50.0, 0.5]), np.pi, 0.5, 0.0, 2.0)
    c = ca.predict(0.0, nav(), [tr], [])[0]
    assert c.decision.value == "replan" and c.obstruction_s >= 15.0
    d = ca.detour
    assert d is not None
    # The detour keeps out of the SVO (it already contains R_vh + safety).
    assert not point_in_polygon(d.streamline, c.svo_polygon).any()
    assert ca.summary()["actions"]["replan"] == 1


def test_new_track_triggers_an_immediate_prediction():
    tracks = []
    perception = SimpleNamespace(tracks=lambda: list(tracks), static_polygons=lambda: [])
    ca, _ = make(perception=perception)
    assert ca.control_refs(0.0, nav()) == (None, "mission")
    tracks.append(crossing())
    assert ca.control_refs(0.1, nav())[1] == "avoidance:yield"
    assert any("new track" in e[1] for e in ca.drain_events())


def test_merge_overlapping_polygons():
    a = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]])
    b = a + [1.0, 1.0]
    c = a + [10.0, 0.0]
    merged = merge_overlapping([a, b, c])
    assert len(merged) == 2
    assert any(point_in_polygon(np.array([[2.9, 2.9], [0.1, 0.1]]), p).all() for p in merged)


# ------------------------------------------------------------------------------------ team mates via comms
def test_prediction_fields_are_validated_by_collision_prediction():
    with pytest.raises(ValueError, match=r"^avoidance\.window_s: must be finite, > 0 and ≤ 3600 s, got -1\.0$"):
        parse_avoidance_options({"window_s": -1}, "avoidance")
    with pytest.raises(ValueError, match=r"^avoidance\.margin_s: must be finite and ≥ 0, got -1\.0$"):
        parse_avoidance_options({"margin_s": -1}, "avoidance")
    with pytest.raises(ValueError, match=r"^avoidance\.margin_s: must be a number, got 'x'$"):  # type: config_tables
        parse_avoidance_options({"margin_s": "x"}, "avoidance")
    with pytest.raises(ValueError, match=r'^avoidance\.window_s: must be a number \[s\] or "dynamic", got \'fast\'$'):
        parse_avoidance_options({"window_s": "fast"}, "avoidance")


class FakeCoordination:
    """The avoidance's view of the coordination layer: ``team_intentions`` and ``last_factor``."""

    def __init__(self):
        self.intentions, self.last_factor = {}, 1.0

    def team_intentions(self, t_s=None, max_age_s=None):
        return {n: i for n, i in self.intentions.items()
                if max_age_s is None or t_s is None or t_s - i.sent_time_s <= max_age_s}


def _with_broadcast(ca, name, t_b, pos, heading, vel, plan=None, gives_way_to=(), stands_on_to=()):
    coord = ca.agent.coordination if isinstance(getattr(ca.agent, "coordination", None), FakeCoordination) \
        else FakeCoordination()
    kw = {} if plan is None else {"plan_times_s": np.asarray(plan[0], float), "plan_points_m": np.asarray(plan[1], float)}
    kw["gives_way_to"] = tuple(gives_way_to)
    kw["stands_on_to"] = tuple(stands_on_to)
    coord.intentions[name] = TeamIntention(name, t_b, np.array(pos, float), heading, np.array(vel, float), 2.2, **kw)
    ca.agent.coordination = coord
    ca._poll_team()


def test_team_mate_in_the_next_lane_is_predicted_from_its_broadcast_not_a_wandering_turn_rate():
    """b sails parallel to a, 10 m to port. Its IMM track's ω̂ = −0.02 rad/s bends the 30 s
    prediction 9 m across a's path (a phantom collision); b's own broadcast (heading steady over
    two messages, velocity east) predicts it straight: no conflict."""
    track = TrackEstimate(5, 10.0, np.array([10.0, 10.0]), 0.0, 1.0, -0.02, 2.2, team_member="b")
    ca, agent = make()
    agent.follower.gamma_m = 10.0
    assert len(ca.predict(10.0, nav(10.0, 0.0), [track], [])) == 1  # IMM only: phantom conflict
    ca, agent = make()
    agent.follower.gamma_m = 10.0
    _with_broadcast(ca, "b", 9.0, [9.0, 10.0], 0.0, [1.0, 0.0])
    _with_broadcast(ca, "b", 10.0, [10.0, 10.0], 0.0, [1.0, 0.0])
    assert ca._team_tracks([track], 10.0)[0].turn_rate_rad_s == 0.0
    assert ca.predict(10.0, nav(10.0, 0.0), [track], []) == []
    # A stale broadcast is not used.
    assert ca._team_tracks([track], 20.0)[0] is track


def test_team_mate_turn_rate_from_successive_broadcast_headings():
    ca, _ = make()
    _with_broadcast(ca, "b", 1.0, [0.0, 10.0], 0.10, [1.0, 0.1])
    _with_broadcast(ca, "b", 2.0, [1.0, 10.1], 0.13, [1.0, 0.13])
    tr = ca._team_tracks([TrackEstimate(5, 2.0, np.array([1.2, 10.0]), 0.0, 0.5, 0.0, 2.2, team_member="b")], 2.5)[0]
    assert tr.turn_rate_rad_s == pytest.approx(0.03)
    assert tr.speed_m_s == pytest.approx(np.hypot(1.0, 0.13)) and tr.time_s == 2.0
    np.testing.assert_allclose(tr.position_m, [1.0, 10.1])


def test_stand_on_vessel_never_slows_for_a_team_mate_abaft_its_beam():
    """At the last resort (t_c − t < last_resort_s) a stand-on vessel acts, but with the give-way
    team mate coming from behind its beam it must not slow down (the other would run into it):
    it speeds up to pass first, or keeps its speed."""
    ca, _ = make(name="a")
    # b comes from a's port quarter, converging: a has b on its port side → a stands on.
    tr_b = TrackEstimate(3, 0.0, np.array([-4.0, 4.0]), -0.5, 1.6, 0.0, 2.1, team_member="b")
    out = ca.predict(0.0, nav(), [tr_b], [])
    assert out and out[0].t_closest_s < ca.config.last_resort_s
    speed, mode = ca.control_refs(0.0, nav())
    assert mode in ("mission", "avoidance:pass")
    assert ca.summary()["actions"]["yield"] == 0 and ca.summary()["actions"]["emergency"] == 0


def test_prediction_again_when_a_velocity_correction_completes():
    ca, agent = make(perception=SimpleNamespace(tracks=lambda: [crossing()], static_polygons=lambda: []))
    ca.predict(0.0, nav(), [crossing()], [])
    assert ca.correction is not None
    n = ca.stats["predictions"]
    t_goal = ca.correction.law.t_goal
    agent.follower.gamma_m = 60.0  # past the crossing
    ca.control_refs(t_goal + 0.1, nav(60.0, 0.0))
    assert ca.stats["predictions"] == n + 1 and ca.mode == "mission"


def test_team_mate_detour_is_predicted_from_its_broadcast_plan():
    """b sails 10 m to port, parallel, but has re-planned: its broadcast plan swings into a's lane
    at x ≈ 30 m. Its velocity (east) alone predicts nothing; the plan predicts the conflict, and a
    team mate that has sent a plan but has no track (yet) is predicted from the message alone."""
    t_plan = np.arange(0.0, 61.0)
    x = 10.0 + t_plan
    y = np.clip(10.0 - 0.8 * np.maximum(x - 15.0, 0.0), 0.0, 10.0)  # down into a's lane by x = 27.5
    track = TrackEstimate(5, 0.0, np.array([10.0, 10.0]), 0.0, 1.0, 0.0, 2.2, team_member="b")
    ca, agent = make(name="b2", team=("b2", "b"))
    agent.follower.gamma_m = 10.0
    _with_broadcast(ca, "b", 0.0, [10.0, 10.0], 0.0, [1.0, 0.0])
    assert ca.predict(0.0, nav(10.0, 0.0), [track], []) == []  # straight: clear
    for tracks in ([track], []):
        ca, agent = make(name="b2", team=("b2", "b"))
        agent.follower.gamma_m = 10.0
        _with_broadcast(ca, "b", 0.0, [10.0, 10.0], 0.0, [1.0, 0.0], plan=(t_plan, np.column_stack([x, y])))
        team = ca._team_tracks(tracks, 0.0)
        assert len(team) == 1 and isinstance(team[0], PlannedTrack) and team[0].team_member == "b"
        out = ca.predict(0.0, nav(10.0, 0.0), tracks, [])
        assert len(out) == 1 and out[0].min_distance_m < 1.0


def test_a_changed_team_plan_triggers_a_prediction():
    ca, agent = make(name="b2", team=("b2", "b"),
                     perception=SimpleNamespace(tracks=lambda: [], static_polygons=lambda: []))
    t_plan = np.arange(0.0, 61.0)
    straight = np.column_stack([10.0 + t_plan, np.full(61, 10.0)])
    _with_broadcast(ca, "b", 0.0, [10.0, 10.0], 0.0, [1.0, 0.0], plan=(t_plan, straight))
    ca.predict(0.0, nav(), [], [])
    n = ca.stats["predictions"]
    _with_broadcast(ca, "b", 2.0, [12.0, 10.0], 0.0, [1.0, 0.0], plan=(t_plan + 2.0, straight + [2.0, 0.0]))
    ca.control_refs(2.0, nav(2.0, 0.0))
    assert ca.stats["predictions"] == n  # the same plan, sent again: nothing new
    bent = straight.copy()
    bent[10:, 1] = 3.0
    _with_broadcast(ca, "b", 3.0, [13.0, 10.0], 0.0, [1.0, 0.0], plan=(t_plan + 3.0, bent))
    ca.control_refs(3.0, nav(3.0, 0.0))
    assert ca.stats["predictions"] == n + 1


def test_a_stale_copy_of_a_team_mate_is_not_an_obstacle():
    """b braked hard; the tracker lost it and kept coasting its old track east at 1 m/s (now 5 m
    ahead of b, unmatched). Followed back, that track lay on b's broadcast positions: it is b, not
    a stranger to yield to. A real crossing track is kept."""
    ca, _ = make(name="a2", team=("a2", "b"))
    for k in range(6):  # b at 1 m/s until t = 2, then stopped at x = 12
        tb = float(k)
        _with_broadcast(ca, "b", tb, [10.0 + min(tb, 2.0), 10.0], 0.0, [1.0 if tb < 2 else 0.0, 0.0])
    ghost = TrackEstimate(7, 5.0, np.array([15.0, 10.0]), 0.0, 1.0, 0.0, 2.4)  # coasting since t = 2
    other = crossing(x_cross=30.0, t_cross=30.0, track_id=9)
    ids = [tr.track_id for tr in ca._team_tracks([ghost, other], 5.0)]
    assert 7 not in ids and 9 in ids and -1 in ids  # b itself from its message (no matched track)


def test_the_broadcast_plan_follows_the_slowed_virtual_target():
    ca, agent = make(perception=SimpleNamespace(tracks=lambda: [crossing()], static_polygons=lambda: []))
    ca.predict(0.0, nav(), [crossing()], [])
    law = ca.correction.law
    times, pts = ca.planned_trajectory(0.0, nav(), 60.0, 1.0)
    assert times[0] == 0.0 and times.size == 61
    k = int(np.floor(law.t_goal))
    np.testing.assert_allclose(pts[k, 0], law.desired_speed * k, atol=1e-6)  # V_d until the goal time
    np.testing.assert_allclose(pts[k + 10, 0] - pts[k, 0], 10.0 * ca.mission_speed_now(), atol=0.5)  # mission after


def test_a_fresh_detour_is_checked_against_a_give_way_team_mate_with_the_planner_margin():
    """A team mate the vessel gives way to is not in the potential field (it never goes around
    one), so a fresh detour is checked against it with its radius grown by replan_margin_m — the
    margin the planner gives what it goes around — for the hull's lag onto the new path (the
    harbour case, tests/cas_regressions/harbour_colreg_team_seed11.toml). Here b crosses from a's
    starboard (a gives way) 0.5 m outside the collision distance: clear as it is, a conflict grown."""
    from mjasc.avoidance.triage import triage

    ca, _ = make(name="a")
    ca.predict(0.0, nav(), [], [])  # (its guidance state set: nothing to predict)
    cd = ca.radius_m + 2.1 + ca.config.safety_distance_m
    late = crossing(x_cross=15.0, t_cross=15.0 + np.sqrt(2.0) * (cd + 0.5), radius=2.1, track_id=4, team_member="b")
    assert ca.ca._predict(0.0, nav(), [late], [], after_replan=True) == []
    ca, _ = make(name="a")
    ca.predict(0.0, nav(), [], [])
    out = ca.ca._predict(0.0, nav(), [late], [], after_replan=True, grown={4})
    assert len(out) == 1 and out[0].collision_distance_m == pytest.approx(cd + ca.config.replan_margin_m)
    assert ca.correction is not None  # answered on the detour (velocity correction, else the stop)
    # which team mates are grown: those in conflict that this vessel gives way to (b from starboard)
    ca, _ = make(name="a")
    conflicts = ca.predict(0.0, nav(), [crossing(team_member="b", track_id=4, radius=2.1)], [])
    tri = triage(0.0, nav(), 0.0, conflicts, [], {4: crossing(team_member="b", track_id=4, radius=2.1)},
                 {"a", "b"}, ca.config, ca.speed_max_m_s, None)
    assert tri.give_way_mates == {4}
    stranger = crossing(track_id=5, radius=2.1)
    conflicts = make(name="a")[0].predict(0.0, nav(), [stranger], [])
    tri = triage(0.0, nav(), 0.0, conflicts, [], {5: stranger}, {"a", "b"}, ca.config, ca.speed_max_m_s, None)
    assert conflicts and tri.give_way_mates == set()


def test_a_team_mate_that_already_gives_way_makes_this_vessel_stand_on():
    """b crosses from a's starboard: by the geometry a gives way (rule 15) and yields, and then it
    names b as the team mate it gives way to (broadcast to the team: b keeps its speed). When b's
    fresh broadcast says b already gives way to a — b decided earlier, on a geometry since changed
    — a stands on instead: both yielding made both crawl through the crossing. A yield a already
    runs for b is not given up on b's word (both then yield: the earlier state of things); a
    stale broadcast is not taken; a stranger's track is always yielded to."""
    from mjasc.avoidance.triage import triage

    def mate():
        return crossing(team_member="b", track_id=4, radius=2.1)

    ca, _ = make(name="a")
    ca.predict(0.0, nav(), [mate()], [])
    assert ca.correction is not None and ca.correction.kind == "yield" and ca.gives_way_to() == ("b",)
    ca, _ = make(name="a")
    _with_broadcast(ca, "b", 0.0, [30.0, -30.0], np.pi / 2, [0.0, 1.0], gives_way_to=("a",))
    ca.predict(0.0, nav(), [mate()], [])
    assert ca.correction is None and ca.stats["stand_on"] >= 1 and ca.gives_way_to() == ()
    assert any("b gives way to this vessel" in text for _, text in ca.drain_events())
    ca, _ = make(name="a")  # b's word 10 s old (team_broadcast_max_age_s = 3 s): the geometry decides
    _with_broadcast(ca, "b", -10.0, [30.0, -40.0], np.pi / 2, [0.0, 1.0], gives_way_to=("a",))
    ca.predict(0.0, nav(), [mate()], [])
    assert ca.correction is not None and ca.gives_way_to() == ("b",)
    # triage itself: b's word changes the role unless a already yields to b
    ca, _ = make(name="a")
    conflicts = ca.predict(0.0, nav(), [mate()], [])
    running = ca.correction
    for run, words, give_way in [(None, frozenset(), {4}), (None, frozenset({"b"}), set()),
                                 (running, frozenset({"b"}), {4}), (None, frozenset({"c"}), {4})]:
        tri = triage(0.0, nav(), 0.0, conflicts, [], {4: mate()}, {"a", "b"}, ca.config, ca.speed_max_m_s, run, words)
        assert tri.give_way_mates == give_way
        assert (tri.roles[4].startswith("team right of way: stand-on")) == (not give_way)
    ca, _ = make(name="a")  # a stranger: yielded to, and not named in the broadcast
    ca.predict(0.0, nav(), [crossing(track_id=5)], [])
    assert ca.correction is not None and ca.correction.kind == "yield" and ca.gives_way_to() == ()


def test_of_two_team_mates_that_both_stand_on_the_later_name_gives_way():
    """b crosses from c's port side: by the geometry c stands on (rule 15) and says so
    (stands_on_to). If b's fresh broadcast says b stands on toward c too (in a cross current each
    reads the other's course against its own bow), the one whose name sorts later gives way: c,
    at once (the control tick predicts when the declaration arrives), and its broadcast then names
    b as the mate it gives way to. Toward a mate whose name sorts later it keeps standing on."""
    from mjasc.avoidance.triage import triage

    def mate(name="b", track_id=4):
        return crossing(team_member=name, track_id=track_id, radius=2.1, from_south=False)

    ca, _ = make(name="c", team=("b", "c"), perception=SimpleNamespace(tracks=lambda: [mate()],
                                                                       static_polygons=lambda: []))
    ca.predict(0.0, nav(), [mate()], [])
    assert ca.correction is None and ca.stats["stand_on"] >= 1 and ca.stands_on_to() == ("b",)
    _with_broadcast(ca, "b", 1.0, [30.0, 29.0], -np.pi / 2, [0.0, -1.0], stands_on_to=("c",))
    n = ca.stats["predictions"]
    ca.control_refs(1.5, nav(1.5, 0.0))
    assert ca.stats["predictions"] == n + 1  # predicted at once
    assert ca.correction is not None and ca.gives_way_to() == ("b",) and ca.stands_on_to() == ()
    assert any("stands on toward this vessel too" in text for _, text in ca.drain_events())
    # triage: only a mate that says it stands on, and only the later name gives way
    ca, _ = make(name="c", team=("b", "c", "d"))
    conflicts = ca.predict(0.0, nav(), [mate()], [])
    for own, words, give_way in [("c", frozenset(), set()), ("c", frozenset({"b"}), {4}),
                                 ("a", frozenset({"b"}), set()), ("c", frozenset({"d"}), set())]:
        tri = triage(0.0, nav(), 0.0, conflicts, [], {4: mate()}, {"a", "b", "c", "d"} - {own}, ca.config,
                     ca.speed_max_m_s, None, frozenset(), words, own)
        assert tri.give_way_mates == give_way
        assert tri.stand_on_mates == (set() if give_way else {"b"})


def test_a_boat_flagged_static_while_slowing_is_predicted_moving():
    """The tracker's static flag lags its speed estimate (set below its static speed, lifted only
    above twice it). The track a running velocity correction is for, flagged static while it still
    has speed (≥ ``static_speed_m_s``) and more than ``track_deviation_m`` from where the first
    prediction saw it, is a boat slowing down: it is predicted moving (said once). Not so a track
    no correction is for, nor a moored boat flagged static where it was first seen."""
    said = lambda ca: [text for _, text in ca.drain_events() if "flagged static by the tracker" in text]
    ca, _ = make()
    boat = crossing(x_cross=30.0, t_cross=30.0, speed=1.0)  # first seen at (30, −30), heading north
    ca.predict(0.0, nav(), [boat])
    assert ca.ca.correction is not None and ca.ca.correction.track_id == 1  # (yielding to it)
    slowing = replace(boat, time_s=20.0, position_m=np.array([30.0, -10.0]), speed_m_s=0.25, is_static=True)
    ca.predict(20.0, nav(), [slowing])
    predicted = ca.ca.last_prediction.tracks[1]
    assert not predicted.is_static and predicted.speed_m_s == 0.25
    assert [text.split(" of ")[0] for text in said(ca)] == ["track(s) [1]"]
    ca.predict(21.0, nav(), [replace(slowing, time_s=21.0)])
    assert said(ca) == []  # (said once)

    ca, _ = make()
    clear = crossing(x_cross=30.0, t_cross=80.0, speed=0.5)  # first seen at (30, −40): no conflict, no correction
    assert ca.predict(0.0, nav(), [clear]) == [] and ca.ca.correction is None
    ca.predict(20.0, nav(), [replace(clear, time_s=20.0, position_m=np.array([30.0, -30.0]), speed_m_s=0.25,
                                     is_static=True)])
    assert ca.ca.last_prediction.tracks[1].is_static and said(ca) == []

    ca, _ = make()
    moored = TrackEstimate(1, 0.0, np.array([30.0, -8.0]), np.pi / 2, 0.25, 0.0, 2.0, is_static=True)
    assert ca.predict(0.0, nav(), [moored]) == []
    assert ca.predict(20.0, nav(), [replace(moored, time_s=20.0)]) == [] and said(ca) == []
    assert ca.ca.last_prediction.tracks[1].is_static
