"""The start-up rows of an IMM bank's cycle in a few compiled calls (first written around numpy's products
(:class:`mjasc.perception.imm.bank.IMMBank`, :mod:`mjasc.perception.imm.startup`): a bank with a
new track — nearly every tick, for clutter — ran ~25 numpy and kernel calls per cycle for them).

* :func:`gather_startup` — what the prediction of the rows ``rows`` reads: their filters'
  ``x[rows]``, ``P[rows]``, their steps dt (k,), the transitions F (k, 4, 4)
  (:func:`~mjasc.perception.imm.startup._cv_transitions`), and ``z[rows]``, ``use[rows]`` and
  (per-row σ²) ``mv[rows]``;
* the products ``F x``, ``F P Fᵀ`` and ``dt³`` (:func:`~mjasc.perception.imm.startup.cv_predict`):
  :func:`predicted_startup`, in numpy's bits (below);
* :func:`update_startup` — the noise added (:func:`~mjasc.perception.imm.startup._add_cv_noise`),
  the measurement update (:func:`~mjasc.perception.imm.compiled_cycle.position_update`),
  ``ok = use & (d² ≤ gate)`` and the filters written back (``x[rows]``, ``P[rows]``,
  ``n_meas[rows] += ok``): :meth:`~mjasc.perception.imm.startup.StartupFilters.update_rows`;
* :func:`settled_startup` — :func:`update_startup` then the cycle's outcome
  (:func:`~mjasc.perception.imm.bank_kernels.settled_rows`) in one call;
* |v|, atan2 and ``J P Jᵀ`` of :func:`~mjasc.perception.imm.startup.cv_to_polar`: computed in numpy's bits
  by :func:`handover_polar` before it calls :func:`handover_rows`;
* :func:`handover_rows` — the rest of the hand-over (:meth:`IMMBank._handover`): the polar state
  and covariance (:func:`~mjasc.perception.imm.startup._polar_finish`) written as the rows'
  estimate, the test :func:`~mjasc.perception.imm.startup.ready_for_handover`, and the ready rows
  made inactive with their IMM state started (every model at the polar state, μ = μ0).

A bank's births (:meth:`IMMBank._append`) are :func:`born_rows`: the new rows appended
(:func:`~mjasc.perception.imm.bank_kernels.appended_rows`) and handed over at once
(:func:`handover_rows`), around the start-up filters' |v|, atan2 and ``J P Jᵀ``.

A bank's drops (:meth:`IMMBank.keep_rows` in its cycle buffers) are :func:`kept_bank_rows`: the
rows (:func:`~mjasc.perception.imm.bank_kernels.kept_rows`) and the start-up filters
(:func:`~mjasc.perception.imm.startup._kept_started`) kept in one call.

Each is its numpy form's expressions in its order, per row (tests/test_imm_startup_rows.py keeps
the numpy form as the reference, bit for bit).

The products and functions once left to numpy have compiled forms that give numpy's bits here
(``math.hypot``, ``math.atan2`` and ``**`` are glibc's, as numpy's are with mjasc's portable-math
pin; each small product summed as OpenBLAS sums it): :func:`predicted_startup` (``F x``, ``F P Fᵀ``,
``dt³`` in place) and :func:`handover_polar` (|v|, atan2, ``J P Jᵀ``, then :func:`handover_rows`), each
checked against numpy's form in tests/test_imm_startup_rows.py.
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.compiled import kernel
from mjasc.core.small_products import sandwich_into
from mjasc.perception.imm.bank_kernels import appended_rows, kept_rows, settled_rows, settled_rows_into
from mjasc.perception.imm.compiled_cycle import position_update
from mjasc.perception.imm.startup import _add_cv_noise, _kept_started, _polar_finish, _polar_jacobians

__all__ = ["gather_startup", "gather_startup_into", "settled_startup_into", "update_startup", "settled_startup",
           "handover_rows", "born_rows", "kept_bank_rows", "predicted_startup", "handover_polar",
           "startup_cycle_into"]


@kernel
def gather_startup(rows, x, P, dt_rows, dtm, z, use, mv, per_row):
    """(xc (k, 4), Pc (k, 4, 4), dt (k,), F (k, 4, 4), zw (k, 2), use_w (k,), var_w (k,) or (0,)) of
    the start-up rows ``rows`` (k,) of filters x (n, 4), P (n, 4, 4): dt = dt_rows[rows], or dtm
    for every row when dt_rows is empty; z (n, 2), use (n,) and, if ``per_row``, mv (n,) gathered."""
    k = rows.size
    xc = np.empty((k, 4))
    Pc = np.empty((k, 4, 4))
    dt = np.empty(k)
    F = np.zeros((k, 4, 4))
    zw = np.empty((k, 2))
    use_w = np.empty(k, dtype=np.bool_)
    var_w = np.empty(k if per_row else 0)
    gather_startup_into(rows, x, P, dt_rows, dtm, z, use, mv, per_row, xc, Pc, dt, F, zw, use_w, var_w)
    return xc, Pc, dt, F, zw, use_w, var_w


@kernel
def gather_startup_into(rows, x, P, dt_rows, dtm, z, use, mv, per_row, xc, Pc, dt, F, zw, use_w, var_w):
    """:func:`gather_startup` written into the first k rows of xc, Pc, dt, F, zw, use_w and (if
    ``per_row``) var_w, arrays of at least k rows (a bank's scratch rows: nothing returned)."""
    for j in range(rows.size):
        r = rows[j]
        for a in range(4):
            xc[j, a] = x[r, a]
            for b in range(4):
                Pc[j, a, b] = P[r, a, b]
                F[j, a, b] = 0.0
        d = dt_rows[r] if dt_rows.size else dtm
        dt[j] = d
        for a in range(4):
            F[j, a, a] = 1.0
        F[j, 0, 2] = d
        F[j, 1, 3] = d
        zw[j, 0] = z[r, 0]
        zw[j, 1] = z[r, 1]
        use_w[j] = use[r]
        if per_row:
            var_w[j] = mv[r]


@kernel
def update_startup(rows, xp, Pp, dt3, dt, q, zw, var, use_w, gate, x, P, n_meas):
    """The predicted filters xp (k, 4), Pp (k, 4, 4) (changed in place) with the white-acceleration
    noise of intensity q (dt3 (k,) numpy's ``dt**3``), updated with zw (k, 2) of σ² var ((1,) or
    (k,)) where ``use_w`` and inside the gate; written into the rows ``rows`` of x, P, and
    ``n_meas[rows] += ok``. Returns ok (k,) bool: the rows updated."""
    k = rows.size
    _add_cv_noise(Pp, dt3, dt, q)
    d2 = np.empty(k)
    position_update(xp, Pp, zw, var, use_w, gate, d2)
    ok = np.empty(k, dtype=np.bool_)
    for j in range(k):
        o = use_w[j] and d2[j] <= gate
        ok[j] = o
        r = rows[j]
        for a in range(4):
            x[r, a] = xp[j, a]
            for b in range(4):
                P[r, a, b] = Pp[j, a, b]
        n_meas[r] += o
    return ok


@kernel
def settled_startup(rows, xp, Pp, dt3, dt, q, zw, var, use_w, gate, x, P, n_meas, d2_min, use, finite, measured, s,
                    s_P, mu, s_new, P_new, mu_new, n_gated, limit):
    """:func:`update_startup` of the start-up rows (rows … n_meas as there) and then
    :func:`~mjasc.perception.imm.bank_kernels.settled_rows` of the cycle with those rows and their
    ok (d2_min … limit as there, s_P its P): returns settled_rows' (inside, reasons, restart, used,
    the number restarted)."""
    ok_w = update_startup(rows, xp, Pp, dt3, dt, q, zw, var, use_w, gate, x, P, n_meas)
    return settled_rows(d2_min, gate, use, finite, measured, rows, ok_w, use_w, s, s_P, mu, s_new, P_new, mu_new,
                        n_gated, limit)


@kernel
def settled_startup_into(rows, xp, Pp, dt3, dt, q, zw, var, use_w, gate, x, P, n_meas, d2_min, use, finite, measured,
                         s, s_P, mu, s_new, P_new, mu_new, n_gated, limit, inside, ok, reasons, restart, used):
    """:func:`settled_startup` with settled_rows' outcome written into inside, ok, reasons, restart and
    used (:func:`~mjasc.perception.imm.bank_kernels.settled_rows_into`); returns the number restarted."""
    ok_w = update_startup(rows, xp, Pp, dt3, dt, q, zw, var, use_w, gate, x, P, n_meas)
    return settled_rows_into(d2_min, gate, use, finite, measured, rows, ok_w, use_w, s, s_P, mu, s_new, P_new, mu_new,
                             n_gated, limit, inside, ok, reasons, restart, used)


@kernel
def handover_rows(rows, xc, speed, theta, JPJ, cv_P, n_meas, snr2, max_updates, active, x, Pc, s, P, mu, mu0):
    """The hand-over of the start-up rows ``rows`` (k,) with filters xc (k, 4), cv_P (k, 4, 4),
    |v| ``speed`` (k,), atan2 ``theta`` (k,) and ``JPJ`` = J P Jᵀ (k, 4, 4) (changed in place): the
    polar state and covariance (:func:`_polar_finish`) written into the bank's x[rows] and Pc[rows];
    a row ready for the IMM (``V·V ≥ snr2·λ_max`` of the velocity covariance, or
    ``n_meas ≥ max_updates``) made inactive, every model's s[row] the polar state, P[row] its
    covariance and μ[row] = μ0. Returns the number of active rows made inactive."""
    sp, Pp = _polar_finish(xc, speed, theta, JPJ)
    r_models = mu.shape[1]
    off = 0
    for j in range(rows.size):
        r = rows[j]
        for a in range(4):
            x[r, a] = sp[j, a]
            for b in range(4):
                Pc[r, a, b] = Pp[j, a, b]
        a_, b_, c_ = cv_P[j, 2, 2], cv_P[j, 3, 3], cv_P[j, 2, 3]
        half_tr = 0.5 * (a_ + b_)
        d = 0.5 * (a_ - b_)
        lam_max = half_tr + math.sqrt(d * d + c_ * c_)
        v = sp[j, 3]
        if (v * v >= snr2 * lam_max) or (n_meas[r] >= max_updates):
            if active[r]:
                off += 1
            active[r] = False
            for m in range(r_models):
                mu[r, m] = mu0[m]
                for a in range(4):
                    s[r, m, a] = sp[j, a]
                    for b in range(4):
                        P[r, m, a, b] = Pp[j, a, b]
    return off


@kernel
def born_rows(s, P, mu, x, n0, mu0, ids, t, Pc, n_gated, reasons, new_ids, new_t, xc, speed, theta, JPJ, cv_P, n_meas,
              snr2, max_updates, active):
    """k new rows after the first n0 of a bank's state views s, P, μ, x (in place) and its per-track
    arrays (ids, t, Pc, n_gated, reasons: returned as new arrays, with whether every new t equals the
    first, :func:`~mjasc.perception.imm.bank_kernels.appended_rows`), then the hand-over of the new
    rows n0 … n0 + k − 1 (:func:`handover_rows`: their estimate, the ready ones in the IMM; the
    start-up filters' xc (k, 4), cv_P (k, 4, 4), n_meas and active already appended). Returns
    (ids, t, Pc, n_gated, reasons, one_time, number of rows made inactive)."""
    k = new_t.size
    ids2, t2, Pc2, g2, r2, one_time = appended_rows(s, P, mu, x, n0, mu0, np.zeros((k, 4)), ids, t, Pc, n_gated,
                                                    reasons, new_ids, new_t, np.zeros((k, 4, 4)))
    rows = np.arange(n0, n0 + k)
    off = handover_rows(rows, xc, speed, theta, JPJ, cv_P, n_meas, snr2, max_updates, active, x, Pc2, s, P, mu, mu0)
    return ids2, t2, Pc2, g2, r2, one_time, off


@kernel
def kept_bank_rows(keep, s, P, mu, x, s_out, P_out, mu_out, x_out, ids, t, Pc, n_gated, reasons, active, cv_x, cv_P,
                   n_meas):
    """:func:`~mjasc.perception.imm.bank_kernels.kept_rows` (keep … reasons as there) and then
    :func:`~mjasc.perception.imm.startup._kept_started` of the start-up filters (active, cv_x, cv_P,
    n_meas): (ids, t, Pc, n_gated, reasons, active, x, P, n_meas, number of active rows), each array new."""
    ids2, t2, Pc2, g2, r2 = kept_rows(keep, s, P, mu, x, s_out, P_out, mu_out, x_out, ids, t, Pc, n_gated, reasons)
    a2, x2, cP2, c2, n_active = _kept_started(keep, active, cv_x, cv_P, n_meas)
    return ids2, t2, Pc2, g2, r2, a2, x2, cP2, c2, n_active


@kernel
def predicted_startup(xc, Pc, F, dt):
    """The start-up filters' prediction in place, numpy's ``(F @ xc[..., None])[..., 0]``,
    ``F @ Pc @ F.transpose(0, 2, 1)`` and ``dt**3`` with its bits, for the k = dt.size rows of xc
    (k, 4), Pc (k, 4, 4) and the transitions F (k, 4, 4) of :func:`gather_startup` (identity with
    F[0, 2] = F[1, 3] = dt): F x summed in order from +0, unfused (OpenBLAS's dgemv; with F's zeros and ones
    any order of the two non-zero terms gives the same bits), F P Fᵀ as :func:`sandwich_into`.
    Returns dt³ (k,)."""
    k = dt.size
    xo = np.empty(4)
    for i in range(k):
        for a in range(4):
            acc = 0.0
            for b in range(4):
                acc = acc + F[i, a, b] * xc[i, b]
            xo[a] = acc
        for a in range(4):
            xc[i, a] = xo[a]
    Pw = np.empty((k, 4, 4))
    sandwich_into(F, Pc, k, Pw)
    dt3 = np.empty(k)
    for i in range(k):
        for a in range(4):
            for b in range(4):
                Pc[i, a, b] = Pw[i, a, b]
        dt3[i] = dt[i] ** 3.0
    return dt3


@kernel
def handover_polar(rows, xc, cv_P, n_meas, snr2, max_updates, active, x, Pc, s, P, mu, mu0):
    """:func:`handover_rows` (arguments as there) with its |v| (``np.hypot``), θ (``np.arctan2``) and
    ``J P Jᵀ`` (J :func:`~mjasc.perception.imm.startup._polar_jacobians`, the product as
    :func:`sandwich_into`) computed here, with numpy's bits. Returns the number of rows made inactive."""
    k = rows.size
    speed = np.empty(k)
    theta = np.empty(k)
    for j in range(k):
        speed[j] = math.hypot(xc[j, 2], xc[j, 3])
        theta[j] = math.atan2(xc[j, 3], xc[j, 2])
    J = _polar_jacobians(xc, speed)
    JPJ = np.empty((k, 4, 4))
    sandwich_into(J, cv_P, k, JPJ)
    return handover_rows(rows, xc, speed, theta, JPJ, cv_P, n_meas, snr2, max_updates, active, x, Pc, s, P, mu, mu0)


@kernel
def startup_cycle_into(rows, xc, Pc, F, dt, q, zw, var, use_w, gate, x, P, n_meas, d2_min, use, finite, measured, s,
                       s_P, mu, s_new, P_new, mu_new, n_gated, limit, inside, ok, reasons, restart, used, snr2,
                       max_updates, active, x_new, Pc_bank, mu0):
    """The start-up rows' part of a bank's general cycle in one call: :func:`predicted_startup` (xc, Pc, F,
    dt: the gathered rows, in place), :func:`settled_startup_into` (its arguments rows … used as there,
    with xp, Pp = xc, Pc and dt³ from the prediction) and then :func:`handover_polar` of the rows with
    their updated filters (n_meas, snr2, max_updates, active: the start-up filters'; x_new, Pc_bank,
    s_new, P_new, mu_new, mu0: the bank's new state, as its ``_handover`` writes it). Returns (the
    number restarted, the number of rows made inactive)."""
    dt3 = predicted_startup(xc, Pc, F, dt)
    n_restart = settled_startup_into(rows, xc, Pc, dt3, dt, q, zw, var, use_w, gate, x, P, n_meas, d2_min, use,
                                     finite, measured, s, s_P, mu, s_new, P_new, mu_new, n_gated, limit, inside, ok,
                                     reasons, restart, used)
    off = handover_polar(rows, xc, Pc, n_meas, snr2, max_updates, active, x_new, Pc_bank, s_new, P_new, mu_new, mu0)
    return n_restart, off
