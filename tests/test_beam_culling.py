"""Beam culling (mjasc.perception.beam_culling): a sensor that casts only the beams able to meet a
geom reads the same bits as casting its whole fan, on the shipped scenes' models with the vessels
and the traffic placed at random (close together, far apart, the sensor inside another hull's
bounding circle), for full circles and partial fans; and it does cull."""

import math
from pathlib import Path

import mujoco
import numpy as np
import pytest

import mjasc
from mjasc.perception.beam_culling import candidate_geoms, fan_candidates
from mjasc.perception.range_sensor import RangeSensor, SensorConfig
from mjasc.perception.scan_kernels import fan_directions
from mjasc.physics.obstacles import CircleObstacle
from mjasc.physics.vessels import load_vessel_type
from mjasc.physics.world import SENSOR_GEOM_GROUPS, build_world
from mjasc.runs.runner import Runner

TASKS = Path(__file__).resolve().parents[1] / "tasks"


def whole_fan(sensor: RangeSensor, data) -> tuple[np.ndarray, np.ndarray]:
    """The reference: every beam of the fan cast with one ``mj_multiRay`` (the sensor's code before culling)."""
    n = sensor.config.beams
    xm = data.site_xmat[sensor.site_id]
    yaw = math.atan2(xm[3], xm[0])
    pnt = np.array([data.site_xpos[sensor.site_id][0], data.site_xpos[sensor.site_id][1], sensor.config.ray_height_m])
    vec = np.zeros((n, 3))
    fan_directions(sensor.angles_body, yaw, vec)
    dist, gid = np.zeros(n), np.zeros(n, dtype=np.int32)
    mujoco.mj_multiRay(sensor.model, data, pnt, vec.reshape(-1), sensor.geomgroup, 1, sensor.body_id, gid, dist, None,
                       n, sensor.config.max_range_m)
    return dist, gid


def culled(sensor: RangeSensor, data) -> tuple[np.ndarray, np.ndarray]:
    n = sensor.config.beams
    dist, gid = np.full(n, 7.0), np.full(n, 7, dtype=np.int32)  # (every beam must be written)
    sensor.fire(data, dist, gid)
    return dist, gid


def scattered(runner: Runner, rng: np.random.Generator, spread_m: float) -> None:
    """The runner's vessels and traffic at random poses within ``spread_m`` of the scene's centre."""
    sim = runner.sim
    n = len(runner.scenario.vessels)
    poses = np.column_stack([rng.uniform(-spread_m, spread_m, (n, 2)), rng.uniform(-math.pi, math.pi, n)])
    sim.reset(poses, np.zeros((n, 3)))
    d = sim.data
    if d.mocap_pos.shape[0]:
        d.mocap_pos[:, :2] = rng.uniform(-spread_m, spread_m, (d.mocap_pos.shape[0], 2))
    mujoco.mj_forward(sim.model, d)


@pytest.mark.parametrize("task", ["thesis_6_4_crossing", "thesis_6_4_bottleneck", "demo", "thesis_6_2_dock"])
def test_culled_fans_read_the_same_bits_as_whole_fans(task):
    sc = mjasc.load_scenario(TASKS / f"{task}.toml")
    runner = Runner(sc, None, progress=False)
    sensors = [a.perception.sensor for a in runner.agents if getattr(a.perception, "sensor", None) is not None]
    assert sensors and all(s._culling is not None for s in sensors)
    rng = np.random.default_rng(7)
    culled_beams = total = 0
    for trial in range(40):
        scattered(runner, rng, spread_m=(8.0, 40.0, 150.0)[trial % 3])  # (close: inside other hulls' circles)
        for s in sensors:
            want, got = whole_fan(s, runner.sim.data), culled(s, runner.sim.data)
            np.testing.assert_array_equal(got[1], want[1])
            np.testing.assert_array_equal(got[0], want[0])
            x, y, yaw = s.fire(runner.sim.data, np.empty(s.config.beams), np.empty(s.config.beams, np.int32))
            total += s.config.beams
            culled_beams += s.config.beams - int(s.last_beams_cast)
    assert culled_beams > 0.3 * total  # (it does cull: most beams of a scattered scene meet nothing)


@pytest.mark.parametrize("fov_deg, beams", [(360.0, 720), (120.0, 97), (270.0, 300), (359.0, 64), (30.0, 1)])
def test_partial_fans_and_short_cutoffs(fov_deg, beams):
    """Partial fans (their edges near ±π too) and a cutoff that ends inside a hull's circle."""
    vt = load_vessel_type("otter")
    statics = [CircleObstacle(f"buoy{i}", np.array([15.0 * math.cos(i), 15.0 * math.sin(i)]) * (1 + i % 3), 1.0 + i % 2)
               for i in range(9)]
    w = build_world([("a", vt), ("b", vt), ("c", vt)], statics, [])
    rng = np.random.default_rng(beams)
    for cutoff in (10.0, 31.0, 150.0):
        config = SensorConfig(beams=beams, fov_deg=fov_deg, max_range_m=cutoff)
        sensors = [RangeSensor(w.model, config, int(w.hull_body_id[i]),
                               mujoco.mj_name2id(w.model, mujoco.mjtObj.mjOBJ_SITE, f"{n}/sensor_mount"),
                               SENSOR_GEOM_GROUPS) for i, n in enumerate("abc")]
        for _ in range(30):
            for i in range(3):
                w.data.qpos[w.qpos_adr[i]] = [*rng.uniform(-30, 30, 2), rng.uniform(-4, 4)]
            mujoco.mj_forward(w.model, w.data)
            for s in sensors:
                want, got = whole_fan(s, w.data), culled(s, w.data)
                np.testing.assert_array_equal(got[1], want[1])
                np.testing.assert_array_equal(got[0], want[0])


