"""Runs that collided in campaigns before the CAS hardening (tests/cas_regressions/, each file as
`mjasc extract` wrote it): with the hardened CAS none touches a hull, and the mechanism that fixed
it is the one that acted (a lane change where no detour exists, a checked speed choice where the
first choice ran into another target)."""

from pathlib import Path

import pytest

from mjasc.runs.runner import run_scenario
from mjasc.runs.scenario import load_scenario

CASES = Path(__file__).resolve().parent / "cas_regressions"

#: file → (vessel, the avoidance action that must have acted, hull clearance it must keep [m])
EXPECT = {
    "overtaken_82": ("own", "lane_change", 1.0),
    "imazu19_seed94": ("own", "checked_choice", 0.5),
    "imazu21_seed100": ("own", "checked_choice", 0.5),
    "demo_run14": ("bravo", "lane_change", 0.5),
}


def test_every_regression_file_is_checked():
    assert sorted(p.stem for p in CASES.glob("*.toml")) == sorted(EXPECT)


@pytest.mark.parametrize("name", [pytest.param(n, marks=[pytest.mark.slow] if n == "demo_run14" else [])
                                  for n in sorted(EXPECT)])
def test_a_case_that_collided_keeps_clear(name):
    vessel, action, bound = EXPECT[name]
    summary = run_scenario(load_scenario(CASES / f"{name}.toml")).summary
    assert summary["status"] == "completed"
    assert not summary["any_collision"], summary["collisions"]
    v = summary["vessels"][vessel]
    assert v["min_clearance_to_any_m"] > bound, v["min_clearance_m"]
    assert v["avoidance"]["actions"][action] >= 1, v["avoidance"]["actions"]
