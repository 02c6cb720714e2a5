"""An IMM bank's measured cycle in one or two compiled calls. The front of it (:meth:`mjasc.perception.imm.bank.IMMBank.update_measured`)
in one compiled call: :func:`~mjasc.perception.imm.bank_kernels.measurements` (the finite and used rows,
unusable σ² replaced), :func:`~mjasc.perception.imm.compiled_cycle.imm_cycle`, the test of the common
case (every row used and inside the gate, no start-up rows) and, when that fails with start-up rows,
their indices and :func:`~mjasc.perception.imm.startup_rows.gather_startup_into` into the row
buffers' scratch rows — the calls the bank made one after the other (three dispatches, a
``nonzero`` and a reduction), the same code, hence the same bits. What follows (the start-up
filters' products, numpy's) stays the bank's (tests/test_imm_measured_cycle.py: a bank cycling
through it against one cycling through the separate calls, bit for bit).

:func:`measured_settle` is that front and, unless the cycle is the common case, what the bank's general
end of a cycle called next in its own call: the start-up filters' cycle and hand-over
(:func:`~mjasc.perception.imm.startup_rows.startup_cycle_into`) or, with no start-up rows, the rows'
outcome (:func:`~mjasc.perception.imm.bank_kernels.settled_rows_into`) — one call per cycle instead of
two (tests/test_imm_measured_cycle.py: against those calls, bit for bit, on a real run).
"""

from __future__ import annotations

import numpy as np

from mjasc.core.compiled import kernel
from mjasc.perception.imm.bank_kernels import measurements, settled_rows_into
from mjasc.perception.imm.compiled_cycle import imm_cycle
from mjasc.perception.imm.startup_rows import gather_startup_into, startup_cycle_into

__all__ = ["measured_cycle", "measured_settle"]


@kernel
def measured_cycle(z, measured, mv, per_row, R, finite, use, every_true, s, P, mu, markov, dt, dt_omega, q, floor,
                   gate, s_out, P_out, mu_out, x_out, d2_min, n_active, active, cv_x, cv_P, dt_rows, dtm, w_rows, w_x,
                   w_P, w_dt, w_F, w_z, w_use, w_var):
    """:func:`measurements` (z (n, 2), measured (n,), mv ((n,) σ² if ``per_row``, else the config's (1,)), R,
    finite and use (n,) written), :func:`imm_cycle` of the bank's s, P, μ with the step's constants (markov
    … q), σ² mv and the used rows (``every_true`` (n,) all True when every row is used) into s_out … d2_min,
    then, unless every row was used and inside the gate with no start-up rows (``n_active``), the
    start-up rows (``active`` (n,)) written into w_rows and gathered (:func:`gather_startup_into` of
    cv_x, cv_P, dt_rows / dtm, z, the used rows and mv, into w_x … w_var). Returns (every row used,
    the common case, the number of start-up rows gathered)."""
    n = z.shape[0]
    every = measurements(z, measured, mv, per_row, R, finite, use)
    u = every_true if every else use
    imm_cycle(s, P, mu, markov, dt, dt_omega, q, z, mv, u, floor, gate, s_out, P_out, mu_out, x_out, d2_min)
    if every and n_active == 0:
        inside = True
        for k in range(n):
            if not d2_min[k] <= gate:  # (NaN: not inside, as numpy's maximum.reduce propagates it)
                inside = False
                break
        if inside:
            return every, True, 0
    k = 0
    if n_active > 0:
        for r in range(n):
            if active[r]:
                w_rows[k] = r
                k += 1
        gather_startup_into(w_rows[:k], cv_x, cv_P, dt_rows, dtm, z, u, mv, per_row, w_x, w_P, w_dt, w_F, w_z, w_use,
                            w_var)
    return every, False, k


