"""The thesis method's control tick (mjasc.avoidance.control_tick): its shortcuts give the same run as
the full checks."""

from dataclasses import replace
from pathlib import Path

from mjasc.avoidance.system import CollisionAvoidance
from mjasc.avoidance.team_mates import TeamMates
from mjasc.campaigns.engine import without_timing
from mjasc.runs.runner import Runner
from mjasc.runs.scenario import load_scenario

TASKS = Path(__file__).resolve().parents[1] / "tasks"


def _demo_summary(duration_s: float) -> dict:
    sc = load_scenario(TASKS / "demo.toml").with_overrides(duration_s=duration_s)
    return Runner(replace(sc, outputs=replace(sc.outputs, recording=False, video=False)), None,
                  progress=False).run().summary


def test_the_control_tick_shortcuts_give_the_same_demo_run(monkeypatch):
    """The control tick calls neither the team poll nor the plan comparison for the intentions
    mapping they last went through, and on the mission without a manoeuvre it notes the mode only.
    The reference form — every tick polls and compares (returning early on the mapping's key, as
    before) and asks the manoeuvre's references — gives the same demo run, and the shortcuts were
    taken."""
    calls = {"poll": 0, "plans_changed": 0}
    for name in calls:
        orig = getattr(TeamMates, name)

        def counted(self, *a, _orig=orig, _name=name, **k):
            calls[_name] += 1
            return _orig(self, *a, **k)

        monkeypatch.setattr(TeamMates, name, counted)
    fast = _demo_summary(60.0)
    fast_calls = dict(calls)
    assert sum(v["avoidance"]["predictions"] for v in fast["vessels"].values()) >= 10  # it did predict

    query = CollisionAvoidance._control_query

    def full_query(self, t):  # every tick polls and compares: the mappings gone through forgotten
        self.team_mates.polled_intentions = self.team_mates.compared_intentions = None
        return query(self, t)

    def full_rest(self, t, nav):  # the manoeuvre's references asked on every tick
        override, course = self._manoeuvre_refs(t, nav)
        return override, self._note_mode(t), course

    monkeypatch.setattr(CollisionAvoidance, "_control_query", full_query)
    monkeypatch.setattr(CollisionAvoidance, "_control_rest", full_rest)
    for name in calls:
        calls[name] = 0
    full = _demo_summary(60.0)
    assert calls["poll"] > 2 * fast_calls["poll"] and calls["plans_changed"] > 2 * fast_calls["plans_changed"]
    assert without_timing(fast) == without_timing(full)
