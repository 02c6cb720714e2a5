"""What an IMM bank hands out for some of its tracks, as one compiled pass over the rows instead of
~10 small numpy calls (the bank's :meth:`~mjasc.perception.imm.bank.IMMBank.estimate_fields` and
:meth:`~mjasc.perception.imm.bank.IMMBank.prediction_fields`, read twice per tick and tracker: the
disc test of the sensing pass and the reports), and the combined covariances of the IMM rows
written in place (:meth:`~mjasc.perception.imm.bank.IMMBank._covariances`).

Bits: the expressions of the numpy form, in its order (tests/test_imm_row_fields.py keeps it as the
reference): the course wrapped as :func:`~mjasc.perception.imm.compiled_cycle.wrap`'s
``π − np.mod(π − θ, 2π)`` (numpy's floor modulo and Python's, which numba compiles, are the same
algorithm); ω̂ = ``np.add.reduce(μ·ω, −1)``, which for r < 8 models is the plain sum in model
order (numpy's pairwise sum starts blocking at 8 terms; the bank keeps its numpy form for r ≥ 8:
:data:`SEQUENTIAL_MODELS`); 0 for start-up rows; the covariance of each IMM row
:func:`~mjasc.perception.imm.compiled_cycle.combine_covariance`'s, row by row.
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.compiled import kernel
from mjasc.perception.imm.compiled_cycle import combine_row

__all__ = ["SEQUENTIAL_MODELS", "row_fields", "wrapped_states", "combine_covariance_rows"]

#: Largest number of models whose ω̂ numpy sums in model order (its reduction blocks from 8 terms).
SEQUENTIAL_MODELS = 7

_TWO_PI = 2.0 * math.pi


@kernel
def row_fields(rows, x, t, mu, omega, active, Pc, full_cov):
    """For the bank rows ``rows`` (k,) int: times t[rows] (k,) [s], states (k, 4) [x, y, θ, V] with θ
    wrapped to (−π, π], the wrapped courses again (k,) (a contiguous array), ω̂ (k,) [rad/s] (0 where
    ``active``: start-up rows) and the covariances Pc[rows] — (k, 4, 4) if ``full_cov``, else the
    position block (k, 2, 2). x (n, 4), t (n,), μ (n, r), ω (r,) with r ≤ :data:`SEQUENTIAL_MODELS`,
    active (n,) bool, Pc (n, 4, 4) current (the bank's ``_covariances()``)."""
    k = rows.size
    r = omega.size
    d = 4 if full_cov else 2
    tt = np.empty(k)
    xs = np.empty((k, 4))
    th = np.empty(k)
    w = np.empty(k)
    P = np.empty((k, d, d))
    for i in range(k):
        j = rows[i]
        tt[i] = t[j]
        a = math.pi - (math.pi - x[j, 2]) % _TWO_PI
        xs[i, 0] = x[j, 0]
        xs[i, 1] = x[j, 1]
        xs[i, 2] = a
        xs[i, 3] = x[j, 3]
        th[i] = a
        if active[j]:
            w[i] = 0.0
        else:
            acc = mu[j, 0] * omega[0]
            for m in range(1, r):
                acc += mu[j, m] * omega[m]
            w[i] = acc
        for b in range(d):
            for c in range(d):
                P[i, b, c] = Pc[j, b, c]
    return tt, xs, th, w, P


@kernel
def wrapped_states(x):
    """A copy of the states x (n, 4) [x, y, θ, V] with θ wrapped to (−π, π] (the bank's ``states``)."""
    n = x.shape[0]
    out = np.empty((n, 4))
    for k in range(n):
        out[k, 0] = x[k, 0]
        out[k, 1] = x[k, 1]
        out[k, 2] = math.pi - (math.pi - x[k, 2]) % _TWO_PI
        out[k, 3] = x[k, 3]
    return out


@kernel
def combine_covariance_rows(s, P, mu, active, out):
    """:func:`~mjasc.perception.imm.compiled_cycle.combine_covariance` of the rows not ``active``
    (n,) bool, written into out (n, 4, 4) in place (the start-up rows' entries are left as they are)."""
    x = np.empty(4)
    for k in range(mu.shape[0]):
        if not active[k]:
            combine_row(k, s, P, mu, x, out)
