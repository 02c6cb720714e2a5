"""Scans taken in one batch (mjasc.perception.scan_batch, the fleet's sensing slot) are the scans
of the numpy form RangeSensor.scan had (its cast and post-processing kept here as the reference),
bit for bit: several sensors with noise, dropout, clutter, partial fans and other beam counts, in
batches of changing composition and order; the stacked arrays are the scans' own; the compiled
batch kernel equals the per-scan kernels; carving from the stack equals carving from the lists."""

import math

import mujoco
import numpy as np
import pytest

from mjasc.perception.range_sensor import CLUTTER_GEOM, SensorConfig, sensor_for_vessel
from mjasc.perception.scan_batch import ScanBatch, scan_pose, scan_time
from mjasc.perception.scan_kernels import clean_hits, scan_batch, scan_points, scan_returns
from mjasc.perception.static_map import StaticMapStore, StaticMapConfig
from mjasc.physics.obstacles import CircleObstacle, MovingObstacle
from mjasc.physics.vessels import load_vessel_type
from mjasc.physics.world import build_world

CONFIGS = [SensorConfig(range_noise_std_m=0.1, dropout_probability=0.2, clutter_per_scan=3.0),
           SensorConfig(),
           SensorConfig(beams=90, fov_deg=90.0, max_range_m=100.0, clutter_per_scan=2.0),
           SensorConfig(beams=361, range_noise_std_m=0.0, dropout_probability=0.0, clutter_per_scan=0.0,
                        min_range_m=0.0)]


def _world():
    vt = load_vessel_type("otter")
    statics = [CircleObstacle(f"b{k}", (40 * math.cos(a), 40 * math.sin(a)), 6.0)
               for k, a in enumerate(np.linspace(0, 2 * math.pi, 9, endpoint=False))]
    w = build_world([(f"v{i}", vt) for i in range(4)], statics, [MovingObstacle("m", 2.0, (0.0, 25.0))])
    for i, pose in enumerate([(1.0, 2.0, 0.3), (15.0, -3.0, 2.0), (-12.0, 8.0, -1.0), (3.0, -20.0, 2.5)]):
        w.data.qpos[w.qpos_adr[i]] = pose
    mujoco.mj_forward(w.model, w.data)
    return w


def _reference_scan(s, data, rng):
    """RangeSensor.cast + scan as they were before the batch: (ranges, hit, geom ids, hit beams,
    points body, points world, origin, yaw)."""
    c = s.config
    n = c.beams
    xm = data.site_xmat[s.site_id]
    yaw = math.atan2(xm[3], xm[0])
    pnt = np.zeros(3)
    pnt[:2] = data.site_xpos[s.site_id, :2]
    origin = pnt[:2].copy()
    pnt[2] = c.ray_height_m
    a = s.angles_body + yaw
    vec = np.zeros((n, 3))
    vec[:, 0] = np.cos(a)
    vec[:, 1] = np.sin(a)
    gid, dist = np.zeros(n, dtype=np.int32), np.zeros(n)
    mujoco.mj_multiRay(s.model, data, pnt, vec.reshape(-1), s.geomgroup, 1, s.body_id, gid, dist, None, n,
                       c.max_range_m)
    dist, gid = clean_hits(dist, gid, c.max_range_m)
    normals = uniforms = np.zeros(0)
    cb, cr = np.zeros(0, dtype=np.int64), np.zeros(0)
    if rng is not None:
        if c.range_noise_std_m > 0:
            normals = rng.standard_normal(n)
        if c.dropout_probability > 0:
            uniforms = rng.random(n)
        if c.clutter_per_scan > 0:
            k = int(rng.poisson(c.clutter_per_scan))
            if k:
                cb = rng.integers(0, n, size=k)
                cr = rng.uniform(c.min_range_m, c.max_range_m, size=k)
    ranges, hit, gid, beams = scan_returns(dist, gid, c.range_noise_std_m, normals, c.dropout_probability, uniforms,
                                           cb, cr, c.min_range_m, c.max_range_m, CLUTTER_GEOM)
    ab = s.angles_body[beams]
    body, world = scan_points(ranges, beams, np.cos(ab), np.sin(ab), origin[0], origin[1], math.cos(yaw),
                              math.sin(yaw))
    return ranges, hit, gid, beams, body, world, origin, yaw


