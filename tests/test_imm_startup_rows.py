"""The start-up rows of a bank's cycle in three compiled calls (mjasc.perception.imm.startup_rows)
against the numpy form they replaced (StartupFilters.update_rows, cv_to_polar, hand_over and the
bank's state writes), bit for bit, on filters from a bank's run and on random ones; and a bank's run
with start-up tracks, coasting, gating and per-row variances against the same run through the numpy
form."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from mjasc.perception.imm.bank import IMMBank
from mjasc.perception.imm.startup import cv_to_polar
from mjasc.core.small_products import sandwich_into
from mjasc.perception.imm.startup_rows import (gather_startup, handover_polar, handover_rows, predicted_startup,
                                               update_startup)


def _same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


def _filters(seed):
    """A bank's start-up filters after a few cycles (some rows handed over), and the bank."""
    rng = np.random.default_rng(seed)
    bank = IMMBank()
    n = int(rng.integers(3, 12))
    bank.add_tracks(rng.normal(size=(n, 2)) * 50.0, 0.0, rng.uniform(0.1, 2.0, n) if seed % 2 else None)
    for step in range(1, int(rng.integers(1, 4))):
        z = bank.positions + rng.normal(size=(len(bank), 2)) * (0.3 + 3.0 * (step % 2))
        bank.update(z, step * 0.2, rng.random(len(bank)) < 0.8)
    return rng, bank


@pytest.mark.parametrize("seed", range(12))
def test_startup_update_equals_update_rows(seed):
    rng, bank = _filters(seed)
    st = bank._startup
    n = len(bank)
    rows = np.flatnonzero(rng.random(n) < 0.7).astype(np.int64)
    per_row_dt = seed % 3 == 0
    dt_all = rng.uniform(0.0, 0.5, n) if per_row_dt else np.zeros(0)
    dtm = 0.2
    z = bank.positions + rng.normal(size=(n, 2)) * (1.0 + 5.0 * rng.random(n))[:, None]
    use = rng.random(n) < 0.8
    mv = rng.uniform(0.05, 3.0, n)
    per_row = seed % 2 == 0
    gate = bank._gate
    ref = copy.deepcopy(st)
    dt_rows = dt_all[rows] if per_row_dt else np.full(rows.size, dtm)
    var = mv[rows] if per_row else bank._var
    ok_ref, x_ref, P_ref = ref.update_rows(rows, dt_rows, z[rows], var, use[rows], gate)

    xc, Pc, dt, F, zw, use_w, var_w = gather_startup(rows, st.x, st.P, dt_all, dtm, z, use, mv, per_row)
    xp = (F @ xc[..., None])[..., 0]
    Pp = F @ Pc @ np.swapaxes(F, 1, 2)
    ok = update_startup(rows, xp, Pp, dt**3, dt, float(st.acceleration_noise), zw, var_w if per_row else bank._var,
                        use_w, gate, st.x, st.P, st.n_meas)
    _same(ok, ok_ref)
    _same(xp, x_ref)
    _same(Pp, P_ref)
    for a, b in ((st.x, ref.x), (st.P, ref.P), (st.n_meas, ref.n_meas), (st.active, ref.active)):
        _same(a, b)


@pytest.mark.parametrize("seed", range(12))
def test_handover_rows_equals_numpy_form(seed):
    rng, bank = _filters(seed)
    n = len(bank)
    st = bank._startup
    if seed % 3 == 0:  # random filters too (fast ones hand over, slow ones wait)
        st.x[...] = rng.normal(size=st.x.shape) * 3.0
        A = rng.normal(size=(n, 4, 4))
        st.P[...] = A @ np.swapaxes(A, 1, 2) + 0.1 * np.eye(4)
        st.n_meas[...] = rng.integers(1, 6, n)
        st.active[...] = True
        st.n_active = n
    rows = np.flatnonzero(st.active).astype(np.int64)
    xc, cv_P = st.x[rows], st.P[rows]
    ref = copy.deepcopy(bank)
    # the numpy form (IMMBank._handover before)
    rs = ref._startup
    s, P = cv_to_polar(xc, cv_P)
    ref._x[rows] = s
    ref._Pc[rows] = P
    ready = rs.hand_over(rows, s, cv_P)
    if ready.any():
        done = rows[ready]
        ref._s[done] = s[ready][:, None, :]
        ref._P[done] = P[ready][:, None, :, :]
        ref._mu[done] = ref._mu0

    vx, vy = xc[:, 2], xc[:, 3]
    speed = np.hypot(vx, vy)
    from mjasc.perception.imm.startup import _polar_jacobians

    J = _polar_jacobians(xc, speed)
    off = handover_rows(rows, xc, speed, np.arctan2(vy, vx), J @ cv_P @ np.swapaxes(J, 1, 2), cv_P, st.n_meas,
                        st.snr2, st.max_updates, st.active, bank._x, bank._Pc, bank._s, bank._P, bank._mu, bank._mu0)
    st.n_active -= off
    assert st.n_active == rs.n_active and type(st.n_active) is int
    for name in ("_x", "_Pc", "_s", "_P", "_mu"):
        _same(getattr(bank, name), getattr(ref, name))
    _same(st.active, rs.active)


