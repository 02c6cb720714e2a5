"""Range sensor (mjasc.perception.range_sensor): geometry against closed form, own-hull exclusion, occlusion,
other hulls seen at the ray height, noise / dropout / clutter statistics, option parsing."""

import math

import mujoco
import numpy as np
import pytest

from mjasc.perception.range_sensor import CLUTTER_GEOM, SensorConfig, parse_sensor_options, sensor_for_vessel
from mjasc.physics.obstacles import CircleObstacle, MovingObstacle
from mjasc.physics.vessels import load_vessel_type
from mjasc.physics.world import build_world

QUIET = SensorConfig(range_noise_std_m=0.0, dropout_probability=0.0, clutter_per_scan=0.0)


def make(vessels=(("a", (0.0, 0.0, 0.0)),), statics=(), moving=(), config=QUIET):
    vt = load_vessel_type("otter")
    w = build_world([(n, vt) for n, _ in vessels], list(statics), list(moving))
    d = w.data
    for i, (_, pose) in enumerate(vessels):
        d.qpos[w.qpos_adr[i]] = pose
    mujoco.mj_forward(w.model, d)
    return w, sensor_for_vessel(w, 0, config)


def test_beam_geometry_and_range_to_a_disc_in_closed_form():
    """A buoy of radius 2 m centred 40 m away at bearing 30° from the mount: the beam along the centre
    line reads 40 − 2 m, every return lies on the disc's surface, and body ↔ world agree."""
    yaw = 0.7
    w, s = make(vessels=[("a", (5.0, -3.0, yaw))])
    mount, head = s.pose(w.data)
    assert head == pytest.approx(yaw)
    bearing = math.radians(30.0)
    centre = mount + 40.0 * np.array([math.cos(yaw + bearing), math.sin(yaw + bearing)])
    w, s = make(vessels=[("a", (5.0, -3.0, yaw))], statics=[CircleObstacle("buoy", centre, 2.0)])
    scan = s.scan(w.data, None)
    k = np.argmin(np.abs(scan.angles_body - bearing))
    assert scan.angles_body[k] == pytest.approx(bearing, abs=0.5 * scan.beam_spacing_rad + 1e-9)
    off = 40.0 * math.sin(scan.angles_body[k] - bearing)
    assert scan.ranges[k] == pytest.approx(40.0 * math.cos(scan.angles_body[k] - bearing) - math.sqrt(4 - off**2),
                                           abs=1e-6)
    np.testing.assert_allclose(np.hypot(*(scan.hit_points_world - centre).T), 2.0, atol=1e-6)
    c, sn = math.cos(yaw), math.sin(yaw)
    back = mount + scan.hit_points_body @ np.array([[c, sn], [-sn, c]])
    np.testing.assert_allclose(back, scan.hit_points_world, atol=1e-9)
    # a 2 m disc at 40 m subtends 2·asin(2/40) = 5.7°: 11 or 12 beams of 0.5°
    assert 10 <= scan.hit_beams.size <= 12
    assert scan.angles_body[0] == pytest.approx(-math.pi + 0.5 * scan.beam_spacing_rad)


def test_own_hull_is_excluded_other_hulls_are_seen_at_the_ray_height():
    """The own Otter (all geoms in one body) never returns; another Otter's low collision hull
    (0.28 m high, the mounts are at 0.8 m) is seen from 20 m; the water never is."""
    w, s = make(vessels=[("a", (0.0, 0.0, 0.0)), ("b", (20.0, 0.0, 1.0))])
    scan = s.scan(w.data, None)
    owners = {w.geom_owner[g] for g in scan.geom_ids[scan.hit]}
    assert owners == {"b"}
    assert scan.ranges[scan.hit].min() > 18.0


def test_occlusion_near_object_hides_what_is_behind():
    w, s = make(statics=[CircleObstacle("near", (20.0, 0.0), 1.0), CircleObstacle("far", (60.0, 0.0), 4.0)])
    scan = s.scan(w.data, None)
    ids = scan.geom_ids
    names = np.array([w.geom_owner[g] if g >= 0 else "" for g in ids])
    ahead = np.abs(scan.angles_body) < math.asin(1.0 / 20.0) * 0.9
    assert np.all(names[ahead] == "near")
    assert np.any(names == "far")  # the far disc's edges stick out
    # mocap (moving) obstacles are seen too
    w, s = make(moving=[MovingObstacle("boat", 2.5, (0.0, 30.0))])
    assert {w.geom_owner[g] for g in s.scan(w.data, None).geom_ids if g >= 0} == {"boat"}


def test_noise_dropout_and_clutter_statistics():
    cfg = SensorConfig(range_noise_std_m=0.1, dropout_probability=0.2, clutter_per_scan=3.0)
    w, s = make(statics=[CircleObstacle(f"b{k}", (40 * math.cos(a), 40 * math.sin(a)), 6.0)
                         for k, a in enumerate(np.linspace(0, 2 * math.pi, 12, endpoint=False))], config=cfg)
    truth, gid, _, _ = s.cast(w.data)
    true_hit = gid >= 0
    rng = np.random.default_rng(0)
    kept, noise, clutter = [], [], []
    for _ in range(200):
        scan = s.scan(w.data, rng)
        real = scan.geom_ids >= 0
        kept.append(real[true_hit].mean())
        noise.append(scan.ranges[real] - truth[real])
        clutter.append(int((scan.geom_ids == CLUTTER_GEOM).sum()))
    n_true = int(true_hit.sum())
    assert np.mean(kept) == pytest.approx(0.8, abs=4 * math.sqrt(0.16 / (200 * n_true)) + 0.01)
    assert np.std(np.concatenate(noise)) == pytest.approx(0.1, rel=0.05)
    # a false return only shows where it is nearer than the true return
    assert 1.0 < np.mean(clutter) < 3.0 + 4 * math.sqrt(3.0 / 200)


