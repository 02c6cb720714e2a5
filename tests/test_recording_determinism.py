"""The same scenario and seed give a byte-identical ``recording.rrd``; a different seed a different
one. The Rerun SDK draws row and chunk ids from the wall clock; the Recorder re-encodes the finished
file with derived ids (mjasc.runs.rrd_canonical), and these tests check that re-encoding against
Rerun's own tools: ``rerun rrd verify`` accepts the file, ``rerun rrd compare --unordered`` finds
its content equal to what the SDK wrote, and Rerun's reader finds both stores with the given ids."""

import subprocess
import sys
from pathlib import Path

import pytest
import rerun as rr
import rerun.blueprint as rrb

from mjasc.runs.blueprint import stable_blueprint_ids
from mjasc.runs.recording import size_only_batcher
from mjasc.runs.rrd_canonical import CanonicalRrdError, canonicalise
from mjasc.runs.runner import run_scenario
from mjasc.runs.scenario import load_scenario

ROOT = Path(__file__).resolve().parent.parent
RERUN = Path(sys.executable).parent / "rerun"
needs_cli = pytest.mark.skipif(not RERUN.exists(), reason="the rerun CLI is not installed next to this Python")


def _rerun(*args) -> subprocess.CompletedProcess:
    return subprocess.run([str(RERUN), *map(str, args)], capture_output=True, text=True, timeout=120)


@needs_cli
def test_same_seed_same_bytes_different_seed_different(tmp_path):
    sc = load_scenario(ROOT / "tasks" / "thesis_6_1_static.toml").with_overrides(duration_s=3.0)
    paths = []
    for k, seed in enumerate((5, 5, 6)):
        out = tmp_path / f"r{k}"
        run_scenario(sc.with_overrides(seed=seed), out, progress=False)
        paths.append(out / "recording.rrd")
    assert paths[0].read_bytes() == paths[1].read_bytes()
    assert paths[0].read_bytes() != paths[2].read_bytes()
    assert _rerun("rrd", "verify", paths[0]).returncode == 0
    assert _rerun("rrd", "compare", "--unordered", paths[0], paths[1]).returncode == 0
    assert _rerun("rrd", "compare", "--unordered", paths[0], paths[2]).returncode != 0


def _sdk_file(path: Path, seed: int) -> None:
    """A recording as the SDK writes it with the Recorder's settings (size-only batching, derived
    blueprint view ids): random row, chunk and store ids and a wall-clock blueprint log_time."""
    rec = rr.RecordingStream("mjasc", recording_id=f"sdk-{seed}", send_properties=False,
                             batcher_config=size_only_batcher())
    rec.set_log_time_enabled(False)
    blueprint = rrb.Blueprint(rrb.Horizontal(rrb.Spatial3DView(origin="/world", name="world"),
                                             rrb.TimeSeriesView(origin="/plots", name="plots")))
    stable_blueprint_ids(blueprint, "test")
    rec.save(str(path), default_blueprint=blueprint)
    for k in range(200):
        rec.set_time("sim_time", duration=0.1 * k)
        rec.log("world/p", rr.Points3D([[k, 2.0 * k, 0.0]]))
        rec.log("plots/x", rr.Scalars(float(k) ** 0.5))
    rec.log("world/label", rr.TextDocument("static"), static=True)
    rec.flush()
    rec.disconnect()


@needs_cli
def test_canonicalise_keeps_content_and_gives_equal_bytes_for_equal_content(tmp_path):
    from rerun.chunk import RrdReader

    for k in (1, 2):
        _sdk_file(tmp_path / f"sdk{k}.rrd", k)
        canonicalise(tmp_path / f"sdk{k}.rrd", tmp_path / f"c{k}.rrd", "rec-id", "bp-id")
    assert (tmp_path / "sdk1.rrd").read_bytes() != (tmp_path / "sdk2.rrd").read_bytes()
    assert (tmp_path / "c1.rrd").read_bytes() == (tmp_path / "c2.rrd").read_bytes()
    assert _rerun("rrd", "verify", tmp_path / "c1.rrd").returncode == 0
    assert _rerun("rrd", "compare", "--unordered", tmp_path / "sdk1.rrd", tmp_path / "c1.rrd").returncode == 0
    reader = RrdReader(tmp_path / "c1.rrd")
    (recording,), (blueprint,) = reader.recordings(), reader.blueprints()
    assert (recording.recording_id, blueprint.recording_id, blueprint.kind) == ("rec-id", "bp-id", "blueprint")
    rows = sum(c.num_rows for c in reader.stream(store=recording).to_chunks())
    assert rows == 401  # 200 points, 200 scalars, 1 static text
    printed = _rerun("rrd", "print", tmp_path / "c1.rrd").stdout
    assert "make_default: true" in printed  # the blueprint stays the recording's default


