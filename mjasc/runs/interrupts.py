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

A signal that arrives while the garbage collector runs a finalizer (``__del__``: numba's and
llvmlite's objects have them, and a first run compiles kernels for minutes) raises its exception
inside the finalizer, where Python cannot propagate it: it would print "Exception ignored in …"
with a traceback and lose the interrupt. While :func:`catch_sigterm` is in force,
``sys.unraisablehook`` keeps such an interrupt in :data:`PENDING` instead (:func:`_redeliver`),
silently, and the runner's loop raises it before its next event: the run stops as it would have.
(Sending the signal again from the hook does not work: its handler runs inside the hook.)
"""

from __future__ import annotations

import signal
import sys
import threading

__all__ = ["Terminated", "catch_sigterm", "restore_sigterm", "signal_name", "interrupt_behind", "PENDING",
           "raise_pending"]


class Terminated(KeyboardInterrupt):
    """SIGTERM arrived while a run went (raised by the handler :func:`catch_sigterm` installs)."""


def _raise_terminated(signum, frame):
    raise Terminated(signal.Signals(signum).name)


_HOOKS: list = []  # the unraisable hooks _redeliver replaced, innermost last
#: Interrupts raised inside a finalizer while a run was interruptible, not yet raised again
#: (the runner's loop: ``if PENDING: raise_pending()``; a campaign's, before each run or result).
PENDING: list = []


def _redeliver(unraisable) -> None:
    """``sys.unraisablehook`` while a run is interruptible: an interrupt raised inside a finalizer
    is kept in :data:`PENDING` (module docstring); anything else goes to the hook in force before."""
    exc = unraisable.exc_value
    if isinstance(exc, KeyboardInterrupt):
        PENDING.append(exc)
        return
    (_HOOKS[-1] if _HOOKS else sys.__unraisablehook__)(unraisable)


def raise_pending() -> None:
    """Raise the first interrupt kept in :data:`PENDING` (and forget them all); nothing if none."""
    if PENDING:
        exc = PENDING[0]
        PENDING.clear()
        raise exc


def catch_sigterm():
    """SIGTERM → :class:`Terminated` from now on, and an interrupt raised inside a finalizer sent
    again (:func:`_redeliver`); returns the previous handler (for :func:`restore_sigterm`), or None
    when not called from the main thread (nothing installed)."""
    if threading.current_thread() is not threading.main_thread():
        return None
    _HOOKS.append(sys.unraisablehook)
    sys.unraisablehook = _redeliver
    PENDING.clear()
    return signal.signal(signal.SIGTERM, _raise_terminated)


def restore_sigterm(previous) -> None:
    """Put back the handler :func:`catch_sigterm` returned and the unraisable hook it replaced
    (None: nothing to do)."""
    if previous is not None:
        signal.signal(signal.SIGTERM, previous)
        if _HOOKS:
            sys.unraisablehook = _HOOKS.pop()
        PENDING.clear()


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
