"""The container's wire format under :mod:`mjasc.runs.rrd_canonical`: protobuf's varints and
fields (written and read: Rerun 0.41's log messages are protobuf, their field numbers are in the
callers), the LZ4 blocks around the messages' Arrow IPC streams and the xxHash32 checksum of the
stream footer.

Written here rather than taken from a protobuf or xxhash package: the messages are a handful of
fields, and re-encoding must not depend on a second library's version. xxHash32 follows Yann
Collet's reference algorithm (tests/test_recording_determinism.py checks it against known digests
and the SDK's own footers).
"""

from __future__ import annotations

import functools
import struct

import numpy as np
import pyarrow as pa

from mjasc.core.compiled import kernel

__all__ = ["BASE_NS", "IPC_EOS", "LZ4", "raw_ipc", "CanonicalRrdError", "varint", "pb_int", "pb_fixed64", "pb_bytes",
           "pb_tuid", "pb_store_id", "read_varint", "pb_parse", "store_key", "xxh32"]


#: The time part of every synthetic id (row, chunk, store) and of ``log_time`` in a canonical
#: recording: 2020-01-01T00:00:00Z [ns].
BASE_NS = 1_577_836_800_000_000_000


#: The LZ4 block codec of the SDK's compressed messages (chunks and footer manifests).
LZ4 = pa.Codec("lz4_raw")
#: The end of an Arrow IPC stream.
IPC_EOS = b"\xff\xff\xff\xff\x00\x00\x00\x00"


def raw_ipc(payload: bytes, compression: int, size: int) -> bytes:
    """A message's Arrow IPC stream: ``payload`` LZ4-decompressed to ``size`` bytes when
    ``compression`` is 2 (LZ4), else as it is."""
    return LZ4.decompress(payload, decompressed_size=size, asbytes=True) if compression == 2 else payload


class CanonicalRrdError(ValueError):
    """The file is not a complete Rerun 0.41 recording of the expected shape."""


# ---------------------------------------------------------------- protobuf wire format
_BYTE = tuple(bytes((b,)) for b in range(0x80))


def varint(n: int) -> bytes:
    if n < 0x80:  # (most: field keys, flags, small lengths)
        return _BYTE[n]
    out = bytearray()
    while True:
        b, n = n & 0x7F, n >> 7
        out.append(b | (0x80 if n else 0))
        if not n:
            return bytes(out)


def pb_int(field: int, v: int) -> bytes:
    return varint(field << 3) + varint(v)


def pb_fixed64(field: int, v: int) -> bytes:
    return varint(field << 3 | 1) + struct.pack("<Q", v)


def pb_bytes(field: int, b: bytes | str) -> bytes:
    b = b.encode() if isinstance(b, str) else b
    return varint(field << 3 | 2) + varint(len(b)) + b


def pb_tuid(t_ns: int, inc: int) -> bytes:
    return b"\x09" + struct.pack("<Q", t_ns) + b"\x11" + struct.pack("<Q", inc)  # fields 1, 2: fixed64


def pb_store_id(kind: int, store: str, app: str) -> bytes:
    return pb_int(1, kind) + pb_bytes(2, store) + pb_bytes(3, pb_bytes(1, app))


def read_varint(b, i: int) -> tuple[int, int]:
    r = s = 0
    while True:
        x = b[i]
        i += 1
        r |= (x & 0x7F) << s
        s += 7
        if x < 0x80:
            return r, i


def pb_parse(b) -> dict[int, list]:
    """Field number → values (int for varint / fixed64, bytes for length-delimited). (One-byte
    keys, values and lengths — most of them — are read without :func:`read_varint`'s call.)"""
    out: dict[int, list] = {}
    i, n_b = 0, len(b)
    while i < n_b:
        key = b[i]
        i += 1
        if key >= 0x80:
            key, i = read_varint(b, i - 1)
        wire = key & 7
        if wire == 0:
            v = b[i]
            i += 1
            if v >= 0x80:
                v, i = read_varint(b, i - 1)
        elif wire == 2:
            n = b[i]
            i += 1
            if n >= 0x80:
                n, i = read_varint(b, i - 1)
            v = bytes(b[i:i + n])
            i += n
        elif wire == 1:
            v, i = struct.unpack_from("<Q", b, i)[0], i + 8
        else:
            raise CanonicalRrdError(f"unsupported protobuf wire type {wire}")
        got = out.get(key >> 3)
        if got is None:
            out[key >> 3] = [v]
        else:
            got.append(v)
    return out


@functools.lru_cache(maxsize=16)
def store_key(store_id: bytes) -> tuple[int, str]:
    s = pb_parse(store_id)
    return s.get(1, [0])[0], s[2][0].decode()


def xxh32(data: bytes, seed: int) -> int:
    """xxHash32 of ``data`` with ``seed`` (the stream footer's checksum; the footer of a 50-vessel
    recording is ~4 MB): :func:`_xxh32_words` over the little-endian 32-bit words."""
    n = len(data)
    words = np.frombuffer(data, "<u4", n // 4)
    tail = np.frombuffer(data, np.uint8)[n - n % 4:]
    return int(_xxh32_words(words, tail, n, seed & 0xFFFFFFFF))


@kernel
def _rotl32(x, r):
    """x (< 2³², uint64) rotated left by r (uint64) bits within 32 bits."""
    return ((x << r) | (x >> (np.uint64(32) - r))) & np.uint64(0xFFFFFFFF)


@kernel
def _xxh32_words(words, tail, n, seed):
    """xxHash32 (Yann Collet's reference algorithm) in unsigned 64-bit arithmetic masked to 32 bits
    (every operand uint64: numba would turn mixed signed/unsigned integers into floats): four
    lanes over 16-byte stripes, the merge, the remaining words and bytes, the avalanche."""
    u = np.uint64
    p1, p2, p3, p4, p5, m = u(2654435761), u(2246822519), u(3266489917), u(668265263), u(374761393), u(0xFFFFFFFF)
    seed, n_bytes = u(seed), u(n)
    i = 0
    if n >= 16:
        v = np.empty(4, dtype=np.uint64)
        v[0], v[1], v[2], v[3] = (seed + p1 + p2) & m, (seed + p2) & m, seed, (seed + (u(1) << u(32)) - p1) & m
        while 4 * i + 16 <= n:
            for j in range(4):
                v[j] = _rotl32((v[j] + u(words[i + j]) * p2) & m, u(13)) * p1 & m
            i += 4
        h = (_rotl32(v[0], u(1)) + _rotl32(v[1], u(7)) + _rotl32(v[2], u(12)) + _rotl32(v[3], u(18))) & m
    else:
        h = (seed + p5) & m
    h = (h + n_bytes) & m
    while i < words.size:
        h = _rotl32((h + u(words[i]) * p3) & m, u(17)) * p4 & m
        i += 1
    for j in range(tail.size):
        h = _rotl32((h + u(tail[j]) * p5) & m, u(11)) * p1 & m
    h ^= h >> u(15)
    h = h * p2 & m
    h ^= h >> u(13)
    h = h * p3 & m
    return h ^ (h >> u(16))