def _same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    assert a.dtype == b.dtype and a.shape == b.shape
    assert a.tobytes() == b.tobytes()


def test_batched_scans_equal_the_numpy_form_each_alone():
    w = _world()
    d = w.data
    sensors = [sensor_for_vessel(w, i, CONFIGS[i]) for i in range(4)]
    twins = [sensor_for_vessel(w, i, CONFIGS[i]) for i in range(4)]
    batch = ScanBatch()
    order_rng = np.random.default_rng(3)
    rngs = [np.random.default_rng([5, i]) for i in range(4)]
    ref_rngs = [np.random.default_rng([5, i]) for i in range(4)]
    for step in range(40):
        d.mocap_pos[w.mocap_id[0], :2] = (10.0 * math.cos(0.2 * step), 25.0 - 0.5 * step)
        for i in range(4):
            d.qpos[w.qpos_adr[i][2]] += 0.11 * (i + 1)
        d.time = 0.2 * step
        mujoco.mj_kinematics(w.model, d)
        who = [int(i) for i in order_rng.permutation(4)[:int(order_rng.integers(1, 5))]]
        noisy = [step % 7 != 3 for _ in who]
        refs = [_reference_scan(twins[i], d, ref_rngs[i] if z else None) for i, z in zip(who, noisy)]
        for i, z in zip(who, noisy):
            batch.add(sensors[i], d, rngs[i] if z else None)
        stack = batch.take()
        assert len(stack.scans) == len(who) and len(batch) == 0
        for scan, ref, i in zip(stack.scans, refs, who):
            assert scan_time(scan) == scan_pose(scan)[0] == d.time  # (read before the scan's fields are made)
            ranges, hit, gid, beams, body, world, origin, yaw = ref
            for got, want in [(scan.ranges, ranges), (scan.hit, hit), (scan.geom_ids, gid), (scan.hit_beams, beams),
                              (scan.hit_points_body, body), (scan.hit_points_world, world), (scan.origin_m, origin)]:
                _same(got, want)
            assert scan.heading_rad == yaw and scan.time_s == d.time == scan_time(scan)
            assert scan.angles_body is sensors[i].angles_body
            assert scan.max_range_m == CONFIGS[i].max_range_m and scan.full_circle == CONFIGS[i].full_circle
            assert scan.beam_spacing_rad == CONFIGS[i].beam_spacing_rad
        cat = np.concatenate
        _same(stack.ranges_m, cat([s.ranges for s in stack.scans]))
        _same(stack.hit, cat([s.hit for s in stack.scans]))
        _same(stack.hit_beams, cat([s.hit_beams for s in stack.scans]))
        _same(stack.hit_points_world, cat([s.hit_points_world for s in stack.scans]))
        _same(stack.hit_ranges_m, cat([s.ranges[s.hit_beams] for s in stack.scans]))
        _same(stack.origins_m, np.array([s.origin_m for s in stack.scans]))
        _same(stack.cos_heading, np.array([math.cos(s.heading_rad) for s in stack.scans]))
        _same(stack.ret_off, np.cumsum([0] + [s.hit_beams.size for s in stack.scans]))
        _same(stack.beam_off, np.cumsum([0] + [s.ranges.size for s in stack.scans]))
        _same(stack.times_s, np.array([s.time_s for s in stack.scans], dtype=float))
        _same(stack.headings_rad, np.array([s.heading_rad for s in stack.scans], dtype=float))
    # RangeSensor.scan on its own is a batch of one: the same scans
    for i in range(4):
        got = sensors[i].scan(d, rngs[i])
        want = _reference_scan(twins[i], d, ref_rngs[i])
        _same(got.ranges, want[0])
        _same(got.hit_points_world, want[5])


