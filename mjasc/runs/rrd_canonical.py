"""Byte-identical recordings: re-encode a finished ``.rrd`` file with every id derived, not drawn.

The Rerun SDK stamps each row and chunk with a time-based id (TUID: wall-clock nanoseconds and a
random counter), gives the store-info message a fresh one, writes the blueprint's wall-clock
``log_time`` column, and serialises Arrow schema metadata in hash-map order (random per process).
So two runs with the same scenario and seed write the same *content* in different *bytes*.
:func:`canonicalise` reads the file the SDK wrote and writes it again with

* row ids  → (:data:`BASE_NS`, rank + 1), the rank being the row's place in the store's original
  row-id order (Rerun breaks ties between rows at the same time by row id: the order is kept);
* chunk ids → (:data:`BASE_NS`, store << 40 | k), the chunks in the order of their first row;
* ``log_time`` columns → :data:`BASE_NS`; the store ids → the ones given (derived from the
  scenario and seed by the caller);
* every Arrow schema with its metadata keys sorted, serialised by pyarrow and LZ4-compressed;
* the file footer (the chunk manifest Rerun's reader and viewer use to load lazily) rebuilt from
  the SDK's own: new ids, byte offsets and sizes, rows in the new order.

A chunk is not decoded and encoded again: its Arrow IPC stream keeps the SDK's record-batch message
(the data as Arrow-rs wrote it; the SDK writes the same bytes for the same data) with the new row ids
and ``log_time`` values written over the old ones in place, behind a schema message serialised by
pyarrow from the canonical schema (the schema read, the canonical fields and the schema message
computed once per distinct schema, the chunk id spliced into the message: a run's thousands of
chunks share a few dozen). Cost: ~0.1 ms per chunk (a 50-vessel
recording holds ~1,500) plus about 0.5 s per 50 MB.

Nothing of the data changes (``rerun rrd compare --unordered`` finds the files equal). The file is
held in memory while it is re-encoded (peak ≈ 5× its size). Chunk boundaries must not depend on
wall-clock time either: :class:`~mjasc.runs.recording.Recorder`
gives the SDK a batcher that flushes on size only (:data:`BATCHER`).

**Container format assumptions (Rerun 0.41; re-check on every Rerun upgrade —
tests/test_recording_determinism.py does).**
(1) Stream header ``RRF2`` + 4 version bytes + options (1 = LZ4, 2 = protobuf, 0, 0); each
message a 16-byte header (u64 LE kind: 0 End, 1 SetStoreInfo, 2 ArrowMsg, 3
BlueprintActivationCommand; u64 LE length) and a protobuf body; the End body is the footer,
followed by a 32-byte stream footer (u64 start, u64 length, u32 xxh32 of the footer with seed
7850921, ``RRF2FOOT``, u32 1). (2) Field numbers of rerun.log_msg.v1alpha1 (the ``pb_*`` calls
below; the wire format in :mod:`mjasc.runs.rrd_wire`).
(3) An ArrowMsg payload is one LZ4-block-compressed Arrow IPC stream: one schema message, one
record-batch message (uncompressed buffers: read in place, its row ids written over), the end.
(4) A chunk's column 0 is ``rerun.controls.RowId`` (fixed_size_binary[16], big-endian time and
counter); its id is schema
metadata ``rerun:id`` = ``chunk_`` + %016X time + %016x counter. (5) The footer manifest has
``chunk_id``, ``chunk_byte_offset``, ``chunk_byte_size``, ``chunk_byte_size_uncompressed``
columns. The manifest's schema hash is computed over pyarrow's schema encoding, not Rerun's (Rerun
checks it only in debug builds).
"""

from __future__ import annotations

import struct
from typing import NamedTuple

import numpy as np
import pyarrow as pa

from mjasc.runs.rrd_manifest import canon_field, rebuild_manifest
from mjasc.runs.rrd_wire import (BASE_NS, IPC_EOS, LZ4, CanonicalRrdError, pb_bytes, pb_int, pb_parse, pb_store_id,
                                 pb_tuid, raw_ipc, store_key, xxh32)

__all__ = ["BASE_NS", "BATCHER_FLUSH_BYTES", "CanonicalRrdError", "Encoded", "SdkMessages", "canonicalise",
           "encode_chunks", "encode_file"]

