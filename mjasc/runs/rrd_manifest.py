"""The footer of the canonical recording (:mod:`mjasc.runs.rrd_canonical`): each store's chunk
manifest — an Arrow record batch, one row per chunk, that Rerun's reader and viewer use to load a
file lazily — rebuilt from the one the SDK wrote, with the new store and chunk ids, byte offsets
and sizes, rows in the new order, ``log_time`` at :data:`~mjasc.runs.rrd_wire.BASE_NS` and
every schema's metadata keys sorted.
"""

from __future__ import annotations

import hashlib

import numpy as np
import pyarrow as pa

from mjasc.runs.rrd_wire import BASE_NS, IPC_EOS, LZ4, CanonicalRrdError, pb_bytes, pb_int, pb_parse, raw_ipc

__all__ = ["canon_field", "rebuild_manifest"]


def _sorted(md):
    return dict(sorted(md.items())) if md else None


def canon_field(f: pa.Field) -> pa.Field:
    """``f`` with its metadata keys sorted (``f`` itself when they are: the same field)."""
    md = f.metadata
    if not md:
        return f
    keys = list(md)
    return f if keys == sorted(keys) else f.with_metadata(_sorted(md))


def _canon_schema(schema: pa.Schema, sort_fields: bool = False) -> pa.Schema:
    """``schema`` with every metadata's keys sorted (and its fields by name: ``sort_fields``)."""
    fields = [canon_field(f) for f in schema]
    if sort_fields:
        fields.sort(key=lambda f: f.name.encode())
    return pa.schema(fields, metadata=_sorted(schema.metadata))


def _ipc(batch: pa.RecordBatch | None, schema: pa.Schema | None = None) -> bytes:
    """One Arrow IPC stream: the schema, the batch if any, end of stream."""
    sink = pa.BufferOutputStream()
    with pa.ipc.new_stream(sink, batch.schema if batch is not None else schema) as w:
        if batch is not None:
            w.write_batch(batch)
    return sink.getvalue().to_pybytes()


def _read_ipc(payload: bytes, compression: int, size: int) -> pa.RecordBatch:
    return pa.ipc.open_stream(raw_ipc(payload, compression, size)).read_next_batch()


def _tuids(t_ns: int, incs) -> pa.Array:
    buf = np.empty((len(incs), 2), dtype=">u8")
    buf[:, 0], buf[:, 1] = t_ns, incs
    return pa.Array.from_buffers(pa.binary(16), len(incs), [None, pa.py_buffer(buf.tobytes())])


def _fixed_log_time(batch: pa.RecordBatch, is_log_time) -> pa.RecordBatch:
    """``batch`` with every ``log_time`` column (``is_log_time(field)``, 64-bit values) at
    :data:`BASE_NS` where it has a value and null (value 0) where it has none."""
    cols = list(batch.columns)
    for j, f in enumerate(batch.schema):
        if is_log_time(f):
            cols[j] = _constant_where_valid(cols[j], BASE_NS)
    return pa.RecordBatch.from_arrays(cols, schema=batch.schema)


def _constant_where_valid(c: pa.Array, value: int) -> pa.Array:
    """An array of ``c``'s type (64-bit values) holding ``value`` where ``c`` has a value and null,
    with a 0 value, where it is null (``if_else(is_null, nulls, value)``'s array, built from buffers)."""
    n = len(c)
    if not c.null_count:
        return pa.Array.from_buffers(c.type, n, [None, pa.py_buffer(np.full(n, value, dtype="<i8"))])
    bits = np.unpackbits(np.frombuffer(c.buffers()[0], np.uint8), bitorder="little")[c.offset:c.offset + n]
    valid = bits.astype(bool)
    values = np.where(valid, np.int64(value), np.int64(0)).astype("<i8")
    return pa.Array.from_buffers(c.type, n, [pa.py_buffer(np.packbits(valid, bitorder="little")), pa.py_buffer(values)],
                                 null_count=c.null_count)


def rebuild_manifest(man: dict, sid: bytes, new_ids: dict, spans: dict) -> bytes:
    """The SDK's footer manifest of one store with the new store id, chunk ids, offsets and sizes."""
    sorbet = _canon_schema(pa.ipc.read_schema(pa.py_buffer(pb_parse(man[2][0])[1][0])), sort_fields=True)
    sorbet_ipc = _ipc(None, sorbet)  # (the schema message and the end of stream)
    # The hash is over the schema without its own metadata (it has none: the message itself then).
    sha = hashlib.sha256(pa.schema(list(sorbet)).serialize().to_pybytes() if sorbet.metadata
                         else sorbet_ipc[:-len(IPC_EOS)]).digest()
    part = pb_parse(man[4][0])
    batch = _read_ipc(part[2][0], part.get(3, [0])[0], part.get(4, [0])[0])
    ids = batch.column("chunk_id")  # (fixed_size_binary[16]: big-endian time and counter)
    if ids.null_count:
        raise CanonicalRrdError("the footer has a chunk without an id")
    ids = np.frombuffer(ids.buffers()[1], ">u8", 2 * len(ids), 16 * ids.offset).reshape(-1, 2).tolist()
    olds = [b"chunk_%016X%016x" % (time_ns, counter) for time_ns, counter in ids]
    try:
        ks = [new_ids[c][0] for c in olds]
    except KeyError as e:
        raise CanonicalRrdError(f"the footer names a chunk the file does not hold: {e}") from None
    if sorted(ks) != list(range(len(spans))):
        raise CanonicalRrdError("the footer's chunks do not match the file's")
    cols = dict(zip(batch.schema.names, batch.columns))
    cols["chunk_id"] = _tuids(BASE_NS, np.array([new_ids[c][1] for c in olds], dtype=np.uint64))
    for j, name in enumerate(("chunk_byte_offset", "chunk_byte_size", "chunk_byte_size_uncompressed")):
        cols[name] = pa.array([spans[k][j] for k in ks], pa.uint64())
    batch = pa.RecordBatch.from_arrays([cols[n] for n in batch.schema.names], schema=batch.schema)
    batch = _fixed_log_time(batch, lambda f: pa.types.is_timestamp(f.type)  # (the type first: it is cheap)
                            and (f.metadata or {}).get(b"rerun:index") == b"log_time")
    batch = batch.take(pa.array(np.argsort(ks)))
    ipc = _ipc(pa.RecordBatch.from_arrays(batch.columns, schema=_canon_schema(batch.schema)))
    data = pb_int(1, 1) + pb_bytes(2, LZ4.compress(ipc, asbytes=True)) + pb_int(3, 2) + pb_int(4, len(ipc))
    return pb_bytes(1, sid) + pb_bytes(2, pb_bytes(1, sorbet_ipc)) + pb_bytes(3, sha) + pb_bytes(4, data)
