"""BankUpdates: an IMM bank's measured cycle — the mixin :class:`mjasc.perception.imm.bank.IMMBank`
inherits (thesis §3.2.1, docs/thesis.md §2): ``update`` (checked arrays), ``update_measured`` (a
caller's checked arrays, no copies), ``update_finite`` (every row a finite measurement), and behind them
the measurement check and the IMM cycle (one compiled call with the row buffers' scratch rows,
:func:`~mjasc.perception.imm.measured_cycle.measured_cycle`; with the general end's compiled calls,
:func:`~mjasc.perception.imm.measured_cycle.measured_settle`), the common case (every track measured and
accepted: ``_accept``) and the general end of a cycle (``_settle``: updated, coasting, start-up and
restarted tracks, the start-up filters' products with numpy's bits in one compiled call, the rest in another).

The mixin has no state of its own: it reads and writes the bank's per-track arrays, cycle buffers,
row buffers and start-up filters set by ``IMMBank.__init__`` (and calls its ``_free_side``,
``_handover`` and ``_start``). Rejections are logged on ``mjasc.perception.imm`` (debug: each
rejected measurement; info: each restart).
"""

from __future__ import annotations

import logging

import numpy as np

from mjasc.perception.imm.bank_kernels import (GATED, NON_FINITE, REJECTION_REASONS, RESTARTED, measurements,
                                                settled_rows, settled_rows_into)
from mjasc.perception.imm.compiled_cycle import imm_cycle
from mjasc.perception.imm.markov import cycle_steps
from mjasc.perception.imm.measured_cycle import measured_cycle, measured_settle
from mjasc.perception.imm.startup_rows import (gather_startup, gather_startup_into, predicted_startup,
                                               settled_startup, settled_startup_into, startup_cycle_into)

logger = logging.getLogger("mjasc.perception.imm")

__all__ = ["BankUpdates"]

_ALL = np.ones(1, dtype=bool)  # ``use`` of imm_cycle: every row
_NO_VAR = np.zeros(0)  # (gather_startup: no per-row steps or σ²)
_NO_ROWS, _NO_FLAGS = np.zeros(0, dtype=np.int64), np.zeros(0, dtype=bool)  # (settled_rows: no start-up rows)


