"""map_pass.sense_map (the sensing pass's map step in two compiled calls) against map_steps, the
step-by-step form it replaced (occupancy, sort_returns, add_points, carve_stack), bit for bit: the
targets, the per-scan counts and the whole map store after every sensing pass of a shipped
scenario and of a five-vessel world with a quay, a buoy and moving targets; a return out of the
map's range changes nothing and is left to the steps, which raise the one-line error."""

from __future__ import annotations

import copy
from dataclasses import replace

import numpy as np
import pytest

from mjasc.perception import fleet as fleet_module
from mjasc.perception.map_pass import map_steps, sense_map
from mjasc.perception.static_map import StaticMapConfig, StaticMapStore

_FIELDS = ("_keys", "_key_rows", "_n_occupied", "_version")


def _same_store(a: StaticMapStore, b: StaticMapStore) -> None:
    assert a._n == b._n
    n = a._n
    for x, y in [(getattr(a, f), getattr(b, f)) for f in _FIELDS] + [
            (a._cells[:n], b._cells[:n]), (a._member[:n], b._member[:n]), (a._score[:n], b._score[:n])]:
        assert x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes()


def _checked(calls: list):
    """A sense_map that runs map_steps on a copy of the store first and compares."""
    def wrapped(store, *args):
        ref = copy.deepcopy(store)
        want = map_steps(ref, *args)
        got = sense_map(store, *args)
        assert got is not None
        for x, y in zip(got, want):
            assert x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes()
        _same_store(store, ref)
        calls.append((store._n, int(store._n_occupied.sum()), int(got[0].sum())))
        return got
    return wrapped


def test_sense_map_equals_the_steps_on_a_shipped_scenario(monkeypatch, tmp_path):
    import mjasc
    from mjasc.runs.runner import Runner

    calls: list = []
    monkeypatch.setattr(fleet_module, "sense_map", _checked(calls))
    monkeypatch.setattr(fleet_module.PerceptionFleet, "map_in_pass", False)  # (sense_map after the compiled pass)
    sc = mjasc.load_scenario("demo").with_overrides(duration_s=60.0)
    sc = replace(sc, outputs=replace(sc.outputs, recording=False, video=False))
    Runner(sc, out_dir=None).run()
    assert len(calls) >= 250
    assert calls[-1][0] > 100 and calls[-1][1] > 20  # rows created, cells occupied
    assert sum(c[2] for c in calls) > 100  # targets kept
    assert any(b[0] == a[0] and b[1] < a[1] for a, b in zip(calls, calls[1:]))  # cells freed by carving


def _quay_world():
    from mjasc.physics.obstacles import CircleObstacle, MovingObstacle, PolygonObstacle
    from mjasc.physics.vessels import load_vessel_type
    from mjasc.physics.world import build_world

    quay = PolygonObstacle("quay", np.array([[45.0, -30.0], [80.0, -30.0], [80.0, 30.0], [75.0, 30.0],
                                             [75.0, -25.0], [45.0, -25.0]]))
    moving = [MovingObstacle(f"t{k}", 2.0 + 0.3 * k, (500.0 + 20 * k, 500.0)) for k in range(6)]
    w = build_world([(f"v{i}", load_vessel_type("otter")) for i in range(len(_POSES))],
                    [quay, CircleObstacle("buoy", (-20.0, 25.0), 1.5)], moving)
    for i, pose in enumerate(_POSES):
        w.data.qpos[w.qpos_adr[i]] = pose
    return w


_POSES = [(0.0, 0.0, 0.0), (30.0, 12.0, 0.5), (-25.0, -10.0, 2.0), (10.0, -40.0, -1.0), (-40.0, 35.0, 3.0)]


def sail_quay_fleet():
    """Five vessels (one scanning at half the rate) sensing and tracking for 30 s while six targets
    pass along the quay; the fleet and the vessels' perceptions at the end."""
    import mujoco

    from mjasc.perception.pipeline import Perception
    from mjasc.perception.range_sensor import SensorConfig

    world = _quay_world()
    shared = fleet_module.PerceptionFleet()
    ps = [Perception(world, i, SensorConfig(beams=360, rate_hz=2.5 if i == 2 else 5.0, clutter_per_scan=1.0), None,
                     np.random.default_rng([7, i]), fleet=shared) for i in range(len(_POSES))]
    d = world.data
    n = len(world.mocap_id)
    dt = 0.2
    for k in range(150):
        t = k * dt
        ang = np.arange(n) * 2 * np.pi / n + 0.02 * t
        r = 35.0 + 10.0 * np.arange(n) % 40.0
        d.mocap_pos[world.mocap_id, :2] = np.stack([r * np.cos(ang) + 3.0 * np.sin(0.05 * t), r * np.sin(ang)], -1)
        d.time = t
        mujoco.mj_kinematics(world.model, d)
        for p in ps:
            p.sense(t)
        for p in ps:
            p.update_tracks(t)
    return shared, ps


