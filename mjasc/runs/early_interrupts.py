"""Ctrl-C and SIGTERM in the ``mjasc`` program's first moments: one line and status 130.

The program (the console script, ``python -m mjasc``) handles interrupts through
:func:`mjasc.runs.interrupts.for_the_command` once :func:`mjasc.cli.main` begins. Before that it
imports: the package, its OpenGL and math set-up (``ctypes.util`` asks ``ldconfig``), the command
line's modules (~20 ms; its handler was in force 60–95 ms after the process started on the project's
busy 2-core machine, median 67 ms). A SIGTERM there found Python's default and
ended the process at once (status 143), and a Ctrl-C raised ``KeyboardInterrupt`` inside whatever
import was under way: the console script's ``from mjasc.cli import command_line`` is no code of
mjasc's, so nothing could catch it and Python printed its traceback.

So the package's ``__init__``, as its first statement, calls :func:`install_for_the_program`: in
the program (:func:`is_the_program`) SIGINT and SIGTERM, where Python's default is in force (an
ignored signal stays ignored), go to :func:`interrupted_at_start`, which writes the program's line
``mjasc: interrupted`` and ends the process with 130 at once. Nothing has been written then and no
exception is raised, so none can surface from an import, a finalizer or llvmlite's bindings.
:func:`~mjasc.runs.interrupts.for_the_command` replaces it when the command's set-up begins.

What comes before cannot be covered by mjasc: CPython's own start — the interpreter (until its
Ctrl-C handler is in force a SIGINT ends the process too), ``site`` with the environment's
``.pth`` files (the editable install's finder imports ``pathlib``) and, for ``python -m``,
``runpy`` locating the package: 21–69 ms on that machine (median 39 ms: a bare ``python -c``
whose first statement installs a handler), ~12 ms of it ``site``. A signal then gives Python's own
ending (143 for SIGTERM, a traceback for Ctrl-C). Now the program's handler is in force at a median
48 ms, ~1 ms of it mjasc's (this module's import).

This module imports only ``os``, ``signal`` and ``sys``: it runs before anything else of the program.
"""

from __future__ import annotations

import os
import signal
import sys

__all__ = ["is_the_program", "install_for_the_program", "interrupted_at_start", "EXIT_INTERRUPTED",
           "INTERRUPTED_LINE"]

#: The exit status of an interrupted command (Ctrl-C or SIGTERM), as :func:`mjasc.cli.main` returns it.
EXIT_INTERRUPTED = 130
#: What the program says on stderr when a command is interrupted (here and in :mod:`mjasc.cli`).
INTERRUPTED_LINE = "mjasc: interrupted"
_LINE = f"{INTERRUPTED_LINE}\n".encode()
#: Names of the console script's file (pip's launchers on Windows included).
_SCRIPTS = ("mjasc", "mjasc.exe", "mjasc-script.py")


def _dash_m_module(argv) -> str | None:
    """The module ``python [options] -m MODULE …`` runs, from the interpreter's own command line
    (``sys.orig_argv``), else None (a script, ``-c``, stdin)."""
    args = iter(argv[1:])
    for arg in args:
        if arg in ("-", "--") or not arg.startswith("-"):
            return None
        if arg.startswith("--"):  # (the one long option with a value)
            if arg == "--check-hash-based-pycs":
                next(args, None)
            continue
        for j, flag in enumerate(arg[1:], 1):  # (short flags may be grouped: -Im mjasc, -mmjasc)
            if flag in "cmWX":  # (the rest of the argument, or the next one, is the flag's value)
                value = arg[j + 1:] or next(args, None)
                if flag == "m":
                    return value
                if flag == "c":
                    return None
                break
    return None


def is_the_program() -> bool:
    """Whether this process is the ``mjasc`` program (the console script, or ``python -m mjasc``),
    not a script or a test importing mjasc. Also true while ``python -m mjasc`` imports the package,
    before its ``__main__`` runs (``sys.argv[0]`` is then ``"-m"``)."""
    main_module = sys.modules.get("__main__")
    spec = getattr(main_module, "__spec__", None)
    if spec is not None and spec.name == "mjasc.__main__":
        return True
    script = str(getattr(main_module, "__file__", "") or "").replace("\\", "/").rsplit("/", 1)[-1]
    if script in _SCRIPTS:
        return True
    return sys.argv[:1] == ["-m"] and _dash_m_module(getattr(sys, "orig_argv", ())) == "mjasc"


def interrupted_at_start(signum, frame) -> None:
    """The handler before the command's own: the program's line on stderr, then exit 130 at once
    (a write to the descriptor: Python's ``sys.stderr`` may be in the middle of a write)."""
    try:
        os.write(2, _LINE)
    except OSError:  # (no stderr to tell: the status says it)
        pass
    os._exit(EXIT_INTERRUPTED)


def install_for_the_program() -> None:
    """In the program only, and only where Python's default is in force: SIGINT and SIGTERM →
    :func:`interrupted_at_start` (module docstring). Nothing off the main thread."""
    if not is_the_program():
        return
    for signum, defaults in ((signal.SIGINT, (signal.default_int_handler,)), (signal.SIGTERM, (signal.SIG_DFL, None))):
        try:
            if signal.getsignal(signum) in defaults:
                signal.signal(signum, interrupted_at_start)
        except ValueError:  # (not the main thread: signals are the main thread's)
            return