#: The SDK's batcher flushes when this many bytes are pending (and never on a timer).
BATCHER_FLUSH_BYTES = 8 << 20
_RECORDING, _BLUEPRINT = 1, 2  # StoreKind
_END, _STORE_INFO, _ARROW, _ACTIVATION = 0, 1, 2, 3  # message kinds
_XXH_SEED = 7850921


# ---------------------------------------------------------------- Arrow


class _Chunk:
    """One chunk as the SDK wrote it: its decompressed IPC stream ``raw`` (schema message, one
    record-batch message from ``start``, end of stream), schema, row ids (n, 2) (big-endian time,
    counter), where the row ids and the ``log_time`` values lie in ``raw`` and whether it is static."""

    __slots__ = ("raw", "start", "schema", "id", "fields", "row_ids", "row_id_at", "log_times", "is_static", "parts")

    def __init__(self, raw: bytes, is_static: int):
        buf = pa.py_buffer(raw)
        reader = pa.BufferReader(buf)
        schema, self.id, self.fields, log_times, self.parts = _chunk_schema(raw, reader)
        self.schema = schema
        self.start = reader.tell()
        batch = pa.ipc.read_record_batch(pa.ipc.read_message(reader), schema)  # zero-copy: buffers lie in raw
        if reader.tell() != len(raw) - 8 or raw[-8:] != IPC_EOS:
            raise CanonicalRrdError("a chunk's Arrow stream is not one schema and one record batch")
        self.raw, self.is_static = raw, is_static
        n = batch.num_rows
        self.row_id_at = self._at(batch.column(0), 16, buf, raw)
        self.row_ids = np.frombuffer(raw, ">u8", 2 * n, self.row_id_at).reshape(n, 2)
        self.log_times = [(self._at(batch.column(j), 8, buf, raw), n) for j in log_times]

    def _at(self, column: pa.Array, width: int, buf: pa.Buffer, raw: bytes) -> int:
        """Where the values of ``column`` (fixed ``width`` bytes each) lie in ``raw``."""
        values = column.buffers()[1]
        at = values.address + width * column.offset - buf.address
        size = width * len(column)
        # (within raw's record batch: the values are raw's bytes there — a buffer pyarrow made
        # elsewhere, e.g. decompressed, cannot overlap raw, which is alive: no byte comparison)
        if not (self.start <= at and at + size <= len(raw) - 8):
            raise CanonicalRrdError("a chunk's column does not lie in its Arrow stream")
        return at

    def ipc(self, row_ids: np.ndarray, chunk_id: bytes) -> bytes:
        """The canonical IPC stream: the canonical schema with ``chunk_id``, the record batch with
        ``row_ids`` ((n, 2) big-endian) and every ``log_time`` at :data:`BASE_NS`."""
        body = bytearray(memoryview(self.raw)[self.start:])
        at = self.row_id_at - self.start
        body[at:at + row_ids.nbytes] = row_ids.tobytes()
        for at, n in self.log_times:
            body[at - self.start:at - self.start + 8 * n] = np.full(n, BASE_NS, "<i8").tobytes()
        parts = self.parts  # (the canonical schema message around the id, made once per distinct schema)
        if parts is not None and len(chunk_id) == _CHUNK_ID_LEN:
            return parts[0] + chunk_id + parts[1] + bytes(body)
        return _schema_message(self.fields, self.schema.metadata, chunk_id) + bytes(body)


_CHUNK_ID_LEN = len(b"chunk_") + 32  # ``chunk_`` + %016X time + %016x counter
_SCHEMAS: dict = {}  # a schema message without its chunk id → (schema, canonical fields, log_time indices,
#   the canonical message's parts around the id)


