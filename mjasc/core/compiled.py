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

:func:`inlined_kernel` is a kernel that numba inlines into each kernel calling it (``inline="always"``):
a small body that hot loops share (the IMM's weighted moments) costs what writing it out in each caller
costs — called as a plain kernel, numba keeps the call and a cycle ran ~20 % slower.

``fma(x, y, z)`` is ``x·y + z`` rounded once, for a kernel that must give the bits of a numpy
operation that fuses (numpy's complex multiply on FMA hardware: ``(a·b).real = fma(a.re, b.re,
−a.im·b.im)``, ``(a·b).imag = fma(a.re, b.im, a.im·b.re)``); LLVM's ``llvm.fma``, exact on every
machine (in software where the processor has no FMA). With ``NUMBA_DISABLE_JIT=1`` it is the
exact rational computation, rounded once.

Every kernel is tested against an independent reference (scipy, a closed form or the numpy
formulation it replaces). ``NUMBA_DISABLE_JIT=1`` runs the same code as Python (for a debugger).
"""

from __future__ import annotations

import math
from fractions import Fraction

import numba
from numba.core import types
from numba.extending import intrinsic

__all__ = ["kernel", "inlined_kernel", "fma", "maximum", "minimum", "clip_float", "clip", "search_right", "pairwise_sum"]


def kernel(fn):
    """Decorator: compile ``fn`` with the project's settings (module docstring)."""
    return numba.njit(cache=True, nogil=True, fastmath=False, error_model="numpy")(fn)


def inlined_kernel(fn):
    """Decorator: :func:`kernel` inlined into each kernel calling it (module docstring)."""
    return numba.njit(cache=True, nogil=True, fastmath=False, error_model="numpy", inline="always")(fn)


@kernel
def maximum(a, b):
    """``np.maximum`` of two floats inside a kernel: NaN propagates (the first NaN), and on a tie the
    second operand, as numpy's loop does (``np.maximum(0.0, -0.0)`` is −0.0)."""
    if a != a:
        return a
    if b != b:
        return b
    return a if a > b else b


@kernel
def minimum(a, b):
    """``np.minimum`` of two floats inside a kernel: NaN propagates (the first NaN), and on a tie the
    second operand, as numpy's loop does (``np.minimum(0.0, -0.0)`` is −0.0)."""
    if a != a:
        return a
    if b != b:
        return b
    return a if a < b else b


@kernel
def search_right(a, x, lo, hi):
    """``lo + np.searchsorted(a[lo:hi], x, side="right")`` inside a kernel: the first index in
    [lo, hi) whose value is > x (hi when none), ``a`` sorted ascending; NaN is greater than every
    number, as numpy sorts it; a NaN ``x`` is not looked for (it gives ``lo``, where numpy gives
    ``hi``: callers handle NaN first)."""
    while lo < hi:
        mid = (lo + hi) >> 1
        if a[mid] <= x:
            lo = mid + 1
        else:
            hi = mid
    return lo


@kernel
def pairwise_sum(a, lo, n):
    """numpy's pairwise sum of ``a[lo : lo + n]`` inside a kernel (numpy/_core/src/umath/loops_utils.h.src:
    in order below 8 terms, 8 partial sums up to 128, halves above), the order of ``np.sum`` and of
    ``np.add.reduce`` / ``reduceat`` over a contiguous run."""
    if n < 8:
        res = 0.0
        for i in range(n):
            res += a[lo + i]
        return res
    if n <= 128:
        r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
        r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
        i = 8
        while i < n - (n % 8):
            j = lo + i
            r0 += a[j]
            r1 += a[j + 1]
            r2 += a[j + 2]
            r3 += a[j + 3]
            r4 += a[j + 4]
            r5 += a[j + 5]
            r6 += a[j + 6]
            r7 += a[j + 7]
            i += 8
        res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
        while i < n:
            res += a[lo + i]
            i += 1
        return res
    n2 = n // 2
    n2 -= n2 % 8
    return pairwise_sum(a, lo, n2) + pairwise_sum(a, lo + n2, n - n2)


def clip_float(v: float, lo: float, hi: float) -> float:
    """``float(np.clip(v, lo, hi))`` for Python floats without numpy's call (plain Python, not a
    kernel): numpy's clip loop, min(max(v, lo), hi) with NaN propagating and the value winning
    ties (−0.0 stays −0.0)."""
    if v != v:
        return v
    v = lo if v < lo else v
    return hi if v > hi else v


#: :func:`clip_float` compiled, for kernels (the same rule: numpy's clip of one float).
clip = kernel(clip_float)


@intrinsic
def _fma_llvm(typingctx, x, y, z):
    """``x·y + z`` with one rounding (float64; module docstring). Only inside compiled kernels."""
    if not all(isinstance(a, types.Float) for a in (x, y, z)):
        return None
    sig = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        a, b, c = (context.cast(builder, v, t, types.float64) for v, t in zip(args, signature.args))
        return builder.fma(a, b, c)

    return sig, codegen


def _fma_python(x: float, y: float, z: float) -> float:
    """``x·y + z`` rounded once, in Python (kernels run as Python under ``NUMBA_DISABLE_JIT=1``)."""
    x, y, z = float(x), float(y), float(z)
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
        return x * y + z  # (inf and nan: the same as fused)
    exact = Fraction(x) * Fraction(y) + Fraction(z)
    return float(exact) if exact != 0 else x * y + z  # (an exact zero: IEEE's sign rule)


fma = _fma_python if numba.config.DISABLE_JIT else _fma_llvm
