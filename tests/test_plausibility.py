"""Plausibility checks when a scenario loads (mjasc.runs.plausibility, the bounds declared on the
fields) and the loaders' file errors: every bad input is one ScenarioError / CampaignError line
naming the file or field, the reason and, for overlaps, the distance."""

import tomllib
from pathlib import Path

import numpy as np
import pytest

from mjasc.campaigns.perturbation import CampaignError, load_campaign
from mjasc.campaigns.spec import load_campaign_spec
from mjasc.physics.vessels import load_vessel_type
from mjasc.runs.runner import Runner
from mjasc.runs.scenario import ScenarioError, load_scenario, parse_scenario

TASKS = Path(__file__).resolve().parent.parent / "tasks"


def demo() -> dict:
    with open(TASKS / "demo.toml", "rb") as f:
        return tomllib.load(f)


def rejected(mutation, match: str):
    d = demo()
    mutation(d)
    with pytest.raises(ScenarioError, match=match) as info:
        parse_scenario(d, "demo.toml")
    assert "\n" not in str(info.value)
    return str(info.value)


@pytest.mark.parametrize("name", ["a b", "a<b", "a.b", "x\x00y", "ü", "x" * 65, "obstacle1"])
def test_vessel_names_follow_the_documented_rule(name):
    rejected(lambda d: d["vessels"][1].update(name=name), r"^vessels\[1\]\.name: must")


def test_obstacle_names_follow_the_rule_too():
    rejected(lambda d: d["static_obstacles"][0].update(name="the pontoon"),
             r"^static_obstacles\[0\]\.name: must be ASCII")
    rejected(lambda d: d["moving_obstacles"][0].update(name="fer/ry"), r"^moving_obstacles\[0\]\.name: must be ASCII")


@pytest.mark.parametrize("name", ["../../escaped", "/tmp/abs", "a/b", ".", "two\nlines", "x" * 65])
def test_the_scenario_name_follows_the_rule_it_names_the_output_folder(name):
    rejected(lambda d: d.update(name=name), r"^name: must")


def test_a_scenario_without_a_name_takes_its_file_name_made_to_follow_the_rule():
    d = demo()
    del d["name"]
    assert parse_scenario(d, "/some/where/my demo (v2).toml").name == "my_demo__v2_"


def test_names_are_unique_across_vessels_and_obstacles():
    """The summary's clearances are keyed by name: a vessel and an obstacle sharing one lost the
    obstacle's clearance."""
    def vessel_as_static(d):
        d["vessels"][0]["name"] = d["static_obstacles"][0]["name"]
    rejected(vessel_as_static, r"^obstacles: '\w+' is also a vessel's name")
    rejected(lambda d: d["moving_obstacles"][0].update(name=d["vessels"][1]["name"]),
             r"^obstacles: '\w+' is also a vessel's name")


def test_path_keys_where_nothing_follows_a_path_are_rejected():
    def on_waypoints_with_a_position(d):
        d["moving_obstacles"][0] = {"name": "barge", "radius_m": 3.0, "speed_m_s": 1.0,
                                    "waypoints": [[300.0, 50.0], [0.0, 50.0]], "position_m": [-300.0, 300.0]}
    rejected(on_waypoints_with_a_position, r"^moving_obstacles\[0\]\.position_m: not with waypoints")
    rejected(lambda d: d["vessels"][0].update(controller={"type": "none", "waypoints": [[0.0, 0.0], [9.0, 0.0]]}),
             r"^vessels\[0\]\.controller\.waypoints: unknown field \(allowed: commands, type\)")


def test_campaign_and_family_names_follow_the_rule(tmp_path):
    bad = tmp_path / "c.toml"
    bad.write_text('name = "../../x"\nbase_seed = 1\n[[families]]\nkind = "head_on"\nruns_per_point = 1\n'
                   'duration_s = 5.0\n')
    with pytest.raises(CampaignError, match=r"c.toml: name: must be ASCII"):
        load_campaign_spec(bad)
    bad.write_text('name = "ok"\nbase_seed = 1\n[[families]]\nname = "a b"\nkind = "head_on"\n'
                   'runs_per_point = 1\nduration_s = 5.0\n')
    with pytest.raises(CampaignError, match=r"c.toml: families\[0\]\.name: must be ASCII"):
        load_campaign_spec(bad)


