"""RowBuffers: an IMM bank's per-track arrays and its start-up filters in capacity buffers, so a
birth writes its rows into spare room and a drop compacts the rows in place — one compiled call
each, nothing allocated and no arrays returned (each array a kernel returns is a Python object to
box; the births and drops of a tracker's clutter, on ~¾ of a demo's tracking steps, made ~20 of
them per step).

The bank's births and drops are :func:`append_rows` and :func:`keep_rows`, bound as its methods
``_append`` and ``keep_rows``. The bank (:class:`mjasc.perception.imm.bank.IMMBank`) reads its arrays ``_ids``, ``_t``, ``_Pc``,
``_n_gated``, ``_reasons`` and its start-up filters' ``active``, ``x``, ``P``, ``n_meas``
(:class:`~mjasc.perception.imm.startup.StartupFilters`) as the views of the first n rows of these
buffers (:meth:`RowBuffers.views`); a cycle may replace one of them by an array of its own (new
times, rejection codes), which the next birth or drop copies back (:meth:`RowBuffers.home`).
The state (s, P, μ, x) lives in the bank's :class:`~mjasc.perception.imm.cycle_buffers.CycleBuffers`.

* :func:`started_rows` — :func:`~mjasc.perception.imm.startup._appended_started`'s new rows
  (active, one measurement, x = [z, 0, 0], P = diag(R, R, σ_v0², σ_v0²)) written into rows n0 …;
* :func:`born_into` — :func:`~mjasc.perception.imm.startup_rows.born_rows` with the per-track
  arrays' new rows written into the buffers (:func:`~mjasc.perception.imm.bank_kernels.appended_rows`'
  values) and the hand-over (:func:`~mjasc.perception.imm.startup_rows.handover_rows`) of them;
* :func:`kept_into` — :func:`~mjasc.perception.imm.startup_rows.kept_bank_rows`: the state's kept
  rows copied into the other side, the per-track arrays and the start-up filters compacted in place.

Each writes the values of the form it replaces (tests/test_imm_row_buffers.py: a bank in buffers
against one whose births and drops make new arrays, bit for bit).
"""

from __future__ import annotations

import numpy as np

from mjasc.core.compiled import kernel
from mjasc.perception.imm.bank_kernels import _copy_model_row
from mjasc.perception.imm.startup import _polar_jacobians
from mjasc.perception.imm.startup_rows import handover_rows

__all__ = ["RowBuffers", "append_rows", "birth_room", "born_set", "home_rows", "keep_rows", "kept_set",
           "started_rows", "born_into", "started_born_into", "kept_into", "step_room"]

_NO_VAR = np.zeros(0)  # (started_rows: no per-row σ²)


