"""Compiled kernels: numba's ``njit`` with the project's settings, for the few inner loops numpy
cannot make cheap.

Most of mjasc is numpy over arrays of the whole fleet. What is left after that is numpy's own cost
per call (~0.3–1.5 µs) on arrays of a few dozen numbers, paid dozens of times per vessel and tick:
a convex hull of a track's returns, the distance from a handful of points to a polygon, the IMM
cycle of a few tracks. Those few kernels are written as plain loops and compiled here:

* ``cache=True``: the machine code is kept next to the module (``__pycache__``; numba falls back
  to a per-user cache where that is not writable), so a process compiles a kernel once per
  machine, not once per run — campaign workers load it in milliseconds;
* ``fastmath=False``: IEEE arithmetic, no reassociation and no fused multiply-adds, so a kernel
  rounds exactly as its loops are written (each kernel's docstring says in which order it sums);
* ``error_model="numpy"``: a division by zero gives inf or nan as numpy does, never an exception;
* ``nogil=True``: a kernel releases the GIL (threads of a Dask worker may overlap).

Every kernel is tested against an independent reference (scipy, a closed form or the numpy
formulation it replaces). ``NUMBA_DISABLE_JIT=1`` runs the same code as Python (for a debugger).
"""

from __future__ import annotations

import numba

__all__ = ["kernel"]


def kernel(fn):
    """Decorator: compile ``fn`` with the project's settings (module docstring)."""
    return numba.njit(cache=True, nogil=True, fastmath=False, error_model="numpy")(fn)