def test_canonicalise_refuses_a_file_that_is_not_a_recording(tmp_path):
    bad = tmp_path / "bad.rrd"
    bad.write_bytes(b"not a recording")
    with pytest.raises(CanonicalRrdError, match="RRF2"):
        canonicalise(bad, tmp_path / "out.rrd", "a", "b")
    assert not (tmp_path / "out.rrd").exists()


@needs_cli
def test_recording_holds_no_wall_clock_start_time_and_derived_blueprint_ids(tmp_path):
    import re
    import uuid

    from mjasc.runs.recording import Recorder, default_blueprint

    rec = Recorder(tmp_path / "r.rrd", "x", 3, default_blueprint(vessels=("a",), avoidance=True))
    rec.close()
    text = _rerun("rrd", "print", "-vv", tmp_path / "r.rrd").stdout
    assert "RecordingInfo:name" in text and "start_time" not in text
    ids = set(re.findall(r"/(?:view|container)/([0-9a-f-]{36})", text))
    assert len(ids) >= 5 and all(uuid.UUID(i).version == 5 for i in ids)
    key = "mjasc/x/3/blueprint"
    assert str(uuid.uuid5(uuid.NAMESPACE_URL, f"{key}/1")) in ids  # the first view under the root container
    assert str(uuid.uuid5(uuid.NAMESPACE_URL, key)) in text  # the blueprint store's own id


