"""The ``mjasc`` command (the console script and ``python -m mjasc``: :func:`command_line`):
:func:`main` parses the command line (:mod:`mjasc.cli.parser`, which holds the usage of every
command) and runs the command — :mod:`mjasc.cli.run_commands` (run, view, list, trial, figures,
render) or :mod:`mjasc.cli.campaign_commands` (campaign, report, extract, search) — turning bad
input into one line on stderr and an exit status; the program then leaves without the
interpreter's final clean-up (:mod:`mjasc.cli.process_exit`)."""

from __future__ import annotations

import sys

import mjasc  # noqa: F401  (chooses the OpenGL backend before mujoco is imported)
from mjasc.cli import process_exit  # (first: its exit handler must be the first registered)
from mjasc.cli.parser import build_parser
from mjasc.cli.run_commands import viewer_command, viewer_executable
from mjasc.runs.early_interrupts import EXIT_INTERRUPTED, INTERRUPTED_LINE

__all__ = ["command_line", "main", "build_parser", "viewer_command", "viewer_executable"]

#: The command-line arguments that name an input file or folder (checked before a command runs).
_INPUTS = ("scenario", "campaign", "folder", "run")

#: The commands that simulate (their first call in a fresh checkout compiles the kernels: said first).
_SIMULATING = frozenset({"run", "campaign", "search", "trial", "figures", "render"})


def main(argv: list[str] | None = None) -> int:
    """Run one command. Exit status: 0 done, 1 a run or campaign failed, 2 bad input (a scenario,
    campaign, argument or output folder: one line on stderr, no traceback), 130 interrupted.
    An unexpected error (a bug) is one line too; ``MJASC_TRACEBACK=1`` shows its traceback."""
    import os

    from mjasc.runs.interrupts import for_the_command, restore_handlers

    os.environ.setdefault("RUST_LOG", "off")  # (the Rerun SDK's own log lines, in colour: mjasc says what failed)
    listening = None
    handlers = for_the_command()  # (SIGTERM as Ctrl-C from here on: the set-up below is interruptible too)
    try:
        status = _checked_inputs(args := build_parser(argv).parse_args(argv))
        if status is not None:
            return status
        if args.command in _SIMULATING and os.environ.get("MJASC_COMPILE_HINTS", "1") != "0":
            from mjasc.core.kernel_cache import COLD_HINT, announce_compiles, cache_is_cold

            if cache_is_cold():
                print(COLD_HINT, file=sys.stderr)
            else:  # (a kernel missing from a partly filled cache compiles silently otherwise: said while it runs)
                listening = announce_compiles(sys.stderr)
        status = args.func(args)
        sys.stdout.flush()  # (here, not at exit: a reader that left is answered below)
        return status
    except KeyboardInterrupt:
        print(INTERRUPTED_LINE, file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:  # (the reader of our output left: ``mjasc list | head -1``) — as a Unix
        # tool killed by SIGPIPE, quietly; the rest of our output goes nowhere (no second error at exit)
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 141
    except Exception as exc:  # noqa: BLE001 - the last line of defence: one line, not a traceback
        from mjasc.campaigns.perturbation import CampaignError
        from mjasc.core.config_tables import ConfigError

        if isinstance(exc, ConfigError):  # includes ScenarioError and OutputError
            print(f"mjasc: {exc}", file=sys.stderr)
            return 2
        if isinstance(exc, CampaignError):
            print(f"mjasc: invalid campaign: {exc}", file=sys.stderr)
            return 2
        if os.environ.get("MJASC_TRACEBACK"):
            raise
        text = str(exc).replace("\n", " ")
        print(f"mjasc: internal error: {type(exc).__name__}: {text[:500]} (MJASC_TRACEBACK=1 shows where)",
              file=sys.stderr)
        return 1
    finally:
        if listening is not None:
            from numba.core import event

            event.unregister("numba:compile", listening)
        restore_handlers(handlers)


def _checked_inputs(args) -> int | None:
    """2 (after one line on stderr) when an input argument is no usable file name, else None."""
    from mjasc.core.config_tables import path_problem, show_path

    for name in _INPUTS:
        value = getattr(args, name, None)
        if value == "":
            print(f"mjasc: {name}: an empty name, not a file or a bundled name", file=sys.stderr)
            return 2
        if isinstance(value, str) and path_problem(value):
            print(f"mjasc: {name} {show_path(value)}: not a usable file name ({path_problem(value)})", file=sys.stderr)
            return 2
    return None


def command_line() -> None:
    """The ``mjasc`` program: :func:`main` on ``sys.argv``, then the process ends with its exit
    status — without the interpreter's final clean-up once every exit handler ran
    (:mod:`mjasc.cli.process_exit`). Raises SystemExit like ``sys.exit(main())`` when the
    command raised or its status is not an exit status. Python's cyclic collector runs as during a
    run's loop from the start (:func:`mjasc.runs.collector.for_the_program`)."""
    import signal

    try:
        from mjasc.runs.collector import for_the_program

        for_the_program()
        status = main()
    except KeyboardInterrupt:  # (Ctrl-C before main's own handling began: one line all the same)
        print(INTERRUPTED_LINE, file=sys.stderr)
        status = EXIT_INTERRUPTED
    for signum in (signal.SIGINT, signal.SIGTERM):  # (leaving: the command's outputs are complete; an
        signal.signal(signum, signal.SIG_IGN)       # interrupt now would only cut the exit short with a traceback)
    if isinstance(status, int) and 0 <= status <= 255:
        process_exit.leave_with(status)
    raise SystemExit(status)
