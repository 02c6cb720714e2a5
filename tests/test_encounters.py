"""Encounter families and campaign specs: every generated scenario parses, its undisturbed
straight-line motion has exactly the requested DCPA/TCPA (closed form, from the parsed scenario),
the bearing it reports and the family's COLREG role; draws resample to the role or fail with a
clear error; runs are deterministic per campaign file; today's perturbation campaign gives the same
run k scenarios as before; the digest follows the content; short runs show every family's own
vessels tracking their targets."""

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from mjasc.evaluation.colreg import own_bearing_from_target_deg, role_from_geometry, wrap_deg
from mjasc.campaigns.cpa import bearing_deg, course_for_bearing, cpa, place_target
from mjasc.campaigns.encounter_parameters import ROLE_DEFAULTS
from mjasc.campaigns.encounters import FAMILY_KINDS, START_MARGIN_M
from mjasc.campaigns.perturbation import load_campaign, randomized_scenario
from mjasc.campaigns.scenario_text import scenario_toml
from mjasc.campaigns.spec import CampaignError, load_campaign_spec, parse_campaign_spec
from mjasc.core.geometry import signed_distance_to_polygon

TASKS = Path(__file__).resolve().parent.parent / "tasks"


def spec(*families, **top):
    return parse_campaign_spec({"name": "t", "base_seed": top.pop("base_seed", 3), **top, "families": list(families)})


# ---------------------------------------------------------------------- the undisturbed motion, from a parsed scenario
def undisturbed(sc):
    """Per target: (TCPA, signed DCPA, bearing at t = 0, relative course) of straight-line motion
    against the own vessels' reference (the team's centre), computed from the parsed scenario."""
    own = sc.vessels
    ref = np.mean([v.position_m for v in own], axis=0)
    psi = own[0].heading_rad
    assert all(v.heading_rad == psi and v.cruise_speed_m_s == own[0].cruise_speed_m_s for v in own)
    e = np.array([math.cos(psi), math.sin(psi)])
    for v in own:  # the mission path is the straight line along the heading, from the start
        assert float(v.path.tangent_angle(0.0)) == pytest.approx(psi, abs=1e-7)  # waypoints written to 1 µm
        np.testing.assert_allclose(v.path.point(0.0), v.position_m, atol=1e-9)
    vo = own[0].cruise_speed_m_s * e
    out = []
    for o in sc.moving_obstacles:
        d0 = o.position_m - ref
        w = o.speed_m_s * np.array([math.cos(o.heading_rad), math.sin(o.heading_rad)]) - vo
        t, d = cpa(d0, w)
        dc = d0 + w * t
        signed = math.copysign(d, dc[0] * w[1] - dc[1] * w[0]) if d > 1e-9 else 0.0
        body = np.array([d0 @ e, d0 @ np.array([-e[1], e[0]])])
        out.append((t, signed, float(bearing_deg(*body)), wrap_deg(-math.degrees(o.heading_rad - psi))))
    return out


def targets_of(run, sc):
    n = len(sc.moving_obstacles)
    return [f"t{j + 1}." if n > 1 else "" for j in range(n)]


RANDOM = {"dcpa_m": {"uniform": [-15.0, 15.0]}, "speed_ratio": {"uniform": [0.8, 1.2]},
          "tcpa_s": {"uniform": [30.0, 60.0]}, "target_radius_m": {"choice": [1.2, 2.5]},
          "current_m_s": {"uniform": [0.0, 0.2]}, "own_heading_deg": {"uniform": [-180.0, 180.0]}}
PER_KIND = {"overtaking": {"speed_ratio": {"uniform": [0.2, 0.6]}, "tcpa_s": {"uniform": [60.0, 100.0]}},
            "overtaken": {"speed_ratio": {"uniform": [1.4, 2.0]}, "tcpa_s": {"uniform": [60.0, 100.0]}},
            "head_on": {"relative_course_deg": {"uniform": [170.0, 180.0]}, "dcpa_m": {"uniform": [-10.0, 10.0]}},
            "bottleneck": {"dcpa_m": {"uniform": [-6.0, 6.0]}}}


@pytest.fixture(scope="module")
def every_kind():
    fams = [{"kind": kind, "runs_per_point": 12, "parameters": {**RANDOM, **PER_KIND.get(kind, {})}}
            for kind in FAMILY_KINDS]
    s = spec(*fams)
    runs = list(s.runs())
    return s, runs, [r.scenario() for r in runs]  # parsing costs ~0.1 s a scenario: once