class RowBuffers:
    """Room for ``cap`` tracks: ids, t [s], Pc (4, 4), n_gated, reasons (int8) and the start-up
    filters' active, x (4,), P (4, 4), n_meas, one row per track."""

    def __init__(self, cap: int):
        self.cap = cap
        self.ids = np.zeros(cap, dtype=np.int64)
        self.t = np.zeros(cap)
        self.Pc = np.zeros((cap, 4, 4))
        self.n_gated = np.zeros(cap, dtype=np.int64)
        self.reasons = np.zeros(cap, dtype=np.int8)
        self.active = np.zeros(cap, dtype=bool)
        self.cv_x = np.zeros((cap, 4))
        self.cv_P = np.zeros((cap, 4, 4))
        self.n_meas = np.zeros(cap, dtype=np.int64)
        # scratch rows of a general cycle's start-up rows (startup_rows.gather_startup_into)
        self.w_x, self.w_P, self.w_dt = np.zeros((cap, 4)), np.zeros((cap, 4, 4)), np.zeros(cap)
        self.w_F = np.zeros((cap, 4, 4))
        self.w_rows = np.zeros(cap, dtype=np.int64)  # (the start-up rows of a cycle: measured_cycle)
        self.w_z, self.w_use, self.w_var = np.zeros((cap, 2)), np.zeros(cap, dtype=bool), np.zeros(cap)
        self.w_fin, self.w_use2 = np.zeros(cap, dtype=bool), np.zeros(cap, dtype=bool)  # (an update's finite, use)
        # (a general cycle's inside, ok and restart flags; every row measured and used: all True, never written)
        self.w_in, self.w_ok = np.zeros(cap, dtype=bool), np.zeros(cap, dtype=bool)
        self.w_rs = np.zeros(cap, dtype=bool)
        self.w_true = np.ones(cap, dtype=bool)
        self._views: dict[int, tuple] = {}
        self._zero_polar = None  # (zeros, J at V = 0) for zero_polar
        self._scratch: dict[int, tuple] = {}  # k → scratch_rows(k); −n − 1 → scratch_flags(n)

    def views(self, n: int) -> tuple:
        """The first n rows: (ids, t, Pc, n_gated, reasons, active, x, P, n_meas) (the same view
        objects for the same n)."""
        v = self._views.get(n)
        if v is None:
            if len(self._views) > 64:
                self._views.clear()
            v = self._views[n] = (self.ids[:n], self.t[:n], self.Pc[:n], self.n_gated[:n], self.reasons[:n],
                                  self.active[:n], self.cv_x[:n], self.cv_P[:n], self.n_meas[:n])
        return v

    def scratch_rows(self, k: int) -> tuple:
        """The first k scratch rows of a general cycle's start-up rows: (w_x, w_P, w_dt, w_F, w_z, w_use,
        w_var) (the same view objects for the same k)."""
        v = self._scratch.get(k)
        if v is None:
            if len(self._scratch) > 128:
                self._scratch.clear()
            v = self._scratch[k] = (self.w_x[:k], self.w_P[:k], self.w_dt[:k], self.w_F[:k], self.w_z[:k],
                                    self.w_use[:k], self.w_var[:k])
        return v

    def scratch_flags(self, n: int) -> tuple:
        """The first n scratch flags of an update: (w_fin, w_use2, w_true, w_in, w_rs, w_ok) (the same view
        objects for the same n)."""
        v = self._scratch.get(-n - 1)
        if v is None:
            if len(self._scratch) > 128:
                self._scratch.clear()
            v = self._scratch[-n - 1] = (self.w_fin[:n], self.w_use2[:n], self.w_true[:n], self.w_in[:n],
                                         self.w_rs[:n], self.w_ok[:n])
        return v

    def zero_polar(self, k: int) -> tuple:
        """(zeros (k,), J (k, 4, 4)): |v| and atan2 of k new start-up filters (velocity (+0, +0)) and
        their polar Jacobians (:func:`~mjasc.perception.imm.startup._polar_jacobians` at V = 0): rows of
        arrays made once (for up to ``cap`` rows), never written."""
        zp = self._zero_polar
        if zp is None or zp[0].size < k:
            m = max(k, self.cap)
            zeros = np.zeros(m)
            zp = self._zero_polar = (zeros, _polar_jacobians(np.zeros((m, 4)), zeros))
        return zp[0][:k], zp[1][:k]

    def home(self, arrays: tuple) -> None:
        """Make the first n rows hold ``arrays`` (the bank's nine, n rows each, in the order of
        :meth:`views`): those that are not these buffers' views are copied in."""
        v = self.views(arrays[0].shape[0])
        for a, b in zip(arrays, v):
            if a is not b:
                b[...] = a


def append_rows(bank, z, t, ids, meas_var, id0=0) -> None:
    """:meth:`IMMBank._append <mjasc.perception.imm.bank.IMMBank>` (bound as that method): new rows
    started from z (k, 2) at t (k,), ids ``ids`` (k,) (empty: id0, id0 + 1, …): the start-up filter
    at z (σ² meas_var (k,) or the config's), its estimate as the row's, the ready ones handed over
    (as the bank's ``_start``) — written into spare rows of the cycle buffers and of the row buffers
    (:func:`started_rows`, :func:`born_into` around :func:`~mjasc.perception.imm.startup.cv_to_polar`'s
    numpy |v|, atan2 and J P Jᵀ)."""
    k = z.shape[0]
    n_before = bank._ids.size
    n = n_before + k
    cyc = bank._cyc
    if cyc is None or cyc.cap < n or bank._side is None:
        cyc = bank._own_state(n)
    s, P, mu, x, _ = cyc.views(bank._side, n)  # the state's rows, then spare ones
    st = bank._startup
    rb = home_rows(bank, n)
    per_row = meas_var is not None
    # a new filter's velocity is (+0, +0): |v| = hypot(0, 0) = +0, atan2(+0, +0) = +0 and its polar
    # Jacobian the constant one of V = 0 (_polar_jacobians' V ≤ 0 branch), whatever z — the rows of
    # zero_polar's arrays (the same values numpy's hypot, arctan2 and _polar_jacobians give); the filters
    # started, J P Jᵀ and the rows born in one call (started_born_into)
    zero, J = rb.zero_polar(k)
    one_time, off = started_born_into(rb.active, rb.cv_x, rb.cv_P, rb.n_meas, z, bank._R, bank._sv2,
                                      meas_var if per_row else _NO_VAR, per_row, J, s, P, mu, x, n_before, bank._mu0,
                                      rb.ids, rb.t, rb.Pc, rb.n_gated, rb.reasons, ids, id0, t, zero, st.snr2,
                                      st.max_updates)
    _rows_born(bank, rb, n_before, n, (s, P, mu, x), k - off, one_time, float(t[0]))