def test_a_batch_that_grows_while_casting_keeps_every_scan():
    """The buffers grow at the third cast of a batch (720 + 720 + 720 beams > 1024): the earlier
    casts' rows and every later batch's scans stay those of the numpy form."""
    w = _world()
    d = w.data
    cfg = SensorConfig()
    sensors = [sensor_for_vessel(w, i, cfg) for i in range(3)]
    twins = [sensor_for_vessel(w, i, cfg) for i in range(3)]
    rngs = [np.random.default_rng([9, i]) for i in range(3)]
    ref_rngs = [np.random.default_rng([9, i]) for i in range(3)]
    batch = ScanBatch()
    for step in range(3):
        d.time = 0.2 * step
        refs = [_reference_scan(twins[i], d, ref_rngs[i]) for i in range(3)]
        for i in range(3):
            batch.add(sensors[i], d, rngs[i])
        stack = batch.take()
        for scan, ref in zip(stack.scans, refs):
            for got, want in [(scan.ranges, ref[0]), (scan.hit, ref[1]), (scan.geom_ids, ref[2]),
                              (scan.hit_beams, ref[3]), (scan.hit_points_world, ref[5])]:
                _same(got, want)


@pytest.mark.parametrize("seed", range(12))
def test_scan_batch_kernel_equals_the_per_scan_kernels(seed):
    rng = np.random.default_rng(seed)
    S = int(rng.integers(1, 6))
    parts = []
    for _ in range(S):
        n = int(rng.choice([1, 7, 90, 360]))
        max_r, min_r = float(rng.choice([100.0, 150.0])), float(rng.choice([0.0, 1.0]))
        dist = rng.uniform(-0.5, 1.2 * max_r, n)
        gid = rng.integers(-1, 9, n).astype(np.int32)
        dist[gid < 0] = -1.0
        dist[rng.random(n) < 0.03] = np.nan
        z = rng.standard_normal(n) if rng.random() < 0.7 else None
        u = rng.random(n) if rng.random() < 0.7 else None
        k = int(rng.integers(0, 5))
        cb, cr = rng.integers(0, n, size=k), rng.uniform(min_r, max_r, size=k)
        ang = -math.pi + (np.arange(n) + 0.5) * 2.0 * math.pi / n
        parts.append((dist, gid, float(rng.choice([0.0, 0.05])), z, float(rng.choice([0.0, 0.3])), u, cb, cr, min_r,
                      max_r, ang, rng.uniform(-1e3, 1e3, 2), float(rng.uniform(-4, 4))))
    tail = int(rng.choice([0, 3, 400]))  # the per-beam inputs may run on past the casts (a batch's buffers)

    def cat(arrays, per_beam=False):
        a = np.concatenate(arrays)
        return np.concatenate([a, rng.uniform(-9.0, 9.0, tail).astype(a.dtype)]) if per_beam else a

    beam_off = np.cumsum([0] + [p[0].size for p in parts])
    c_off = np.cumsum([0] + [p[6].size for p in parts])
    cos_h, sin_h = np.full(S, np.nan), np.full(S, np.nan)  # (written: the headings' cosines and sines)
    got = scan_batch(cat([p[0] for p in parts], True), cat([p[1] for p in parts], True), beam_off,
                     np.array([p[2] for p in parts]), cat([p[0] * 0 if p[3] is None else p[3] for p in parts], True),
                     np.array([p[3] is not None for p in parts]), np.array([p[4] for p in parts]),
                     cat([p[0] * 0 if p[5] is None else p[5] for p in parts], True),
                     np.array([p[5] is not None for p in parts]),
                     cat([p[6] for p in parts]), cat([p[7] for p in parts]), c_off, np.array([p[8] for p in parts]),
                     np.array([p[9] for p in parts]), CLUTTER_GEOM, cat([np.cos(p[10]) for p in parts], True),
                     cat([np.sin(p[10]) for p in parts], True), np.array([p[11] for p in parts]),
                     np.array([p[12] for p in parts]), cos_h, sin_h)
    want = [[] for _ in range(7)]
    none = np.zeros(0)
    for dist, gid, std, z, p, u, cb, cr, min_r, max_r, ang, o, yaw in parts:
        d, g = clean_hits(dist, gid, max_r)
        r, h, gg, bm = scan_returns(d, g, std, none if z is None else z, p, none if u is None else u, cb, cr, min_r,
                                    max_r, CLUTTER_GEOM)
        body, world = scan_points(r, bm, np.cos(ang[bm]), np.sin(ang[bm]), o[0], o[1], math.cos(yaw), math.sin(yaw))
        for lst, x in zip(want, (r, h, gg, bm, r[bm], body, world)):
            lst.append(x)
    floats, points, hit, geom, ints, k = got
    N = beam_off[-1]
    ranges, rho, body, world, beams, ret_off = floats[:N], floats[N:N + k], points[:k], points[N:N + k], ints[:k], \
        ints[N:]
    _same(cos_h, np.array([math.cos(p[12]) for p in parts]))  # (math's, the C library's, in the kernel too)
    _same(sin_h, np.array([math.sin(p[12]) for p in parts]))
    for a, b in zip((ranges, hit, geom, beams, rho, body, world), want):
        _same(a, cat(b))
    _same(ret_off, np.cumsum([0] + [b.size for b in want[3]]))


