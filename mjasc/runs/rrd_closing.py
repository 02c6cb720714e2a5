"""Closing a recording: the Rerun SDK's last writes and the canonical re-encoding, overlapped.

When :meth:`~mjasc.runs.recording.Recorder.close` has handed the SDK its last columns, the SDK
encodes them and writes them to the file on its own threads (``flush``), then builds and writes the
footer (``disconnect``): waits of ~5 and ~6 ms on a §6.4.1 crossing run (~9 and ~10 ms on a slower
host) during which the main thread had nothing to do, the Python bindings releasing the GIL.
:func:`close_canonical` makes each SDK call on a thread of its own and meanwhile parses the chunks
as they reach the file (:class:`~mjasc.runs.rrd_canonical.SdkMessages`), then re-encodes them
(:func:`~mjasc.runs.rrd_canonical.encode_chunks`) while the SDK writes the footer, whose manifests
come last (:func:`~mjasc.runs.rrd_canonical.encode_file`). The bytes are
:func:`~mjasc.runs.rrd_canonical.canonicalise`'s: a chunk that reached the file after the
re-encoding began (none does: ``flush`` returns once every chunk is written) has it done again.
"""

from __future__ import annotations

import threading
from pathlib import Path
from typing import Callable

from mjasc.runs.rrd_canonical import CanonicalRrdError, SdkMessages, encode_chunks, encode_file

__all__ = ["ReencodingError", "close_canonical", "meanwhile"]

_POLL_S = 0.0005  # how long the main thread waits for the SDK between two reads of the file [s]


def meanwhile(call: Callable[[], None], work: Callable[[], bool]) -> Exception | None:
    """``call()`` on a thread while ``work()`` runs here, again and again until the call is done
    (``work`` returns False when it had nothing to do: then wait a little). An exception of
    ``call`` is raised here; the first of ``work`` stops the work and is returned."""
    failed: list[BaseException] = []

    def run() -> None:
        try:
            call()
        except BaseException as e:  # noqa: BLE001 - raised again on the main thread
            failed.append(e)

    thread = threading.Thread(target=run, name="mjasc-rerun-close", daemon=True)
    thread.start()
    error = None
    try:
        busy = True
        while thread.is_alive():
            if busy:
                try:
                    busy = work()
                except Exception as e:  # noqa: BLE001 - the caller's to report
                    busy, error = False, e
            if not busy:
                thread.join(_POLL_S)
    finally:
        thread.join()  # (an interrupt here still lets the SDK finish its call first)
    if failed:
        raise failed[0]
    return error


class ReencodingError(Exception):
    """The re-encoding of a finished recording failed (its cause says why); the SDK's file is complete."""


def close_canonical(part: Path, canonical: Path, ids: tuple[str, str], flush: Callable[[], None],
                    disconnect: Callable[[], None]) -> None:
    """Finish the SDK's file ``part`` (``flush``, ``disconnect``: the SDK's calls, whose exceptions
    are raised here as they are) and write it re-encoded to ``canonical``
    (:func:`~mjasc.runs.rrd_canonical.canonicalise` with ``ids`` (recording, blueprint)). A
    failure of the re-encoding is raised as :class:`ReencodingError` once both SDK calls are done
    (the SDK's file complete)."""
    sdk = SdkMessages()
    encoded = error = None
    try:
        f = open(part, "rb")
    except OSError as e:
        f, error = None, e

    def read() -> bool:
        return f is not None and sdk.feed(f.read())

    def encode() -> bool:
        nonlocal encoded
        encoded = encode_chunks(sdk, *ids)
        return False

    try:
        error = meanwhile(flush, read) or error
        if error is None:
            try:
                read()  # (every chunk is written once flush is done)
            except Exception as e:  # noqa: BLE001 - raised below, after the SDK closed its file
                error = e
        meanwhile(disconnect, encode if error is None else lambda: False)  # (encode's error: again below)
        if error is None:
            try:
                read()  # the footer
                if not sdk.manifests and sdk.n_chunks:
                    raise CanonicalRrdError(f"{part}: no footer after the SDK closed the file")
                if encoded is None or encoded.n_chunks != sdk.n_chunks:  # (chunks written after the flush: again)
                    encoded = encode_chunks(sdk, *ids)
                data = encode_file(sdk, encoded)
                with open(canonical, "wb") as out:
                    out.write(data)
                return
            except Exception as e:  # noqa: BLE001 - raised below
                error = e
    finally:
        if f is not None:
            f.close()
    raise ReencodingError(f"{type(error).__name__}: {error}") from error
