"""The fleet-batched perception (mjasc.perception.fleet) gives every vessel the same detections, maps
and tracks, bit for bit, as a perception processed on its own (a fleet of one): on a world with five
vessels, moving targets, a quay and a buoy, vessels that scan at different rates and one with its
own tracking configuration; and through the runner on the thesis bottleneck scenario."""

import math

import mujoco
import numpy as np

from mjasc.perception import pipeline
from mjasc.perception.fleet import PerceptionFleet
from mjasc.perception.pipeline import Perception
from mjasc.perception.range_sensor import SensorConfig
from mjasc.perception.tracking import TrackingConfig
from mjasc.physics.obstacles import CircleObstacle, MovingObstacle, PolygonObstacle
from mjasc.physics.vessels import load_vessel_type
from mjasc.physics.world import build_world

DT = 0.2
POSES = [(0.0, 0.0, 0.0), (30.0, 12.0, 0.5), (-25.0, -10.0, 2.0), (10.0, -40.0, -1.0), (-40.0, 35.0, 3.0)]


def _world(n_targets=6):
    vt = load_vessel_type("otter")
    quay = PolygonObstacle("quay", np.array([[45.0, -30.0], [80.0, -30.0], [80.0, 30.0], [75.0, 30.0],
                                             [75.0, -25.0], [45.0, -25.0]]))
    moving = [MovingObstacle(f"t{k}", 2.0 + 0.3 * k, (500.0 + 20 * k, 500.0)) for k in range(n_targets)]
    w = build_world([(f"v{i}", vt) for i in range(len(POSES))], [quay, CircleObstacle("buoy", (-20.0, 25.0), 1.5)],
                    moving)
    for i, pose in enumerate(POSES):
        w.data.qpos[w.qpos_adr[i]] = pose
    return w


def _targets(k, n):
    t = k * DT
    ang = np.arange(n) * 2 * math.pi / n + 0.02 * t
    r = 35.0 + 10.0 * np.arange(n) % 40.0
    return np.stack([r * np.cos(ang) + 3.0 * np.sin(0.05 * t), r * np.sin(ang)], axis=-1)


def _perceptions(world, fleet_factory):
    out = []
    for i in range(len(POSES)):
        sensor = SensorConfig(beams=360, rate_hz=2.5 if i == 2 else 5.0, clutter_per_scan=1.0)
        tracking = TrackingConfig(confirm_hits=3) if i == 4 else TrackingConfig()
        out.append(Perception(world, i, sensor, tracking, np.random.default_rng([7, i]), fleet=fleet_factory()))
    return out


def sail_compared(world, a_ps, b_ps, seconds: float):
    """Move the traffic along :func:`_targets` and step both perception sets every ``DT`` for
    ``seconds`` [s], compared by :func:`step_and_compare`; yields the step index after each step."""
    d = world.data
    n = len(world.mocap_id)
    for k in range(int(seconds / DT)):
        d.mocap_pos[world.mocap_id, :2] = _targets(k, n)
        d.time = k * DT
        mujoco.mj_kinematics(world.model, d)
        step_and_compare(a_ps, b_ps, k * DT)
        yield k


def step_and_compare(ps_a, ps_b, t_s: float) -> None:
    """Both groups sense and track at t_s [s] (each group's vessels in turn, as the runner's slots
    call them); then each pair of vessels has the same arrays, bit for bit, the same counts and the
    same events."""
    for ps in (ps_a, ps_b):
        for p in ps:
            p.sense(t_s)
        for p in ps:
            p.update_tracks(t_s)
    for a, b in zip(ps_a, ps_b):
        sa, sb = _state(a), _state(b)
        for x, y in zip(sa[0], sb[0]):
            assert x.dtype == y.dtype and np.array_equal(x, y)
        assert sa[1:] == sb[1:]
        assert a.drain_events() == b.drain_events()


def _state(p: Perception):
    det, tr = p.detections, p.tracker
    b = tr.bank
    arrays = [det.centres_m, det.radii_m, det.variances_m2, det.labels, det.occluded, p._target_mask,
              p.map.occupied_cells(), b.track_ids, b.states, b.state_covariances, b.mode_probabilities,
              tr.confirmed, tr.radii_m, tr.static, tr.moved]
    ests = [(e.track_id, e.time_s, *e.position_m, e.heading_rad, e.speed_m_s, e.turn_rate_rad_s, e.radius_m,
             *e.position_covariance.ravel(), e.is_static, e.team_member,
             None if e.outline_m is None else e.outline_m.tobytes()) for e in p.tracks()]
    return arrays, ests, tr.team_members, [tuple(map(np.ndarray.tobytes, q)) for q in p.static_polygons()]


def test_fleet_pass_equals_each_vessel_alone():
    world = _world()
    shared = PerceptionFleet()
    fleet = _perceptions(world, lambda: shared)
    alone = _perceptions(world, PerceptionFleet)
    d = world.data
    n = len(world.mocap_id)
    for k in range(int(40 / DT)):
        d.mocap_pos[world.mocap_id, :2] = _targets(k, n)
        d.time = k * DT
        mujoco.mj_kinematics(world.model, d)
        if k % 25 == 10:  # broadcasts as each vessel's link delivered them
            for ps in (fleet, alone):
                for i, p in enumerate(ps):
                    p.set_team_positions({f"v{j}": (k * DT - 0.5, np.asarray(POSES[j][:2]) + 0.1 * i)
                                          for j in range(len(POSES)) if j != i})
        step_and_compare(fleet, alone, k * DT)
    assert sum(len(p.tracks()) for p in fleet) >= 10
    assert any(e.team_member for p in fleet for e in p.tracks())
    assert all(len(p.static_polygons()) for p in fleet[:2])
    assert len(shared._trackers) == 2  # vessel 4 has its own tracking configuration


def test_runner_fleet_equals_per_vessel(monkeypatch, tmp_path):
    """The thesis bottleneck (3 vessels, islands, team mates) for 40 s through the runner: the same
    summary and the same tracks at the end with the fleet pass and with each vessel alone."""
    from mjasc.runs.runner import Runner
    from mjasc.runs.scenario import load_scenario

    sc = load_scenario("thesis_6_4_bottleneck").with_overrides(video=False, duration_s=40.0)

    def run():
        runner = Runner(sc, tmp_path / str(len(list(tmp_path.iterdir()))), progress=False)
        summary = runner.run().summary
        return summary, [[(e.track_id, *e.position_m, e.heading_rad, e.speed_m_s, e.team_member)
                          for e in a.perception.tracks()] for a in runner.agents]

    with_fleet = run()
    monkeypatch.setattr(pipeline, "fleet_of", lambda world: PerceptionFleet())
    alone = run()

    def strip(s):
        if isinstance(s, dict):
            return {k: strip(v) for k, v in s.items() if not k.endswith("_us") and k not in ("wall_time_s",
                                                                                            "real_time_factor", "timing_s")}
        return s

    assert strip(with_fleet[0]) == strip(alone[0])
    assert with_fleet[1] == alone[1]
