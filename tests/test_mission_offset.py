"""The mission offset (mjasc/runs/mission_offset.py): the distance to the mission path, the same
measure for every avoidance method. The cross-track statistics follow the path being followed —
a thesis detour is one —, so two Otters that swerved 8 m round each other reported a 2.9 m
maximum cross-track with the thesis method and 23 m with the velocity obstacles."""

from types import SimpleNamespace

import numpy as np
import pytest

from mjasc.guidance.paths import Path
from mjasc.runs.mission_offset import CHUNK, MissionOffset
from mjasc.runs.runner import run_scenario
from mjasc.runs.scenario import parse_scenario


def _agent(path, leg=None):
    return SimpleNamespace(config=SimpleNamespace(path=path), mission=None if leg is None else SimpleNamespace(
        leg_path=leg))


def test_distances_to_the_mission_path_at_every_nth_counted_tick():
    line = Path.line([0.0, 0.0], [100.0, 0.0])
    leg = Path.line([0.0, 10.0], [100.0, 10.0])
    offsets = MissionOffset(3, every=2)
    agents = [_agent(line), _agent(line, leg=leg), _agent(None)]
    ys = [1.0, 5.0, 2.0, 9.0, 3.0]
    for k, y in enumerate(ys):  # ticks 0, 2, 4 sampled
        offsets.sample(np.array([[10.0 + k, y], [20.0, y], [0.0, 0.0]]), [0.1, 0.1 if k != 2 else np.nan, 0.1], agents)
    first = offsets.summary(0)
    assert first["mean_mission_offset_m"] == pytest.approx((1.0 + 2.0 + 3.0) / 3)
    assert first["max_mission_offset_m"] == 3.0
    second = offsets.summary(1)  # its mission leg at y = 10; tick 2 not counted
    assert second["mean_mission_offset_m"] == pytest.approx((9.0 + 7.0) / 2) and second["max_mission_offset_m"] == 9.0
    assert offsets.summary(2) == {"mean_mission_offset_m": None, "max_mission_offset_m": None}  # no path


def test_samples_are_folded_in_chunks_with_the_same_numbers():
    line = Path.from_waypoints([[0.0, 0.0], [50.0, 0.0], [50.0, 50.0]])
    rng = np.random.default_rng(3)
    pts = rng.uniform(-10.0, 60.0, (3 * CHUNK + 7, 2))
    offsets = MissionOffset(1, every=1)
    for p in pts:
        offsets.sample(p[None, :], [0.0], [_agent(line)])
    _, d = line.closest_points(pts)
    got = offsets.summary(0)
    assert got["max_mission_offset_m"] == round(float(d.max()), 4)
    assert got["mean_mission_offset_m"] == pytest.approx(float(d.mean()), abs=1e-4)


HEAD_ON = {
    "name": "head_on_offsets", "duration_s": 60.0, "seed": 1, "outputs": {"recording": False},
    "vessels": [{"name": name, "type": "otter", "position_m": [x0, 0.0], "heading_deg": heading, "speed_m_s": 1.5,
                 "controller": {"type": "path_following", "waypoints": [[x0, 0.0], [x1, 0.0]], "speed_m_s": 1.5},
                 "sensor": {"beams": 360, "max_range_m": 80.0}, "tracking": {}}
                for name, x0, x1, heading in (("east", 0.0, 100.0, 0.0), ("west", 100.0, 0.0, 180.0))],
}


def _head_on(avoidance):
    doc = {**HEAD_ON, "vessels": [{**v, "avoidance": dict(avoidance)} for v in HEAD_ON["vessels"]]}
    return run_scenario(parse_scenario(doc)).summary["vessels"]


def test_a_detour_counts_in_the_mission_offset_for_either_method():
    """The pair swerves round each other: the mission offset shows it for both methods; the thesis
    method's cross-track (from its detour) does not, the velocity obstacles' (a course override off
    the path, here ~2–3 m) does."""
    thesis = _head_on({"safety_distance_m": 2.0, "traffic_rule": "colreg"})
    vo = _head_on({"method": "velocity_obstacle"})
    for v in thesis.values():  # a ~10 m detour, sailed on its own path
        assert v["max_mission_offset_m"] > 8.0 and v["max_cross_track_m"] < 0.5 * v["max_mission_offset_m"]
    for v in vo.values():  # on its path the whole time: the two measures sample one distance
        assert v["max_mission_offset_m"] <= v["max_cross_track_m"] + 1e-6
        assert v["max_mission_offset_m"] > 0.8 * v["max_cross_track_m"] > 1.5