def _chunk_schema(raw: bytes, reader: pa.BufferReader) -> tuple:
    """The schema of the chunk whose IPC stream is ``raw``, its chunk id (``rerun:id``), its
    canonical fields and ``log_time`` columns (:func:`_canon_fields`) and its canonical schema
    message before and after the chunk id (:func:`_message_parts`; None: made per chunk);
    ``reader`` (on ``raw``) is left after the schema message. A run's chunks share a few dozen
    schemas that differ only by the chunk id: the schema is read once per distinct message with the
    id left out (the message determines the schema; the id is read from the message). The returned
    schema's ``rerun:id`` is then another chunk's: only :attr:`_Chunk.id` is the chunk's own."""
    n = int.from_bytes(raw[4:8], "little") if raw[:4] == b"\xff\xff\xff\xff" else -1
    end = 8 + n
    at = raw.find(b"chunk_", 0, end) if 0 <= n and end <= len(raw) else -1
    if at < 0 or raw.find(b"chunk_", at + 1, end) >= 0 or at + _CHUNK_ID_LEN > end:
        schema = _row_id_checked(pa.ipc.read_schema(pa.ipc.read_message(reader)))  # (not the expected layout)
        return (schema, schema.metadata[b"rerun:id"], *_canon_fields(schema), None)
    key = (at, raw[:at] + raw[at + _CHUNK_ID_LEN:end])  # (equal keys: the same message but for the id)
    hit = _SCHEMAS.get(key)
    chunk_id = raw[at:at + _CHUNK_ID_LEN]
    if hit is None:
        schema = _row_id_checked(pa.ipc.read_schema(pa.ipc.read_message(reader)))  # (once per distinct schema)
        if reader.tell() != end or schema.metadata.get(b"rerun:id") != chunk_id:
            return (schema, schema.metadata[b"rerun:id"], *_canon_fields(schema), None)
        if len(_SCHEMAS) >= 4096:  # (a long-lived worker stays bounded)
            _SCHEMAS.clear()
        fields, log_times = _canon_fields(schema)
        hit = _SCHEMAS[key] = (schema, fields, log_times, _message_parts(fields, schema.metadata, chunk_id))
        return hit[0], chunk_id, hit[1], hit[2], hit[3]
    reader.seek(end)
    return hit[0], chunk_id, hit[1], hit[2], hit[3]


def _serialized_schema(fields: list, metadata, chunk_id: bytes) -> bytes:
    """The schema message of ``fields`` with ``metadata`` (its keys sorted) and ``rerun:id`` =
    ``chunk_id``, serialised by pyarrow (the reference form of :func:`_schema_message`)."""
    md = dict(metadata or {})
    md[b"rerun:id"] = chunk_id
    return pa.schema(fields, metadata=dict(sorted(md.items()))).serialize().to_pybytes()


def _row_id_checked(schema: pa.Schema) -> pa.Schema:
    """``schema``, whose column 0 must be the row ids (``rerun.controls.RowId``, 16-byte binary)."""
    if schema.field(0).name != "rerun.controls.RowId" or schema.field(0).type != pa.binary(16):
        raise CanonicalRrdError(f"chunk without a row-id column: {schema.field(0).name}")
    return schema


def _message_parts(fields: list, metadata, chunk_id: bytes) -> tuple[bytes, bytes] | None:
    """The canonical schema message of ``fields`` with ``metadata`` (:func:`_serialized_schema`)
    before and after its chunk id, serialised with ``chunk_id``: any id of that length spliced
    between the two gives that id's message (the ids all have one length, so the message's layout
    does not depend on which). None if the id does not appear exactly once in the message."""
    message = _serialized_schema(fields, metadata, chunk_id)
    at = message.find(chunk_id)
    if at < 0 or message.find(chunk_id, at + 1) >= 0:
        return None
    return message[:at], message[at + len(chunk_id):]


_MESSAGES: dict = {}  # (fields, metadata without rerun:id) → (fields, :func:`_message_parts`, id length)


def _schema_message(fields: list, metadata, chunk_id: bytes) -> bytes:
    """:func:`_serialized_schema`, its parts around the id made once per distinct schema
    (:func:`_message_parts`) and the chunk id spliced in — for a chunk whose schema message was read
    outside :func:`_chunk_schema`'s cache (a run's hundreds of chunks share a few dozen schemas)."""
    rest = tuple(sorted((k, v) for k, v in (metadata or {}).items() if k != b"rerun:id"))
    key = (id(fields), rest)
    hit = _MESSAGES.get(key)
    if hit is None or hit[0] is not fields or len(chunk_id) != hit[2]:
        parts = _message_parts(fields, metadata, chunk_id)
        if parts is None:  # (the id must appear once: else no splicing)
            return _serialized_schema(fields, metadata, chunk_id)
        if len(_MESSAGES) >= 4096:  # (a long-lived worker stays bounded)
            _MESSAGES.clear()
        hit = _MESSAGES[key] = (fields, parts, len(chunk_id))
    return hit[1][0] + chunk_id + hit[1][1]


_FIELDS: dict = {}  # schema without its metadata → (canonical fields, indices of log_time columns)


