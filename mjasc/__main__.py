"""``python -m mjasc``: the command line (:func:`mjasc.cli.command_line`, as the ``mjasc`` console
script runs it)."""

try:
    from mjasc.cli import command_line
except KeyboardInterrupt:  # (Ctrl-C while the program imports: one line and 130, as later)
    import sys

    print("mjasc: interrupted", file=sys.stderr)
    raise SystemExit(130) from None

command_line()
