"""The perception report an agent hands to its stages: kept over a comms slot without shared
tracks (a frozen value: the same tracks, the same objects, as a report built anew), rebuilt after
one with shared tracks; and built as the readable ``PerceptionReport(...)`` would be."""

from dataclasses import replace

import mjasc
from mjasc.core.estimates import PerceptionReport
from mjasc.runs.runner import Runner


def _runner(task: str, duration_s: float) -> Runner:
    sc = mjasc.load_scenario(f"tasks/{task}.toml").with_overrides(duration_s=duration_s)
    return Runner(replace(sc, outputs=replace(sc.outputs, recording=False, video=False)), out_dir=None)


def _fresh(agent, t_s: float) -> PerceptionReport:
    """The report as the readable form builds it now."""
    p = agent.perception
    return PerceptionReport(float(t_s), tuple(p.tracks()) if p._fusion is None else p._fusion.fuse(tuple(p.tracks()), t_s),
                            p.static_polygons())


def _check_after_comms(task: str, duration_s: float, sharing: bool) -> int:
    r = _runner(task, duration_s)
    checked = []

    def after_comms(event):
        for agent in r.agents:
            if agent.perception is None:
                continue
            kept = agent._report
            if sharing and agent.coordination is not None and agent.coordination.track_sharing() is not None:
                assert kept is None  # the fused tracks changed: built anew at the next read
            rep = agent.perception_report(event.time_s)
            fresh = _fresh(agent, event.time_s)
            assert len(rep.tracks) == len(fresh.tracks)
            for a, b in zip(rep.tracks, fresh.tracks):
                assert a == b if sharing else a is b
            assert len(rep.static_polygons) == len(fresh.static_polygons)
            for a, b in zip(rep.static_polygons, fresh.static_polygons):
                assert a.tobytes() == b.tobytes()
            checked.append(kept is not None)

    r.observe("comms", after_comms)
    r.run()
    return sum(checked)


def test_report_kept_over_comms_without_shared_tracks():
    kept = _check_after_comms("demo", 6.0, sharing=False)
    assert kept > 0  # reports built at an earlier control tick were handed out again


def test_report_rebuilt_after_comms_with_shared_tracks():
    _check_after_comms("shared_perception_occluded", 6.0, sharing=True)


def test_report_fields_as_the_dataclass_builds_them():
    r = _runner("demo", 2.0)
    r.run()
    agent = next(a for a in r.agents if a.perception is not None)
    agent._report = None
    rep = agent.perception_report(2)
    assert type(rep) is PerceptionReport and type(rep.time_s) is float and rep.time_s == 2.0
    assert rep == PerceptionReport(2.0, rep.tracks, rep.static_polygons)
    assert agent.perception_report(3.0) is rep  # nothing changed the perception: the same value