@kernel
def measured_settle(z, measured, mv, per_row, R, finite, use, every_true, s, P, mu, markov, dt, dt_omega, q, floor,
                    gate, s_out, P_out, mu_out, x_out, d2_min, n_active, active, cv_x, cv_P, dt_rows, dtm, w_rows, w_x,
                    w_P, w_dt, w_F, w_z, w_use, w_var, q_cv, n_meas, n_gated, limit, inside, ok, reasons, restart,
                    used, snr2, max_updates, Pc, mu0):
    """:func:`measured_cycle` (arguments z … w_var as there) and, unless it is the common case, the bank's
    settling of the cycle (``_settle``): with start-up rows :func:`startup_cycle_into` of the k gathered rows
    (q_cv the start-up filters' acceleration noise, their σ² w_var when ``per_row`` else mv; cv_x, cv_P,
    n_meas, snr2, max_updates, active: the start-up filters'; n_gated, limit, reasons: the bank's, changed in
    place; inside, ok, restart, used (n,) written; Pc, mu0: the bank's), else :func:`settled_rows_into` —
    of the used, finite and measured rows (``every_true`` when every row is used). Returns (every row used,
    the common case, the number restarted, the number of start-up rows handed over)."""
    every, common, k = measured_cycle(z, measured, mv, per_row, R, finite, use, every_true, s, P, mu, markov, dt,
                                      dt_omega, q, floor, gate, s_out, P_out, mu_out, x_out, d2_min, n_active, active,
                                      cv_x, cv_P, dt_rows, dtm, w_rows, w_x, w_P, w_dt, w_F, w_z, w_use, w_var)
    if common:
        return every, True, 0, 0
    if every:
        n_restart, off = _settled(every_true, every_true, every_true, k, mv, per_row, gate, s, P, mu, s_out, P_out,
                                  mu_out, x_out, d2_min, n_active, active, cv_x, cv_P, w_rows, w_x, w_P, w_dt, w_F,
                                  w_z, w_use, w_var, q_cv, n_meas, n_gated, limit, inside, ok, reasons, restart, used,
                                  snr2, max_updates, Pc, mu0)
    else:
        n_restart, off = _settled(use, finite, measured, k, mv, per_row, gate, s, P, mu, s_out, P_out, mu_out, x_out,
                                  d2_min, n_active, active, cv_x, cv_P, w_rows, w_x, w_P, w_dt, w_F, w_z, w_use, w_var,
                                  q_cv, n_meas, n_gated, limit, inside, ok, reasons, restart, used, snr2, max_updates,
                                  Pc, mu0)
    return every, False, n_restart, off


@kernel
def _settled(use, finite, measured, k, mv, per_row, gate, s, P, mu, s_out, P_out, mu_out, x_out, d2_min, n_active,
             active, cv_x, cv_P, w_rows, w_x, w_P, w_dt, w_F, w_z, w_use, w_var, q_cv, n_meas, n_gated, limit, inside,
             ok, reasons, restart, used, snr2, max_updates, Pc, mu0):
    """:func:`measured_settle`'s second part (the bank's ``_settle`` calls, with its scratch rows): returns
    (the number restarted, the number of start-up rows handed over)."""
    if n_active > 0:
        rows = w_rows[:k]
        if per_row:
            return startup_cycle_into(rows, w_x[:k], w_P[:k], w_F[:k], w_dt[:k], q_cv, w_z[:k], w_var[:k], w_use[:k],
                                      gate, cv_x, cv_P, n_meas, d2_min, use, finite, measured, s, P, mu, s_out,
                                      P_out, mu_out, n_gated, limit, inside, ok, reasons, restart, used, snr2,
                                      max_updates, active, x_out, Pc, mu0)
        return startup_cycle_into(rows, w_x[:k], w_P[:k], w_F[:k], w_dt[:k], q_cv, w_z[:k], mv, w_use[:k], gate, cv_x,
                                  cv_P, n_meas, d2_min, use, finite, measured, s, P, mu, s_out, P_out, mu_out, n_gated,
                                  limit, inside, ok, reasons, restart, used, snr2, max_updates, active, x_out, Pc, mu0)
    none, no = np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.bool_)
    n_restart = settled_rows_into(d2_min, gate, use, finite, measured, none, no, no, s, P, mu, s_out, P_out, mu_out,
                                  n_gated, limit, inside, ok, reasons, restart, used)
    return n_restart, 0
