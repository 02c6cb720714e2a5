"""scripts/knock_out.py: the paired measurement with a piece of the run replaced by a no-op leaves
every replaced attribute as it was (own or inherited), and a bad target is a one-line error."""

import importlib.util
from pathlib import Path

import pytest

from mjasc.perception.pipeline import Perception
from mjasc.runs.agent import VesselAgent

ROOT = Path(__file__).resolve().parent.parent
_spec = importlib.util.spec_from_file_location("knock_out", ROOT / "scripts" / "knock_out.py")
knock_out = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(knock_out)


def test_measures_and_restores_own_and_inherited_attributes():
    own = Perception.__dict__["log"]

    class Child(VesselAgent):  # an inherited method: knocked out on the child, then removed again
        pass

    import mjasc.runs.agent as agent_module
    agent_module._KnockChild = Child
    try:
        res = knock_out.measure(str(ROOT / "tasks" / "thesis_6_1_static.toml"),
                                ["mjasc.perception.pipeline:Perception.log", "mjasc.runs.agent:_KnockChild.log"],
                                rounds=1, duration_s=1.0, recording=True)
    finally:
        del agent_module._KnockChild
    assert Perception.__dict__["log"] is own
    assert "log" not in vars(Child) and Child.log is VesselAgent.log
    assert set(res) == {"wall", "record", "other stages"}
    for with_it, without, diffs in res.values():
        assert with_it > 0 and without > 0 and len(diffs) == 1


@pytest.mark.parametrize("target, reason", [("mjasc.no_such_module:f", "No module named"),
                                            ("mjasc.runs.agent:VesselAgent.no_such", "is not a function"),
                                            ("mjasc.runs.agent", "expected module:Attribute.path")])
def test_bad_target_is_a_one_line_error(target, reason):
    with pytest.raises(SystemExit, match=reason):
        knock_out.resolve(target)
