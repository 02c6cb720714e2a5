"""Scenario files: every shipped scenario loads; bad files are rejected with the field and the
reason, and nothing is run or written."""

import re
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

from mjasc.runs.scenario import ScenarioError, load_scenario, parse_scenario

TASKS = Path(__file__).resolve().parent.parent / "tasks"
ROOT = TASKS.parent


def demo() -> dict:
    with open(TASKS / "demo.toml", "rb") as f:
        return tomllib.load(f)


@pytest.mark.parametrize("path", sorted(TASKS.glob("*.toml")), ids=lambda p: p.name)
def test_every_shipped_scenario_loads(path):
    sc = load_scenario(path)
    assert sc.duration_s > 0 and sc.vessels


def test_demo_is_parsed_into_typed_values():
    sc = parse_scenario(demo(), "demo.toml")
    assert [v.name for v in sc.vessels] == ["alpha", "bravo", "charlie"]
    assert sc.vessels[0].path.length == pytest.approx(160 + 158 - 2 * 20 + np.pi * 20 / 2, rel=1e-9)
    np.testing.assert_allclose(sc.current.velocity(np.zeros((1, 2)), 0.0), [[0.0, 0.2]])
    assert set(sc.vessels[0].options) == {"sensor", "tracking", "avoidance", "comms", "control"}
    assert sc.vessels[0].options["control"].name == "path_following"
    assert sc.rates.physics_hz == 50.0 and sc.static_obstacles[0].name == "pontoon"


def _mutate(fn):
    d = demo()
    fn(d)
    return d


BAD = {
    "duration_s: must be > 0": lambda d: d.update(duration_s=-5),
    "duration_s: missing": lambda d: d.pop("duration_s"),
    "seed: must be an integer": lambda d: d.update(seed=1.5),
    "scenario.colour: unknown field": lambda d: d.update(colour="red"),
    "vessels[1].type: must be one of": lambda d: d["vessels"][1].update(type="titanic"),
    "vessels[0].controller.speed_m_s: must be > 0": lambda d: d["vessels"][0]["controller"].update(speed_m_s=-1.0),
    "vessels[0].controller.speed_m_s: must be ≤": lambda d: d["vessels"][0]["controller"].update(speed_m_s=99.0),
    "vessels[2].controller.waypoints[1]": lambda d: d["vessels"][2]["controller"].update(waypoints=[[0, 0], "x"]),
    "vessels[1].name: duplicate": lambda d: d["vessels"][1].update(name="alpha"),
    "vessels[0].position_m: must be a point": lambda d: d["vessels"][0].update(position_m=[1, 2, 3]),
    "vessels: need at least one": lambda d: d.update(vessels=[]),
    "static_obstacles[0].vertices": lambda d: d["static_obstacles"][0].update(vertices=[[0, 0], [1, 1]]),
    "static_obstacles[1].radius_m: must be > 0": lambda d: d["static_obstacles"][1].update(radius_m=0),
    "moving_obstacles[0].speed_m_s: must be ≥ 0": lambda d: d["moving_obstacles"][0].update(speed_m_s=-1),
    "rates.control_hz: must not exceed": lambda d: d["rates"].update(control_hz=500.0),
    "outputs.video_width: must be even": lambda d: d["outputs"].update(video_width=641),
    "outputs.video_camera": lambda d: d["outputs"].update(video_camera="chase:nobody"),
    "current.velocity_m_s": lambda d: d["current"].update(velocity_m_s=[0.1]),
    "current.type": lambda d: d["current"].update(type="tsunami"),
    "duration_s: must be finite": lambda d: d.update(duration_s=float("inf")),
    # a sensor faster than the sensing slots was capped to them without a word
    "vessels[0].sensor.rate_hz: must be ≤ rates.sensing_hz = 5 Hz (a sensor scans at the sensing slots), got 10":
        lambda d: (d["rates"].update(sensing_hz=5.0), d["vessels"][0].setdefault("sensor", {}).update(rate_hz=10.0)),
    # the bounds of the start and cruise speeds say what they are (it said "must be ≤ 3.75" alone)
    "vessels[0].speed_m_s: m/s (1.5 × the hull's top speed,": lambda d: d["vessels"][0].update(speed_m_s=20.0),
    "vessels[0].controller.speed_m_s: m/s (the hull's top speed), got 99":
        lambda d: d["vessels"][0]["controller"].update(speed_m_s=99.0),
    # rays above or below the contact band pass every hull (a sensor that saw no vessel)
    "vessels[0].sensor.ray_height_m: must be in [0, 0.15] m":
        lambda d: d["vessels"][0].setdefault("sensor", {}).update(ray_height_m=1.0),
}


@pytest.mark.parametrize("message", list(BAD), ids=list(BAD))
def test_bad_scenarios_are_rejected_naming_the_field(message):
    with pytest.raises(ScenarioError) as err:
        parse_scenario(_mutate(BAD[message]), "bad.toml")
    assert message.split(":")[0] in str(err.value)
    if ":" in message:
        assert message.split(":", 1)[1].strip() in str(err.value)


