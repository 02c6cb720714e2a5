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
:func:`leave_with` was called. So does a process where another exit handler was registered before
this module was imported (a ``sitecustomize``, coverage's subprocess measurement, an interactive
shell): leaving first would skip that handler, so the usual exit is kept there. Leaving flushes C's
stdio buffers too (a library's ``printf`` to a pipe) and, as the usual exit does, ends with status
120 when stdout or stderr cannot be flushed (a full disk), except for a reader that left (a
closed pipe: the command's own status).
"""

from __future__ import annotations

import atexit
import ctypes
import os
import sys

__all__ = ["leave_with"]

_status: int | None = None  # the exit status to leave with, once the program's command returned
#: Whether the handler below is the first registered (then it runs last): else the usual exit is kept.
ARMED = getattr(atexit, "_ncallbacks", lambda: 1)() == 0  # (no way to tell: the usual exit)


def leave_with(status: int) -> None:
    """End the process with ``status`` (0–255) once every other exit handler has run."""
    global _status
    if not (isinstance(status, int) and 0 <= status <= 255):
        raise ValueError(f"exit status: must be an int in 0–255, got {status!r}")
    if ARMED:
        _status = status


def _leave() -> None:
    if _status is None:
        return
    status = _status
    for stream in (sys.stdout, sys.stderr):
        try:
            if stream is not None and not stream.closed:
                stream.flush()
        except BrokenPipeError:  # the reader left: nothing more to say, leave with the command's status
            pass
        except OSError:  # as the usual exit: a stream that cannot be flushed ends with 120
            status = 120
    try:
        ctypes.CDLL(None).fflush(None)  # (C's stdio: what a library printed)
    except (OSError, AttributeError):  # (no C library to ask: nothing of C's to flush)
        pass
    os._exit(status)


atexit.register(_leave)  # (registered at mjasc.cli's import: the last exit handler to run)