def test_every_kind_generates_runs_that_parse(every_kind):
    s, runs, scenarios = every_kind
    assert s.runs_defined == len(runs) == 12 * len(FAMILY_KINDS)
    assert [r.index for r in runs] == list(range(len(runs)))
    assert [r.family for r in runs[::12]] == list(FAMILY_KINDS)
    for r, sc in zip(runs, scenarios):
        assert sc.seed == r.seed == s.base_seed + r.index
        doc = tomllib.loads(r.scenario_toml)
        assert tomllib.loads(scenario_toml(doc)) == doc  # the writer round-trips
        assert sc.duration_s == pytest.approx(r.parameters["duration_s"], abs=1e-6)
        assert all(v.options.keys() >= {"sensor", "tracking", "avoidance"} for v in sc.vessels)


def test_undisturbed_motion_has_the_requested_cpa_bearing_and_role(every_kind):
    _, runs, scenarios = every_kind
    for r, sc in zip(runs, scenarios):
        p = r.parameters
        for pre, (t, d, b, c) in zip(targets_of(r, sc), undisturbed(sc)):
            assert t == pytest.approx(p[pre + "tcpa_s"], abs=2e-3), r.index
            assert d == pytest.approx(p[pre + "dcpa_m"], abs=2e-3), r.index
            assert wrap_deg(b - p[pre + "relative_bearing_deg"]) == pytest.approx(0.0, abs=1e-3)
            assert wrap_deg(c - p[pre + "relative_course_deg"]) == pytest.approx(0.0, abs=1e-3)
            assert role_from_geometry(b, c) == p[pre + "role"]
            assert p["draws"] >= 1
        roles = [p[pre + "role"] for pre in targets_of(r, sc)]
        if r.family in ROLE_DEFAULTS:
            assert roles == [r.family]


def test_the_sign_of_dcpa_is_the_side_the_rules_ask():
    """Head-on with DCPA > 0 passes port to port; a target crossing from starboard with DCPA > 0
    passes ahead of the own vessel (its bearing draws left); stand-on: the target passes astern."""
    for course, d, expect in [(180.0, 5.0, "port"), (-90.0, 5.0, "ahead"), (90.0, 5.0, "astern"),
                              (180.0, -5.0, "starboard"), (-90.0, -5.0, "astern")]:
        p = place_target(1.5, course, 1.0, d, 40.0)
        dc = p.position_body_m + p.relative_velocity_m_s * 40.0  # body frame: x forward, y port
        side = {"port": dc[1] > 4.9, "starboard": dc[1] < -4.9, "ahead": dc[0] > 0, "astern": dc[0] < 0}
        assert side[expect], (course, d, dc)
        assert np.hypot(*dc) == pytest.approx(abs(d))


