"""The control slot of a fleet in one pass (mjasc.runs.fleet_control; coordinated or not) against the
per-agent form of the tick (each agent's mission, γ, avoidance call and answer asked piece by
piece): the same commands, statuses, modes, coordination states and summary at every tick of real
scenes, and the link's delivery for the fleet at once against each vessel's own poll."""

import dataclasses

import numpy as np
import pytest

import mjasc
from mjasc.core.navigation import NavigationList
from mjasc.runs import fleet_control, tick
from mjasc.runs.runner import Runner


def _run(name, duration_s, fleet: bool, monkeypatch):
    """The scene's control outputs at every tick and its summary, with or without the fleet pass."""
    monkeypatch.setattr(tick, "fleet_control_applies", fleet_control.fleet_control_applies if fleet
                        else lambda agents: False)
    used = []
    original = fleet_control.control_fleet

    def spy(*a):
        used.append(1)
        return original(*a)

    monkeypatch.setattr(tick, "control_fleet", spy)
    sc = mjasc.load_scenario(f"tasks/{name}.toml").with_overrides(duration_s=duration_s)
    sc = dataclasses.replace(sc, outputs=dataclasses.replace(sc.outputs, recording=False, video=False))
    runner = Runner(sc, out_dir=None)
    ticks = []

    def keep(event):
        assert isinstance(event.runner, Runner)
        ticks.append([(o.commands.tolist(), o.mode, o.speed_ref_m_s,
                       None if o.status is None else dataclasses.astuple(o.status)) for o in runner.last_outputs]
                     + [(a.coordination.last_factor, a.coordination.last_xi, a.coordination.last_error_m)
                        for a in runner.agents if a.coordination is not None])

    runner.observe("control", keep)
    summary = _untimed(runner.run().summary)
    assert bool(used) == fleet
    return ticks, summary


def _untimed(obj):
    """The summary without its timing fields (as scripts/summary_fingerprints.py compares it)."""
    if isinstance(obj, dict):
        return {k: _untimed(v) for k, v in obj.items()
                if k not in ("wall_time_s", "real_time_factor", "timing_s") and not k.endswith("_us")}
    return [_untimed(v) for v in obj] if isinstance(obj, list) else obj


@pytest.mark.parametrize("name", ["demo", "thesis_6_4_crossing", "thesis_6_2_dock"])  # (the dock: no coordination)
def test_the_fleet_pass_equals_the_per_agent_tick(name, monkeypatch):
    """Every tick's outputs and coordination states, and the summary, bit for bit."""
    want, want_summary = _run(name, 40.0, False, monkeypatch)
    got, got_summary = _run(name, 40.0, True, monkeypatch)
    assert len(got) == len(want) > 300
    assert got == want
    assert got_summary == want_summary


def test_navigation_list_carries_its_fleet():
    from mjasc.core.navigation import FleetNavigation

    fleet = FleetNavigation(2.5, np.arange(6.0).reshape(3, 2), np.array([0.1, 0.2, 0.3]), np.ones((3, 2)),
                            np.zeros((3, 3)))
    navs = fleet.vessels()
    assert isinstance(navs, NavigationList) and navs.fleet is fleet
    assert [n.heading_rad for n in navs] == fleet.heading_rad.tolist()
    np.testing.assert_array_equal(np.array([n.position_m for n in navs]), fleet.position_m)


def test_command_all_equals_command_on_the_demo(monkeypatch):
    """FleetPathFollower.command_all (the fleet pass's call: the fleet's own arrays, speeds and
    course overrides as lists, the scratch arrays) gives command's commands, statuses and loop
    states bit for bit at every control tick of the demo (command on a copy of the fleet's state)."""
    import copy

    from mjasc.guidance.path_following import FleetPathFollower

    original = FleetPathFollower.command_all
    seen = []

    def checked(self, pos, heading, body, speeds, courses, dt_s):
        ref = copy.copy(self)
        ref._S = self._S.copy()
        want_cmd, want_st = ref.command(np.array(pos), np.array(heading), np.array(body),
                                        np.array(speeds, dtype=float), dt_s,
                                        course_override_rad=np.array(courses, dtype=float))
        got_cmd, got_st = original(self, pos, heading, body, speeds, courses, dt_s)
        assert got_cmd.tobytes() == want_cmd.tobytes() and got_cmd.shape == want_cmd.shape
        assert [dataclasses.astuple(s) for s in got_st] == [dataclasses.astuple(s) for s in want_st]
        assert self._S.tobytes() == ref._S.tobytes()
        seen.append(any(not np.isnan(c) for c in courses))
        return got_cmd, got_st

    monkeypatch.setattr(FleetPathFollower, "command_all", checked)
    sc = mjasc.load_scenario("tasks/demo.toml").with_overrides(duration_s=30.0)
    sc = dataclasses.replace(sc, outputs=dataclasses.replace(sc.outputs, recording=False, video=False))
    Runner(sc, out_dir=None).run()
    assert len(seen) > 250
