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

    _run_with(monkeypatch, checked, name, duration)
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


def _per_vessel_slices(ft, cols: tuple) -> dict:
    """The report's rows as they were made before :meth:`TrackRows.of_span`: every field's slice per
    vessel, then :meth:`TrackRows.of_columns` (the reference)."""
    if len(cols) == 1:
        return {}
    spans, k_rows, ids, t, pos, th, v, w, radius, radius_l, P, static, team, slow, id_array, time_array = cols
    outlines = ft.outlines.pendings(k_rows, slow, pos, radius)
    return {o: TrackRows.of_columns((ids[a:b], t[a:b], pos[a:b], th[a:b], v[a:b], w[a:b], radius_l[a:b], P[a:b],
                                     static[a:b], team[a:b], outlines[a:b], (None,) * (b - a)), id_array[a:b],
                                    time_array[a:b])
            for o, (a, b) in spans.items()}


def _same_rows(got: TrackRows, want: TrackRows) -> None:
    for name in ("track_ids", "times_s", "positions_m", "id_array", "time_array"):
        _same(getattr(got, name), getattr(want, name))
    assert len(got) == len(want)
    for x, y in zip(got, want):  # every field of every estimate, an outline made on read
        for f in ("track_id", "time_s", "position_m", "heading_rad", "speed_m_s", "turn_rate_rad_s", "radius_m",
                  "position_covariance", "is_static", "team_member", "outline_m", "source"):
            _same(getattr(x, f), getattr(y, f))


@pytest.mark.parametrize("name, duration", [("thesis_6_4_crossing", 30.0), ("demo", 25.0)])
def test_report_rows_equal_per_vessel_slices_on_a_real_run(monkeypatch, name, duration):
    """Each vessel's report (a span of the fleet's columns, its estimates sliced on first read) gives
    what each field's slice per vessel gave, bit for bit, after every step of a real run."""
    from mjasc.perception.tracking.report_fields import report_estimates

    orig = fleet_mod.FleetTracker.step
    n_checked = [0]

    def checked(self, *args, **kwargs):
        orig(self, *args, **kwargs)
        cols = self._report_columns()
        got, want = report_estimates(self, cols), _per_vessel_slices(self, cols)
        assert got.keys() == want.keys()
        for o in got:
            _same_rows(got[o], want[o])
            n_checked[0] += 1

    _run_with(monkeypatch, checked, name, duration)
    assert n_checked[0] > 50


def test_track_rows_of_span_equal_the_slices_on_random_columns():
    rng = np.random.default_rng(7)
    for n in (0, 1, 2, 5, 9):
        ids = rng.integers(0, 100, n).tolist()
        cols = (ids, rng.random(n).tolist(), rng.random((n, 2)), rng.random(n).tolist(), rng.random(n).tolist(),
                rng.random(n).tolist(), rng.random(n).tolist(), rng.random((n, 2, 2)), (rng.random(n) < 0.5).tolist(),
                [None if x < 0.5 else "m" for x in rng.random(n)], [None] * n)
        id_array, time_array = np.array(ids, dtype=np.int64), np.array(cols[1])
        for a in range(n + 1):
            for b in range(a, n + 1):
                want = TrackRows.of_columns(tuple(c[a:b] for c in cols) + ((None,) * (b - a),), id_array[a:b],
                                            time_array[a:b])
                _same_rows(TrackRows.of_span(cols, a, b, id_array, time_array), want)


def _run_with(monkeypatch, step, name: str, duration: float) -> None:
    """Run the bundled scenario ``name`` for ``duration`` s (no outputs) with ``step`` as the fleet
    tracker's step."""
    monkeypatch.setattr(fleet_mod.FleetTracker, "step", step)
    sc = mjasc.load_scenario(_ROOT / "tasks" / f"{name}.toml").with_overrides(duration_s=duration)
    sc = replace(sc, outputs=replace(sc.outputs, recording=False, video=False))
    Runner(sc, out_dir=None).run()