def _canon_fields(schema: pa.Schema) -> tuple[list, list]:
    """The fields of ``schema`` with their metadata keys sorted, and which are ``log_time``
    indexes (pyarrow's schema equality ignores the metadata's key order)."""
    key = schema.remove_metadata()
    hit = _FIELDS.get(key)
    if hit is None:
        if len(_FIELDS) >= 4096:  # (a run has a few dozen; a long-lived worker stays bounded)
            _FIELDS.clear()
        fields = [canon_field(f) for f in schema]
        log_times = [j for j, f in enumerate(schema) if (f.metadata or {}).get(b"rerun:index_name") == b"log_time"]
        hit = _FIELDS[key] = (fields, log_times)
    return hit


# ---------------------------------------------------------------- the file
class SdkMessages:
    """The messages of an SDK-written file, parsed as whole messages arrive (:meth:`feed`: the
    file's bytes in order, in pieces as the SDK writes them): store infos, Arrow chunks
    (:class:`_Chunk`) and footer manifests per store, the blueprint activation command."""

    def __init__(self):
        self.header = b""  # the stream header (12 bytes)
        self.stores, self.chunks, self.manifests, self.activation = {}, {}, {}, None
        self.n_chunks = 0
        self._rest = b""  # bytes of a message not yet whole

    def feed(self, data: bytes) -> bool:
        """Parse the whole messages in ``data`` (after what was fed before); True if any."""
        data = self._rest + data if self._rest else data
        i = 0
        if not self.header:
            if len(data) < 12:
                self._rest = data
                return False
            if data[:4] != b"RRF2":
                raise CanonicalRrdError("not a Rerun RRF2 stream")
            self.header, i = data[:12], 12
        stores, chunks = self.stores, self.chunks
        start = i
        while i + 16 <= len(data):
            if data[i:i + 4] == b"RRF2":  # a second stream header (concatenated streams)
                i += 12
                continue
            kind, n = struct.unpack_from("<QQ", data, i)
            end = i + 16 + n + (32 if kind == _END else 0)  # (the End message: then the stream footer)
            if end > len(data):
                break
            body = data[i + 16:i + 16 + n]
            i = end
            if kind == _STORE_INFO:
                info = pb_parse(pb_parse(body)[2][0])
                stores.setdefault(store_key(info[2][0]), info)
            elif kind == _ARROW:
                m = pb_parse(body)
                raw = raw_ipc(m[5][0], m.get(2, [0])[0], m.get(3, [0])[0])
                chunks.setdefault(store_key(m[1][0]), []).append(_Chunk(raw, m.get(7, [0])[0]))
                self.n_chunks += 1
            elif kind == _ACTIVATION:
                self.activation = pb_parse(body)
            elif kind == _END:
                for man in pb_parse(body).get(1, []):
                    parsed = pb_parse(man)
                    self.manifests[store_key(parsed[1][0])] = parsed
        self._rest = data[i:]
        return i > start


def _read(data: bytes):
    """Store infos, Arrow chunks and footer manifests per store, and the blueprint activation
    command, of one SDK-written file (:class:`SdkMessages`)."""
    sdk = SdkMessages()
    sdk.feed(data)
    return sdk.stores, sdk.chunks, sdk.manifests, sdk.activation


def canonicalise(src_path, dst_path, recording_id: str, blueprint_id: str, app_id: str = "mjasc") -> None:
    """Write ``src_path`` (a complete recording written by the Rerun 0.41 SDK: one recording
    store, at most one blueprint store, with its footer) to ``dst_path`` with derived ids
    (module docstring). The same content always gives the same bytes. In steps, for a file the
    SDK is still writing: :func:`~mjasc.runs.rrd_closing.close_canonical`."""
    sdk = SdkMessages()
    with open(src_path, "rb") as f:
        sdk.feed(f.read())
    data = encode_file(sdk, encode_chunks(sdk, recording_id, blueprint_id, app_id))
    with open(dst_path, "wb") as f:
        f.write(data)


class Encoded(NamedTuple):
    """The canonical file up to its footer (:func:`encode_chunks`): ``out``, the stores written
    (the SDK's store key, store id, new chunk ids, chunk spans) and how many chunks were read."""

    out: bytearray
    stores: list
    n_chunks: int