def test_carving_from_the_stack_equals_carving_from_the_lists():
    w = _world()
    d = w.data
    sensors = [sensor_for_vessel(w, i, CONFIGS[i]) for i in range(4)]
    stores = [StaticMapStore(), StaticMapStore()]
    for st in stores:
        for i in range(4):
            st.add_member(StaticMapConfig(cell_m=1.0 + 0.5 * (i % 2)))
    batch = ScanBatch()
    rngs = [np.random.default_rng(i) for i in range(4)]
    freed = 0
    for step in range(12):
        for i in range(4):
            d.qpos[w.qpos_adr[i][:2]] += (0.7, -0.4 * i)
        mujoco.mj_kinematics(w.model, d)
        for i in range(4):
            batch.add(sensors[i], d, rngs[i])
        stack = batch.take()
        members = np.array([3, 1, 0, 2])
        sig = [0.05, 0.0, 0.1, 0.02]
        for st in stores:  # static returns of this scan (the walls of the map), then the free space
            st.add_points(np.repeat(members, np.diff(stack.ret_off)), stack.hit_points_world)
        sc = stack.scans
        a = stores[0].carve(members.tolist(), [s.origin_m for s in sc], [s.angles_body + s.heading_rad for s in sc],
                            [s.ranges for s in sc], [s.hit for s in sc], [s.max_range_m for s in sc],
                            [s.full_circle for s in sc], sig, [s.hit_points_world for s in sc])
        b = stores[1].carve_stack(members, stack, sig)
        _same(a, b)
        freed += int(b.sum())
        n = stores[0]._n
        _same(stores[0]._score[:n], stores[1]._score[:n])
        _same(stores[0]._cells[:n], stores[1]._cells[:n])
    assert stores[0]._n > 100 and freed > 20


def test_scan_batch_heading_cosines_are_maths():
    """The kernel's cosine and sine of each cast's heading are Python's ``math.cos`` / ``math.sin``
    bit for bit (what ScanBatch.add took before, per cast), over many headings."""
    rng = np.random.default_rng(5)
    S = 4000
    headings = np.concatenate([rng.uniform(-math.pi, math.pi, S - 6), [0.0, -0.0, math.pi, -math.pi, 1e-300, 3.1]])
    beam_off = np.arange(S + 1, dtype=np.int64)
    ones, zeros = np.ones(S), np.zeros(S)
    cos_h, sin_h = np.empty(S), np.empty(S)
    scan_batch(np.full(S, 5.0), np.zeros(S, dtype=np.int32), beam_off, zeros, zeros, np.zeros(S, dtype=bool), zeros,
               zeros, np.zeros(S, dtype=bool), np.zeros(0, dtype=np.int64), np.zeros(0), np.zeros(S + 1, dtype=np.int64),
               zeros, 100.0 * ones, CLUTTER_GEOM, ones, zeros, np.zeros((S, 2)), headings, cos_h, sin_h)
    _same(cos_h, np.array([math.cos(h) for h in headings.tolist()]))
    _same(sin_h, np.array([math.sin(h) for h in headings.tolist()]))