@pytest.mark.parametrize("mutation, match", [
    (lambda d: d["moving_obstacles"][0].update(heading_deg=1e20), r"heading_deg: must be ≤ 3600.0"),
    (lambda d: d["vessels"][0]["sensor"].update(beams=100_000_000), r"sensor\.beams: must be ≤ 100000"),
    (lambda d: d["vessels"][0]["sensor"].update(max_range_m=1e300), r"sensor\.max_range_m: .* ≤ 100 km"),
    (lambda d: d["vessels"][0]["avoidance"].update(window_s=1e300), r"avoidance\.window_s: .* ≤ 3600 s"),
    (lambda d: d["vessels"][0]["avoidance"].update(safety_distance_m=1e300),
     r"avoidance\.safety_distance_m: .* ≤ 10 km"),
    (lambda d: d.update(current={"type": "gauss_markov", "mean_velocity_m_s": [0.0, 0.0], "time_constant_s": 300.0,
                                 "sigma_m_s": 0.05, "step_s": 1e-6}), r"current\.step_s: must be ≥ 0.01"),
    (lambda d: d.update(current={"type": "gauss_markov", "mean_velocity_m_s": [0.0, 0.0], "time_constant_s": 1e-300,
                                 "sigma_m_s": 0.05}), r"current\.time_constant_s: must be ≥ 1.0"),
])
def test_absurd_values_that_would_hang_or_crash_a_run_are_rejected(mutation, match):
    """Values with no physical meaning that made a run hang (a current sampled every microsecond
    over the run: gigabytes), crash (an overflow in the map grid or the planner's hull) or diverge
    at once are one line at load."""
    rejected(mutation, match)


def test_a_vortex_core_of_no_size_is_rejected():
    from mjasc.physics.currents import current_from_config

    with pytest.raises(ValueError, match=r"core_radius_m: must be ≥ 0.01"):
        current_from_config({"type": "vortex", "centre_m": [0.0, 0.0], "max_speed_m_s": 1.0,
                             "core_radius_m": 1e-300})


def test_overrides_get_the_checks_a_file_with_their_values_gets():
    """--duration and --seed: the scenario with the new values passes the same plausibility checks
    as a file written with them (traffic reaching a structure later, a seeded current too strong)."""
    d = demo()
    d["duration_s"] = 100.0
    d["static_obstacles"].append({"name": "rock", "type": "circle", "centre_m": [105.0, -200.0], "radius_m": 2.0})
    sc = parse_scenario(d, "demo.toml")  # (the ferry reaches the rock at ~229 s: fine for 100 s)
    with pytest.raises(ScenarioError, match=r"sails into static obstacle 'rock'"):
        sc.with_overrides(duration_s=240.0)
    d = demo()
    d["current"] = {"type": "gauss_markov", "mean_velocity_m_s": [0.0, 0.0], "time_constant_s": 300.0,
                    "sigma_m_s": 6.0}
    strong = [seed for seed in range(40) if _too_strong(d, seed)]
    assert strong and len(strong) < 40
    d["seed"] = next(seed for seed in range(40) if seed not in strong)
    sc = parse_scenario(d, "demo.toml")
    with pytest.raises(ScenarioError, match=r"current: the water speed .* must be ≤ 10.0 m/s"):
        sc.with_overrides(seed=strong[0])


