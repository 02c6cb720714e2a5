"""Few chunks, same content: labels ride in their points' chunk (null where a row has none), a
vessel without views has its overlay styles written only with the overlay's first rows, entities
whose rows are all empty and never drew anything are not written, and the re-encoding that patches
the SDK's record batches in place keeps every chunk's data, bit for bit, against decoding them."""

from pathlib import Path

import numpy as np
import pyarrow as pa
import rerun as rr

import mjasc.runs.recording as recording
from mjasc.runs.recording import Recorder
from mjasc.runs.rrd_canonical import BASE_NS, _read
from mjasc.runs.runner import run_scenario
from mjasc.runs.scenario import load_scenario

TASKS = Path(__file__).resolve().parents[1] / "tasks"


def _chunks(path) -> dict[str, list[pa.RecordBatch]]:
    """Entity path → its chunks' record batches (static ones too), read with Rerun's reader."""
    out: dict[str, list] = {}
    for chunk in rr.chunk.RrdReader(path).store().stream():
        out.setdefault(chunk.entity_path, []).append(chunk.to_record_batch())
    return out


def test_labels_share_the_points_chunk_and_silent_entities_are_not_written(tmp_path):
    rec = Recorder(tmp_path / "r.rrd", "chunks", 1, detail="standard")
    rec.set_vessels(("a", "b"), ("a",))
    style = rr.LineStrips3D.from_fields(colors=[(1, 2, 3, 255)], radii=[0.1])
    rec.vessel_style("a", "world/a/overlay", style)  # a vessel with views: written now
    rec.vessel_style("b", "world/b/overlay", style)  # without: with its first rows, never here
    rec.vessel_style("b", "world/b/drawn", style)
    rec.points("world/p", 0.0, np.array([[1.0, 2.0]]), labels=["one"])
    rec.points("world/p", 0.1, np.array([[1.5, 2.0]]))  # keeps "one" (Rerun's latest-at skips null)
    rec.points("world/p", 0.2, np.array([[2.0, 2.0], [3.0, 1.0]]), labels=["one", "two"])
    for t in (0.0, 0.1):
        rec.strips("world/b/overlay", t, [])  # empty rows of an overlay that never drew anything
    rec.strips("world/b/drawn", 0.0, [])
    rec.strips("world/b/drawn", 0.1, [np.array([[0.0, 0.0], [1.0, 1.0]])])
    rec.close()
    chunks = _chunks(tmp_path / "r.rrd")
    (p,) = chunks["/world/p"]
    assert p.column("Points3D:labels").to_pylist() == [["one"], None, ["one", "two"]]
    assert [len(r) for r in p.column("Points3D:positions").to_pylist()] == [1, 1, 2]
    assert "/world/b/overlay" not in chunks  # neither its style nor its empty rows
    assert "/world/a/overlay" in chunks  # the style of a vessel with views, drawn or not
    drawn = chunks["/world/b/drawn"]
    assert len(drawn) == 2  # the style (static) and both rows, the empty one first
    rows = next(b for b in drawn if "LineStrips3D:strips" in b.schema.names)
    assert [len(r) for r in rows.column("LineStrips3D:strips").to_pylist()] == [0, 1]


def _batches(path) -> dict[int, list[pa.RecordBatch]]:
    """Store kind (1 recording, 2 blueprint) → its chunks decoded by pyarrow, in file order."""
    stores, chunks, _, _ = _read(path.read_bytes())
    return {key[0]: [pa.ipc.open_stream(c.raw).read_next_batch() for c in chunks[key]] for key in chunks}


def _row_ids(batch: pa.RecordBatch) -> np.ndarray:
    return np.frombuffer(batch.column(0).buffers()[1], ">u8").reshape(-1, 2)[:batch.num_rows]


def test_in_place_patch_keeps_every_chunk_of_a_run_bit_for_bit(tmp_path, monkeypatch):
    """The canonical file's chunks decode to the SDK's, column by column (the same bytes under
    one encoder), in the order of their first rows; only the row ids (derived, increasing) and
    ``log_time`` (:data:`BASE_NS`) differ."""
    kept = tmp_path / "sdk.rrd"
    close_canonical = recording.close_canonical

    def keep(part, *args):
        close_canonical(part, *args)
        kept.write_bytes(Path(part).read_bytes())  # (the SDK's file until the recorder renames the canonical one)

    monkeypatch.setattr(recording, "close_canonical", keep)
    run_scenario(load_scenario(TASKS / "demo.toml").with_overrides(duration_s=8.0), tmp_path / "run", progress=False)
    sdk, ours = _batches(kept), _batches(tmp_path / "run" / "recording.rrd")
    assert sdk.keys() == ours.keys() and sum(len(v) for v in ours.values()) > 100
    for kind in sdk:
        ordered = sorted(sdk[kind], key=lambda b: min(map(tuple, _row_ids(b))))
        assert len(ordered) == len(ours[kind])
        every = sorted(tuple(r) for a in ordered for r in _row_ids(a))  # the SDK's row order
        rank = {r: k + 1 for k, r in enumerate(every)}
        for a, b in zip(ordered, ours[kind]):
            assert a.schema.metadata[b"rerun:entity_path"] == b.schema.metadata[b"rerun:entity_path"]
            assert a.schema.names == b.schema.names
            ids = _row_ids(b)
            assert (ids[:, 0] == BASE_NS).all()
            assert ids[:, 1].tolist() == [rank[tuple(r)] for r in _row_ids(a)]
            for name in a.schema.names[1:]:
                x, y = a.column(name), b.column(name)
                if name == "log_time":
                    assert y.cast(pa.int64()).to_pylist() == [BASE_NS] * len(y)
                    continue
                one = [pa.RecordBatch.from_arrays([c], names=["c"]).serialize().to_pybytes() for c in (x, y)]
                assert one[0] == one[1], name