def test_sense_map_equals_the_steps_in_a_fleet_with_a_quay(monkeypatch):
    """Five vessels (one scanning at half the rate), targets passing along the quay."""
    calls: list = []
    monkeypatch.setattr(fleet_module, "sense_map", _checked(calls))
    monkeypatch.setattr(fleet_module.PerceptionFleet, "map_in_pass", False)  # (sense_map after the compiled pass)
    sail_quay_fleet()
    assert len(calls) >= 140 and calls[-1][1] > 0


def test_a_return_out_of_range_changes_nothing_and_the_steps_raise():
    store = StaticMapStore()
    for _ in range(2):
        store.add_member(StaticMapConfig())
    store.add_points(np.array([0, 1, 1]), np.array([[3.2, 4.1], [5.0, 5.0], [5.2, 5.1]]))
    ref = copy.deepcopy(store)

    class Stack:  # the stack's fields sense_map reads (no carving asked)
        origins_m = np.zeros((2, 2))
        max_range_m = np.full(2, 150.0)
        n_beams = np.array([4, 4])

    pts = np.array([[1.0, 1.0], [2.0e9, 0.0], [4.0, 4.0]])
    args = (np.array([-1, 0, 0]), np.array([0, 1, 3]), np.array([0, 0, 1]), np.array([True]), np.array([2]),
            np.array([[3.0, 2.0]]), np.array([9.0]), np.array([0.01]), pts, np.array([0.05, 0.05]), 0.15,
            np.zeros((0, 2)), np.zeros(0), np.zeros(0, dtype=np.int64), np.array([0, 1]), Stack(), False)
    assert sense_map(store, *args) is None
    _same_store(store, ref)
    with pytest.raises(ValueError, match="cell index beyond"):
        map_steps(store, *args)


