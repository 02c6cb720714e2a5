"""A fleet tracker's report columns through the compiled gather
(:func:`mjasc.perception.tracking.report_fields.report_fields`) against the readable form
(``FleetTracker._report_columns_numpy``: confirmed_by_owner, the bank's estimate_fields, numpy's
indexing and ``tolist``), bit for bit, after every step of a real run (the 3-vessel crossing scene and
the demo's first seconds: births, drops, confirmations, static and slow tracks)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import mjasc
from mjasc.core.estimates import TrackRows
from mjasc.perception.tracking import fleet as fleet_mod
from mjasc.runs.runner import Runner

_ROOT = __import__("pathlib").Path(__file__).resolve().parents[1]


def _same(a, b):
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        assert a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()
        return
    assert type(a) is type(b)
    if isinstance(a, (list, tuple)):
        assert len(a) == len(b)
        for x, y in zip(a, b):
            _same(x, y)
    elif isinstance(a, float):
        assert np.float64(a).tobytes() == np.float64(b).tobytes()
    else:
        assert a == b


@pytest.mark.parametrize("name, duration", [("thesis_6_4_crossing", 30.0), ("demo", 25.0)])
def test_report_columns_equal_the_readable_form_on_a_real_run(monkeypatch, name, duration):
    orig = fleet_mod.FleetTracker.step
    n_checked = [0]

    def checked(self, *args, **kwargs):
        orig(self, *args, **kwargs)
        got, want = self._report_columns(), self._report_columns_numpy()
        assert len(got) == len(want)
        if len(got) == 1:
            assert got == want == ({},)
            return
        assert got[0] == want[0]
        for a, b in zip(got[1:], want[1:]):
            _same(a, b)
        n_checked[0] += 1

    monkeypatch.setattr(fleet_mod.FleetTracker, "step", checked)
    sc = mjasc.load_scenario(_ROOT / "tasks" / f"{name}.toml").with_overrides(duration_s=duration)
    sc = replace(sc, outputs=replace(sc.outputs, recording=False, video=False))
    Runner(sc, out_dir=None).run()
    assert n_checked[0] > 50


def test_track_rows_of_columns_equal_the_constructor():
    cols = ([3, 5], [1.0, 2.0], np.ones((2, 2)), [0.1, 0.2], [1.0, 0.0], [0.0, 0.0], [2.0, 1.0],
            np.zeros((2, 2, 2)), [False, True], [None, "b"], [None, None], (None, None))
    a, b = TrackRows(cols), TrackRows.of_columns(tuple(cols))
    assert a.track_ids is b.track_ids and a.times_s is b.times_s and a.positions_m is b.positions_m
    assert len(a) == len(b) == 2
    for x, y in zip(a, b):
        assert x.track_id == y.track_id and x.time_s == y.time_s and x.team_member == y.team_member
        _same(x.position_m, y.position_m)
