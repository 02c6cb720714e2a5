"""Imported once, by the fork server of :mod:`mjasc.campaigns.forked` (its preload): what every
run imports, numba's compiler target, and the warm-up (one simulated second of the bundled demo,
which loads the cached kernels that runs use first), so that every child forked from the server
starts with them instead of paying them in its first run. Nothing else of the warm-up stays: a run
is a function of its own text. What the server and its children print goes to /dev/null, as a new
interpreter's child's does (the server inherits the driver's terminal). Only for the server: imported
anywhere else it would silence that process's output."""

import os

_devnull = os.open(os.devnull, os.O_WRONLY)
os.dup2(_devnull, 1)
os.dup2(_devnull, 2)
os.close(_devnull)

from mjasc.campaigns.executor import _prepare, _warm_up  # noqa: E402  (after the output is redirected)

_prepare()
_warm_up()
