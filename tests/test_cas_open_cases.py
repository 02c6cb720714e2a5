"""Open collision-avoidance cases (tests/cas_regressions/open/, each file's header says what collides
and what is known): runs that still touch a hull. Each is expected to fail until its cause is fixed;
then its file moves to tests/cas_regressions/ with the fix's mechanism in test_cas_regressions.py."""

from pathlib import Path

import pytest

from mjasc.runs.runner import run_scenario
from mjasc.runs.scenario import load_scenario

OPEN = Path(__file__).resolve().parent / "cas_regressions" / "open"


@pytest.mark.parametrize("name", sorted(p.stem for p in OPEN.glob("*.toml")))
@pytest.mark.xfail(reason="an open case: it collides (its file's header)", strict=False)
def test_an_open_case_keeps_clear(name):
    summary = run_scenario(load_scenario(OPEN / f"{name}.toml")).summary
    assert summary["status"] == "completed"
    assert not summary["any_collision"], summary["collisions"]