@pytest.mark.parametrize("seed", range(12))
def test_predicted_startup_is_numpys_products(seed):
    """F x, F P Fᵀ (in place) and dt³ compiled: numpy's bits, on a bank's filters and on random ones of every
    scale (zero and negative-zero velocities included)."""
    rng, bank = _filters(seed)
    st = bank._startup
    n = len(bank)
    for trial in range(30):
        if trial == 0:
            x, P, rows = st.x, st.P, np.arange(n, dtype=np.int64)
        else:
            k = int(rng.integers(1, 25))
            x = rng.normal(size=(k, 4)) * 10.0 ** rng.uniform(-3, 4, size=(k, 4))
            x[rng.random((k, 4)) < 0.1] = 0.0
            x[rng.random((k, 4)) < 0.05] = -0.0
            A = rng.normal(size=(k, 4, 4)) * 10.0 ** rng.uniform(-3, 3, size=(k, 1, 1))
            P = A @ np.swapaxes(A, 1, 2)
            rows = np.arange(k, dtype=np.int64)
        m = rows.size
        dt_all = rng.uniform(0.0, 2.0, m) * (rng.random(m) < 0.9) if trial % 2 else np.zeros(0)
        xc, Pc, dt, F, _, _, _ = gather_startup(rows, x, P, dt_all, 0.2, np.zeros((m, 2)), np.ones(m, dtype=bool),
                                                np.zeros(0), False)
        want_x, want_P, want_dt3 = (F @ xc[..., None])[..., 0], F @ Pc @ np.swapaxes(F, 1, 2), dt**3
        dt3 = predicted_startup(xc, Pc, F, dt)
        _same(xc, want_x)
        _same(Pc, want_P)
        _same(dt3, want_dt3)


@pytest.mark.parametrize("seed", range(12))
def test_handover_polar_is_handover_rows_with_numpys_products(seed):
    """handover_polar: handover_rows with numpy's hypot, arctan2 and J P Jᵀ, bit for bit (every array it writes)."""
    from mjasc.perception.imm.startup import _polar_jacobians

    rng, bank = _filters(seed)
    n = len(bank)
    st = bank._startup
    if seed % 2 == 0:  # random filters too (fast ones hand over, slow ones wait; some at rest)
        st.x[...] = rng.normal(size=st.x.shape) * 10.0 ** rng.uniform(-3, 2, size=st.x.shape)
        st.x[rng.random(n) < 0.2, 2:] = 0.0
        A = rng.normal(size=(n, 4, 4)) * 10.0 ** rng.uniform(-2, 2, size=(n, 1, 1))
        st.P[...] = A @ np.swapaxes(A, 1, 2) + 0.1 * np.eye(4)
        st.n_meas[...] = rng.integers(1, 6, n)
        st.active[...] = True
        st.n_active = n
    rows = np.flatnonzero(st.active).astype(np.int64)
    xc, cv_P = st.x[rows], st.P[rows]
    ref = copy.deepcopy(bank)
    rs = ref._startup
    vx, vy = xc[:, 2], xc[:, 3]
    speed = np.hypot(vx, vy)
    J = _polar_jacobians(xc, speed)
    off_ref = handover_rows(rows, xc.copy(), speed, np.arctan2(vy, vx), J @ cv_P @ np.swapaxes(J, 1, 2), cv_P.copy(),
                            rs.n_meas, rs.snr2, rs.max_updates, rs.active, ref._x, ref._Pc, ref._s, ref._P, ref._mu,
                            ref._mu0)
    off = handover_polar(rows, xc, cv_P, st.n_meas, st.snr2, st.max_updates, st.active, bank._x, bank._Pc, bank._s,
                         bank._P, bank._mu, bank._mu0)
    assert off == off_ref
    for name in ("_x", "_Pc", "_s", "_P", "_mu"):
        _same(getattr(bank, name), getattr(ref, name))
    _same(st.active, rs.active)


