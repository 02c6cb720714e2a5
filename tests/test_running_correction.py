"""The running correction as an option of the checked choice (mjasc.avoidance.manoeuvres,
``CheckedChoice._checked_choice``), end to end in the stressed §6.4.2 head-on on seed 168
(tests/cas_regressions/head_on_stressed_seed168.toml): a vessel yielding to a track ahead, whose
next prediction sails that yield and so sees only a new conflict, must not trade the yield for a
manoeuvre that runs into the track it settled."""

from pathlib import Path

import pytest

from tests.helpers import avoidance_events

CASE = Path(__file__).resolve().parent / "cas_regressions" / "head_on_stressed_seed168.toml"


@pytest.mark.slow
def test_alpha_keeps_its_running_stop_for_the_mate_ahead_and_looks_again_every_second(monkeypatch):
    from mjasc.runs.runner import run_scenario
    from mjasc.runs.scenario import load_scenario

    said = avoidance_events(monkeypatch)
    summary = run_scenario(load_scenario(CASE).with_overrides(duration_s=135.0)).summary
    assert not summary["any_collision"], summary["collisions"]
    # the pass first for the oncoming stranger collided with the track alpha was yielding to (before
    # session 63 it was taken at 113.8 s, and alpha ran into bravo at 116.4 s): the running correction is kept
    kept = [(t, text) for name, t, text in said if name == "alpha" and ": its running " in text]
    assert kept and all(text.startswith("pass for track") for _, text in kept), kept
    assert all("no plan clears every track" in text for _, text in kept), kept  # (kept: it keeps the most distance)
    # kept though it still collides: alpha predicts again within about a second, with nothing else new
    t0 = kept[0][0]
    again = [t for name, t, text in said
             if name == "alpha" and text.startswith("collision predicted") and t0 < t <= t0 + 1.5]
    assert again, [(t, text) for name, t, text in said if name == "alpha" and t > t0][:5]
    # a kept running correction is not a new one: neither counted nor said again as a velocity correction
    assert not [t for name, t, text in said if name == "alpha" and t == t0 and text.startswith("velocity correction")]
    assert summary["vessels"]["alpha"]["min_clearance_to_any_m"] > 1.0
