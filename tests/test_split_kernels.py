"""split_kernels.split_pass_scan (through tracked_returns.split_in_pass) against split_tracked, the
numpy form it replaces in the sensing pass, bit for bit: on every scan of a shipped scenario whose
wall clusters swallowed a tracked boat's returns."""

from __future__ import annotations

import dataclasses

import numpy as np

import mjasc
import mjasc.perception.fleet as fleet_module
from mjasc.perception.detection import Detections
from mjasc.runs.runner import Runner


def _same(got: Detections, want: Detections) -> None:
    assert (got is None) == (want is None)
    for f in dataclasses.fields(Detections):
        a, b = getattr(got, f.name), getattr(want, f.name)
        if isinstance(b, np.ndarray):
            assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes(), f.name
        else:
            assert a == b or (a is None and b is None), f.name


def test_split_in_pass_matches_split_tracked(monkeypatch):
    compiled = fleet_module.split_in_pass
    seen = {"split": 0, "same": 0}

    def both(k, det, batch, stack, discs, a, b, constants, tables, map_member, fallback):
        got = compiled(k, det, batch, stack, discs, a, b, constants, tables, map_member, fallback)
        want = fallback()
        if want is det:
            assert got is det
            seen["same"] += 1
        else:
            _same(got, want)
            seen["split"] += 1
        return got

    monkeypatch.setattr(fleet_module, "split_in_pass", both)
    sc = mjasc.load_scenario("tasks/thesis_6_4_bottleneck.toml").with_overrides(duration_s=90.0)
    sc = dataclasses.replace(sc, outputs=dataclasses.replace(sc.outputs, recording=False, video=False))
    Runner(sc, out_dir=None).run()
    assert seen["split"] > 10 and seen["same"] > 0, seen