def test_sandwich_into_is_numpys_product_on_random_stacks():
    rng = np.random.default_rng(5)
    for it in range(300):
        k = int(rng.integers(1, 30))
        A = rng.normal(size=(k, 4, 4)) * 10.0 ** rng.uniform(-4, 4, size=(k, 4, 4))
        B = rng.normal(size=(k, 4, 4)) * 10.0 ** rng.uniform(-3, 3, size=(k, 1, 1))
        P = B @ np.swapaxes(B, 1, 2) if it % 2 else B
        if it % 3 == 0:  # (exact zeros of both signs: a sum of −0 products is +0, as OpenBLAS's)
            A = np.where(rng.random(A.shape) < 0.3, -0.0, np.where(rng.random(A.shape) < 0.3, 0.0, A))
            P = np.where(rng.random(P.shape) < 0.3, -0.0, np.where(rng.random(P.shape) < 0.3, 0.0, P))
        out = np.empty((k, 4, 4))
        sandwich_into(A, P, k, out)
        _same(out, A @ P @ np.swapaxes(A, 1, 2))


def _numpy_cycle_bank():
    """An IMMBank whose start-up rows run through the numpy form (StartupFilters.update_rows, cv_to_polar,
    hand_over): the bank's general cycle as it was, for the run test below."""
    import mjasc.perception.imm.bank as bank_mod

    from mjasc.perception.imm.bank_kernels import appended_rows

    class _Ref(IMMBank):
        _startup_in_one_call = False  # (its _handover below, the numpy form, after the start-up rows' update)

        def _append(self, z, t, ids, meas_var) -> None:  # (IMMBank._append before born_rows)
            k = z.shape[0]
            n_before = self._ids.size
            n = n_before + k
            cyc = self._cyc
            if cyc is None or cyc.cap < n or self._side is None:
                cyc = self._own_state(n)
            s, P, mu, x, _ = cyc.views(self._side, n)
            xc, Pcv = self._startup.append_started(z, self._R, meas_var)
            sp, Pp = cv_to_polar(xc, Pcv)
            self._ids, self._t, self._Pc, self._n_gated, self._reasons, one_time = appended_rows(
                s, P, mu, x, n_before, self._mu0, sp, self._ids, self._t, self._Pc, self._n_gated, self._reasons,
                ids, np.ascontiguousarray(t, dtype=float), Pp)
            self._s, self._P, self._mu, self._x = s, P, mu, x
            tc, t0 = self._t_common, float(t[0])
            self._t_common = t0 if (n_before == 0 or tc == t0) and one_time else None
            rows = np.arange(n_before, n)
            ready = self._startup.hand_over(rows, sp, Pcv)
            if ready.any():
                done = rows[ready]
                self._s[done] = sp[ready][:, None, :]
                self._P[done] = Pp[ready][:, None, :, :]
                self._mu[done] = self._mu0

        def _handover(self, rows, xc=None, cv_P=None):
            s, P = self._startup.polar(rows) if xc is None else cv_to_polar(xc, cv_P)
            self._x[rows] = s
            self._Pc[rows] = P
            ready = self._startup.hand_over(rows, s, cv_P)
            if ready.any():
                done = rows[ready]
                self._s[done] = s[ready][:, None, :]
                self._P[done] = P[ready][:, None, :, :]
                self._mu[done] = self._mu0

    return _Ref, bank_mod