class BankUpdates:
    """The measured cycle of :class:`~mjasc.perception.imm.bank.IMMBank` (a mixin: the bank's base
    class; see the module docstring for what it reads)."""

    _startup_in_one_call = True  # (False: the start-up rows' hand-over through the bank's ``_handover`` after
    # their update — the fused call's reference in tests/test_imm_startup_rows.py)

    def update(self, z, t_s, mask=None, measurement_variance=None) -> np.ndarray:
        """One IMM cycle for every track at time t_s (scalar or (n,) [s]).

        z: (n, 2) measured positions [m], one row per track (row order of ``track_ids``).
        mask: (n,) bool, True where the row carries a measurement (default: all rows). Rows that
        are unmeasured, not finite or outside the gate are not used: the track coasts to t_s.
        Returns (n,) bool, True where the row was used (updated, or restarted from it after
        ``restart_after_gated`` gated rows in a row); ``rejection_reasons`` says why not.
        measurement_variance: optional (n,) σ² per row [m²] (R = σ² I₂ for that row's
        measurement, e.g. from the detection that produced it); default the config's.
        """
        n = self._ids.size
        z = np.asarray(z, dtype=float)
        if z.shape != (n, 2):
            raise ValueError(f"z: need shape ({n}, 2) (one [x, y] per track), got {z.shape}")
        if n == 0:
            return np.zeros(0, dtype=bool)
        if measurement_variance is not None:
            mv = np.array(measurement_variance, dtype=float)  # (a copy: unusable σ² are replaced in it)
            if mv.shape != (n,):
                raise ValueError(f"measurement_variance: need shape ({n},), got {mv.shape}")
        else:
            mv = None
        if mask is None:
            measured = np.ones(n, dtype=bool)
        else:
            measured = np.asarray(mask, dtype=bool)
            if measured.shape != (n,):
                raise ValueError(f"mask: need shape ({n},), got {measured.shape}")
        return self._measured_cycle(z, t_s, measured, mv, np.empty(n, dtype=bool), np.empty(n, dtype=bool))

    def update_measured(self, z, t_s, measured, measurement_variance=None) -> np.ndarray:
        """:meth:`update` for a caller that has checked its arrays: z (n, 2) float, ``measured`` (n,)
        bool, ``measurement_variance`` (n,) float or None — changed in place (its unusable σ²
        replaced by the config's, as :meth:`update` does in its copy); n ≥ 1. The same cycle and
        result as :meth:`update`, without the checks and copies."""
        n = self._ids.size
        rb = self._rb
        if rb is not None and rb.cap >= n:  # (the row buffers' scratch rows: no arrays made)
            finite, use = rb.scratch_flags(n)[:2]
        else:
            finite, use = np.empty(n, dtype=bool), np.empty(n, dtype=bool)
        return self._measured_cycle(z, t_s, measured, measurement_variance, finite, use)

    def _measured_cycle(self, z, t_s, measured, mv, finite, use) -> np.ndarray:
        """The cycle of :meth:`update` / :meth:`update_measured` on checked arrays: the finite rows
        and the rows used written into ``finite`` / ``use`` (n,) and unusable σ² in ``mv`` replaced
        by the config's, in one compiled pass; then one IMM cycle (of every row when all are used).
        With the row buffers' scratch rows, those, the cycle and the settling of a general cycle (``_settle``'s
        compiled calls) are one compiled call (:func:`~mjasc.perception.imm.measured_cycle.measured_settle`; with
        ``_startup_in_one_call`` False, the front alone, :func:`~mjasc.perception.imm.measured_cycle.measured_cycle`,
        then ``_settle``)."""
        rb = self._rb
        n = z.shape[0]
        if rb is not None and rb.cap >= n:
            t0, t, dt, dtm, step = cycle_steps(self._t, self._t_common, self._ids, t_s, self._consts)  # (_times)
            out, side = self._free_side()
            st = self._startup
            _, _, every_true, inside, restart, ok = rb.scratch_flags(n)
            front = (z, measured, self._var if mv is None else mv, mv is not None, self._R, finite, use, every_true,
                     self._s, self._P, self._mu, *step, self._floor, self._gate, *side, st.n_active, st.active, st.x,
                     st.P, _NO_VAR if t is None else dt, dtm if t is None else 0.0, rb.w_rows, rb.w_x, rb.w_P, rb.w_dt,
                     rb.w_F, rb.w_z, rb.w_use, rb.w_var)
            if self._startup_in_one_call:  # (the settling in the same call: measured_settle)
                used = np.empty(n, dtype=bool)
                reasons = self._reasons
                every, common, n_restart, off = measured_settle(
                    *front, self._q_cv, st.n_meas, self._n_gated, self.config.restart_after_gated, inside, ok,
                    reasons, restart, used, st.snr2, st.max_updates, self._Pc, self._mu0)
                if common:
                    self._accept(out, side, t0, t)
                    return np.ones(n, dtype=bool)
                st.n_active -= off
                if every:
                    use = finite = measured = every_true
                return self._settled(z, out, side, t0, t, use, finite, measured, mv, inside, restart, reasons, used,
                                     n_restart)
            every, common, k = measured_cycle(*front)
            if common:
                self._accept(out, side, t0, t)
                return np.ones(n, dtype=bool)
            if every:
                use = finite = measured = every_true
            return self._settle(z, out, side, t0, t, dt, dtm, use, finite, measured, mv,
                                rb.w_rows[:k] if st.n_active else None)
        return self._separate_cycle(z, t_s, measured, mv, finite, use)

    def _separate_cycle(self, z, t_s, measured, mv, finite, use) -> np.ndarray:
        """:meth:`_measured_cycle` through the separate calls (the measurement check, then
        :meth:`_cycle`): the path without the row buffers' scratch rows, and the fused call's
        reference in the tests."""
        all_used = measurements(z, measured, mv if mv is not None else self._var, mv is not None, self._R, finite, use)
        self._mv = mv
        try:
            if all_used:
                ok = self._cycle(z, t_s)
                return np.ones(z.shape[0], dtype=bool) if ok is None else ok
            return self._cycle(z, t_s, use, finite, measured)
        finally:
            self._mv = None

    def update_finite(self, z, t_s):
        """:meth:`update`'s fast path, for a caller that has checked that every row of z (n, 2) [m]
        is a finite measurement (no mask, the config's σ²): one IMM cycle at t_s (scalar or (n,)
        [s]). Returns None when every row was used, else the (n,) bool of the used rows (the
        others were gated, or restarted the track: ``rejection_reasons``)."""
        return self._cycle(z, t_s)

    def _cycle(self, z, t_s, use=None, finite=None, measured=None):
        """The IMM cycle behind ``update``: rows of z (n, 2) where ``use`` (None: every row is a
        finite measurement). Returns the (n,) bool array of used rows, or None when every row was
        used."""
        n = self._ids.size
        t0, t, dt, dtm, step = cycle_steps(self._t, self._t_common, self._ids, t_s, self._consts)  # (_times)
        out, side = self._free_side()
        mv = self._mv
        d2_min = side[4]
        imm_cycle(self._s, self._P, self._mu, *step, z, self._var if mv is None else mv,
                  _ALL if use is None else use, self._floor, self._gate, *side)

        if (
            use is None
            and not self._startup.n_active
            and (d2_min.item() if n == 1 else np.maximum.reduce(d2_min)) <= self._gate
        ):  # the common case: every track measured and accepted
            self._accept(out, side, t0, t)
            return None
        rb = self._rb
        if use is None:
            scratch = rb is not None and rb.cap >= n
            use = finite = measured = rb.scratch_flags(n)[2] if scratch else np.ones(n, dtype=bool)
        return self._settle(z, out, side, t0, t, dt, dtm, use, finite, measured, mv, None)

    def _accept(self, out, side, t0, t) -> None:
        """The end of a cycle whose every track was measured and accepted (no start-up rows): the new
        state from ``side``, the cycle's times (``out``: the free side's index; t0, t of ``cycle_steps``)."""
        self._s, self._P, self._mu, self._x = side[:4]
        self._side = out
        self._Pc_stale = True
        if self._flagged:  # some track has consecutive gated rows or a rejection reason
            self._n_gated.fill(0)
            self._reasons.fill(0)
            self._flagged = False
        if t is None:
            self._t.fill(t0)
        else:
            self._t = t
        self._t_common = t0

    def _settle(self, z, out, side, t0, t, dt, dtm, use, finite, measured, mv, rows_w) -> np.ndarray:
        """The end of the general cycle: a mix of updated, coasting, start-up and restarted tracks (t
        None: every row at t0), ``side`` written by the IMM cycle with the used rows ``use`` (n,) of
        z (n, 2) and σ² mv (n,) or None; ``rows_w``: the start-up rows when already gathered into the
        row buffers' scratch rows (:func:`~mjasc.perception.imm.measured_cycle.measured_cycle`), else
        None. Returns the (n,) bool array of used rows."""
        n = self._ids.size
        d2_min = side[4]
        rb = self._rb
        scratch = rb is not None and rb.cap >= n  # (the row buffers' scratch rows for the flags: no arrays made)
        warm = self._startup.active
        any_warm = self._startup.n_active > 0
        # the cycle updated the rows ``use & (d2_min <= gate)`` of the IMM rows, coasted the others; the
        # start-up rows keep their (unused) IMM state, their x is set by the hand-over below
        s_new, P_new, mu_new, x_new, _ = side
        if any_warm:  # the start-up filters' cycle (StartupFilters.update_rows): the products with numpy's bits
            st = self._startup
            if rows_w is not None:  # (gathered already)
                rows = rows_w
                xc, Pc, dtw, F, zw, use_w, var_w = rb.scratch_rows(rows.size)
            else:
                rows_w = rows = warm.nonzero()[0]  # (still the start-up rows at the hand-over below)
                k = rows.size
                if rb is not None and rb.cap >= k:  # (gathered into the row buffers' scratch rows: no arrays made)
                    gather_startup_into(rows, st.x, st.P, _NO_VAR if t is None else dt, dtm if t is None else 0.0, z,
                                        use, _NO_VAR if mv is None else mv, mv is not None, rb.w_x, rb.w_P, rb.w_dt,
                                        rb.w_F, rb.w_z, rb.w_use, rb.w_var)
                    xc, Pc, dtw, F, zw, use_w, var_w = rb.scratch_rows(k)
                else:
                    xc, Pc, dtw, F, zw, use_w, var_w = gather_startup(rows, st.x, st.P, _NO_VAR if t is None else dt,
                                                                      dtm if t is None else 0.0, z, use,
                                                                      _NO_VAR if mv is None else mv, mv is not None)
        limit = self.config.restart_after_gated
        handed = False  # (the start-up rows handed over already)
        if any_warm:  # (the start-up filters predicted — F x, F P Fᵀ, dt³ in numpy's bits — and updated, then
            # inside, ok, the start-up rows, rejections: one compiled call; with scratch rows the hand-over too)
            var_a = self._var if mv is None else var_w
            if scratch:  # (the codes written into the bank's own, the flags into scratch rows)
                _, _, _, inside, restart, ok = rb.scratch_flags(n)
                reasons, used = self._reasons, np.empty(n, dtype=bool)
            if scratch and self._startup_in_one_call:
                n_restart, off = startup_cycle_into(
                    rows, xc, Pc, F, dtw, self._q_cv, zw, var_a, use_w, self._gate, st.x, st.P, st.n_meas, d2_min, use,
                    finite, measured, self._s, self._P, self._mu, s_new, P_new, mu_new, self._n_gated, limit, inside,
                    ok, reasons, restart, used, st.snr2, st.max_updates, st.active, x_new, self._Pc, self._mu0)
                st.n_active -= off
                handed = True
            else:
                dt3 = predicted_startup(xc, Pc, F, dtw)  # (F x, F P Fᵀ in place and dt³, numpy's bits: one call)
                args = (rows, xc, Pc, dt3, dtw, self._q_cv, zw, var_a, use_w, self._gate, st.x, st.P, st.n_meas,
                        d2_min, use, finite, measured, self._s, self._P, self._mu, s_new, P_new, mu_new,
                        self._n_gated, limit)
                if scratch:
                    n_restart = settled_startup_into(*args, inside, ok, reasons, restart, used)
                else:
                    inside, reasons, restart, used, n_restart = settled_startup(*args)
        else:  # (inside, ok, rejections: one compiled pass)
            rows_w = _NO_ROWS
            args = (d2_min, self._gate, use, finite, measured, _NO_ROWS, _NO_FLAGS, _NO_FLAGS, self._s, self._P,
                    self._mu, s_new, P_new, mu_new, self._n_gated, limit)
            if scratch:
                _, _, _, inside, restart, ok = rb.scratch_flags(n)
                reasons, used = self._reasons, np.empty(n, dtype=bool)
                n_restart = settled_rows_into(*args, inside, ok, reasons, restart, used)
            else:
                inside, reasons, restart, used, n_restart = settled_rows(*args)
        return self._settled(z, out, side, t0, t, use, finite, measured, mv, inside, restart, reasons, used, n_restart,
                             (rows_w, xc, Pc) if any_warm and not handed else None)

    def _settled(self, z, out, side, t0, t, use, finite, measured, mv, inside, restart, reasons, used, n_restart,
                 handover=None) -> np.ndarray:
        """The end of :meth:`_settle` (and of :func:`~mjasc.perception.imm.measured_cycle.measured_settle`):
        the new state from ``side`` (``out``: the free side's index), the cycle's times (t None: every row
        at t0), the start-up rows' hand-over when not done yet (``handover``: ``_handover``'s arguments), the
        restarted rows started again from z, the rejection codes ``reasons`` and their log. Returns ``used``."""
        s_new, P_new, mu_new, x_new, d2_min = side
        self._s, self._P, self._mu, self._x = s_new, P_new, mu_new, x_new
        self._side = out
        self._Pc_stale = True

        if t is None:  # (_set_times(t0, t) without its call)
            self._t.fill(t0)
            t = self._t  # (for the log below)
        else:
            self._t = t
        self._t_common = t0
        if handover is not None:
            self._handover(*handover)
        if n_restart:
            rows = restart.nonzero()[0]
            self._start(rows, z[rows], None if mv is None else mv[rows])
            reasons[rows] = RESTARTED
            for k in rows:
                logger.info(
                    "IMM track %d restarted at t=%.3f s from z=%s after %d gated measurements",
                    self._ids[k], t[k], z[k], self.config.restart_after_gated,
                )
        self._reasons = reasons
        self._flagged = True
        if logger.isEnabledFor(logging.DEBUG):
            gated = use & ~inside
            for k in (measured & ~finite).nonzero()[0]:
                logger.debug(
                    "IMM track %d at t=%.3f s: rejected z=%s (%s)",
                    self._ids[k], t[k], z[k], REJECTION_REASONS[NON_FINITE],
                )
            for k in (gated & ~restart).nonzero()[0]:
                logger.debug(
                    "IMM track %d at t=%.3f s: rejected z=%s (%s; min d²=%.4g > gate %.4g)",
                    self._ids[k], t[k], z[k], REJECTION_REASONS[GATED], d2_min[k], self._gate,
                )
        return used