EXACT = {
    # the field named once, with the index of the offending point (the builders' own messages used
    # to come out under the field again: "waypoints: waypoints[1]: …", "vertices: pontoon.vertices: …")
    "vessels[0].controller.waypoints[1]: repeats the previous point":
        lambda d: d["vessels"][0]["controller"].update(waypoints=[[0.0, 12.0], [0.0, 12.0], [160.0, 12.0]]),
    "vessels[0].controller.waypoints[1]: the path reverses (180° turn) here; cannot round the corner":
        lambda d: d["vessels"][0]["controller"].update(waypoints=[[0.0, 12.0], [160.0, 12.0], [50.0, 12.0]]),
    "vessels[0].controller.turn_radius_m: 500 m is too large for the corner at waypoints[1]":
        lambda d: d["vessels"][0]["controller"].update(turn_radius_m=500.0),
    "static_obstacles[0].vertices[1]: repeats the next vertex":
        lambda d: d["static_obstacles"][0].update(vertices=[[55.0, 28.0], [95.0, 28.0], [95.0, 28.0], [55.0, 38.0]]),
    # vertices out of order: a bow tie, its walls crossing (it used to load, with no error)
    "static_obstacles[0].vertices: polygon is self-intersecting (edges 0 and 2 cross)":
        lambda d: d["static_obstacles"][0].update(vertices=[[55.0, 28.0], [95.0, 38.0], [95.0, 28.0], [55.0, 40.0]]),
    "static_obstacles[0].vertices: polygon is self-intersecting":
        lambda d: d["static_obstacles"][0].update(vertices=[[55.0, 28.0], [95.0, 38.0], [95.0, 28.0], [55.0, 38.0]]),
    # a path's keys on traffic without a path (they were ignored silently)
    "moving_obstacles[0].turn_radius_m: only with waypoints":
        lambda d: d["moving_obstacles"][0].update(turn_radius_m=5.0),
    "moving_obstacles[0].start_gamma_m: only with waypoints":
        lambda d: d["moving_obstacles"][0].update(start_gamma_m=5.0),
    # avoidance on an open-loop vessel (it ran, predicting nothing and never acting)
    "vessels[0].avoidance: needs a path-following controller":
        lambda d: d["vessels"][0].update(controller={"type": "none", "commands": [0.5, 0.5]}),
    # a tracker without a sensor (it ran with a default sensor nobody asked for), as avoidance without one
    "vessels[0].tracking: needs a [vessels.sensor] table — a vessel tracks only what its own sensor sees":
        lambda d: (d["vessels"][0].pop("sensor", None), d["vessels"][0].pop("avoidance", None),
                   d["vessels"][0].update(tracking={})),
    "vessels[0].avoidance: needs a [vessels.sensor] table — a vessel avoids only what its own sensor sees":
        lambda d: (d["vessels"][0].pop("sensor", None), d["vessels"][0].update(tracking={}, avoidance={})),
    # a mission on an open-loop vessel (its legs went to no follower: ignored), as avoidance on one
    "vessels[0].mission: needs a path-following controller — an open-loop vessel (controller type \"none\", "
    "constant commands) sails no mission":
        lambda d: (d["vessels"][0].pop("avoidance", None),
                   d["vessels"][0].update(controller={"type": "none"}, mission={"target_offset_m": [-25.0, -20.0]})),
    # shared tracks without a sensor (it ran and sent none)
    "vessels[0].comms.share_tracks: needs a [vessels.sensor] table — a vessel shares the tracks its own sensor sees":
        lambda d: ([d["vessels"][0].pop(k, None) for k in ("sensor", "tracking", "avoidance")],
                   d["vessels"][0].setdefault("comms", {}).update(share_tracks=True)),
    # a missing type says so (it said "must be a non-empty string, got None")
    "vessels[1].type: missing (the vessel type: one of delfim, otter, or a vessel folder's path)":
        lambda d: d["vessels"][1].pop("type"),
    "static_obstacles[1].type: missing (one of circle, polygon)": lambda d: d["static_obstacles"][1].pop("type"),
}


@pytest.mark.parametrize("message", list(EXACT), ids=list(EXACT))
def test_bad_scenarios_name_the_field_once(message):
    with pytest.raises(ScenarioError) as err:
        parse_scenario(_mutate(EXACT[message]), "bad.toml")
    assert str(err.value).startswith(message), str(err.value)
    assert "\n" not in str(err.value)


