"""Small matrix products with numpy's bits, for compiled kernels that replace numpy's ``@`` on stacks
of small matrices.

numpy's ``matmul`` of small float64 matrices is OpenBLAS's: a matrix·matrix product (``dgemm``, on
this machine class OpenBLAS's Haswell/Zen kernel, which :mod:`mjasc.core.portable_math` pins) sums
each entry over the inner index in order, from +0, by fused multiply-adds — so a sum of −0 products
is +0. :func:`sandwich_into` repeats that order for A P Aᵀ; its users' tests compare it with numpy
bit for bit (tests/test_imm_startup_rows.py, tests/test_tracking_step_buffers.py), so on a machine
whose BLAS sums otherwise they fail there. (A row·matrix product is ``dgemv`` and sums otherwise:
:func:`mjasc.physics.hydro_kernels.linear_form`.)
"""

from __future__ import annotations

import numpy as np

from mjasc.core.compiled import fma, kernel

__all__ = ["sandwich_into"]


@kernel
def sandwich_into(A, P, k, out):
    """``out[:k] = A[:k] @ P[:k] @ A[:k].transpose(0, 2, 1)`` for stacks of A (·, r, n) and P (·, n, n)
    into out (·, r, r), with numpy's bits (module docstring): A P first, then (A P) Aᵀ, each entry
    summed over the inner index in order from +0 by fused multiply-adds."""
    r, n = A.shape[1], A.shape[2]
    T = np.empty((r, n))
    for i in range(k):
        for a in range(r):
            for d in range(n):
                acc = 0.0
                for b in range(n):
                    acc = fma(A[i, a, b], P[i, b, d], acc)
                T[a, d] = acc
        for a in range(r):
            for c in range(r):
                acc = 0.0
                for d in range(n):
                    acc = fma(T[a, d], A[i, c, d], acc)
                out[i, a, c] = acc