def test_sense_map_equals_the_steps_with_partial_fans_and_mixed_maps():
    """Four sensors (a 90° fan, other beam counts and ranges, clutter) by a quay and a ring of buoys, maps of
    different cell sizes, thresholds and miss weights, tracked discs drawn at random, the vessels
    moving between scans: the two stores stay the same bits."""
    import math

    import mujoco

    from mjasc.perception.detection import DetectionConfig, detect_many
    from mjasc.perception.fleet import FLAT_M
    from mjasc.perception.range_sensor import SensorConfig, sensor_for_vessel
    from mjasc.perception.scan_batch import ScanBatch
    from mjasc.physics.obstacles import CircleObstacle, MovingObstacle, PolygonObstacle
    from mjasc.physics.vessels import load_vessel_type
    from mjasc.physics.world import build_world

    configs = [SensorConfig(range_noise_std_m=0.1, dropout_probability=0.2, clutter_per_scan=3.0), SensorConfig(),
               SensorConfig(beams=90, fov_deg=90.0, max_range_m=100.0, clutter_per_scan=2.0),
               SensorConfig(beams=361, range_noise_std_m=0.0, dropout_probability=0.0, clutter_per_scan=0.0,
                            min_range_m=0.0)]
    statics = [CircleObstacle(f"b{k}", (40 * math.cos(a), 40 * math.sin(a)), 6.0)
               for k, a in enumerate(np.linspace(0, 2 * math.pi, 9, endpoint=False))]
    statics.append(PolygonObstacle("quay", np.array([[-30.0, 55.0], [60.0, 55.0], [60.0, 60.0], [-30.0, 60.0]])))
    w = build_world([(f"v{i}", load_vessel_type("otter")) for i in range(4)], statics,
                    [MovingObstacle("m", 2.0, (0.0, 25.0))])
    for i, pose in enumerate([(1.0, 2.0, 0.3), (15.0, -3.0, 2.0), (-12.0, 8.0, -1.0), (3.0, -20.0, 2.5)]):
        w.data.qpos[w.qpos_adr[i]] = pose
    d = w.data
    sensors = [sensor_for_vessel(w, i, configs[i]) for i in range(4)]
    stores = [StaticMapStore(), StaticMapStore()]
    for st in stores:
        for i in range(4):
            st.add_member(StaticMapConfig(cell_m=1.0 + 0.5 * (i % 2), min_hits=1 + i % 3,
                                          miss_weight=(0.5, 1.0, 0.25, 0.5)[i]))
    batch, rng = ScanBatch(), np.random.default_rng(5)
    rngs = [np.random.default_rng(i) for i in range(4)]
    dcfg = [DetectionConfig()] * 4
    freed = 0
    for step in range(16):
        for i in range(4):
            d.qpos[w.qpos_adr[i][:2]] += (0.7, -0.4 * i)
        mujoco.mj_kinematics(w.model, d)
        who = [int(i) for i in rng.permutation(4)[:int(rng.integers(1, 5))]]
        for i in who:
            batch.add(sensors[i], d, rngs[i])
        stack = batch.take()
        S = len(who)
        sig = np.array([configs[i].range_noise_std_m for i in who])
        det = detect_many(stack.scans, dcfg[:S], sig, [configs[i].dropout_probability for i in who], stack=stack)
        n_disc = rng.integers(0, 3, S)
        d_k = np.repeat(np.arange(S), n_disc)
        dc = rng.uniform(-40.0, 40.0, (d_k.size, 2))
        dr = rng.uniform(1.0, 8.0, d_k.size)
        slot = np.array([3 - i for i in who], dtype=np.int64)
        args = (det.labels, stack.ret_off, det.det_offsets, det.extended, det.n_points, det.centres_m, det.radii_m,
                det.variances_m2, stack.hit_points_world, sig, FLAT_M, dc, dr, d_k, slot, stack, True)
        before = stores[0]._score[:stores[0]._n].copy()
        got = sense_map(stores[0], *args)
        want = map_steps(stores[1], *args)
        assert got is not None
        for x, y in zip(got, want):
            assert x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes()
        _same_store(stores[0], stores[1])
        freed += int((stores[0]._score[:before.size] < before).sum())  # cells seen through
    assert stores[0]._n > 100 and stores[0]._n_occupied.sum() > 20 and freed > 20


def test_the_carving_candidates_are_the_cells_in_reach_it_can_change(monkeypatch):
    """returns_to_map leaves out of cells_in_reach's rows those whose carving changes nothing: a
    cell with one of the tick's returns (never seen through) and a cell scored 0 (the store's
    equality with the steps, which carve every cell in reach, is checked above). Its candidates
    are the others, in cells_in_reach's order, with their geometry."""
    from mjasc.perception import map_pass
    from mjasc.perception.carve_kernels import cells_in_reach
    from mjasc.perception.cell_keys import find_rows, point_keys

    real = map_pass.returns_to_map
    seen = {"scored 0": 0, "with a return": 0, "kept": 0}

    def wrapped(*a):
        got = real(*a)
        ok, _, _, keys, key_rows, n, cand, geo, rel = got
        ret_off, points, slot, carve, origins, max_range_m, n_beams, cell_m = a[1], a[8], *a[14:20]
        cells, member, score, version = a[22], a[23], a[24], a[29]
        if ok and carve and n:
            fan = np.full(version.shape[0], -1, dtype=np.int64)
            for s in range(slot.shape[0]):
                fan[slot[s]] = s if n_beams[s] > 0 else -1
            rows, qs, rel0, r, half, far = cells_in_reach(cells[:n], member[:n], fan, cell_m, origins, max_range_m)
            pk, _ = point_keys(np.repeat(slot, np.diff(ret_off)), points, cell_m)
            now = find_rows(pk, keys, key_rows)
            held = np.isin(rows, now[now >= 0])
            live = (score[rows] > 0.0) & ~held
            assert np.array_equal(cand, np.stack([rows[live], qs[live]]))
            assert np.array_equal(geo, np.stack([r[live], half[live], far[live]])) and np.array_equal(rel, rel0[live])
            seen["scored 0"] += int((score[rows] == 0.0).sum())
            seen["with a return"] += int(held.sum())
            seen["kept"] += int(live.sum())
        return got

    monkeypatch.setattr(map_pass, "returns_to_map", wrapped)
    monkeypatch.setattr(fleet_module.PerceptionFleet, "map_in_pass", False)  # (sense_map after the compiled pass)
    sail_quay_fleet()
    assert min(seen.values()) > 100, seen
