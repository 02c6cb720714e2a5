"""Stopping a run from outside: Ctrl-C (SIGINT) and SIGTERM become one exception in the main loop.

Python turns SIGINT into ``KeyboardInterrupt`` at the next bytecode of the main thread. SIGTERM
(``kill``, a batch system's stop, ``docker stop``) ends the process at once unless handled:
:func:`catch_sigterm` installs a handler that raises :class:`Terminated`, a ``KeyboardInterrupt``,
so the runner handles both alike — it closes the recording and writes the summary (status
``interrupted``). Signals can only be handled in the main thread: elsewhere (a Dask worker's
thread) nothing is installed. SIGKILL cannot be handled: the files then stay under their
temporary names (:mod:`mjasc.runs.outputs`), never half-written under their own.

A signal that arrives while a compiled kernel's result is being converted back to Python objects
surfaces as the ``SystemError`` "returned a result with an exception set", the interrupt as its
context: :func:`interrupt_behind` finds it, and the run counts as interrupted, not failed.
"""

from __future__ import annotations

import signal
import threading

__all__ = ["Terminated", "catch_sigterm", "restore_sigterm", "signal_name", "interrupt_behind"]


class Terminated(KeyboardInterrupt):
    """SIGTERM arrived while a run went (raised by the handler :func:`catch_sigterm` installs)."""


def _raise_terminated(signum, frame):
    raise Terminated(signal.Signals(signum).name)


def catch_sigterm():
    """SIGTERM → :class:`Terminated` from now on; returns the previous handler (for
    :func:`restore_sigterm`), or None when not called from the main thread (nothing installed)."""
    if threading.current_thread() is not threading.main_thread():
        return None
    return signal.signal(signal.SIGTERM, _raise_terminated)


def restore_sigterm(previous) -> None:
    """Put back the handler :func:`catch_sigterm` returned (None: nothing to do)."""
    if previous is not None:
        signal.signal(signal.SIGTERM, previous)


def signal_name(exc: KeyboardInterrupt) -> str:
    """``"SIGTERM"`` for :class:`Terminated`, ``"SIGINT"`` for any other KeyboardInterrupt."""
    return "SIGTERM" if isinstance(exc, Terminated) else "SIGINT"


def interrupt_behind(exc: BaseException) -> KeyboardInterrupt | None:
    """The ``KeyboardInterrupt`` (Ctrl-C or :class:`Terminated`) that ``exc`` was raised from or
    while handling (its ``__cause__`` / ``__context__`` chain), or None."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return exc
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return None