def test_field_of_view_and_range_limit():
    cfg = SensorConfig(beams=90, fov_deg=90.0, max_range_m=100.0, range_noise_std_m=0.0, dropout_probability=0.0,
                       clutter_per_scan=0.0)
    w, s = make(statics=[CircleObstacle("ahead", (50.0, 0.0), 2.0), CircleObstacle("behind", (-20.0, 0.0), 2.0),
                         CircleObstacle("far", (0.0, 130.0), 5.0)], config=cfg)
    scan = s.scan(w.data, None)
    assert np.all(np.abs(scan.angles_body) < math.radians(45.0))
    assert {w.geom_owner[g] for g in scan.geom_ids if g >= 0} == {"ahead"}
    assert not scan.full_circle


def test_a_short_range_lidar_sees_only_within_its_range():
    """A 30 m sensor (≥ 10 m is allowed: a small craft's lidar) sees the boat 20 m ahead and not
    the one 50 m ahead that a 100 m sensor sees."""
    statics = [CircleObstacle("near", (20.0, 0.0), 2.0), CircleObstacle("far", (50.0, 5.0), 2.0)]
    seen = {}
    for rng_m in (30.0, 100.0):
        cfg = SensorConfig(beams=360, max_range_m=rng_m, range_noise_std_m=0.0, dropout_probability=0.0,
                           clutter_per_scan=0.0)
        w, s = make(statics=statics, config=cfg)
        scan = s.scan(w.data, None)
        seen[rng_m] = {w.geom_owner[g] for g in scan.geom_ids if g >= 0}
        assert np.all(scan.ranges[scan.geom_ids >= 0] <= rng_m)
    assert seen == {30.0: {"near"}, 100.0: {"near", "far"}}
    assert parse_sensor_options({"max_range_m": 10.0}, "s").max_range_m == 10.0
    with pytest.raises(ValueError, match=r"^s\.max_range_m: must be ≥ 10 m and ≤ 100 km"):
        parse_sensor_options({"max_range_m": 9.0}, "s")


def test_parse_sensor_options():
    cfg = parse_sensor_options({"beams": 360, "max_range_m": 120, "fov_deg": 180.0}, "vessels[0].sensor")
    assert cfg.beams == 360 and cfg.max_range_m == 120.0 and cfg.fov_deg == 180.0
    assert parse_sensor_options({}, "s") == SensorConfig()
    w = "vessels[2].sensor"
    for table, key in [({"beam": 3}, "beam"), ({"beams": 3.0}, "beams"), ({"beams": 0}, "beams"),
                       ({"max_range_m": 5.0}, "max_range_m"), ({"fov_deg": 400}, "fov_deg"),
                       ({"dropout_probability": 1.0}, "dropout_probability"), ({"rate_hz": "fast"}, "rate_hz"),
                       ({"clutter_per_scan": -1}, "clutter_per_scan"), ({"min_range_m": 200.0}, "min_range_m"),
                       ({"range_noise_std_m": True}, "range_noise_std_m"),
                       ({"beams": 360, "clutter_per_scan": 361.0}, "clutter_per_scan"),
                       ({"clutter_per_scan": 1e7}, "clutter_per_scan")]:  # (hung: each false return drawn alone)
        with pytest.raises(ValueError, match=rf"^vessels\[2\]\.sensor\.{key}:"):
            parse_sensor_options(table, w)
    assert parse_sensor_options({"beams": 360, "clutter_per_scan": 360.0}, w).clutter_per_scan == 360.0


@pytest.mark.parametrize("clutter", [0.5, 3.0, 12.0])
def test_draws_are_numpys_array_draws_in_the_same_order(clutter):
    """RangeSensor.draw draws the clutter's beams and ranges one at a time: the same numbers, and
    the generator left in the same state, as the array draws it replaced (normals, uniforms,
    Poisson count, ``integers(0, n, size=k)``, ``uniform(min, max, size=k)``), for every k."""
    cfg = SensorConfig(beams=360, range_noise_std_m=0.05, dropout_probability=0.02, clutter_per_scan=clutter,
                       min_range_m=1.5, max_range_m=150.0)
    _, s = make(config=cfg)
    n = cfg.beams
    ks = set()
    for seed in range(300):
        a, b = np.random.default_rng([seed, 3]), np.random.default_rng([seed, 3])
        for _ in range(3):  # a few scans in a row: the generator's buffered 32 bits carry over
            normals, uniforms, cb, cr = np.empty(n), np.empty(n), [], []
            assert s.draw(a, normals, uniforms, cb, cr) == (True, True)
            want_n, want_u = b.standard_normal(n), b.random(n)
            k = int(b.poisson(clutter))
            want_b, want_r = b.integers(0, n, size=k), b.uniform(cfg.min_range_m, cfg.max_range_m, size=k)
            ks.add(k)
            assert normals.tobytes() == want_n.tobytes() and uniforms.tobytes() == want_u.tobytes()
            assert np.array(cb, dtype=np.int64).tobytes() == want_b.tobytes()
            assert np.array(cr, dtype=float).tobytes() == want_r.tobytes()
            assert a.bit_generator.state == b.bit_generator.state
    assert len(ks) >= 3
    assert s.draw(None, np.empty(n), np.empty(n), [], []) == (False, False)
