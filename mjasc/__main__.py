"""``python -m mjasc``: the command line (:func:`mjasc.cli.command_line`, as the ``mjasc`` console
script runs it). Ctrl-C or SIGTERM while it imports: one line and 130 (:mod:`mjasc.runs.early_interrupts`,
in force from the package's first statement)."""

from mjasc.cli import command_line

command_line()
