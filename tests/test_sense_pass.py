"""The sensing pass in one compiled call (mjasc.perception.sense_pass: scans, detections and the
map step up to the carving's bearings) against its reference form, the map step after the call in
Python (tracked_in_walls, sense_map; ``PerceptionFleet.map_in_pass = False``), bit for bit: every
vessel's scan, detections, targets and counts after every sensing pass, and the whole map store, on
a shipped scenario and in a five-vessel world with a quay, a buoy and moving targets (walls whose
clusters swallow tracked boats' returns)."""

from __future__ import annotations

from dataclasses import replace


from mjasc.perception import fleet as fleet_module
from mjasc.perception import pipeline as pipeline_module
from mjasc.perception import sense_pass
from tests.test_map_pass import sail_quay_fleet

_SCAN = ("origin_m", "ranges", "hit", "hit_beams", "hit_points_body", "hit_points_world", "geom_ids")
_DET = ("centres_m", "centres_body", "radii_m", "variances_m2", "n_points", "ranges_m", "extended", "labels",
        "occluded")


def _record(monkeypatch, map_in_pass: bool):
    """Patch the fleet for one form; returns the list every scanned vessel's results go to and
    the statuses of the compiled calls."""
    seen: list = []
    statuses: list = []
    scanned = pipeline_module.Perception._scanned
    call = fleet_module.scan_detect_map

    def recording(self, scan, det, targets, counts):
        seen.append((scan.time_s, scan.heading_rad, tuple(getattr(scan, f).tobytes() for f in _SCAN),
                     tuple(getattr(det, f).tobytes() for f in _DET), targets.tobytes(), tuple(counts)))
        return scanned(self, scan, det, targets, counts)

    def counting(*args):
        out = call(*args)
        statuses.append(out[0])
        return out

    monkeypatch.setattr(pipeline_module.Perception, "_scanned", recording)
    monkeypatch.setattr(fleet_module, "scan_detect_map", counting)
    monkeypatch.setattr(fleet_module.PerceptionFleet, "map_in_pass", map_in_pass)
    return seen, statuses


def _store_bytes(store) -> tuple:
    n = store._n
    return (n, store._keys.tobytes(), store._key_rows.tobytes(), store._cells[:n].tobytes(),
            store._member[:n].tobytes(), store._score[:n].tobytes(), store._n_occupied.tobytes(),
            store._version.tobytes())


def test_the_compiled_pass_equals_the_reference_on_a_shipped_scenario(monkeypatch):
    import mjasc
    from mjasc.runs.runner import Runner

    sc = mjasc.load_scenario("demo").with_overrides(duration_s=60.0)
    sc = replace(sc, outputs=replace(sc.outputs, recording=False, video=False))
    got = []
    swallowed: list = []  # the reference form's scans whose wall clusters hold a tracked return
    walls = fleet_module.tracked_in_walls

    def counting_walls(*args):
        out = walls(*args)
        swallowed.append(int(out.sum()))
        return out

    for map_in_pass in (True, False):
        with monkeypatch.context() as m:
            seen, statuses = _record(m, map_in_pass)
            m.setattr(fleet_module, "tracked_in_walls", counting_walls)
            runner = Runner(sc, out_dir=None)
            runner.run()
            got.append((seen, statuses))
    (a, sa), (b, sb) = got
    assert len(a) == len(b) > 600
    assert a == b
    # (the demo's swallowed returns all lie on mapped cells: the compiled pass keeps them the wall's
    # without stopping, sense_pass.walls_mapped; the quay fleet below stops it)
    assert sense_pass.MAPPED in set(sa) and set(sb) == {sense_pass.DETECTED} and sum(swallowed) > 0


def test_the_compiled_pass_equals_the_reference_in_a_fleet_with_a_quay(monkeypatch):
    """Five vessels (one scanning at half the rate), targets passing along the quay: both
    statuses of the compiled call (mapped, and a wall's cluster holding a tracked return) occur."""


    got = []
    for map_in_pass in (True, False):
        with monkeypatch.context() as m:
            seen, statuses = _record(m, map_in_pass)
            shared, ps = sail_quay_fleet()
            got.append((seen, statuses, _store_bytes(shared.map_store),
                        [(len(p.tracks()), p.map.version) for p in ps]))
    a, b = got
    assert len(a[0]) == len(b[0]) > 600
    assert a[0] == b[0]
    assert a[2] == b[2] and a[3] == b[3]
    assert {sense_pass.MAPPED, sense_pass.SWALLOWED} <= set(a[1])
