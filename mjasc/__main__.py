"""``python -m mjasc``: the command line (:func:`mjasc.cli.command_line`, as the ``mjasc`` console
script runs it)."""

from mjasc.cli import command_line

command_line()