def test_a_lone_disc_marks_its_angular_width_and_open_water_none():
    """One buoy (radius R) at range ρ: the beams within asin(R/ρ) of its bearing and one more on each
    side are cast, nothing else; with the buoy beyond the cutoff, no beam at all."""
    vt = load_vessel_type("otter")
    for rho, radius, bearing in ((40.0, 2.0, 0.3), (90.0, 3.0, -2.9), (12.0, 1.5, math.pi - 0.01)):
        centre = rho * np.array([math.cos(bearing), math.sin(bearing)])
        w = build_world([("a", vt)], [CircleObstacle("buoy", centre, radius)], [])
        mujoco.mj_forward(w.model, w.data)
        config = SensorConfig(beams=720, max_range_m=100.0)
        s = RangeSensor(w.model, config, int(w.hull_body_id[0]),
                        mujoco.mj_name2id(w.model, mujoco.mjtObj.mjOBJ_SITE, "a/sensor_mount"), SENSOR_GEOM_GROUPS)
        got = culled(s, w.data)
        np.testing.assert_array_equal(got[1], whole_fan(s, w.data)[1])
        mount, yaw = s.pose(w.data)
        rel = np.array(centre) - mount
        r = float(np.hypot(*rel))
        half = math.asin(w.model.geom_rbound[s._culling[0][0]] / r)
        step = s.beam_spacing_rad
        # (the buoy's geom is a cylinder: its bounding sphere is a little larger than its radius)
        assert s.last_beams_cast <= 2 * half / step + 5  # (rounded out, one more each side, both ends)
        assert s.last_beams_cast >= np.count_nonzero(got[1] >= 0)
        far = build_world([("a", vt)], [CircleObstacle("buoy", centre / rho * (100.0 + 3 * radius), radius)], [])
        mujoco.mj_forward(far.model, far.data)
        s = RangeSensor(far.model, config, int(far.hull_body_id[0]),
                        mujoco.mj_name2id(far.model, mujoco.mjtObj.mjOBJ_SITE, "a/sensor_mount"), SENSOR_GEOM_GROUPS)
        got = culled(s, far.data)
        assert s.last_beams_cast == 0 and np.all(got[0] == -1) and np.all(got[1] == -1)


def test_a_plane_in_the_seen_groups_turns_culling_off():
    m = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><geom type="plane" size="5 5 1"/><body name="b"><freejoint/>'
        '<geom type="sphere" size="1" pos="5 0 0"/></body></worldbody></mujoco>')
    assert candidate_geoms(m, np.array([1, 0, 0, 1, 0, 0], np.uint8), 1) is None
    ids, radii, boxes = candidate_geoms(m, np.array([0, 1, 0, 0, 0, 0], np.uint8), -1)
    assert ids.size == 0 and radii.size == 0 and boxes.shape == (0, 3)
    # (with no geom at all nothing is cast, and every beam reads a miss)
    n = 8
    mark, beams, vec = np.zeros(n, bool), np.zeros(n, np.int64), np.zeros((n, 3))
    dist, gid = np.zeros(n), np.zeros(n, np.int32)
    angles = -math.pi + (np.arange(n) + 0.5) * 2 * math.pi / n
    data = mujoco.MjData(m)
    assert fan_candidates(0.0, 0.0, 0.0, angles, True, data.geom_xpos, data.geom_xmat, ids, radii, boxes, 100.0, mark,
                          beams, vec, dist, gid) == 0
    assert np.all(dist == -1) and np.all(gid == -1)


def test_groups_outside_the_range_count_as_the_nearest_one_as_mujoco_takes_them():
    """MJCF accepts group −1 and 7: MuJoCo's ray casting clamps them to 0 and 5, and so does the
    culling's choice of candidate geoms (a sphere of each, 10 m away, read alike both ways)."""
    m = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><site name="mount" pos="0 0 0.1"/>'
        '<geom type="sphere" size="1" pos="10 0 0.1" group="-1"/>'
        '<geom type="sphere" size="1" pos="0 10 0.1" group="7"/></worldbody></mujoco>')
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    config = SensorConfig(beams=360, max_range_m=50.0, ray_height_m=0.1)
    for groups, seen in (([1, 0, 0, 1, 0, 0], 1), ([0, 0, 0, 0, 0, 1], 1), ([1, 0, 0, 0, 0, 1], 2)):
        s = RangeSensor(m, config, -1, 0, np.array(groups, np.uint8))
        want, got = whole_fan(s, d), culled(s, d)
        np.testing.assert_array_equal(got[1], want[1])
        np.testing.assert_array_equal(got[0], want[0])
        assert len(set(got[1][got[1] >= 0].tolist())) == seen


def test_the_seen_groups_and_the_excluded_body_are_fixed_with_the_sensor():
    """The candidate geoms are chosen once from them: the sensor keeps its own read-only copy."""
    m = mujoco.MjModel.from_xml_string('<mujoco><worldbody><site name="mount"/></worldbody></mujoco>')
    mine = np.array([1, 0, 0, 1, 0, 0], np.uint8)
    s = RangeSensor(m, SensorConfig(), -1, 0, mine)
    mine[1] = 1
    assert s.geomgroup.tolist() == [1, 0, 0, 1, 0, 0] and not s.geomgroup.flags.writeable
    with pytest.raises(ValueError):
        s.geomgroup[1] = 1
    with pytest.raises(AttributeError):
        s.body_id = 3
    with pytest.raises(ValueError, match="geomgroup: expected 6 flags"):
        RangeSensor(m, SensorConfig(), -1, 0, np.array([1, 0, 0, 1], np.uint8))
