"""Closing a recording with the SDK's last writes and the re-encoding overlapped
(mjasc.runs.rrd_closing) gives canonicalise's bytes, whenever the chunks reach the file."""

import struct
import threading
import time
import warnings
from pathlib import Path

import numpy as np
import pytest
import rerun as rr

from mjasc.runs import recording, rrd_canonical, rrd_closing
from mjasc.runs.recording import Recorder, default_blueprint
from mjasc.runs.rrd_canonical import canonicalise
from mjasc.runs.rrd_closing import ReencodingError, close_canonical, meanwhile

IDS = ("rec-id", "bp-id")


def _sdk_file(tmp_path: Path) -> bytes:
    """A finished SDK file (a blueprint, statics and columns) as the SDK wrote it."""
    kept = []
    original = recording.close_canonical

    def keep(part, *args):
        original(part, *args)
        kept.append(Path(part).read_bytes())

    recording.close_canonical = keep
    try:
        rec = Recorder(tmp_path / "r.rrd", "closing", 1, default_blueprint(vessels=("a", "b"), avoidance=True))
        for k in range(30):
            rec.static(f"world/s{k}", rr.Points3D([[k, 0.0, 0.0]]))
        for k in range(200):
            rec.scalar(f"plots/x{k % 20}", 0.1 * k, float(k))
            rec.points("world/p", 0.1 * k, np.array([[k, 1.0]]))
        rec.close()
    finally:
        recording.close_canonical = original
    return kept[0]


def _messages(data: bytes) -> list[bytes]:
    """The file's stream header and messages (the End message with the stream footer), in order."""
    out, i = [data[:12]], 12
    while i < len(data):
        kind, n = struct.unpack_from("<QQ", data, i)
        end = i + 16 + n + (32 if kind == 0 else 0)
        out.append(data[i:end])
        i = end
    return out


@pytest.mark.parametrize("late", [0, 1, 5])
def test_closing_gives_canonicalise_bytes_however_late_the_chunks_come(tmp_path, late):
    """The SDK's file written in three parts: before the flush, during it and — ``late`` chunks
    after the re-encoding began — during the disconnect, as a slow SDK would."""
    sdk = _sdk_file(tmp_path)
    canonicalise(_write(tmp_path / "sdk.rrd", sdk), tmp_path / "ref.rrd", *IDS)
    msgs = _messages(sdk)
    arrow = [k for k, m in enumerate(msgs) if k and struct.unpack_from("<Q", m)[0] == 2]
    first, last = arrow[len(arrow) // 2], len(msgs) - 1 - late  # (the End message is last)
    part = tmp_path / "part.rrd"
    part.write_bytes(b"".join(msgs[:first]))

    def append(pieces, wait_s=0.0):
        def call():
            time.sleep(wait_s)
            with open(part, "ab") as f:
                for p in pieces:  # (message by message, as the SDK's writer)
                    f.write(p)
                    f.flush()
        return call

    close_canonical(part, tmp_path / "out.rrd", IDS, append(msgs[first:last], 0.02), append(msgs[last:], 0.05))
    assert (tmp_path / "out.rrd").read_bytes() == (tmp_path / "ref.rrd").read_bytes()


def _write(path: Path, data: bytes) -> Path:
    path.write_bytes(data)
    return path


def test_a_failed_reencoding_keeps_the_complete_sdk_file(tmp_path, monkeypatch):
    def broken(*args):
        raise rrd_canonical.CanonicalRrdError("broken on purpose")

    monkeypatch.setattr(rrd_closing, "encode_file", broken)
    rec = Recorder(tmp_path / "r.rrd", "closing", 2, default_blueprint())
    rec.scalar("plots/x", 0.0, 1.0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rec.close()
    assert any("broken on purpose" in str(w.message) for w in caught)
    data = (tmp_path / "r.rrd").read_bytes()
    assert data.endswith(b"RRF2FOOT" + struct.pack("<I", 1))  # the SDK's footer: a complete file
    assert not list(tmp_path.glob(".*part*"))
    calls = []
    with pytest.raises(ReencodingError, match="No such file"):
        close_canonical(tmp_path / "missing.rrd", tmp_path / "o.rrd", IDS, lambda: calls.append("flush"),
                        lambda: calls.append("disconnect"))
    assert calls == ["flush", "disconnect"]  # (the SDK's file is finished whatever happens)


def test_meanwhile_raises_the_calls_error_and_returns_the_works():
    done = threading.Event()

    def slow():
        time.sleep(0.02)
        done.set()

    def bad_work():
        raise ValueError("work")

    assert isinstance(meanwhile(slow, bad_work), ValueError) and done.is_set()  # (the call ran to its end)
    calls = []
    assert meanwhile(lambda: time.sleep(0.01), lambda: calls.append(1) or len(calls) < 3) is None and len(calls) == 3

    def failing():
        raise RuntimeError("sdk")

    with pytest.raises(RuntimeError, match="sdk"):
        meanwhile(failing, lambda: False)