def test_a_key_written_after_a_table_header_is_explained():
    """TOML puts every key after a ``[table]`` header into that table: a vessel's ``sensor`` written
    after its ``[vessels.controller]`` header, or ``seed`` after ``[outputs]``, is reported with
    that explanation, and the controller's unknown-key list names its own keys too (it listed
    only the control method's options: ``waypoints`` looked like an unknown key)."""
    d = demo()
    d["vessels"][0]["controller"]["sensor"] = d["vessels"][0].pop("sensor")
    with pytest.raises(ScenarioError) as err:
        parse_scenario(d, "bad.toml")
    assert str(err.value).startswith("vessels[0].controller.sensor: unknown field; 'sensor' is a key of the vessel")
    d = demo()
    d["outputs"]["seed"] = d.pop("seed", 1)
    with pytest.raises(ScenarioError, match=r"^outputs\.seed: unknown field \(allowed: .*\); 'seed' is a top-level key"):
        parse_scenario(d, "bad.toml")
    # ... also after a nested table's header ([mission.go_to_formation], [[current.components]]), where
    # the hint was missing
    d = demo()
    d["mission"] = {"phases": ["follow_path"], "follow_path": {"seed": d.pop("seed", 1)}}
    with pytest.raises(ScenarioError, match=r"^mission\.follow_path\.seed: unknown field .*; 'seed' is a top-level "
                                            r"key, not one of \[mission\.follow_path\]"):
        parse_scenario(d, "bad.toml")
    d = demo()
    d["current"] = {"type": "sum", "components": [{"type": "uniform", "velocity_m_s": [0.1, 0.0]},
                                                  {"type": "uniform", "velocity_m_s": [0.0, 0.1],
                                                   "description": d.pop("description", "x")}]}
    with pytest.raises(ScenarioError, match=r"'description' is a top-level key, not one of "
                                            r"\[\[current\.components\]\]"):
        parse_scenario(d, "bad.toml")
    d = demo()
    d["vessels"][0]["controller"]["sped_m_s"] = 1.0
    with pytest.raises(ScenarioError) as err:
        parse_scenario(d, "bad.toml")
    allowed = str(err.value).split("(allowed: ", 1)[1].rstrip(")").split(", ")
    assert {"waypoints", "turn_radius_m", "speed_m_s", "type", "commands", "lookahead_m"} <= set(allowed)
    assert "key of the vessel" not in str(err.value)


def test_description_must_be_text():
    with pytest.raises(ScenarioError, match=r"^description: must be a string, got 5"):
        parse_scenario({**demo(), "description": 5}, "bad.toml")


def test_invalid_toml_and_missing_file(tmp_path):
    bad = tmp_path / "broken.toml"
    bad.write_text("duration_s = = 3\n")
    with pytest.raises(ScenarioError, match="not valid TOML"):
        load_scenario(bad)
    with pytest.raises(ScenarioError, match="no such scenario file"):
        load_scenario(tmp_path / "missing.toml")


def test_cli_rejects_a_bad_file_and_writes_nothing(tmp_path):
    text = (TASKS / "demo.toml").read_text().replace("duration_s = 240.0", "duration_s = -1.0")
    assert "duration_s = -1.0" in text
    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    out = tmp_path / "out"
    proc = subprocess.run([sys.executable, "-m", "mjasc", "run", str(bad), "--out", str(out)], cwd=ROOT,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert "duration_s: must be > 0" in proc.stderr
    assert not out.exists()


def test_the_documented_example_is_a_valid_scenario():
    text = (TASKS / "README.md").read_text()
    example = text.split("```toml", 1)[1].split("```", 1)[0]
    sc = parse_scenario(tomllib.loads(example), "README example")
    assert [v.name for v in sc.vessels] == ["alpha", "bravo"]
    assert len(sc.static_obstacles) == 2 and len(sc.moving_obstacles) == 2
    assert sc.moving_obstacles[1].path is not None


def test_the_documented_example_shows_every_key():
    """tasks/README.md's complete example (commented lines count) names every key a scenario's
    tables accept, so a user writing a file from it finds them all (it lacked recording_detail,
    an obstacle's height_m and a waypoint traffic's turn_radius_m and start_gamma_m)."""
    import dataclasses

    from mjasc.runs import scenario as module
    from mjasc.runs.scenario_values import Outputs, Rates

    example = (TASKS / "README.md").read_text().split("```toml", 1)[1].split("```", 1)[0]
    keys = set(module._TOP) | set(module._VESSEL) | set(module._CONTROLLER)
    keys |= {f.name for cls in (Rates, Outputs) for f in dataclasses.fields(cls)}
    keys |= {"vertices", "centre_m", "radius_m", "height_m", "turn_rate_deg_s", "turn_radius_m", "start_gamma_m"}
    missing = sorted(k for k in keys if not re.search(rf"(^|[\s`{{,\[])({k}) =|\[{k}\]|\[\[{k}\]\]|\[vessels\.{k}\]",
                                                     example, flags=re.M))
    assert missing == []


def test_seed_override_reseeds_a_seeded_current():
    d = demo()
    d["current"] = {"type": "gauss_markov", "mean_velocity_m_s": [0.1, 0.0], "time_constant_s": 60.0,
                    "sigma_m_s": 0.1}
    sc = parse_scenario(d, "gm.toml")
    p = np.zeros((1, 2))
    same = sc.with_overrides(seed=sc.seed)
    other = sc.with_overrides(seed=sc.seed + 1)
    np.testing.assert_array_equal(same.current.velocity(p, 300.0), sc.current.velocity(p, 300.0))
    assert not np.array_equal(other.current.velocity(p, 300.0), sc.current.velocity(p, 300.0))
    assert other.current.velocity(p, 300.0).tolist() == parse_scenario({**d, "seed": sc.seed + 1}).current.velocity(
        p, 300.0).tolist()