def birth_room(bank, m: int) -> tuple:
    """Room for m tracks in the bank's cycle buffers (its state in one side) and row buffers (its
    per-track arrays and start-up filters homed there, :func:`home_rows`), for births written past its
    n rows by a compiled caller (:func:`started_born_into`; a fleet tracker's births, one call with
    theirs): ((s, P, μ, x) of the state's side, every row of the buffers; the row buffers)."""
    cyc = bank._cyc
    if cyc is None or cyc.cap < m or bank._side is None:
        cyc = bank._own_state(m)
    rb = home_rows(bank, m)
    _view_rows(bank, rb, bank._ids.size)  # (the bank's arrays its rows there: the same values, rows following or not)
    return cyc.sides[bank._side], rb


def born_set(bank, k: int, one_time: bool, off: int) -> None:
    """After :func:`started_born_into` wrote k new rows past the bank's n into the buffers of
    :func:`birth_room` (ids the next k integers; ``one_time``, ``off``: its returns): the bank's arrays
    made the views of its n + k rows, its counts and common time set, as :func:`append_rows` ends."""
    n0 = bank._ids.size
    n = n0 + k
    rb = bank._rb
    _rows_born(bank, rb, n0, n, bank._cyc.views(bank._side, n)[:4], k - off, one_time, float(rb.t[n0]))
    bank._next_id += k


def _rows_born(bank, rb: RowBuffers, n0: int, n: int, state: tuple, started: int, one_time: bool,
               t0: float) -> None:
    """The end of a birth of n − n0 rows (:func:`append_rows`, :func:`born_set`): the bank's per-track
    arrays made the views of its n rows, its state (s, P, μ, x) those of the cycle buffers, ``started``
    more start-up filters active, and its common time t0 [s] kept only when every row shares it
    (``one_time``: the new rows do, and so did the old ones)."""
    _view_rows(bank, rb, n)
    bank._startup.n_active += started
    bank._s, bank._P, bank._mu, bank._x = state
    tc = bank._t_common
    bank._t_common = t0 if (n0 == 0 or tc == t0) and one_time else None


def _view_rows(bank, rb: RowBuffers, n: int) -> None:
    """The bank's per-track arrays and start-up filters made the views of the first n rows of its row
    buffers ``rb`` (and kept as its ``_rv``)."""
    st = bank._startup
    (bank._ids, bank._t, bank._Pc, bank._n_gated, bank._reasons, st.active, st.x, st.P,
     st.n_meas) = bank._rv = rb.views(n)


