"""A method registered in code reaches a campaign's runs whatever its stage: a tracking method that a
family's scenarios select (not only a compared avoidance method) is carried to the runs' child
processes by its import path, and one that cannot be imported by name is a one-line error before
any run starts (it used to fail every run in the child with "unknown tracking method")."""

from __future__ import annotations

import pytest

from mjasc.campaigns.engine import run_campaign
from mjasc.campaigns.methods import scenario_plugins
from mjasc.campaigns.spec import parse_campaign_spec
from mjasc.plugins import TrackingMethod, register, unregister
from tests.test_tracking_methods import EchoTracker


def _spec(method: str) -> object:
    return parse_campaign_spec({"name": "trk", "evaluation": {"mission_cost": False}, "families": [
        {"kind": "head_on", "runs_per_point": 1, "duration_s": 3.0,
         "own": {"tracking": {"method": method}}}]})


@pytest.fixture
def echo():
    register("tracking", EchoTracker)
    yield EchoTracker
    unregister("tracking", "test_echo")


def test_a_tracking_method_registered_in_code_reaches_the_runs_child_process(echo, tmp_path):
    spec = _spec("test_echo")
    assert scenario_plugins(r.scenario_toml for r in spec.runs()) == {
        "tracking": {"test_echo": "tests.test_tracking_methods:EchoTracker"}}
    res = run_campaign(spec, tmp_path / "c", workers=0, progress=False)  # (each run in a child process)
    assert [(r.status, r.error) for r in res.runs] == [("completed", None)]
    perception = res.runs[0].metrics["vessels"]["own"]["perception"]
    assert perception["tracking_method"] == "test_echo"
    assert "tracking" in res.runs[0].metrics["evaluation"]  # scored against the truth like the built-in


def test_nothing_registered_in_code_reads_no_scenario_text():
    assert scenario_plugins(["not toml at all ["]) == {}


def test_a_tracking_method_not_importable_by_name_runs_only_in_this_process(tmp_path):
    class LocalTracker(TrackingMethod):  # defined in a function: a child process cannot import it
        method = "test_local_tracker"

        def update(self, t_s, nav, detections):
            pass

        def tracks(self):
            return ()

    register("tracking", LocalTracker)
    try:
        spec = _spec("test_local_tracker")
        message = (r"^tracking method 'test_local_tracker' is registered only in this process .* "
                   r"\(group 'mjasc\.tracking'\).*workers=0, isolate=False")
        with pytest.raises(ValueError, match=message) as info:
            run_campaign(spec, tmp_path / "a", workers=0, progress=False)
        assert "\n" not in str(info.value)
        res = run_campaign(spec, tmp_path / "b", workers=0, isolate=False, progress=False)
        assert [r.status for r in res.runs] == ["completed"]
    finally:
        unregister("tracking", "test_local_tracker")
