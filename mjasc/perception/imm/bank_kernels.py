"""The compiled per-row bookkeeping of :class:`mjasc.perception.imm.bank.IMMBank` (one call instead
of ~10 small numpy calls each): the rejection codes and why a row was not used
(:func:`rejections`), the measurement checks of an update (:func:`measurements`), the start-up rows
of a general cycle (:func:`warm_rows`) and the whole outcome of one (:func:`settled_rows`), and the bank's births and drops in its cycle buffers
(:func:`appended_rows`, :func:`kept_rows`). Each equals its numpy form bit for bit (the tests)."""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.compiled import kernel

__all__ = ["ACCEPTED", "NOT_MEASURED", "NON_FINITE", "GATED", "RESTARTED", "REJECTION_REASONS",
           "rejections", "measurements", "warm_rows", "settled_rows", "settled_rows_into", "appended_rows", "kept_rows"]

#: Codes of :attr:`mjasc.perception.imm.bank.IMMBank.rejection_codes` (indices into ``REJECTION_REASONS``).
ACCEPTED, NOT_MEASURED, NON_FINITE, GATED, RESTARTED = 0, 1, 2, 3, 4
REJECTION_REASONS = (
    "",
    "no measurement for this track",
    "measurement is not finite",
    "measurement outside the chi-square gate of every model",
    "track restarted from this measurement after consecutive gated measurements",
)


@kernel
def rejections(use, finite, measured, inside, ok, n_gated, limit, reasons, restart):
    """Per row of a general cycle, in place: why it was not used (``reasons``: not finite, then
    gated — used but outside the gate —, then not measured, each overriding the one before),
    its consecutive gated count ``n_gated`` (+1 when gated, 0 when used) and whether the track
    restarts (``restart``: gated ``limit`` > 0 times in a row)."""
    for k in range(use.size):
        r = ACCEPTED
        if not finite[k]:
            r = NON_FINITE
        g = use[k] and not inside[k]
        if g:
            r = GATED
        if not measured[k]:
            r = NOT_MEASURED
        reasons[k] = r
        if g:
            n_gated[k] += 1
        elif ok[k]:
            n_gated[k] = 0
        restart[k] = g and limit > 0 and n_gated[k] >= limit


@kernel
def measurements(z, measured, mv, per_row, R, finite, use):
    """Per row of an update, in place: ``finite`` (both coordinates of z finite), ``use`` (measured
    and finite) and, where ``per_row``, the σ² mv replaced by R where it is not finite and > 0.
    Returns whether every row is used."""
    every = True
    for k in range(z.shape[0]):
        f = math.isfinite(z[k, 0]) and math.isfinite(z[k, 1])
        finite[k] = f
        u = measured[k] and f
        use[k] = u
        every = every and u
        if per_row and not (math.isfinite(mv[k]) and mv[k] > 0):
            mv[k] = R
    return every


@kernel
def _copy_model_row(s, P, mu, k, s_out, P_out, mu_out, c):
    """Row k of the models' states s (n, r, 4), covariances P (n, r, 4, 4) and probabilities μ
    (n, r) copied into row c of s_out, P_out, mu_out."""
    for a in range(s.shape[1]):
        mu_out[c, a] = mu[k, a]
        for b in range(4):
            s_out[c, a, b] = s[k, a, b]
            for d in range(4):
                P_out[c, a, b, d] = P[k, a, b, d]


@kernel
def warm_rows(rows, ok_w, use_w, ok, inside, s, P, mu, s_new, P_new, mu_new):
    """A general cycle's start-up rows k = rows[j], in place: ``ok[k] = ok_w[j]``, ``inside[k] =
    ok_w[j] or not use_w[j]``, and their IMM state (s, P, μ) kept unchanged in the cycle's output."""
    for j in range(rows.size):
        k = rows[j]
        ok[k] = ok_w[j]
        inside[k] = ok_w[j] or not use_w[j]
        _copy_model_row(s, P, mu, k, s_new, P_new, mu_new, k)