def test_footer_checksum_is_xxh32():
    """The stream footer's checksum (xxHash32, compiled) on the reference
    vectors of the xxHash project, and across the 16-byte stripe boundaries."""
    from mjasc.runs.rrd_wire import xxh32 as _xxh32

    assert [_xxh32(b, 0) for b in (b"", b"a", b"abc", b"Nobody inspects the spammish repetition")] == \
        [0x02CC5D05, 0x550D7456, 0x32D153FF, 0xE2293B2F]

    def reference(data: bytes, seed: int) -> int:  # the algorithm as specified, lane by lane
        p1, p2, p3, p4, p5, m = 2654435761, 2246822519, 3266489917, 668265263, 374761393, 0xFFFFFFFF
        rotl = lambda x, r: ((x << r) | (x >> (32 - r))) & m  # noqa: E731
        n, i = len(data), 0
        if n >= 16:
            v = [(seed + p1 + p2) & m, (seed + p2) & m, seed & m, (seed - p1) & m]
            while i + 16 <= n:
                for j in range(4):
                    v[j] = rotl((v[j] + int.from_bytes(data[i + 4 * j:i + 4 * j + 4], "little") * p2) & m, 13) * p1 & m
                i += 16
            h = (rotl(v[0], 1) + rotl(v[1], 7) + rotl(v[2], 12) + rotl(v[3], 18) + n) & m
        else:
            h = (seed + p5 + n) & m
        for k in range(i, n - 3, 4):
            h = rotl((h + int.from_bytes(data[k:k + 4], "little") * p3) & m, 17) * p4 & m
        for b in data[i + (n - i) // 4 * 4:]:
            h = rotl((h + b * p5) & m, 11) * p1 & m
        h = (h ^ (h >> 15)) * p2 & m
        h = (h ^ (h >> 13)) * p3 & m
        return h ^ (h >> 16)

    data = bytes(range(256)) * 3
    for n in (15, 16, 17, 31, 32, 33, 63, 64, 65, 255, 768):
        assert _xxh32(data[:n], 7850921) == reference(data[:n], 7850921), n


def test_spliced_schema_messages_equal_pyarrows_serialisation(tmp_path):
    """Each chunk's canonical schema message, serialised once per distinct schema with the chunk id
    spliced in (rrd_canonical._schema_message), is pyarrow's own serialisation of that schema bit for
    bit; a field whose metadata keys are already sorted is kept as it is (the same field)."""
    import pyarrow as pa

    from mjasc.runs import rrd_canonical as rc

    _sdk_file(tmp_path / "sdk.rrd", 1)
    _, chunks, _, _ = rc._read((tmp_path / "sdk.rrd").read_bytes())
    every = [c for cs in chunks.values() for c in cs]
    assert len(every) >= 3
    for k, c in enumerate(every * 2):  # the second pass is served from the cache
        chunk_id = f"chunk_{rc.BASE_NS:016X}{(k + 1) << 40 | k:016x}".encode()
        reference = rc._serialized_schema(c.fields, c.schema.metadata, chunk_id)
        assert rc._schema_message(c.fields, c.schema.metadata, chunk_id) == reference
        # a chunk's canonical stream: its schema's message parts (made once per schema) around the id
        assert c.parts is not None
        ipc = c.ipc(c.row_ids.copy(), chunk_id)
        assert ipc[:len(reference)] == reference and len(ipc) == len(reference) + len(c.raw) - c.start
        if not c.log_times:  # (else their values are set to BASE_NS)
            assert ipc[len(reference):] == c.raw[c.start:]
    field = pa.field("x", pa.int64(), metadata={b"b": b"2", b"a": b"1"})
    assert list(rc.canon_field(field).metadata) == [b"a", b"b"]
    tidy = rc.canon_field(field)
    assert rc.canon_field(tidy) is tidy


def test_chunk_schemas_read_once_give_each_chunk_its_own_id(tmp_path):
    """rrd_canonical._chunk_schema reads a schema once per distinct schema message (the chunk id
    left out): each chunk still gets its own id, and the schema and canonical fields of reading
    its message in full (but for rerun:id); an entity path holding ``chunk_`` is read in full."""
    import pyarrow as pa

    from mjasc.runs import rrd_canonical as rc

    _sdk_file(tmp_path / "sdk.rrd", 1)
    rec = rr.RecordingStream("mjasc", recording_id="odd", send_properties=False, batcher_config=size_only_batcher())
    rec.save(str(tmp_path / "odd.rrd"))
    for k in range(3):
        rec.set_time("sim_time", duration=0.1 * k)
        rec.send_columns("world/chunk_like", indexes=[rr.TimeColumn("sim_time", duration=[0.1 * k])],
                         columns=rr.Scalars.columns(scalars=[float(k)]))
    rec.flush()
    rec.disconnect()
    rc._SCHEMAS.clear()
    for name in ("sdk.rrd", "odd.rrd"):
        for _ in range(2):  # the second pass is served from the cache
            _, chunks, _, _ = rc._read((tmp_path / name).read_bytes())
            for c in (c for cs in chunks.values() for c in cs):
                own = pa.ipc.read_schema(pa.ipc.read_message(pa.BufferReader(pa.py_buffer(c.raw))))
                assert c.id == own.metadata[b"rerun:id"]
                assert c.schema.remove_metadata() == own.remove_metadata()
                assert {k: v for k, v in c.schema.metadata.items() if k != b"rerun:id"} == \
                    {k: v for k, v in own.metadata.items() if k != b"rerun:id"}
                assert c.fields == rc._canon_fields(own)[0]
    assert rc._SCHEMAS  # (the SDK's chunks went through the cache)


def test_protobuf_fields_read_as_written():
    """rrd_wire.pb_parse reads back what the pb_* writers wrote: varints of one and of several
    bytes (keys of high field numbers, values, lengths), fixed64 and length-delimited fields, a
    repeated field's values in order; an unknown wire type is a one-line error."""
    from mjasc.runs.rrd_wire import CanonicalRrdError, pb_bytes, pb_fixed64, pb_int, pb_parse

    long = bytes(range(256)) * 3  # a length of two varint bytes
    msg = (pb_int(1, 0) + pb_int(2, 127) + pb_int(2, 128) + pb_int(3, 2 ** 63 - 1) + pb_fixed64(4, 2 ** 64 - 1)
           + pb_bytes(5, b"") + pb_bytes(5, long) + pb_int(300, 5) + pb_bytes(17, "é"))
    assert pb_parse(msg) == {1: [0], 2: [127, 128], 3: [2 ** 63 - 1], 4: [2 ** 64 - 1], 5: [b"", long], 300: [5],
                             17: ["é".encode()]}
    assert pb_parse(memoryview(msg)) == pb_parse(msg)
    with pytest.raises(CanonicalRrdError, match="wire type 5"):
        pb_parse(bytes([1 << 3 | 5, 0, 0, 0, 0]))
