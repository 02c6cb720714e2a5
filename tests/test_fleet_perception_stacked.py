"""The tracking pass takes the sensing pass's detection batch as it is (``FleetTracker.step(...,
stacked=...)``, no stacking of each vessel's detections again): the same tracks, events and
counts, bit for bit, as the reference form that stacks every vessel's ``Detections`` again (the
world of tests/test_fleet_perception.py: five vessels, two tracking configurations, one vessel
scanning at half the rate, clutter)."""


from mjasc.perception.fleet import PerceptionFleet
from mjasc.perception.tracking.fleet import FleetTracker
from tests.test_fleet_perception import _perceptions, _world, sail_compared


class _Restacking(PerceptionFleet):
    """The reference: every tracking step stacks the vessels' detections itself."""

    def _sense(self, members, stack):
        super()._sense(members, stack)
        self._sensed = None


def test_stacked_batch_equals_restacked_detections(monkeypatch):
    taken = []
    step = FleetTracker.step

    def counting(self, *args, **kw):
        taken.append(len(args) > 6 and args[6] is not None)
        return step(self, *args, **kw)

    monkeypatch.setattr(FleetTracker, "step", counting)
    world = _world()
    fast, slow = PerceptionFleet(), _Restacking()
    a_ps = _perceptions(world, lambda: fast)
    b_ps = _perceptions(world, lambda: slow)
    for _ in sail_compared(world, a_ps, b_ps, 30.0):
        for a, b in zip(a_ps, b_ps):
            assert a.tracker.counts == b.tracker.counts
            ft = a.tracker.fleet  # (the counts of rows per vessel, kept per change of rows: n_rows)
            assert ft.n_rows(a.tracker.owner) == ft.rows_of(a.tracker.owner).size == len(a.tracker)
    assert sum(len(p.tracks()) for p in a_ps) >= 10
    assert any(taken) and not all(taken)  # (the fast path taken, and the reference's steps restacked)
