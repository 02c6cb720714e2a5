"""A sensing pass's per-vessel Scan and Detections are made on first read (mjasc.perception.pass_views,
detection.PassDetections): the same dataclasses with the same fields (views of the pass's arrays)
as the objects made at once, whichever field is read first; replace, equality, copies and pickles
work; the fleet's tracking pass reads the pass's arrays, not their fields."""

import copy
import dataclasses
import pickle

import numpy as np

from mjasc.perception.detection import DetectionConfig, Detections, PassDetections, centres_body, detect_many
from mjasc.perception.pass_views import PassScan
from mjasc.perception.range_sensor import Scan, sensor_for_vessel
from mjasc.perception.scan_batch import ScanBatch
from tests.test_scan_batch import CONFIGS, _world


def _pass():
    w = _world()
    sensors = [sensor_for_vessel(w, i, c) for i, c in enumerate(CONFIGS)]
    batch = ScanBatch()
    for k, s in enumerate(sensors):
        batch.add(s, w.data, np.random.default_rng(k))
    stack = batch.take()
    unread = [set(vars(scan)) for scan in stack.scans]
    dets = detect_many(stack.scans, [DetectionConfig()] * len(sensors), [c.range_noise_std_m for c in CONFIGS],
                       [c.dropout_probability for c in CONFIGS], stack=stack)
    return stack, dets, unread


def _fields(obj) -> dict:
    return {f.name: getattr(obj, f.name) for f in dataclasses.fields(obj)}


def _same(a: dict, b: dict) -> None:
    assert a.keys() == b.keys()
    for k in a:
        x, y = a[k], b[k]
        if isinstance(x, np.ndarray):
            assert x.dtype == y.dtype and x.shape == y.shape and np.array_equal(x, y)
        else:
            assert x == y


def test_fields_are_made_on_first_read_and_equal_the_eager_ones():
    stack, batch, unread = _pass()
    assert unread == [{"_src"}] * len(stack.scans)  # (nothing made before a read)
    for k, scan in enumerate(stack.scans):
        assert type(scan) is PassScan and isinstance(scan, Scan)
        first = scan.hit_points_world  # any field makes them all
        assert "_src" not in vars(scan) and first is scan.hit_points_world
        a, b = stack.ret_off[k], stack.ret_off[k + 1]
        assert np.shares_memory(first, stack.hit_points_world) and np.array_equal(first, stack.hit_points_world[a:b])
        eager = Scan(**_fields(scan))
        _same(_fields(scan), _fields(eager))
    stack, batch, _ = _pass()  # (scans not read yet)
    dets = batch.split()
    for k, det in enumerate(dets):
        assert type(det) is PassDetections and isinstance(det, Detections) and set(vars(det)) == {"_src"}
        unmade = centres_body(det)  # (read without making the fields: what the recording draws)
        assert set(vars(det)) == {"_src"}
        occ = det.occluded  # (the field with a class default: made like the others)
        assert unmade.tobytes() == det.centres_body.tobytes() and unmade.shape == det.centres_body.shape
        assert centres_body(det) is det.centres_body  # (made: the field itself)
        a, b = batch.det_offsets[k], batch.det_offsets[k + 1]
        assert np.array_equal(occ, batch.occluded[a:b]) and len(det) == b - a
        _same(_fields(det), _fields(Detections(**_fields(det))))
        sc = stack.scans[k]  # (made before the scan: what the detections carry of it is the scan's)
        assert det.time_s == sc.time_s and det.heading_rad == sc.heading_rad
        assert np.array_equal(det.origin_m, sc.origin_m)


def test_replace_equality_copies_and_pickles():
    stack, batch, _ = _pass()
    det = batch.split()[0]
    fresh = batch.split()[0]
    changed = dataclasses.replace(det, labels=det.labels + 1)  # (made through __init__: the property's setter)
    assert type(changed) is PassDetections and np.array_equal(changed.labels, det.labels + 1)
    assert changed.occluded is det.occluded
    for other in (copy.copy(fresh), copy.deepcopy(batch.split()[0]), pickle.loads(pickle.dumps(batch.split()[0]))):
        _same(_fields(other), _fields(det))
    scan = pickle.loads(pickle.dumps(stack.scans[1]))
    _same(_fields(scan), _fields(stack.scans[1]))
    try:
        det.labels = None
    except dataclasses.FrozenInstanceError:
        pass
    else:
        raise AssertionError("a PassDetections must stay frozen")
    try:
        stack.scans[0].no_such_field
    except AttributeError:
        pass
    else:
        raise AssertionError("an unknown attribute must raise AttributeError")


def test_the_fleet_tracking_pass_makes_no_fields(monkeypatch):
    """What the tracking pass hands the fleet tracker comes from the sensing pass's arrays: no
    vessel's scan or detections made on the way (the tracker itself reads a detection's labels
    for the outlines of slow tracks unless the pass's labels are given, ``labels=``). A pass stacked
    again, after a wall swallowed a tracked boat's returns, has read every vessel's detections on the
    way (the split's and the views' fields); the tracker still reads none of them."""
    import mujoco

    from mjasc.perception.fleet import PerceptionFleet
    from mjasc.perception.tracking.fleet import FleetTracker
    from tests.test_fleet_perception import DT, _perceptions, _targets, _world

    import mjasc.perception.fleet as fleet_module

    seen = []
    step = FleetTracker.step
    tick, split_ticks = [0], set()  # the sail's tick; the ticks whose pass a split stacked again
    split = fleet_module.split_in_pass

    def splitting(k, det, *args):
        got = split(k, det, *args)
        if got is not det:
            split_ticks.add(tick[0])
        return got

    def lazy(d):
        return "_src" in vars(d) and "_src" in vars(d.__dict__["_src"][1][1].scans[d.__dict__["_src"][1][0]])

    def checking(self, owners, t_s, dets, origins, use, points, stacked, labels=None):
        dets = list(dets)
        if stacked is not None and tick[0] not in split_ticks:  # (stacking again read every vessel's detections)
            seen.append(all(lazy(d) for d in dets))
        views = [d for d in dets if "_src" in vars(d)]
        out = step(self, owners, t_s, dets, origins, use, points, stacked, labels)
        if labels is not None:  # (the pass's labels given: the tracker's outlines make no detections either)
            assert all("_src" in vars(d) for d in views)
        return out

    monkeypatch.setattr(FleetTracker, "step", checking)
    monkeypatch.setattr(fleet_module, "split_in_pass", splitting)
    world = _world()
    fleet = PerceptionFleet()
    ps = _perceptions(world, lambda: fleet)
    d = world.data
    n = len(world.mocap_id)
    for k in range(int(6 / DT)):
        tick[0] = k
        d.mocap_pos[world.mocap_id, :2] = _targets(k, n)
        d.time = k * DT
        mujoco.mj_kinematics(world.model, d)
        for p in ps:
            p.sense(k * DT)
        for p in ps:
            p.update_tracks(k * DT)
    assert len(seen) >= 30 and all(seen)
    assert sum(len(p.tracks()) for p in ps) > 0