@pytest.mark.parametrize("seed", range(4))
def test_bank_run_with_startup_rows_equals_numpy_handover(seed):
    """A run with births, coasting, gated rows and restarts: the bank's state after every cycle equals that of
    a bank whose births and hand-over are the numpy form (the start-up filters' update is compared above)."""
    from mjasc.perception.imm.config import IMMConfig

    Ref, _ = _numpy_cycle_bank()
    rng = np.random.default_rng(seed)
    cfg = IMMConfig() if seed < 2 else IMMConfig(init_max_updates=1)  # (then every birth hands over at once)
    a, b = IMMBank(cfg), Ref(cfg)
    truth = rng.normal(size=(6, 2)) * 40.0
    vel = rng.normal(size=(6, 2)) * 2.0
    for bank in (a, b):
        bank.add_tracks(truth[:3], 0.0)
    for step in range(1, 40):
        t = step * 0.2
        if step % 7 == 0:
            z0 = truth[3:] + vel[3:] * t
            var0 = rng.uniform(0.1, 1.0, 3) if step % 14 else None
            for bank in (a, b):
                bank.add_tracks(z0, t, var0)
            for name in ("_x", "_s", "_P", "_mu", "_t", "_ids", "_Pc"):
                _same(getattr(a, name), getattr(b, name))
            assert a._t_common == b._t_common and a._startup.n_active == b._startup.n_active
        n = len(a)
        k = min(n, 6)
        z = np.empty((n, 2))
        z[:k] = truth[:k] + vel[:k] * t + rng.normal(size=(k, 2)) * 0.5
        z[k:] = rng.normal(size=(n - k, 2))
        if step % 11 == 0:
            z[0] += 200.0  # gated
        mask = rng.random(n) < 0.85
        var = rng.uniform(0.05, 2.0, n) if step % 2 else None
        ua = a.update(z, t, mask, var)
        ub = b.update(z, t, mask, var)
        _same(ua, ub)
        for name in ("_x", "_s", "_P", "_mu", "_t", "_n_gated", "_reasons"):
            _same(getattr(a, name), getattr(b, name))
        _same(a.state_covariances, b.state_covariances)
        for name in ("active", "x", "P", "n_meas"):
            _same(getattr(a._startup, name), getattr(b._startup, name))
        assert a._startup.n_active == b._startup.n_active


@pytest.mark.parametrize("seed", range(20))
def test_settled_rows_equals_numpy_form(seed):
    """settled_rows against the numpy form of the general cycle's outcome before it: inside, ok, warm_rows, the
    rejections and ok | restart."""
    from mjasc.perception.imm.bank_kernels import rejections, settled_rows, warm_rows

    rng = np.random.default_rng(seed)
    n, r = int(rng.integers(1, 12)), 3
    d2_min = np.where(rng.random(n) < 0.2, np.nan, rng.uniform(0, 20, n))
    use, finite = rng.random(n) < 0.8, rng.random(n) < 0.9
    measured = use | (rng.random(n) < 0.3)
    rows_w = np.flatnonzero(rng.random(n) < 0.4).astype(np.int64)
    ok_w, use_w = rng.random(rows_w.size) < 0.5, rng.random(rows_w.size) < 0.7
    s, P, mu = rng.normal(size=(n, r, 4)), rng.normal(size=(n, r, 4, 4)), rng.random((n, r))
    s_new, P_new, mu_new = rng.normal(size=(n, r, 4)), rng.normal(size=(n, r, 4, 4)), rng.random((n, r))
    n_gated = rng.integers(0, 4, n)
    limit = int(rng.integers(0, 4))
    ref = [a.copy() for a in (s_new, P_new, mu_new, n_gated)]
    inside = d2_min <= 9.2
    ok = use & inside
    warm_rows(rows_w, ok_w, use_w, ok, inside, s, P, mu, ref[0], ref[1], ref[2])
    reasons, restart = np.empty(n, dtype=np.int8), np.empty(n, dtype=bool)
    rejections(use, finite, measured, inside, ok, ref[3], limit, reasons, restart)
    got = settled_rows(d2_min, 9.2, use, finite, measured, rows_w, ok_w, use_w, s, P, mu, s_new, P_new, mu_new, n_gated,
                       limit)
    for a, b in zip(got[:4], (inside, reasons, restart, ok | restart)):
        _same(a, b)
    assert got[4] == np.count_nonzero(restart)
    for a, b in zip((s_new, P_new, mu_new, n_gated), ref):
        _same(a, b)