@kernel
def settled_rows(d2_min, gate, use, finite, measured, rows_w, ok_w, use_w, s, P, mu, s_new, P_new, mu_new, n_gated,
                 limit):
    """A general cycle's outcome per row in one pass: ``inside = d2_min <= gate`` (NaN: False),
    ``ok = use & inside``; the start-up rows ``rows_w`` as :func:`warm_rows` (their ok and inside
    from their filters, their IMM state kept); then :func:`rejections` (n_gated changed in place).
    Returns (inside, reasons, restart, used = ok | restart, the number restarted)."""
    n = d2_min.size
    inside = np.empty(n, dtype=np.bool_)
    ok = np.empty(n, dtype=np.bool_)
    reasons = np.empty(n, dtype=np.int8)
    restart = np.empty(n, dtype=np.bool_)
    used = np.empty(n, dtype=np.bool_)
    n_restart = settled_rows_into(d2_min, gate, use, finite, measured, rows_w, ok_w, use_w, s, P, mu, s_new, P_new,
                                  mu_new, n_gated, limit, inside, ok, reasons, restart, used)
    return inside, reasons, restart, used, n_restart


@kernel
def settled_rows_into(d2_min, gate, use, finite, measured, rows_w, ok_w, use_w, s, P, mu, s_new, P_new, mu_new,
                      n_gated, limit, inside, ok, reasons, restart, used):
    """:func:`settled_rows` written into inside, ok, reasons, restart and used (n rows or more: a bank's
    scratch rows and its own rejection codes); returns the number restarted."""
    n = d2_min.size
    for k in range(n):
        inside[k] = d2_min[k] <= gate
        ok[k] = use[k] and inside[k]
    warm_rows(rows_w, ok_w, use_w, ok, inside, s, P, mu, s_new, P_new, mu_new)
    rejections(use, finite, measured, inside, ok, n_gated, limit, reasons, restart)
    n_restart = 0
    for k in range(n):
        used[k] = ok[k] or restart[k]
        n_restart += restart[k]
    return n_restart


@kernel
def appended_rows(s, P, mu, x, n0, mu0, sp, ids, t, Pc, n_gated, reasons, new_ids, new_t, Pp):
    """:meth:`~mjasc.perception.imm.bank.IMMBank._append` of k rows after the first n0: in place, the rows
    n0… of the state's views s, P (zero), μ (μ0) and x (sp (k, 4)); returned, the per-track arrays (ids, t,
    Pc, n_gated, reasons) each a new array with the k rows appended (new_ids, new_t, Pp, 0, 0), and whether
    every new t equals the first."""
    k = new_t.size
    mu[n0:n0 + k] = mu0
    s[n0:n0 + k] = 0.0
    P[n0:n0 + k] = 0.0
    x[n0:n0 + k] = sp
    m = n0 + k
    ids2 = np.empty(m, dtype=np.int64)
    t2 = np.empty(m)
    Pc2 = np.empty((m, 4, 4))
    g2 = np.empty(m, dtype=np.int64)
    r2 = np.empty(m, dtype=np.int8)
    ids2[:n0], ids2[n0:] = ids[:n0], new_ids
    t2[:n0], t2[n0:] = t[:n0], new_t
    Pc2[:n0], Pc2[n0:] = Pc[:n0], Pp
    g2[:n0], g2[n0:] = n_gated[:n0], 0
    r2[:n0], r2[n0:] = reasons[:n0], 0
    one_time = True
    for j in range(k):
        if new_t[j] != new_t[0]:
            one_time = False
    return ids2, t2, Pc2, g2, r2, one_time


@kernel
def kept_rows(keep, s, P, mu, x, s_out, P_out, mu_out, x_out, ids, t, Pc, n_gated, reasons):
    """:meth:`~mjasc.perception.imm.bank.IMMBank.keep_rows` of a bank in its cycle buffers: the rows where
    ``keep`` (n,) of s, P, μ, x copied in order into the other side's views s_out, P_out, mu_out, x_out (m
    rows, m the number kept: ``np.compress(keep, a, 0, out)``), and the per-track arrays (ids, t, Pc,
    n_gated, reasons) returned as new arrays of the kept rows (``a[keep]``)."""
    m = s_out.shape[0]
    ids2 = np.empty(m, dtype=ids.dtype)
    t2 = np.empty(m)
    Pc2 = np.empty((m, 4, 4))
    g2 = np.empty(m, dtype=n_gated.dtype)
    r2 = np.empty(m, dtype=reasons.dtype)
    c = 0
    for k in range(keep.size):
        if not keep[k]:
            continue
        _copy_model_row(s, P, mu, k, s_out, P_out, mu_out, c)
        for a in range(4):
            x_out[c, a] = x[k, a]
            for b in range(4):
                Pc2[c, a, b] = Pc[k, a, b]
        ids2[c] = ids[k]
        t2[c] = t[k]
        g2[c] = n_gated[k]
        r2[c] = reasons[k]
        c += 1
    return ids2, t2, Pc2, g2, r2