def encode_chunks(sdk: SdkMessages, recording_id: str, blueprint_id: str, app_id: str = "mjasc") -> Encoded:
    """Every store's messages of the canonical file (:func:`canonicalise`) from the chunks ``sdk``
    holds, without the footer (it needs the SDK's manifests: :func:`encode_file`)."""
    stores, chunks, activation = sdk.stores, sdk.chunks, sdk.activation
    by_kind = {k: [s for s in stores if s[0] == k] for k in (_RECORDING, _BLUEPRINT)}
    if len(by_kind[_RECORDING]) != 1 or len(by_kind[_BLUEPRINT]) > 1:
        raise CanonicalRrdError(f"expected one recording and at most one blueprint store, got {sorted(stores)}")
    out = bytearray(b"RRF2" + sdk.header[4:8] + bytes([1, 2, 0, 0]))

    def message(kind: int, body: bytes) -> None:
        out.extend(struct.pack("<QQ", kind, len(body)))
        out.extend(body)

    written = []
    order = [(_BLUEPRINT, blueprint_id)] * len(by_kind[_BLUEPRINT]) + [(_RECORDING, recording_id)]
    for store_no, (kind, new_id) in enumerate(order, start=1):
        old = by_kind[kind][0]
        sid = pb_store_id(kind, new_id, app_id)
        info = stores[old]
        message(_STORE_INFO, pb_bytes(1, pb_tuid(BASE_NS, store_no)) + pb_bytes(
            2, pb_bytes(2, sid) + b"".join(pb_bytes(f, info[f][0]) for f in (5, 6) if f in info)))
        src = chunks.get(old, [])
        # Rank of every row id within the store: the new row ids keep the original order.
        every = np.concatenate([c.row_ids for c in src]) if src else np.empty((0, 2), ">u8")
        rank = np.empty(len(every), np.int64)
        rank[np.lexsort((every[:, 1], every[:, 0]))] = np.arange(len(every))
        counts = np.array([len(c.row_ids) for c in src], dtype=np.int64)
        if src and not counts.all():
            raise CanonicalRrdError("a chunk without rows")
        starts = np.concatenate([[0], np.cumsum(counts)])
        first = np.minimum.reduceat(rank, starts[:-1]) if src else rank
        head = pb_bytes(1, sid) + pb_int(2, 2)
        tail = pb_int(4, 1)
        new_ids, spans = {}, {}
        for k, ci in enumerate(np.argsort(first, kind="stable").tolist()):
            chunk = src[ci]
            inc = store_no << 40 | k
            new_ids[chunk.id] = (k, inc)
            ids = np.empty((counts[ci], 2), ">u8")
            ids[:, 0], ids[:, 1] = BASE_NS, rank[starts[ci]:starts[ci + 1]] + 1
            ipc = chunk.ipc(ids, f"chunk_{BASE_NS:016X}{inc:016x}".encode())
            body = (head + pb_int(3, len(ipc)) + tail + pb_bytes(5, LZ4.compress(ipc, asbytes=True))
                    + pb_bytes(6, pb_tuid(BASE_NS, inc)) + pb_int(7, chunk.is_static))
            spans[k] = (len(out) + 16, len(body), len(ipc))
            message(_ARROW, body)
        if kind == _BLUEPRINT and activation is not None:
            message(_ACTIVATION, pb_bytes(1, sid) + b"".join(pb_int(f, 1) for f in (2, 3)
                                                               if activation.get(f, [0])[0]))
        written.append((old, sid, new_ids, spans))
    return Encoded(out, written, sdk.n_chunks)


def encode_file(sdk: SdkMessages, encoded: Encoded) -> bytearray:
    """The canonical file: ``encoded.out`` (:func:`encode_chunks` of ``sdk``'s chunks) completed
    with its footer from the SDK's manifests."""
    out, footer = encoded.out, []
    for old, sid, new_ids, spans in encoded.stores:
        if spans:
            if old not in sdk.manifests:
                raise CanonicalRrdError(f"store {old[1]} has no footer manifest (the file was not closed)")
            footer.append(rebuild_manifest(sdk.manifests[old], sid, new_ids, spans))
    rrd_footer = b"".join(pb_bytes(1, m) for m in footer)
    out += struct.pack("<QQ", _END, len(rrd_footer)) + rrd_footer
    out += struct.pack("<QQI", len(out) - len(rrd_footer), len(rrd_footer), xxh32(rrd_footer, _XXH_SEED))
    out += b"RRF2FOOT" + struct.pack("<I", 1)
    return out
