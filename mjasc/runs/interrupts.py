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

A signal must not land either inside llvmlite's bindings (numba compiles through them): their
Python keeps LLVM objects' ownership beside C calls, and an exception between a call and its
bookkeeping leaves an object without its pointer (``ObjectRef.__init__`` interrupted as it
began: the finalizer's ``AttributeError`` printed, seen once in CI, SIGTERM at t = 0.2 s), half
released (``detach``), freed but still pointing at its memory (``OutputString.close``: freed again
by its finalizer, the process aborts) or owned twice (``ExecutionEngine.add_module``: a
segmentation fault). So the handlers :func:`catch_sigterm` installs — for SIGTERM, and for SIGINT
where Python's own handler is in force — look first at where the signal landed
(:func:`_in_release`): with a frame of llvmlite's ``binding`` package or a finalizer on the stack
they keep the interrupt in :data:`PENDING` and return, and have it raised at the main thread's
first Python call or return outside them (:func:`_deliver_when_out`, a profile function, for as
long as that takes: each binding call is short), which keeps Ctrl-C as quick as before during a
first run's minutes of compiling. (When another profiler is in force — ``cProfile`` — it is left
alone and the runner's next event raises the interrupt.) Anywhere else they raise at once. The
runner also looks after its loop's last event, and :func:`restore_sigterm` hands back one that
landed after its caller's last look.
"""

from __future__ import annotations

import signal
import sys
import threading

from mjasc.runs.early_interrupts import interrupted_at_start

__all__ = ["Terminated", "catch_sigterm", "restore_sigterm", "signal_name", "interrupt_behind", "PENDING",
           "raise_pending", "for_the_command", "restore_handlers", "hold_interrupts", "release_interrupts"]


class Terminated(KeyboardInterrupt):
    """SIGTERM arrived while a run went (raised by the handler :func:`catch_sigterm` installs)."""


#: Where an exception must not be raised (module docstring): llvmlite's bindings (any frame on
#: the stack from a file in this folder) and finalizers (``__del__``).
_LLVMLITE_BINDING = "/llvmlite/binding/"


def _in_release(frame) -> bool:
    """Whether ``frame`` (where a signal's handler was called) or a caller is a finalizer
    (``__del__``) or in llvmlite's bindings — where an exception could leave an LLVM object half
    made, half released or owned twice (module docstring)."""
    while frame is not None:
        code = frame.f_code
        if code.co_name == "__del__" or _LLVMLITE_BINDING in code.co_filename.replace("\\", "/"):
            return True
        frame = frame.f_back
    return False


def _interrupt(signum, frame):
    """The handler of SIGTERM (→ :class:`Terminated`) and SIGINT (→ ``KeyboardInterrupt``): raised
    at once, or kept in :data:`PENDING` when the signal landed in a release (:func:`_in_release`)
    and raised as soon as the main thread is out of it (:func:`_deliver_when_out`)."""
    exc = Terminated(signal.Signals(signum).name) if signum == signal.SIGTERM else KeyboardInterrupt()
    if _in_release(frame):
        PENDING.append(exc)
        _deliver_when_out()
        return
    raise exc


def _deliver_when_out() -> None:
    """Raise what :data:`PENDING` keeps at the main thread's first Python call or return outside a
    release: :func:`_out_of_release` as the thread's profile function until then. Nothing when not
    on the main thread or when another profile function is in force (a user's ``cProfile``): the
    runner's next event raises it then."""
    if sys.getprofile() is None and threading.current_thread() is threading.main_thread():
        sys.setprofile(_out_of_release)


def _out_of_release(frame, event, arg):
    """The profile function of :func:`_deliver_when_out` (not raising in this module's own
    functions: :func:`restore_sigterm` puts the handlers back first and hands the interrupt on)."""
    if not PENDING:  # (raised meanwhile by the runner's loop, or handed on by restore_sigterm)
        sys.setprofile(None)
    elif event in ("call", "return") and frame.f_code.co_filename != __file__ and not _in_release(frame):
        sys.setprofile(None)
        raise_pending()


def _pause_delivery() -> bool:
    """Stop :func:`_out_of_release` for the calls that swap the handlers (it would raise inside
    them); True when it was in force (for :func:`_resume_delivery`)."""
    if sys.getprofile() is _out_of_release:
        sys.setprofile(None)
        return True
    return False


def _resume_delivery(paused: bool) -> None:
    """Put :func:`_out_of_release` back after :func:`_pause_delivery` when an interrupt still waits."""
    if paused and PENDING:
        _deliver_when_out()


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
        _deliver_when_out()
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
    paused = _pause_delivery()  # (an outer call's interrupt on its way: not raised in the calls below)
    if not _HOOKS:
        PENDING.clear()
    _HOOKS.append(sys.unraisablehook)
    sys.unraisablehook = _redeliver
    previous_int = None
    if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        previous_int = signal.signal(signal.SIGINT, _interrupt)
    previous = signal.signal(signal.SIGTERM, _interrupt), previous_int
    _resume_delivery(paused)
    return previous


def restore_sigterm(previous) -> KeyboardInterrupt | None:
    """Put back the handlers :func:`catch_sigterm` returned and the unraisable hook it replaced
    (None: nothing to do). Returns the interrupt still kept in :data:`PENDING` when this was the
    outermost call — one that landed after its caller's last look — and forgets it: the caller
    raises it once its outputs are complete (a command then ends as interrupted); an inner call
    leaves it to the outer one and returns None."""
    if previous is None:
        return None
    paused = _pause_delivery()  # (first: its profile function would raise in the calls below)
    previous_term, previous_int = previous
    signal.signal(signal.SIGTERM, signal.SIG_DFL if previous_term is None else previous_term)
    if previous_int is not None:
        signal.signal(signal.SIGINT, previous_int)
    if _HOOKS:
        sys.unraisablehook = _HOOKS.pop()
    if _HOOKS:  # (an outer call's: it keeps what is pending, delivered as before)
        _resume_delivery(paused)
        return None
    if not PENDING:
        return None
    late = PENDING[0]
    PENDING.clear()
    return late


def for_the_command():
    """SIGTERM → :class:`Terminated` and SIGINT → ``KeyboardInterrupt`` through :func:`_interrupt`
    for a whole ``mjasc`` command (:func:`mjasc.cli.main`: its set-up — imports, a scenario's
    world, numba loading or compiling kernels — too, not only a run's loop), where the handler in
    force is the default (a SIGTERM otherwise ends the process at once, exit 143, leaving a run's
    temporary files) or the program's handler of its first moments
    (:func:`mjasc.runs.early_interrupts.interrupted_at_start`). Nothing off the main thread.
    Returns what :func:`restore_handlers` needs."""
    if threading.current_thread() is not threading.main_thread():
        return None
    previous = {}
    if signal.getsignal(signal.SIGTERM) in (signal.SIG_DFL, None, _interrupt, interrupted_at_start):
        previous[signal.SIGTERM] = signal.signal(signal.SIGTERM, _interrupt)
    if signal.getsignal(signal.SIGINT) in (signal.default_int_handler, _interrupt, interrupted_at_start):
        previous[signal.SIGINT] = signal.signal(signal.SIGINT, _interrupt)
    return previous


def restore_handlers(previous) -> None:
    """Put back the handlers :func:`for_the_command` replaced (None: nothing to do)."""
    for signum, handler in (previous or {}).items():
        signal.signal(signum, signal.SIG_DFL if handler is None else handler)


class _Held:
    """What :func:`hold_interrupts` replaced and the interrupts it kept since."""

    def __init__(self):
        self.kept: list = []
        self.previous: dict = {}


def hold_interrupts(caught=None) -> _Held:
    """From now until :func:`release_interrupts`, SIGINT and SIGTERM are kept, not raised (where
    their handler in force would raise: Python's, :func:`_interrupt`): what runs meanwhile — a
    run closing its recording and writing its summary after a first interrupt — finishes whole
    however often Ctrl-C is pressed. ``caught``: what :func:`catch_sigterm` returned, ended here as
    :func:`restore_sigterm` would end it (its handlers are the ones :func:`release_interrupts` puts
    back; no moment between the two where an interrupt would raise). An interrupt in
    :data:`PENDING` is taken too (and forgotten there): ``held.kept`` holds them in order.
    Nothing is installed off the main thread."""
    held = _Held()
    if threading.current_thread() is not threading.main_thread():
        return held
    _pause_delivery()
    restore = {}
    if caught is not None:
        term, intr = caught
        restore[signal.SIGTERM] = signal.SIG_DFL if term is None else term
        if intr is not None:
            restore[signal.SIGINT] = intr

    def keep(signum, frame):
        held.kept.append(Terminated(signal.Signals(signum).name) if signum == signal.SIGTERM else KeyboardInterrupt())

    for signum in (signal.SIGINT, signal.SIGTERM):  # (first: from here on nothing raises)
        current = signal.getsignal(signum)
        if current is _interrupt or (signum == signal.SIGINT and current is signal.default_int_handler):
            held.previous[signum] = restore.pop(signum, current)
            signal.signal(signum, keep)
    for signum, handler in restore.items():  # (those the catch replaced and nothing here holds)
        signal.signal(signum, handler)
    if caught is not None and _HOOKS:
        sys.unraisablehook = _HOOKS.pop()
    held.kept += PENDING
    PENDING.clear()
    return held


def release_interrupts(held: _Held) -> KeyboardInterrupt | None:
    """End :func:`hold_interrupts`: its handlers put back; returns the first interrupt kept (or None)."""
    for signum, handler in held.previous.items():
        signal.signal(signum, handler)
    held.previous = {}
    return held.kept[0] if held.kept else None


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