def test_a_given_bearing_is_met_and_the_course_follows():
    s = spec({"kind": "crossing_give_way", "runs_per_point": 3,
              "parameters": {"relative_bearing_deg": {"grid": [15.0, 45.0, 70.0]},
                             "speed_ratio": {"uniform": [0.7, 1.3]}, "dcpa_m": {"uniform": [-8.0, 8.0]}}})
    for r in s.runs():
        (t, d, b, c), = undisturbed(r.scenario())
        assert b == pytest.approx(r.parameters["relative_bearing_deg"], abs=1e-4)
        assert [15.0, 45.0, 70.0][r.index // 3] == r.parameters["relative_bearing_deg"]
        assert (t, d) == pytest.approx((50.0, r.parameters["dcpa_m"]), abs=2e-3)
        assert c == pytest.approx(r.parameters["relative_course_deg"], abs=1e-4)
        assert role_from_geometry(b, c) == "crossing_give_way"


def test_course_for_bearing_solves_the_closed_form():
    for bearing, ratio, d in [(30.0, 1.0, 5.0), (5.0, 1.0, -3.0), (-40.0, 0.8, 2.0), (60.0, 1.5, 0.0)]:
        p = course_for_bearing(1.5, bearing, ratio, d, 45.0, nominal_course_deg=-90.0 if bearing > 0 else 90.0)
        q = place_target(1.5, p.relative_course_deg, ratio, d, 45.0)
        assert q.bearing_deg == pytest.approx(bearing, abs=1e-8)
        assert cpa(q.position_body_m, q.relative_velocity_m_s) == pytest.approx((45.0, abs(d)), abs=1e-8)
    assert course_for_bearing(1.5, 100.0, 1.0, 0.0, 45.0) is None  # an equal-speed target cannot close from abaft


def test_colreg_classification():
    assert role_from_geometry(0.0, 180.0) == "head_on" and role_from_geometry(14.0, -170.0) == "head_on"
    assert role_from_geometry(20.0, 180.0) == "crossing_give_way" and role_from_geometry(-30.0, 90.0) == "crossing_stand_on"
    assert role_from_geometry(0.0, 0.0) == "overtaking" and role_from_geometry(180.0, 0.0) == "overtaken"
    assert role_from_geometry(130.0, -30.0) == "overtaken" and role_from_geometry(100.0, -90.0) == "crossing_give_way"
    assert own_bearing_from_target_deg(0.0, 0.0) == 180.0


def test_draws_resample_to_the_role_and_an_impossible_family_fails_clearly():
    s = spec({"kind": "head_on", "runs_per_point": 20,
              "parameters": {"relative_course_deg": {"uniform": [90.0, 180.0]}}})
    runs = list(s.runs())
    assert all(r.parameters["role"] == "head_on" for r in runs)
    assert all(abs(180.0 - r.parameters["relative_course_deg"]) <= 15.0 for r in runs)
    assert max(r.parameters["draws"] for r in runs) > 1
    with pytest.raises(CampaignError, match=r"^families\[0\] \(head_on\) run 0: no draw in 1000 attempts .*"
                                            r"is crossing_stand_on, not head_on"):
        spec({"kind": "head_on", "parameters": {"relative_course_deg": 90.0}})  # run 0 is generated on reading
    with pytest.raises(CampaignError, match=r"^families\[0\] \(head_on\): its first run is not a valid scenario: "
                                            r"vessels\[0\]\.speed_m_s: must be ≤"):
        spec({"kind": "head_on", "parameters": {"own_speed_m_s": 9.0}})


def test_runs_cut_before_their_encounter_are_counted_and_said():
    """A family's ``duration_s`` no longer than a target's TCPA ends the run before
    the encounter: such runs count as runs without contact, so the campaign's table and report say
    how many there are (a reviewer's campaign of 10 s runs for a 30 s TCPA printed "collision 0/3"
    with nothing else)."""
    from types import SimpleNamespace

    from mjasc.campaigns.report import _before_cpa
    from mjasc.campaigns.statistics import aggregate, ended_before_cpa, format_aggregate

    cut = next(spec({"kind": "head_on", "duration_s": 10.0, "parameters": {"tcpa_s": 30.0}}).runs()).parameters
    whole = next(spec({"kind": "head_on", "parameters": {"tcpa_s": 30.0}}).runs()).parameters
    teams = next(spec({"kind": "multi_target", "duration_s": 45.0,
                       "parameters": {"t1.tcpa_s": 30.0, "t2.tcpa_s": 50.0}}).runs()).parameters
    assert ended_before_cpa(cut) and not ended_before_cpa(whole) and ended_before_cpa(teams)
    assert whole["duration_s"] > 30.0 and not ended_before_cpa({"duration_s": 5.0})  # (a perturbation run)
    # an Imazu run cut before its scaled TCPA too (its duration was not among its parameters: counted as a pass)
    imazu_cut = next(spec({"kind": "imazu", "duration_s": 20.0, "parameters": {"case": 1}}).runs()).parameters
    imazu_whole = next(spec({"kind": "imazu", "parameters": {"case": 1}}).runs()).parameters
    assert imazu_cut["t1.tcpa_s"] > 20.0 and ended_before_cpa(imazu_cut) and not ended_before_cpa(imazu_whole)
    runs = [SimpleNamespace(index=i, family="head_on", status="completed", parameters=p, metrics={}, wall_time_s=1.0)
            for i, p in enumerate([cut, cut, whole])]
    agg = aggregate(runs, 3)
    assert agg["ended_before_cpa"] == 2 and agg["families"]["head_on"]["ended_before_cpa"] == 2
    note = format_aggregate(agg, "c")
    assert "note: 2 of 3 completed run(s) ended before their encounter's closest approach" in note
    assert "--duration" not in note  # (mjasc campaign has no such option)
    assert _before_cpa({**agg, "ended_before_cpa": 0}) == [] and "2 of 3" in _before_cpa(agg)[1]


def test_a_bad_field_of_a_familys_own_table_is_named_where_it_was_written():
    """An encounter family merges its ``own`` table into every own vessel of the scenarios it makes:
    a bad field there is reported as ``families[i].own.…`` (where the user wrote it), not as the
    generated scenario's ``vessels[k].…``; for a team too (the own vessels come first)."""
    for own, match in [({"sensor": {"beams": -5}}, r"^families\[0\]\.own\.sensor\.beams: must be ≥ 1"),
                       ({"tracking": {"gate": 1}}, r"^families\[0\]\.own\.tracking\.gate: unknown field"),
                       ({"avoidance": {"method": "nope"}}, r"^families\[0\]\.own\.avoidance\.method: unknown")]:
        with pytest.raises(CampaignError, match=match):
            spec({"kind": "head_on", "own": own})
    with pytest.raises(CampaignError, match=r"^families\[0\]\.own\.comms\.x: unknown field"):
        spec({"kind": "team_vs_traffic", "own": {"comms": {"x": 1}}})
    # a field the family generates itself keeps the generated scenario's name
    with pytest.raises(CampaignError, match=r"its first run is not a valid scenario: vessels\[0\]\.speed_m_s"):
        spec({"kind": "head_on", "own": {"sensor": {"beams": 90}}, "parameters": {"own_speed_m_s": 9.0}})


def test_targets_start_clear_of_the_own_vessels():
    s = spec({"kind": "team_vs_traffic", "runs_per_point": 10,
              "parameters": {"tcpa_s": {"uniform": [2.0, 40.0]}, "team_spacing_m": 20.0, "team_size": 4}})
    for r in s.runs():
        sc = r.scenario()
        for o in sc.moving_obstacles:
            gap = min(np.hypot(*(o.position_m - v.position_m)) for v in sc.vessels) - o.radius_m - 1.2
            assert gap >= START_MARGIN_M


def test_team_and_bottleneck_geometry():
    s = spec({"kind": "team_vs_traffic", "parameters": {"team_size": 3, "comms_loss": 0.3}},
             {"kind": "bottleneck", "runs_per_point": 8, "parameters": {"dcpa_m": {"uniform": [-6.0, 6.0]},
                                                                         "gap_width_m": 20.0}})
    team = s.run(0).scenario()
    pos = np.array([v.position_m for v in team.vessels])
    np.testing.assert_allclose(pos, [[-12.0, 0.0], [0.0, 0.0], [12.0, 0.0]], atol=1e-9)  # abreast, heading north
    assert team.comms.loss_probability == 0.3 and all("comms" in v.options for v in team.vessels)
    for r in list(s.runs())[1:]:
        sc = r.scenario()
        islands = [o.vertices for o in sc.static_obstacles]
        assert len(islands) == 2
        gap_centre = np.mean([np.min(islands[0][:, 0]), np.max(islands[1][:, 0])])
        assert gap_centre == pytest.approx(0.0, abs=1e-6)  # the gap is centred on the own track (north)
        ys = [np.mean(isl[:, 1]) for isl in islands]
        assert np.mean(ys) == pytest.approx(1.5 * 35.0, abs=1e-6)  # where the own vessel is at the TCPA
        o = sc.moving_obstacles[0]
        t = np.arange(0.0, sc.duration_s, 0.25)
        track = o.position_m + np.outer(t * o.speed_m_s, [math.cos(o.heading_rad), math.sin(o.heading_rad)])
        for isl in islands:
            assert signed_distance_to_polygon(track, isl).min() >= o.radius_m + 1.0


def test_runs_are_deterministic_per_campaign_file():
    fam = {"kind": "multi_target", "runs_per_point": 4, "parameters": {**RANDOM, "t2.tcpa_s": 55.0}}
    a, b = spec(fam), spec(fam)
    assert [r.scenario_toml for r in a.runs()] == [r.scenario_toml for r in b.runs()]
    c = spec(fam, base_seed=4)
    assert a.run(2).parameters["t1.dcpa_m"] != c.run(2).parameters["t1.dcpa_m"] and c.run(2).seed == 6
    assert all(r.parameters["t2.tcpa_s"] == 55.0 for r in a.runs())
    fixed_seed = spec({"kind": "head_on", "runs_per_point": 2, "parameters": {"seed": 42}})
    assert [r.seed for r in fixed_seed.runs()] == [42, 42]


def test_a_family_keeps_its_draws_when_another_family_is_added_before_it_changes_nothing_else():
    one = spec({"kind": "head_on", "runs_per_point": 3, "parameters": RANDOM})
    two = spec({"kind": "head_on", "runs_per_point": 3, "parameters": RANDOM},
               {"kind": "overtaking", "name": "extra"})
    assert [r.scenario_toml.split("\n", 1)[1] for r in one.runs()] != []
    assert [r.parameters for r in one.runs()] == [two.run(k).parameters for k in range(3)]


@pytest.mark.parametrize("family, message", [
    ({"kind": "head_on", "parameters": {"relative_bearing_deg": 3.0, "relative_course_deg": 178.0}},
     r"families\[0\]\.parameters\.relative_bearing_deg: give relative_bearing_deg or relative_course_deg, not both"),
    ({"kind": "head_on", "roles": ["head_on"]}, r"families\[0\]\.roles: only for multi_target"),
    ({"kind": "multi_target", "parameters": {"t4": {"dcpa_m": 1.0}}}, r"parameters\.t4: there are targets t1 … t3"),
    ({"kind": "multi_target", "roles": ["head_on", "sideways"]}, r"roles\[1\]: must be one of"),
    ({"kind": "head_on", "parameters": {"comms_loss": 0.1}}, r"parameters\.comms_loss: unknown parameter"),
    ({"kind": "head_on", "parameters": {"dcpa_m": {"uniform": [-300.0, 0.0]}}}, r"parameters\.dcpa_m: must be ≥ -200"),
    ({"kind": "head_on", "own": {"type": "jetski"}}, r"own\.type: must be one of"),
    ({"kind": "sideways"}, r"families\[0\]\.kind: must be one of"),
    ({"kind": "imazu", "parameters": {"case": 23}}, r"parameters\.case: must be ≤ 22"),
])
def test_bad_families_name_the_field(family, message):
    with pytest.raises(CampaignError, match=message):
        spec(family)


def test_a_key_written_after_a_table_header_is_explained():
    """A family's ``runs_per_point`` written after its ``[families.parameters]`` header (TOML puts
    it into that table), or ``base_seed`` after ``[evaluation]``, is explained, not only refused."""
    with pytest.raises(CampaignError, match=r"^families\[0\]\.parameters\.runs_per_point: unknown parameter "
                                            r"\(allowed: .*\); 'runs_per_point' is a key of the family"):
        spec({"kind": "head_on", "parameters": {"runs_per_point": 2}})
    with pytest.raises(CampaignError, match=r"^evaluation\.base_seed: unknown field .*; 'base_seed' is a top-level key"):
        parse_campaign_spec({"name": "t", "evaluation": {"base_seed": 3}, "families": [{"kind": "head_on"}]})
    with pytest.raises(CampaignError) as err:  # (a plain typo: no such explanation)
        spec({"kind": "head_on", "parameters": {"dcpa": 2.0}})
    assert "top-level" not in str(err.value) and "key of the family" not in str(err.value)


def test_own_overrides_and_rates_reach_the_scenario():
    s = spec({"kind": "head_on", "own": {"avoidance": {"window_s": 25.0}, "sensor": {"beams": 720}},
              "rates": {"prediction_period_s": 2.0}, "duration_s": 12.0,
              "parameters": {"sensor_range_noise_m": 0.2, "sensor_dropout": 0.3}})
    sc = s.run(0).scenario()
    v = sc.vessels[0]
    prediction = v.options["avoidance"].options.prediction
    assert prediction.window_s == 25.0 and prediction.safety_distance_m == 1.5  # merged into the defaults
    assert v.options["sensor"].beams == 720 and v.options["sensor"].range_noise_std_m == 0.2
    assert v.options["sensor"].dropout_probability == 0.3
    assert sc.rates.prediction_period_s == 2.0 and sc.duration_s == 12.0


# ---------------------------------------------------------------------- the campaign file, its digest, the first format
def test_digest_follows_the_content_not_the_layout(tmp_path):
    body = '[[families]]\nkind = "head_on"\nruns_per_point = 2\n'
    (tmp_path / "a.toml").write_text(f'name = "x"\n{body}')
    (tmp_path / "b.toml").write_text(f'# a comment\nname   =  "x"\n\n{body}')
    (tmp_path / "c.toml").write_text(f'name = "x"\n{body.replace("2", "3")}')
    a, b, c = (load_campaign_spec(tmp_path / f"{n}.toml") for n in "abc")
    assert a.digest == b.digest != c.digest and len(a.digest) == 64
    assert a.with_overrides(runs_per_point=3).digest != a.digest
    assert a.with_overrides(runs_per_point=3).runs_defined == 3


def test_an_edited_referenced_scenario_is_a_new_campaign(tmp_path):
    scenario = (TASKS / "demo.toml").read_text()
    (tmp_path / "s.toml").write_text(scenario)
    (tmp_path / "c.toml").write_text('scenario = "s.toml"\nruns = 2\n')
    before = load_campaign_spec(tmp_path / "c.toml").digest
    (tmp_path / "s.toml").write_text(scenario.replace("seed = 7", "seed = 8"))
    assert load_campaign_spec(tmp_path / "c.toml").digest != before


def test_the_demo_campaign_gives_the_same_run_k_scenarios_as_before():
    path = TASKS / "campaigns" / "demo_monte_carlo.toml"
    s, old = load_campaign_spec(path), load_campaign(path)
    assert s.runs_defined == old.runs == 200 and [f.kind for f in s.families] == ["perturbation"]
    origin = np.zeros((1, 2))
    for r in s.runs():
        a, b = r.scenario(), randomized_scenario(old.scenario, old, r.index)
        assert (a.name, a.seed, a.duration_s, r.seed) == (b.name, b.seed, b.duration_s, old.seed(r.index))
        for va, vb in zip(a.vessels, b.vessels):
            np.testing.assert_array_equal(va.position_m, vb.position_m)
            assert va.heading_rad == pytest.approx(vb.heading_rad, abs=1e-15)  # degrees in the file: ≤ 1 ulp
        np.testing.assert_array_equal(a.current.velocity(origin, 0.0), b.current.velocity(origin, 0.0))
        for oa, ob in zip(a.moving_obstacles, b.moving_obstacles):
            assert (oa.speed_m_s, tuple(oa.position_m)) == (ob.speed_m_s, tuple(ob.position_m))
            assert oa.heading_rad == pytest.approx(ob.heading_rad, abs=1e-15)
        assert r.parameters["alpha.dx_m"] == pytest.approx(a.vessels[0].position_m[0] - 0.0, abs=1e-6)


@pytest.mark.parametrize("path", sorted((TASKS / "campaigns").glob("*.toml")), ids=lambda p: p.name)
def test_every_shipped_campaign_loads_as_a_spec(path):
    import tomllib

    from mjasc.plugins import available

    names = [m if isinstance(m, str) else m.get("name") for m in tomllib.loads(path.read_text()).get("methods", [])]
    missing = [n for n in names if n not in available("avoidance")]
    if missing:  # a comparison of a method not registered here (tests/test_campaign_methods.py checks the error)
        pytest.skip(f"needs the avoidance method(s) {', '.join(missing)}")
    s = load_campaign_spec(path)
    assert s.runs_defined >= 1 and s.description
    for index in (0, s.runs_per_method - 1):
        for label in s.method_labels:  # ("",) without methods
            assert s.run(index, label or None).scenario().vessels


# ---------------------------------------------------------------------- the generated encounters happen
@pytest.mark.parametrize("kind", FAMILY_KINDS)
def test_each_family_s_own_vessels_track_their_targets(kind):
    """6 s of the family's default run: every own vessel holds a track within 3 m of every target."""
    from dataclasses import replace

    from mjasc.runs.runner import Runner

    sc = spec({"kind": kind, "duration_s": 6.0}).run(0).scenario()
    runner = Runner(replace(sc, outputs=replace(sc.outputs, recording=False)), None, progress=False)
    t = runner.run().summary["sim_time_s"]
    for agent in runner.agents:
        tracks = [e.position_m for e in agent.perception.tracks() if e.team_member is None]
        for o in sc.moving_obstacles:
            truth = o.position_m + o.speed_m_s * t * np.array([math.cos(o.heading_rad), math.sin(o.heading_rad)])
            assert min(np.hypot(*(p - truth)) for p in tracks) < 3.0, (agent.name, o.name)
