"""The front of an IMM bank's measured cycle (:meth:`mjasc.perception.imm.bank.IMMBank.update_measured`)
in one compiled call: :func:`~mjasc.perception.imm.bank_kernels.measurements` (the finite and used rows,
unusable σ² replaced), :func:`~mjasc.perception.imm.compiled_cycle.imm_cycle`, the test of the common
case (every row used and inside the gate, no start-up rows) and, when that fails with start-up rows,
their indices and :func:`~mjasc.perception.imm.startup_rows.gather_startup_into` into the row
buffers' scratch rows — the calls the bank made one after the other (three dispatches, a
``nonzero`` and a reduction), the same code, hence the same bits. What follows (the start-up
filters' products, numpy's) stays the bank's (tests/test_imm_measured_cycle.py: a bank cycling
through it against one cycling through the separate calls, bit for bit).
"""

from __future__ import annotations

from mjasc.core.compiled import kernel
from mjasc.perception.imm.bank_kernels import measurements
from mjasc.perception.imm.compiled_cycle import imm_cycle
from mjasc.perception.imm.startup_rows import gather_startup_into

__all__ = ["measured_cycle"]


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