@pytest.mark.parametrize("seed", range(12))
def test_settled_startup_is_update_then_settled(seed):
    """settled_startup against update_startup then settled_rows (the general cycle's two calls before it)."""
    from mjasc.perception.imm.bank_kernels import settled_rows
    from mjasc.perception.imm.startup_rows import settled_startup

    rng, bank = _filters(seed)
    st = bank._startup
    n = len(bank)
    rows = np.flatnonzero(rng.random(n) < 0.7).astype(np.int64)
    dtm = 0.2
    z = bank.positions + rng.normal(size=(n, 2)) * (1.0 + 5.0 * rng.random(n))[:, None]
    use = rng.random(n) < 0.8
    finite = rng.random(n) < 0.95
    measured = use | (rng.random(n) < 0.3)
    mv = rng.uniform(0.05, 3.0, n)
    per_row = seed % 2 == 0
    gate = bank._gate
    r = bank._r
    d2_min = np.where(rng.random(n) < 0.1, np.nan, rng.uniform(0, 20, n))
    s, P, mu = rng.normal(size=(n, r, 4)), rng.normal(size=(n, r, 4, 4)), rng.random((n, r))
    news = [rng.normal(size=(n, r, 4)), rng.normal(size=(n, r, 4, 4)), rng.random((n, r))]
    n_gated = rng.integers(0, 4, n)
    limit = int(rng.integers(0, 4))
    ref_st = copy.deepcopy(st)
    ref_new, ref_g = [a.copy() for a in news], n_gated.copy()
    outs = []
    for filt, new, g, fused in ((ref_st, ref_new, ref_g, False), (st, news, n_gated, True)):
        xc, Pc, dt, F, zw, use_w, var_w = gather_startup(rows, filt.x, filt.P, np.zeros(0), dtm, z, use, mv, per_row)
        xp = (F @ xc[..., None])[..., 0]
        Pp = F @ Pc @ np.swapaxes(F, 1, 2)
        args = (rows, xp, Pp, dt**3, dt, float(filt.acceleration_noise), zw, var_w if per_row else bank._var, use_w,
                gate, filt.x, filt.P, filt.n_meas)
        if fused:
            outs.append(settled_startup(*args, d2_min, use, finite, measured, s, P, mu, *new, g, limit))
        else:
            ok_w = update_startup(*args)
            outs.append(settled_rows(d2_min, gate, use, finite, measured, rows, ok_w, use_w, s, P, mu, *new, g, limit))
        outs.append((xp, Pp))
    for a, b in zip(outs[0][:4] + outs[1], outs[2][:4] + outs[3]):
        _same(a, b)
    assert outs[0][4] == outs[2][4]
    for a, b in zip(news + [n_gated, st.x, st.P, st.n_meas], ref_new + [ref_g, ref_st.x, ref_st.P, ref_st.n_meas]):
        _same(a, b)


@pytest.mark.parametrize("seed", range(8))
def test_kept_bank_rows_is_kept_rows_then_kept_started(seed):
    """kept_bank_rows against kept_rows then _kept_started (a bank's drop before it), on a bank's rows."""
    from mjasc.perception.imm.bank_kernels import kept_rows
    from mjasc.perception.imm.startup import _kept_started
    from mjasc.perception.imm.startup_rows import kept_bank_rows

    rng, bank = _filters(seed)
    n, r = len(bank), bank._r
    keep = rng.random(n) < 0.6
    m = int(np.count_nonzero(keep))
    st = bank._startup
    outs = [tuple(np.full(a.shape, -1.0) for a in (np.zeros((m, r, 4)), np.zeros((m, r, 4, 4)), np.zeros((m, r)),
                                                    np.zeros((m, 4)))) for _ in range(2)]
    base = (bank._s, bank._P, bank._mu, bank._x)
    per = (bank._ids, bank._t, bank._Pc, bank._n_gated, bank._reasons)
    want = kept_rows(keep, *base, *outs[0], *per) + _kept_started(keep, st.active, st.x, st.P, st.n_meas)
    got = kept_bank_rows(keep, *base, *outs[1], *per, st.active, st.x, st.P, st.n_meas)
    for a, b in zip(got[:9] + outs[1], want[:9] + outs[0]):
        _same(a, b)
    assert got[9] == want[9]
