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

A signal must not land either while llvmlite makes or releases an LLVM object: an exception
raised as ``ObjectRef.__init__`` begins (``ValueRef.__init__`` calls it last) leaves an object
without its pointer attribute, one raised inside ``detach`` an object half released, and either's
finalizer later fails with an ``AttributeError`` that Python prints as "Exception ignored in …", a
traceback (seen once in CI: SIGTERM at t = 0.2 s, a ``ValueRef``). So the handlers
:func:`catch_sigterm` installs — for SIGTERM, and for SIGINT where Python's own handler is in
force — look first at where the signal landed (:func:`_in_release`): inside a finalizer, or
inside llvmlite's ``__init__`` or ``detach``, they keep the interrupt in :data:`PENDING` and
return, and it is raised, as above, at the runner's next event (also after its last one). Those
are a few bytecodes each, so anywhere else — nearly always — they raise at once, and Ctrl-C still
stops a first run's minutes of compiling. A signal that lands in one of them during such a compile
waits for the compile to end (the next event), which is rare.
"""

from __future__ import annotations

import signal
import sys
import threading

__all__ = ["Terminated", "catch_sigterm", "restore_sigterm", "signal_name", "interrupt_behind", "PENDING",
           "raise_pending"]


class Terminated(KeyboardInterrupt):
    """SIGTERM arrived while a run went (raised by the handler :func:`catch_sigterm` installs)."""


#: Where llvmlite makes and releases its LLVM objects (module docstring): its functions of these
#: names in its ``binding`` package; and a finalizer anywhere.
_LLVMLITE_BINDING = "/llvmlite/binding/"
_UNSAFE = frozenset({"__init__", "detach"})


def _in_release(frame) -> bool:
    """Whether ``frame`` (where a signal's handler was called) or a caller is a finalizer
    (``__del__``) or llvmlite making or releasing an object (``__init__``, ``detach`` in its binding
    package) — where an exception would leave an object half made or half released (module
    docstring)."""
    while frame is not None:
        code = frame.f_code
        if code.co_name == "__del__" or (code.co_name in _UNSAFE and _LLVMLITE_BINDING in
                                         code.co_filename.replace("\\", "/")):
            return True
        frame = frame.f_back
    return False


def _interrupt(signum, frame):
    """The handler of SIGTERM (→ :class:`Terminated`) and SIGINT (→ ``KeyboardInterrupt``): raised
    at once, or kept in :data:`PENDING` when the signal landed in a release (:func:`_in_release`)."""
    exc = Terminated(signal.Signals(signum).name) if signum == signal.SIGTERM else KeyboardInterrupt()
    if _in_release(frame):
        PENDING.append(exc)
        return
    raise exc


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
    """SIGTERM → :class:`Terminated` from now on, SIGINT → ``KeyboardInterrupt`` as before, both
    kept for later when they land in a release (:func:`_interrupt`), and an interrupt raised inside
    a finalizer kept too (:func:`_redeliver`). SIGINT is left alone unless Python's own handler is
    in force (an ignored Ctrl-C stays ignored). Returns the previous handlers (for
    :func:`restore_sigterm`), or None when not called from the main thread (nothing installed).
    Calls nest: an inner one keeps what the outer one holds in :data:`PENDING`."""
    if threading.current_thread() is not threading.main_thread():
        return None
    if not _HOOKS:
        PENDING.clear()
    _HOOKS.append(sys.unraisablehook)
    sys.unraisablehook = _redeliver
    previous_int = None
    if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        previous_int = signal.signal(signal.SIGINT, _interrupt)
    return signal.signal(signal.SIGTERM, _interrupt), previous_int


def restore_sigterm(previous) -> KeyboardInterrupt | None:
    """Put back the handlers :func:`catch_sigterm` returned and the unraisable hook it replaced
    (None: nothing to do). Returns the interrupt still kept in :data:`PENDING` when this was the
    outermost call — one that landed after its caller's last look — and forgets it: the caller
    raises it once its outputs are complete (a command then ends as interrupted); an inner call
    leaves it to the outer one and returns None."""
    if previous is None:
        return None
    previous_term, previous_int = previous
    signal.signal(signal.SIGTERM, signal.SIG_DFL if previous_term is None else previous_term)
    if previous_int is not None:
        signal.signal(signal.SIGINT, previous_int)
    if _HOOKS:
        sys.unraisablehook = _HOOKS.pop()
    if _HOOKS or not PENDING:
        return None
    late = PENDING[0]
    PENDING.clear()
    return late


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
