"""TrackManagement.drops_every (one compiled call, three arrays) against drops_all and the step's
readable selection of the lost tracks (``drop`` rows confirmed with a reason, in row order), bit for
bit and string for string, on every step of real runs (the crossing and the demo's first seconds:
clutter dropped nearly every step, tracks lost and merged; the fleet's drops read through drops_every
on every step, not its one call with the compactions: tests/test_fleet_rows.py)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import mjasc
from mjasc.perception.tracking.fleet_rows import FleetRows
from mjasc.perception.tracking.management import TrackManagement
from mjasc.runs.runner import Runner

_ROOT = __import__("pathlib").Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("name, duration", [("thesis_6_4_crossing", 60.0), ("demo", 30.0)])
def test_drops_every_equals_drops_all(monkeypatch, name, duration):
    orig = TrackManagement.drops_every
    seen = {"steps": 0, "dropped": 0}

    def checked(self, group, pos_of, t_o, states, covs, org, max_range):
        conf = self.cols.confirmed.copy()
        want_drop, reason, want_merged = self.drops_all(group, pos_of, t_o, states, covs, org, max_range)
        want_lost = [(j, reason[j]) for j in want_drop.nonzero()[0].tolist() if conf[j] and reason[j]]
        drop, n_drop, lost, merged = orig(self, group, pos_of, t_o, states, covs, org, max_range)
        assert drop.dtype == want_drop.dtype and drop.tobytes() == want_drop.tobytes()
        assert n_drop == np.count_nonzero(want_drop)
        assert list(lost) == want_lost and list(merged) == want_merged
        seen["steps"] += 1
        seen["dropped"] += n_drop
        return drop, n_drop, lost, merged

    monkeypatch.setattr(TrackManagement, "drops_every", checked)
    monkeypatch.setattr(FleetRows, "_drops_in_one_call", False)  # (every step's drops through drops_every)
    sc = mjasc.load_scenario(_ROOT / "tasks" / f"{name}.toml").with_overrides(duration_s=duration)
    sc = replace(sc, outputs=replace(sc.outputs, recording=False, video=False))
    Runner(sc, out_dir=None).run()
    assert seen["steps"] > 50 and seen["dropped"] > 10
