"""The COLREG traffic rule for non-team traffic (``[vessels.avoidance] traffic_rule = "colreg"``),
checked on the Imazu single-target cases with the evaluation's own COLREG judge
(mjasc.evaluation.colreg): head-on, the thesis rule re-plans around the target and turns to port
(rule 14 broken); the COLREG rule changes lane to starboard. Crossing, the give-way vessel acts
without passing first and the stand-on vessel keeps course and speed until action is required."""

import tomllib
from pathlib import Path

import pytest

from mjasc.evaluation.run_evaluation import RunEvaluator
from mjasc.runs.runner import Runner
from mjasc.runs.scenario import parse_scenario

IMAZU = Path(__file__).resolve().parents[1] / "tasks" / "imazu"


def run_all(case: int, rule: str):
    """Imazu case ``case`` with the own vessel's traffic rule set: (summary, its avoidance actions,
    the evaluation's encounters)."""
    doc = tomllib.loads((IMAZU / f"imazu_{case:02d}.toml").read_text())
    doc["vessels"][0]["avoidance"]["traffic_rule"] = rule
    runner = Runner(parse_scenario(doc, f"imazu_{case:02d}"), None, progress=False)
    evaluator = RunEvaluator(runner)
    runner.observe("record", evaluator)
    summary = runner.run().summary
    return summary, summary["vessels"]["own"]["avoidance"]["actions"], evaluator.summary()["encounters"]


def run(case: int, rule: str):
    summary, actions, (encounter,) = run_all(case, rule)
    return summary, actions, encounter


def test_head_on_the_colreg_rule_turns_to_starboard_where_the_thesis_rule_turns_to_port():
    s, actions, enc = run(1, "thesis")
    assert not s["any_collision"] and enc["role"] == "head_on"
    assert "altered course to port" in enc["compliance_issues"]
    s, actions, enc = run(1, "colreg")
    assert not s["any_collision"] and enc["compliant"], enc["compliance_issues"]
    assert actions["lane_change"] >= 1
    assert s["vessels"]["own"]["min_clearance_to_any_m"] > 3.0


@pytest.mark.parametrize("case, role", [(2, "crossing_give_way"), (4, "crossing_stand_on")])
def test_crossing_give_way_acts_without_passing_first_and_stand_on_keeps_its_course(case, role):
    s, actions, enc = run(case, "colreg")
    assert not s["any_collision"] and enc["role"] == role
    assert enc["compliant"], enc["compliance_issues"]
    assert actions["pass"] == 0
    assert enc["acted"] == (role == "crossing_give_way")  # compliant: not crossed ahead, not early


def test_the_traffic_rule_reads_the_role_from_the_course_over_ground_not_the_crabbed_bow():
    # Heading north over ground at 1 m/s in a cross current, the bow crabbed 20° to port; a stranger
    # 60 m ahead on the reciprocal course is head-on (as the evaluation judges it). From the bow it
    # read as a crossing from starboard (courses 20° off reciprocal), and the vessel slowed down
    # instead of changing lane to starboard.
    import math
    from types import SimpleNamespace

    import numpy as np

    from mjasc.avoidance.triage import colreg_role

    nav = SimpleNamespace(position_m=np.zeros(2), heading_rad=math.radians(110.0), velocity_m_s=np.array([0.0, 1.0]))
    track = SimpleNamespace(position_m=np.array([0.0, 60.0]), heading_rad=-math.pi / 2, speed_m_s=1.5)
    assert colreg_role(nav, track, "colreg") == "head_on"
    assert colreg_role(nav, track, "thesis") is None
    still = SimpleNamespace(position_m=np.zeros(2), heading_rad=math.pi / 2, velocity_m_s=np.array([0.05, 0.0]))
    assert colreg_role(still, track, "colreg") == "head_on"  # barely moving: its heading


@pytest.mark.parametrize("case", [14, 22])
def test_among_several_targets_no_pass_first_ahead_of_one_it_gives_way_to(case):
    """Imazu 14 and 22 under the COLREG rule: three targets, two or three of them crossing from
    starboard (the own vessel gives way: slow down, pass astern). When a yield still collided with
    another target the checked choice took passing first — speeding up across the bow of a target
    it had to give way to (rule 15), two encounters of each case judged non-compliant. Passing
    first is no option toward those targets now: every give-way encounter is compliant."""
    s, actions, encounters = run_all(case, "colreg")
    assert not s["any_collision"]
    assert actions["pass"] == 0
    give_way = [e for e in encounters if e["role"] == "crossing_give_way"]
    assert len(give_way) >= 2 and all(e["compliant"] for e in give_way), give_way