def home_rows(bank, n: int) -> RowBuffers:
    """The bank's row buffers with room for n tracks, holding its per-track arrays and start-up
    filters in their first rows (copied there when a cycle replaced one since — the bank's ``_rv``:
    the views they were last set to —, or into larger buffers). Bound as ``IMMBank._rows_home``."""
    rb = bank._rb
    st = bank._startup
    arrays = (bank._ids, bank._t, bank._Pc, bank._n_gated, bank._reasons, st.active, st.x, st.P, st.n_meas)
    rv = bank._rv
    if rb is None or rb.cap < n or rv[0].shape[0] != arrays[0].shape[0]:
        if rb is None or rb.cap < n:
            rb = bank._rb = RowBuffers(n + max(16, n // 2))
        rb.home(arrays)
    else:
        for a, b in zip(arrays, rv):
            if a is not b:
                b[...] = a
    return rb


def keep_rows(bank, keep) -> None:
    """Keep the rows where ``keep`` (n,) bool is True (drop the others at once): ``IMMBank.keep_rows``
    (bound as that method). A bank in its cycle buffers compacts its state into the other side's
    first rows and its per-track arrays and start-up filters in place in the row buffers, in one
    compiled pass (:func:`kept_into`)."""
    if type(keep) is not np.ndarray or keep.dtype != np.bool_:
        keep = np.asarray(keep, dtype=bool)
    if keep.shape != bank._ids.shape:
        raise IndexError(f"keep: need shape {bank._ids.shape}, got {keep.shape}")
    if bank._side is None:
        for name in bank._PER_TRACK:
            setattr(bank, name, getattr(bank, name)[keep])
        bank._startup.keep(keep)
        if bank._ids.size == 0:
            bank._t_common = None
        return
    rb = home_rows(bank, keep.size)
    m, n_active = kept_into(keep, bank._s, bank._P, bank._mu, bank._x, *bank._cyc.sides[1 - bank._side], rb.ids, rb.t,
                            rb.Pc, rb.n_gated, rb.reasons, rb.active, rb.cv_x, rb.cv_P, rb.n_meas)
    kept_set(bank, m, n_active)


def step_room(bank, m: int) -> tuple:
    """The bank (in its cycle buffers) ready for a compiled caller that drops rows and then adds births,
    :func:`kept_into` then :func:`started_born_into` (a fleet tracker's drops and births, one call): room for
    m tracks in the cycle buffers and the row buffers, the bank's per-track arrays and start-up filters homed
    there and made the views of its rows (what the drops' and the births' rooms make, at once). Returns ((s, P,
    μ, x) of the state's side and of the other side, every row of each; the row buffers)."""
    cyc = bank._cyc
    if cyc.cap < m:
        cyc = bank._own_state(m)
    rb = home_rows(bank, m)
    _view_rows(bank, rb, bank._ids.size)
    side = bank._side
    return cyc.sides[side], cyc.sides[1 - side], rb


def kept_set(bank, m: int, n_active: int) -> None:
    """After :func:`kept_into` compacted the bank to m rows (n_active of them start-up rows), its state in
    the other side of the cycle buffers: the bank's arrays made the views of its m rows."""
    side = 1 - bank._side
    st = bank._startup
    st.n_active = n_active
    bank._s, bank._P, bank._mu, bank._x, _ = bank._cyc.views(side, m)
    bank._side = side
    _view_rows(bank, bank._rb, m)
    if m == 0:
        bank._t_common = None


@kernel
def started_rows(active, x, P, n_meas, n0, z, R, sv2, meas_var, per_row):
    """Rows n0 … n0 + k − 1 (k = len(z)) of the start-up filters' buffers active, x, P, n_meas written
    in place as :func:`~mjasc.perception.imm.startup._appended_started` makes new rows: active, one
    measurement, x = [z, 0, 0], P = diag(R, R, sv2, sv2) with meas_var[j] (if ``per_row``) for R."""
    for j in range(z.shape[0]):
        i = n0 + j
        active[i] = True
        n_meas[i] = 1
        x[i, 0] = z[j, 0]
        x[i, 1] = z[j, 1]
        x[i, 2] = 0.0
        x[i, 3] = 0.0
        r = meas_var[j] if per_row else R
        for a in range(4):
            for b in range(4):
                P[i, a, b] = 0.0
        P[i, 0, 0] = r
        P[i, 1, 1] = r
        P[i, 2, 2] = sv2
        P[i, 3, 3] = sv2


@kernel
def born_into(s, P, mu, x, n0, mu0, ids, t, Pc, n_gated, reasons, new_ids, id0, new_t, xc, speed, theta, JPJ, cv_P,
              n_meas, snr2, max_updates, active):
    """k new rows after the first n0 (k = new_t.size): the state's views s, P (zero), μ (μ0), x
    (zero) and the per-track buffers ids (new_ids (k,), or id0, id0 + 1, … when new_ids is empty),
    t (new_t), Pc (zero), n_gated and reasons (0) written in place
    (:func:`~mjasc.perception.imm.bank_kernels.appended_rows`' values), then the hand-over of the new rows (:func:`handover_rows`: their x and Pc, the ready ones in the
    IMM; xc, speed, theta, JPJ, cv_P as there). Returns (whether every new t equals the first, the
    number of rows made inactive)."""
    k = new_t.size
    r = mu.shape[1]
    one_time = True
    for j in range(k):
        i = n0 + j
        for m in range(r):
            mu[i, m] = mu0[m]
            for a in range(4):
                s[i, m, a] = 0.0
                for b in range(4):
                    P[i, m, a, b] = 0.0
        for a in range(4):
            x[i, a] = 0.0
            for b in range(4):
                Pc[i, a, b] = 0.0
        ids[i] = new_ids[j] if new_ids.size else id0 + j
        t[i] = new_t[j]
        n_gated[i] = 0
        reasons[i] = 0
        if new_t[j] != new_t[0]:
            one_time = False
    off = handover_rows(np.arange(n0, n0 + k), xc, speed, theta, JPJ, cv_P, n_meas, snr2, max_updates, active, x, Pc,
                        s, P, mu, mu0)
    return one_time, off


@kernel
def started_born_into(active, cv_x, cv_P, n_meas, z, R, sv2, meas_var, per_row, J, s, P, mu, x, n0, mu0, ids, t, Pc,
                      n_gated, reasons, new_ids, id0, new_t, zero, snr2, max_updates):
    """:func:`started_rows` (the start-up filters' rows n0 … n0 + k − 1, k = len(z)), then their polar
    covariances J P Jᵀ (J (k, 4, 4): the polar Jacobians of V = 0, :meth:`RowBuffers.zero_polar`) and
    :func:`born_into` of the new rows (``zero`` (k,): their |v| and atan2, +0). J P Jᵀ as products over
    every term in order: each entry of J P and of (J P) Jᵀ has at most one non-zero term (P diagonal, J
    that of V = 0) and at least one +0 term, so it is that term's product exactly, as numpy's matmul
    gives it whatever its order of sums (tests/test_imm_row_buffers.py: against the numpy form). Returns
    born_into's (one_time, the number of rows made inactive)."""
    started_rows(active, cv_x, cv_P, n_meas, n0, z, R, sv2, meas_var, per_row)
    k = z.shape[0]
    JPJ = np.empty((k, 4, 4))
    A = np.empty((4, 4))
    for j in range(k):
        Pj = cv_P[n0 + j]
        Jj = J[j]
        for a in range(4):
            for b in range(4):
                acc = 0.0
                for c in range(4):
                    acc += Jj[a, c] * Pj[c, b]
                A[a, b] = acc
        for a in range(4):
            for b in range(4):
                acc = 0.0
                for c in range(4):
                    acc += A[a, c] * Jj[b, c]
                JPJ[j, a, b] = acc
    return born_into(s, P, mu, x, n0, mu0, ids, t, Pc, n_gated, reasons, new_ids, id0, new_t, cv_x[n0:n0 + k], zero,
                     zero, JPJ, cv_P[n0:n0 + k], n_meas, snr2, max_updates, active)


@kernel
def kept_into(keep, s, P, mu, x, s_out, P_out, mu_out, x_out, ids, t, Pc, n_gated, reasons, active, cv_x, cv_P,
              n_meas):
    """The rows where ``keep`` (n,) of the state s, P, μ, x copied in order into the other side's s_out,
    P_out, mu_out, x_out (their first m rows), and the per-track arrays ids, t, Pc, n_gated, reasons and
    the start-up filters' active, cv_x, cv_P, n_meas (n rows or more) compacted in place (``a[:m] =
    a[:n][keep]``). Returns (m, the number of active rows kept)."""
    c = 0
    n_active = 0
    for k in range(keep.size):
        if not keep[k]:
            continue
        _copy_model_row(s, P, mu, k, s_out, P_out, mu_out, c)
        for a in range(4):
            x_out[c, a] = x[k, a]
        if c != k:
            for a in range(4):
                cv_x[c, a] = cv_x[k, a]
                for b in range(4):
                    Pc[c, a, b] = Pc[k, a, b]
                    cv_P[c, a, b] = cv_P[k, a, b]
            ids[c] = ids[k]
            t[c] = t[k]
            n_gated[c] = n_gated[k]
            reasons[c] = reasons[k]
            active[c] = active[k]
            n_meas[c] = n_meas[k]
        n_active += active[c]
        c += 1
    return c, n_active