def test_a_duration_override_is_checked_instead_of_the_files_duration(tmp_path, monkeypatch, capsys):
    """``mjasc run --duration`` checks the file as if it said that duration, and only that: a quick
    run of a file whose traffic reaches a rock after the new duration runs (it was refused for
    the file's own, longer duration); the file as written, or a longer --duration, is refused."""
    from mjasc.campaigns.scenario_text import scenario_toml
    from mjasc.cli import main

    d = demo()  # (the ferry reaches the rock at ~229 s: refused for the file's 240 s)
    d["static_obstacles"].append({"name": "rock", "type": "circle", "centre_m": [105.0, -200.0], "radius_m": 2.0})
    path = tmp_path / "rock.toml"
    path.write_text(scenario_toml(d))
    with pytest.raises(ScenarioError, match=r"sails into static obstacle 'rock'"):
        load_scenario(path)
    assert load_scenario(path, duration_s=100.0).duration_s == 100.0
    assert load_scenario(path, duration_s=100.0, seed=7).seed == 7
    monkeypatch.chdir(tmp_path)
    assert main(["run", "rock.toml", "--duration", "0.5", "--out", "o", "--no-progress"]) == 0
    capsys.readouterr()
    assert main(["run", "rock.toml", "--duration", "300", "--out", "o2", "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("mjasc: invalid scenario: rock.toml: moving_obstacles[0]") and "'rock'" in err
    assert not (tmp_path / "o2").exists()


def _too_strong(d: dict, seed: int) -> bool:
    try:
        parse_scenario({**d, "seed": seed}, "demo.toml")
    except ScenarioError as exc:
        assert "water speed" in str(exc)
        return True
    return False


def test_a_polygon_written_as_a_closed_ring_is_the_same_polygon():
    d = demo()
    open_ring = parse_scenario(d, "demo.toml").static_obstacles[0].vertices
    d["static_obstacles"][0]["vertices"].append(list(d["static_obstacles"][0]["vertices"][0]))
    sc = parse_scenario(d, "demo.toml")
    np.testing.assert_array_equal(sc.static_obstacles[0].vertices, open_ring)
    Runner(sc, None, progress=False)  # the world builds (it rejected the repeated vertex before)


@pytest.mark.parametrize("mutation, match", [
    (lambda d: d["vessels"][0]["controller"]["waypoints"].append([1e308, 0.0]),
     r"vessels\[0\]\.controller\.waypoints\[\d\]\[0\]: must be ≤ 1000000.0, got 1e\+308"),
    (lambda d: d["vessels"][0].update(position_m=[0.0, -2e6]),
     r"vessels\[0\]\.position_m\[1\]: must be ≥ -1000000.0"),
    (lambda d: d["static_obstacles"][1].update(centre_m=[2e6, 0.0]),
     r"static_obstacles\[1\]\.centre_m\[0\]: must be ≤"),
    (lambda d: d["static_obstacles"][0]["vertices"].__setitem__(0, [0, 1e7]), r"static_obstacles\[0\]\.vertices"),
    (lambda d: d["moving_obstacles"][0].update(position_m=[1e9, 0.0]), r"moving_obstacles\[0\]\.position_m\[0\]"),
    (lambda d: d["moving_obstacles"][0].update(speed_m_s=1e6), r"moving_obstacles\[0\]\.speed_m_s: must be ≤ 30.0"),
    (lambda d: d["rates"].update(physics_hz=1e15), r"^rates\.physics_hz: must be ≤ 1000.0"),
    (lambda d: d["rates"].update(physics_hz=1.0), r"^rates\.physics_hz: must be ≥ 10.0"),
    (lambda d: d.update(duration_s=0.05),
     r"^duration_s: must be at least one control period \(1 / rates\.control_hz = 0\.1 s\)"),
    (lambda d: d.update(duration_s=1e9), r"^duration_s: must be ≤ 86400"),
    (lambda d: d.update(current={"type": "uniform", "velocity_m_s": [1e6, 0.0]}),
     r"^current: the water speed at \[0\.0, 12\.0\] m, t = 0 s is 1e\+06 m/s, must be ≤ 10\.0 m/s"),
])
def test_implausible_values_are_rejected_naming_the_field(mutation, match):
    rejected(mutation, match)


def test_a_path_ending_inside_a_static_obstacle_is_rejected():
    """A destination where the hull overlaps an island can never be reached (a review: a formation pose inside
    an island ran the vessel into it); a waypoint on the way through one is the avoidance's business."""
    rejected(lambda d: d["vessels"][0]["controller"].update(waypoints=[[0.0, 12.0], [75.0, 33.0]]),
             r"^vessels\[0\]\.controller\.waypoints: the path ends at \[\d.*\] m, where the hull overlaps static "
             r"obstacle 'pontoon': it could never get there")
    d = demo()  # through the pontoon and on: accepted
    d["vessels"][0]["controller"]["waypoints"] = [[0.0, 12.0], [75.0, 33.0], [150.0, 54.0]]
    parse_scenario(d, "demo.toml")


def test_vessels_starting_on_top_of_each_other_are_rejected_with_the_distance():
    msg = rejected(lambda d: d["vessels"][1].update(position_m=[0.5, 12.0]),
                   r"^vessels\[1\]\.position_m: the hull overlaps vessel 'alpha' at the start")
    assert "(centres 0.50 m apart)" in msg


@pytest.mark.parametrize("gap_m, ok", [(0.05, True), (-0.05, False)])
def test_side_by_side_hulls_overlap_exactly_when_closer_than_one_beam(gap_m, ok):
    """Two Otters abeam on parallel headings: the hulls (beam B) touch at centre distance B."""
    beam = load_vessel_type("otter").beam_m
    d = demo()
    d["vessels"] = d["vessels"][:2]
    for v, y in zip(d["vessels"], (0.0, beam + gap_m)):
        v.update(position_m=[-50.0, y], heading_deg=0.0)
    if ok:
        parse_scenario(d, "demo.toml")
    else:
        with pytest.raises(ScenarioError, match=f"centres {beam + gap_m:.2f} m apart"):
            parse_scenario(d, "demo.toml")


def test_vessels_starting_inside_or_on_obstacles_are_rejected():
    rejected(lambda d: d["vessels"][0].update(position_m=[75.0, 33.0]),
             r"vessels\[0\]\.position_m: the hull overlaps static obstacle 'pontoon' at the start \(its centre "
             r"5\.00 m inside the obstacle's edge\)")
    rejected(lambda d: d["vessels"][0].update(position_m=[130.0, -26.0]),
             r"overlaps static obstacle 'buoy' at the start \(centres 2\.00 m apart, radius 1\.5 m\)")
    rejected(lambda d: d["vessels"][2].update(position_m=[105.0, 76.0]),
             r"vessels\[2\]\.position_m: the hull overlaps moving obstacle 'ferry' at the start \(centres 4\.00 m")


def test_bad_files_are_one_line_errors_naming_the_file(tmp_path):
    f = tmp_path / "bin.toml"
    f.write_bytes((TASKS / "demo.toml").read_bytes()[:100] + b"\xff\xfe" + b"x = 1\n")
    with pytest.raises(ScenarioError, match=r"bin\.toml: not UTF-8 text \(byte 0xff at offset 100\)"):
        load_scenario(f)
    with pytest.raises(ScenarioError, match="not a usable file name \\(contains a NUL character\\)"):
        load_scenario("a\x00.toml")
    with pytest.raises(ScenarioError, match="not a usable file name \\(a name in it is longer than 255 bytes\\)"):
        load_scenario("x" * 300 + ".toml")
    with pytest.raises(CampaignError, match=r"tasks: a folder, not a campaign file"):
        load_campaign_spec(str(TASKS))


def test_a_campaign_naming_its_scenario_with_a_nul_is_a_campaign_error(tmp_path):
    f = tmp_path / "c.toml"
    f.write_text('runs = 2\nscenario = "demo\\u0000.toml"\n')
    with pytest.raises(CampaignError, match=r"c\.toml: scenario: not a usable file name \(contains a NUL"):
        load_campaign(f)
    f.write_text('runs = 2\nscenario = "' + "d" * 5000 + '.toml"\n')
    with pytest.raises(CampaignError, match=r"scenario: not a usable file name \(longer than 4096 bytes\)"):
        load_campaign(f)


def test_a_duration_override_below_one_control_period_is_rejected():
    sc = parse_scenario(demo(), "demo.toml")
    with pytest.raises(ScenarioError, match=r"^duration_s: must be at least one control period"):
        sc.with_overrides(duration_s=0.01)
    assert sc.with_overrides(duration_s=0.1).duration_s == 0.1


# ---------------------------------------------------------------------- traffic through structures
def test_traffic_sailing_into_a_static_obstacle_is_rejected_with_the_time():
    """The demo's ferry starts at (105, 80) heading south at 1.2 m/s; the pontoon spans x 55–95,
    y 28–38. Heading −100° it crosses the pontoon's north edge y = 38 at x = 105 − 42·tan 10° ≈ 97.6,
    so its 4 m disc first touches the pontoon's north-east corner (95, 38): from the closed form,
    when the centre comes within 4 m of the corner."""
    msg = rejected(lambda d: d["moving_obstacles"][0].update(heading_deg=-100.0),
                   r"^moving_obstacles\[0\]: 'ferry' \(a disc of radius 4 m\) sails into static obstacle 'pontoon' "
                   r"at t = \d+\.\d s")
    t_msg = float(msg.split("at t = ")[1].split(" s")[0])
    p0, v = np.array([105.0, 80.0]), 1.2 * np.array([np.cos(np.radians(-100)), np.sin(np.radians(-100))])
    # first time |p0 + v t − corner| = 4 (the disc meets the corner before it meets an edge here)
    d0 = p0 - np.array([95.0, 38.0])
    a, b, c = v @ v, 2 * d0 @ v, d0 @ d0 - 16.0
    t_touch = (-b - np.sqrt(b * b - 4 * a * c)) / (2 * a)
    step = 0.25 * 4.0 / 1.2  # the check's sampling interval
    assert t_touch <= t_msg <= t_touch + step + 0.05
    # The same line shifted to pass 4.5 m east of the corner is accepted.
    d = demo()
    d["moving_obstacles"][0].update(heading_deg=-90.0, position_m=[99.5, 80.0])
    parse_scenario(d, "demo.toml")
    rejected(lambda d: d["moving_obstacles"][0].update(heading_deg=-90.0, position_m=[98.5, 80.0]),
             r"sails into static obstacle 'pontoon'")


def test_traffic_into_a_circle_and_path_traffic_are_checked_too():
    rejected(lambda d: d["moving_obstacles"][0].update(heading_deg=-76.0),  # reaches y = −28 at x ≈ 131.9: 1.9 m from the buoy
             r"sails into static obstacle 'buoy'")
    rejected(lambda d: d["moving_obstacles"].__setitem__(0, {
        "name": "barge", "radius_m": 2.0, "speed_m_s": 1.0, "waypoints": [[40.0, 45.0], [75.0, 45.0], [75.0, 20.0]]}),
        r"^moving_obstacles\[0\]: 'barge' .* sails into static obstacle 'pontoon' at t = 4[01]\.\d s")  # 40 m along its path at 1 m/s


def test_the_campaign_run_with_the_ferry_through_the_pontoon_is_rejected():
    """Demo campaign run 14 (before draws were checked): the ferry sailed through the pontoon and
    came out of it next to bravo (tests/cas_regressions/README.md, "Withdrawn")."""
    path = Path(__file__).resolve().parent / "cas_regressions" / "withdrawn" / "demo_run14.toml"
    with pytest.raises(ScenarioError, match=r"demo_run14\.toml: moving_obstacles\[0\]: 'ferry' .* sails into static "
                                            r"obstacle 'pontoon' at t = 3\d\.\d s"):
        load_scenario(path)
