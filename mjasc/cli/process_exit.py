"""Leaving the ``mjasc`` program without the interpreter's final clean-up.

When a command has returned, everything it wrote is closed (a run's recording, video and summary;
a campaign's store, exports and cluster). What Python does after that — tearing down every module
and a last garbage collection of MuJoCo, numba's compiled kernels, SciPy, Rerun and Dask — changes
nothing the user sees and took ~0.4–0.6 s of wall time per command on the project's machines (a
thesis scenario's whole run takes ~1 s). So the program (:func:`mjasc.cli.command_line`, the
console script and ``python -m mjasc``) asks :func:`leave_with` for its exit status, and the exit
handler registered here — when this module is imported by :mod:`mjasc.cli`, before anything else
registers one, so it runs last: after logging's flush, multiprocessing's and Dask's handlers and
every ``weakref.finalize`` — flushes stdout and stderr and ends the process with that status.

A command that raised exits as usual (its traceback printed as usual); so does every use of
:func:`mjasc.cli.main` as a function (tests, scripts): the handler does nothing unless
:func:`leave_with` was called.
"""

from __future__ import annotations

import atexit
import os
import sys

__all__ = ["leave_with"]

_status: int | None = None  # the exit status to leave with, once the program's command returned


def leave_with(status: int) -> None:
    """End the process with ``status`` (0–255) once every other exit handler has run."""
    global _status
    if not (isinstance(status, int) and 0 <= status <= 255):
        raise ValueError(f"exit status: must be an int in 0–255, got {status!r}")
    _status = status


def _leave() -> None:
    if _status is None:
        return
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except Exception:  # noqa: BLE001 — a closed pipe: nothing more to say, leave all the same
        pass
    os._exit(_status)


atexit.register(_leave)  # (registered at mjasc.cli's import: the last exit handler to run)
