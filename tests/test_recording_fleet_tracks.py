"""The confirmed tracks' rows of standard detail written for the whole fleet at once
(:mod:`mjasc.perception.track_rows`) are the rows each vessel's log wrote on its own: on real
multi-vessel runs, the same entities in the same order, at the same ticks, with the same positions
and the labels on the same rows — with the vessels scanning in step and out of step, and with flushes
inside record ticks."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import mjasc.perception.track_rows as track_rows
import mjasc.runs.recording as recording
from mjasc.runs.recording import Recorder
from mjasc.runs.runner import Runner
from mjasc.runs.scenario import load_scenario

ROOT = Path(__file__).resolve().parent.parent
TRACKS = "/tracks/positions"


def _scenario(tmp_path, text_edit=None, duration_s=40.0, detail="standard"):
    text = (ROOT / "tasks" / "thesis_6_4_crossing.toml").read_text()
    if text_edit is not None:
        text = text_edit(text)
    path = tmp_path / "scenario.toml"
    path.write_text(text)
    sc = load_scenario(path).with_overrides(duration_s=duration_s)
    return replace(sc, outputs=replace(sc.outputs, recording=True, video=False, recording_detail=detail))


def _recorded_tracks(monkeypatch, sc, out_dir, fleet: bool):
    """Every track row the run buffered, per entity in the order of the flushes' entities:
    {entity: [(t, xy, labels), ...]}, and the order of the point entities at each flush."""
    rows: dict[str, list] = {}
    orders: list[list[str]] = []
    points, flush = Recorder.points, Recorder.flush

    def spy_points(self, entity, t_s, positions_xy, z=0.0, labels=None):
        if entity.endswith(TRACKS):
            rows.setdefault(entity, []).append((t_s, np.array(positions_xy, dtype=float).reshape(-1, 2),
                                                None if labels is None else list(labels)))
        return points(self, entity, t_s, positions_xy, z, labels)

    def spy_flush(self):
        orders.append([e for e, _ in self._points])
        for (entity, _), buffer in self._points.items():
            if type(buffer) is not tuple:
                times, xy, per_row, labels = buffer.rows()
                ends = np.cumsum(per_row)
                for t, a, b, lab in zip(times.tolist(), ends - per_row, ends, labels):
                    rows.setdefault(entity, []).append((t, xy[a:b], lab))
        return flush(self)

    with monkeypatch.context() as m:
        m.setattr(Recorder, "points", spy_points)
        m.setattr(Recorder, "flush", spy_flush)
        if not fleet:
            m.setattr(track_rows, "fleet_track_rows", lambda agents: [])
        runner = Runner(sc, out_dir=out_dir)
        runner.run()
    return rows, orders, runner


def _assert_same(a: dict, b: dict) -> int:
    assert a.keys() == b.keys()
    labelled = 0
    for entity in a:
        assert len(a[entity]) == len(b[entity]), entity
        for (t1, xy1, l1), (t2, xy2, l2) in zip(a[entity], b[entity]):
            assert t1 == t2 and xy1.tobytes() == xy2.tobytes() and l1 == l2, (entity, t1)
            labelled += l1 is not None
    return labelled


def _staggered(text: str) -> str:
    """bravo scans at 2 Hz, charlie at 3 Hz (alpha at 5 Hz: every record tick)."""
    parts = text.split('sensor = { beams = 360, max_range_m = 100.0 }')
    assert len(parts) == 4
    return (parts[0] + 'sensor = { beams = 360, max_range_m = 100.0 }' + parts[1] +
            'sensor = { beams = 360, max_range_m = 100.0, rate_hz = 2.0 }' + parts[2] +
            'sensor = { beams = 360, max_range_m = 100.0, rate_hz = 3.0 }' + parts[3])


@pytest.mark.parametrize("edit", [None, _staggered], ids=["in_step", "staggered"])
def test_fleet_rows_are_the_per_vessel_rows(tmp_path, monkeypatch, edit):
    sc = _scenario(tmp_path, edit)
    old, old_order, _ = _recorded_tracks(monkeypatch, sc, tmp_path / "old", fleet=False)
    new, new_order, runner = _recorded_tracks(monkeypatch, sc, tmp_path / "new", fleet=True)
    assert len(runner._truth.fleet_logs) == 1  # (the fleet wrote them)
    assert len(old) == 3 and sum(map(len, old.values())) > 100
    labelled = _assert_same(old, new)
    assert labelled > 3  # (labels change during the run: more than the first rows carry them)
    assert old_order == new_order  # the entities in the same order: the same chunks
    assert (tmp_path / "old" / "recording.rrd").read_bytes() == (tmp_path / "new" / "recording.rrd").read_bytes()


def test_fleet_rows_survive_flushes_inside_record_ticks(tmp_path, monkeypatch):
    """With a tiny flush threshold the recorder flushes inside record ticks, before some vessels'
    logs registered the tick's rows: every row still arrives, once, with its labels."""
    monkeypatch.setattr(recording, "FLUSH_ROWS", 7)
    sc = _scenario(tmp_path, _staggered, duration_s=15.0)
    old, _, _ = _recorded_tracks(monkeypatch, sc, tmp_path / "old", fleet=False)
    new, orders, _ = _recorded_tracks(monkeypatch, sc, tmp_path / "new", fleet=True)
    assert len(orders) > 20
    _assert_same(old, new)


def test_full_detail_keeps_the_per_vessel_tracks(tmp_path, monkeypatch):
    sc = _scenario(tmp_path, duration_s=6.0, detail="full")
    rows, _, runner = _recorded_tracks(monkeypatch, sc, tmp_path / "full", fleet=True)
    assert runner._truth.fleet_logs == []
    assert len(rows) == 3 and all(len(r) == 31 for r in rows.values())  # (a row per record tick, 0 to 6 s)
    assert (tmp_path / "full" / "recording.rrd").stat().st_size > 0
