"""TrackRows — a vessel's confirmed tracks kept as columns, the estimates made on first read — hands
on the same estimates as the readable form (``TrackEstimate(*row)`` / the tracker's
``_estimates_of``), and the avoidance's control-tick checks read its columns with the same
answers as from the objects."""

import numpy as np
import pytest
from dataclasses import replace

import mjasc
from mjasc.core.estimates import TrackEstimate, TrackRows, track_columns
from mjasc.runs.runner import Runner


def _columns(rng, n):
    pos, P = rng.normal(size=(n, 2)), rng.normal(size=(n, 2, 2))
    return [list(range(3, 3 + n)), rng.normal(size=n).tolist(), pos, rng.normal(size=n).tolist(),
            rng.random(n).tolist(), rng.normal(size=n).tolist(), (1.0 + rng.random(n)).tolist(), P,
            [bool(b) for b in rng.random(n) < 0.5], [None] * n, [None] * n, [None] * n]


def test_rows_equal_the_constructor_and_columns_without_objects():
    cols = _columns(np.random.default_rng(1), 4)
    rows = TrackRows(cols)
    assert rows.track_ids == cols[0] and rows.times_s == cols[1] and rows.positions_m is cols[2]
    assert rows._items is None and len(rows) == 4 and bool(rows)  # no estimate made yet
    ref = [TrackEstimate(*row) for row in zip(*cols)]
    got = list(rows)
    assert rows._items is not None
    for g, r in zip(got, ref):
        assert type(g) is TrackEstimate and list(vars(g)) == list(vars(r))
        for name, value in vars(r).items():
            if isinstance(value, np.ndarray):
                assert vars(g)[name].tobytes() == value.tobytes()
            else:
                assert vars(g)[name] is value
    assert rows[1] is got[1] and rows[-1] is got[-1] and list(rows[1:3]) == got[1:3]
    assert rows == tuple(got) and rows == got
    assert track_columns(rows) == (rows.track_ids, rows.times_s, rows.positions_m)
    ids, times, pos = track_columns(tuple(got))  # the readable form: read from the objects
    assert ids == cols[0] and times == cols[1] and np.array_equal(np.array(pos), cols[2])
    empty = TrackRows([[] for _ in cols])
    assert len(empty) == 0 and not empty and list(empty) == []
    with pytest.raises(ValueError, match="columns"):
        TrackRows(cols[:-1])


def _runner(task, duration_s):
    sc = mjasc.load_scenario(f"tasks/{task}.toml").with_overrides(duration_s=duration_s)
    return Runner(replace(sc, outputs=replace(sc.outputs, recording=False, video=False)), out_dir=None)


def test_report_rows_are_the_trackers_estimates():
    """On a real run: every vessel's report rows give the same estimates, bit for bit, as the
    tracker's readable form (``_estimates_of`` of the vessel's confirmed rows)."""
    r = _runner("demo", 8.0)
    checked = []

    def after_tracking(event):
        for agent in r.agents:
            p = agent.perception
            if p is None:
                continue
            fleet, owner = p._tracker.fleet, p._tracker.owner
            rows = fleet.report_rows(owner)
            assert fleet.report_rows(owner) is rows  # one value per step
            cols = fleet._report_columns()  # (spans per vessel, bank rows, ...)
            a, b = cols[0].get(owner, (0, 0)) if len(cols) > 1 else (0, 0)
            ref = fleet._estimates_of(np.array(cols[1][a:b] if len(cols) > 1 else [], dtype=np.int64))
            assert rows.track_ids == [e.track_id for e in ref] and rows.times_s == [e.time_s for e in ref]
            if rows.track_ids:  # the ids and times as arrays too: the lists' conversions, bit for bit
                assert rows.id_array.tobytes() == np.array(rows.track_ids).tobytes()
                assert rows.time_array.tobytes() == np.array(rows.times_s, dtype=float).tobytes()
                assert rows.id_array.dtype == np.int64 and rows.time_array.dtype == np.float64
            assert np.asarray(rows.positions_m).reshape(-1, 2).tobytes() == \
                np.array([e.position_m for e in ref]).reshape(-1, 2).tobytes()
            for a, b in zip(rows, ref):
                assert list(vars(a)) == list(vars(b))
                for name in vars(b):
                    va, vb = getattr(a, name), getattr(b, name)
                    if isinstance(vb, np.ndarray):
                        assert va.tobytes() == vb.tobytes()
                    else:
                        assert va == vb
            checked.append(len(rows))

    r.observe("tracking", after_tracking)
    r.run()
    assert sum(checked) > 0


def test_deviation_check_on_columns_as_on_objects():
    """The control tick's deviation check answers the same from the report's columns as from the
    same tracks as objects (a tuple: the readable form)."""
    r = _runner("demo", 40.0)
    answers = []

    def after_control(event):
        for agent in r.agents:
            a, rep = agent.avoidance, agent._report
            if a is None or rep is None or a._predicted_tracks is None or not len(rep.tracks):
                continue
            saved = (a._checked_tracks, a._predicted_motion, a._predicted_row)
            a._checked_tracks = None
            cols = a._deviating(rep.tracks)
            a._checked_tracks = None
            objs = a._deviating(tuple(rep.tracks))
            a._checked_tracks, a._predicted_motion, a._predicted_row = saved
            assert cols == objs
            answers.append(cols)

    r.observe("control", after_control)
    r.run()
    assert len(answers) > 100
