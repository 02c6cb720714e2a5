"""The tracker's reports hand on slow tracks' outlines as Pending values made on first read
(:meth:`mjasc.perception.tracking.outlines.TrackOutlines.pending`): on the demo's real scans, at
every step, they equal the outlines made at once (the readable form), bit for bit — also when
read only after later steps."""

from __future__ import annotations

from dataclasses import replace

import mjasc
from mjasc.core.estimates import Pending
from mjasc.perception.tracking.fleet import FleetTracker
from mjasc.runs.runner import Runner


def _fields(ests):
    return [(e.track_id, e.time_s, e.position_m.tobytes(), e.heading_rad, e.speed_m_s, e.turn_rate_rad_s,
             e.radius_m, e.position_covariance.tobytes(), e.is_static, e.team_member,
             None if e.outline_m is None else e.outline_m.tobytes(), e.source) for e in ests]


def test_pending_outlines_equal_the_outlines_made_at_once_on_the_demo(monkeypatch):
    seen = {"pending": 0, "steps": 0}
    late = []  # (estimates not read yet, the readable form's fields) read after later steps
    step = FleetTracker.step

    def checked_step(self, *args, **kwargs):
        step(self, *args, **kwargs)
        seen["steps"] += 1
        for o in range(self.n_owners):
            rows = self.rows_of(o)
            readable = _fields(self._estimates_of(rows[self.mgmt._confirmed[rows]]))
            lazy = self.estimates(o)
            seen["pending"] += sum(type(e.__dict__["outline_m"]) is Pending for e in lazy)
            if seen["steps"] % 7 == 0:
                late.append((lazy, readable))
            else:
                assert _fields(lazy) == readable

    monkeypatch.setattr(FleetTracker, "step", checked_step)
    sc = mjasc.load_scenario("tasks/demo.toml").with_overrides(duration_s=30.0)
    sc = replace(sc, outputs=replace(sc.outputs, recording=False, video=False))
    Runner(sc, out_dir=None).run()
    assert seen["steps"] > 100 and seen["pending"] > 50 and late
    for lazy, readable in late:
        assert _fields(lazy) == readable
