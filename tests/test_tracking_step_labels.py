"""``FleetTracker.step(..., labels=...)`` — every vessel's returns' labels as the sensing pass has them
(the pass's detections not made only for the outlines to read their labels) — gives the same tracks,
outlines, events and counts, bit for bit, as reading each vessel's ``detections.labels`` (the world of
tests/test_fleet_perception.py: five vessels, two tracking configurations, one vessel scanning at half
the rate, clutter, a quay and a buoy: slow tracks with outlines)."""

import numpy as np

from mjasc.perception.fleet import PerceptionFleet
from mjasc.perception.tracking.fleet import FleetTracker
from tests.test_fleet_perception import _perceptions, _world, sail_compared


def test_pass_labels_give_the_same_tracks(monkeypatch):
    step = FleetTracker.step
    with_labels, plain = PerceptionFleet(), PerceptionFleet()
    given = []

    def labelled(self, owners, t_s, detections, origins=None, use=None, points=None, stacked=None, labels=None):
        if not any(ft is self for ft in with_labels._trackers):
            labels = None  # (the reference: each vessel's detections' labels, whatever the caller hands on)
        else:
            if labels is None and points is not None:  # (a caller without the pass's labels: made here)
                dets = list(detections)
                lab = [np.zeros(0, dtype=np.int64) if d is None else np.asarray(d.labels, dtype=np.int64)
                       for d in dets]
                off = np.zeros(len(lab) + 1, dtype=np.int64)
                np.cumsum([x.size for x in lab], out=off[1:])
                pad = np.full(3, -7, dtype=np.int64)  # (offsets into a larger array: only each vessel's span read)
                labels = (np.concatenate([pad] + lab), (off + 3).tolist())
                detections = dets
            given.append(labels is not None)
        return step(self, owners, t_s, detections, origins, use, points, stacked, labels)

    monkeypatch.setattr(FleetTracker, "step", labelled)
    world = _world()
    a_ps = _perceptions(world, lambda: with_labels)
    b_ps = _perceptions(world, lambda: plain)
    for _ in sail_compared(world, a_ps, b_ps, 30.0):
        for a, b in zip(a_ps, b_ps):
            assert a.tracker.counts == b.tracker.counts
    assert given and all(given)  # (every tracking step of the labelled fleet had labels)
    hulls = [h for ft in with_labels._trackers for h in ft.cols.hull.tolist() if h is not None]
    assert hulls  # (the outlines read the labels given)
    ref = [h for ft in plain._trackers for h in ft.cols.hull.tolist() if h is not None]
    assert len(hulls) == len(ref) and all(np.array_equal(x, y) for x, y in zip(hulls, ref))
