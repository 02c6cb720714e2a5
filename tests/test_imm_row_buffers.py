"""IMMBank's births and drops in its row buffers (mjasc.perception.imm.row_buffers) against the form they
replaced — births through StartupFilters.append_started and born_rows, drops through kept_bank_rows, each
making new arrays — bit for bit, over runs with births, drops, gated rows and restarts."""

import numpy as np
import pytest

from mjasc.perception.imm.bank import IMMBank
from mjasc.perception.imm.config import IMMConfig
from mjasc.perception.imm.row_buffers import RowBuffers, kept_into, started_rows
from mjasc.perception.imm.startup import _polar_jacobians
from mjasc.perception.imm.startup_rows import born_rows, kept_bank_rows


class _NewArrays(IMMBank):
    """The bank's births and drops as they were before the row buffers (new arrays each time)."""

    def _append(self, z, t, ids, meas_var, id0=0) -> None:
        k = z.shape[0]
        if ids.size == 0:
            ids = np.arange(id0, id0 + k, dtype=np.int64)
        n_before = self._ids.size
        n = n_before + k
        cyc = self._cyc
        if cyc is None or cyc.cap < n or self._side is None:
            cyc = self._own_state(n)
        s, P, mu, x, _ = cyc.views(self._side, n)
        st = self._startup
        xc, Pcv = st.append_started(z, self._R, meas_var)
        vx, vy = xc[:, 2], xc[:, 3]
        speed = np.hypot(vx, vy)
        J = _polar_jacobians(xc, speed)
        self._ids, self._t, self._Pc, self._n_gated, self._reasons, one_time, off = born_rows(
            s, P, mu, x, n_before, self._mu0, self._ids, self._t, self._Pc, self._n_gated, self._reasons,
            ids, np.ascontiguousarray(t, dtype=float), xc, speed, np.arctan2(vy, vx), J @ Pcv @ np.swapaxes(J, 1, 2),
            Pcv, st.n_meas, st.snr2, st.max_updates, st.active)
        st.n_active -= off
        self._s, self._P, self._mu, self._x = s, P, mu, x
        tc, t0 = self._t_common, float(t[0])
        self._t_common = t0 if (n_before == 0 or tc == t0) and one_time else None

    def keep_rows(self, keep) -> None:
        keep = np.asarray(keep, dtype=bool)
        side = 1 - self._side
        out = self._cyc.views(side, int(np.count_nonzero(keep)))
        st = self._startup
        (self._ids, self._t, self._Pc, self._n_gated, self._reasons, st.active, st.x, st.P, st.n_meas,
         st.n_active) = kept_bank_rows(keep, self._s, self._P, self._mu, self._x, out[0], out[1], out[2], out[3],
                                       self._ids, self._t, self._Pc, self._n_gated, self._reasons, st.active, st.x,
                                       st.P, st.n_meas)
        self._s, self._P, self._mu, self._x = out[:4]
        self._side = side
        if self._ids.size == 0:
            self._t_common = None


def _same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape and a.dtype == b.dtype
    assert np.array_equal(a.view(np.uint8) if a.dtype.kind == "f" else a, b.view(np.uint8) if b.dtype.kind == "f" else b)


def _compare(a, b):
    for name in ("_ids", "_t", "_x", "_s", "_P", "_mu", "_n_gated", "_reasons"):
        _same(getattr(a, name), getattr(b, name))
    _same(a.state_covariances, b.state_covariances)
    for name in ("active", "x", "P", "n_meas"):
        _same(getattr(a._startup, name), getattr(b._startup, name))
    assert a._startup.n_active == b._startup.n_active and type(a._startup.n_active) is type(b._startup.n_active)
    assert a._t_common == b._t_common


@pytest.mark.parametrize("seed", range(6))
def test_births_and_drops_in_row_buffers_equal_new_arrays(seed):
    """A clutter-like run: tracks born (the tracker's append_tracks, and add_tracks with ids and σ²) and
    dropped nearly every cycle, targets kept, gated measurements and restarts; every array equal after
    every birth, drop and cycle."""
    rng = np.random.default_rng(seed)
    cfg = IMMConfig() if seed % 3 else IMMConfig(init_max_updates=1)
    a, b = IMMBank(cfg), _NewArrays(cfg)
    truth = rng.normal(size=(4, 2)) * 40.0
    vel = rng.normal(size=(4, 2)) * 2.0
    for bank in (a, b):
        bank.add_tracks(truth, 0.0)
    _compare(a, b)
    for step in range(1, 60):
        t = step * 0.2
        n = len(a)
        z = rng.normal(size=(n, 2)) * 30.0
        k = min(n, truth.shape[0])
        z[:k] = truth[:k] + vel[:k] * t + rng.normal(size=(k, 2)) * 0.5
        if step % 9 == 0:
            z[0] += 200.0  # gated
        mask = rng.random(n) < 0.8
        var = rng.uniform(0.05, 2.0, n) if step % 3 == 0 else None
        _same(a.update(z, t, mask, var), b.update(z, t, mask, var))
        _compare(a, b)
        if n > k and step % 4:  # drops (clutter rows; sometimes a target row too)
            keep = np.ones(n, dtype=bool)
            keep[k:] = rng.random(n - k) < 0.5
            if step % 11 == 0 and k > 1:
                keep[1] = False
            for bank in (a, b):
                bank.keep_rows(keep.copy())
            _compare(a, b)
            if step % 11 == 0 and k > 1:
                truth, vel = np.delete(truth, 1, 0), np.delete(vel, 1, 0)
        m = int(rng.integers(0, 4))
        if m:  # births, at the cycle's time or spread
            zb = rng.normal(size=(m, 2)) * 50.0
            tb = np.full(m, t) if step % 5 else t - rng.uniform(0.0, 0.1, m)
            vb = rng.uniform(0.1, 1.0, m) if step % 2 else None
            if step % 7 == 0:
                for bank in (a, b):
                    bank.add_tracks(zb, tb, vb, track_ids=list(range(1000 + 10 * step, 1000 + 10 * step + m)))
            else:
                for bank in (a, b):
                    bank.append_tracks(zb.copy(), tb.copy(), None if vb is None else vb.copy())
            _compare(a, b)
        if len(a) > 12:  # everything dropped once in a while (n → 0)
            for bank in (a, b):
                bank.keep_rows(np.zeros(len(bank), dtype=bool))
            _compare(a, b)
            truth, vel = truth[:0], vel[:0]


def test_row_buffer_kernels_equal_their_numpy_forms():
    """started_rows writes _appended_started's new rows; kept_into compacts as boolean indexing."""
    rng = np.random.default_rng(3)
    rb = RowBuffers(12)
    for arr in (rb.cv_x, rb.cv_P, rb.t, rb.Pc):
        arr[...] = rng.normal(size=arr.shape)
    rb.active[:] = rng.random(12) < 0.5
    rb.n_meas[:] = rng.integers(0, 5, 12)
    z, mv = rng.normal(size=(3, 2)), rng.uniform(0.1, 1.0, 3)
    from mjasc.perception.imm.startup import _appended_started

    want = _appended_started(rb.active[:5].copy(), rb.cv_x[:5].copy(), rb.cv_P[:5].copy(), rb.n_meas[:5].copy(), z,
                             0.3, 4.0, mv, True)
    started_rows(rb.active, rb.cv_x, rb.cv_P, rb.n_meas, 5, z, 0.3, 4.0, mv, True)
    for got, w in zip((rb.active[:8], rb.cv_x[:8], rb.cv_P[:8], rb.n_meas[:8]), want):
        _same(got, w)
    n, r = 8, 3
    keep = rng.random(n) < 0.5
    s, P, mu, x = rng.normal(size=(n, r, 4)), rng.normal(size=(n, r, 4, 4)), rng.random((n, r)), rng.normal(size=(n, 4))
    outs = [np.zeros((n, r, 4)), np.zeros((n, r, 4, 4)), np.zeros((n, r)), np.zeros((n, 4))]
    per = [rb.ids, rb.t, rb.Pc, rb.n_gated, rb.reasons, rb.active, rb.cv_x, rb.cv_P, rb.n_meas]
    before = [p[:n].copy() for p in per]
    m, n_active = kept_into(keep, s, P, mu, x, *outs, *per)
    assert m == np.count_nonzero(keep) and n_active == np.count_nonzero(before[5][keep])
    for got, old in zip(per, before):
        _same(got[:m], old[keep])
    for got, old in zip(outs, (s, P, mu, x)):
        _same(got[:m], old[keep])


@pytest.mark.parametrize("seed", range(4))
def test_update_measured_equals_update(seed):
    """update_measured (the tracker's cycle: no checks, scratch rows, σ² replaced in place) against update,
    over a run with births, drops, unmeasured and non-finite rows and per-row σ²."""
    rng = np.random.default_rng(seed)
    a, b = IMMBank(), IMMBank()
    z0 = rng.normal(size=(5, 2)) * 20.0
    for bank in (a, b):
        bank.add_tracks(z0, 0.0)
    for step in range(1, 40):
        t = step * 0.2
        n = len(a)
        z = rng.normal(size=(n, 2)) * 20.0
        if step % 6 == 0:
            z[0, 1] = np.nan
        mask = rng.random(n) < 0.8
        var = rng.uniform(-0.5, 2.0, n) if step % 2 else None
        ua = a.update(z, t, mask, var)
        ub = b.update_measured(z.copy(), t, mask.copy(), None if var is None else var.copy())
        _same(ua, ub)
        _compare(a, b)
        if step % 3 == 0:
            keep = rng.random(n) < 0.7
            zb = rng.normal(size=(2, 2)) * 30.0
            for bank in (a, b):
                bank.keep_rows(keep.copy())
                bank.append_tracks(zb.copy(), np.full(2, t))
            _compare(a, b)


def test_add_process_noise_rows_equals_add_process_noise():
    """The manoeuvre detector's unchecked form against the checked one, on IMM and start-up rows."""
    rng = np.random.default_rng(2)
    a, b = IMMBank(), IMMBank()
    z0 = rng.normal(size=(6, 2)) * 20.0
    for bank in (a, b):
        bank.add_tracks(z0, 0.0)
    for step in range(1, 12):
        z = z0 + rng.normal(size=z0.shape) * 0.3 + step
        for bank in (a, b):
            bank.update(z[:len(bank)], step * 0.2)
        rows = np.sort(rng.choice(len(a), size=3, replace=False)).astype(np.int64)
        dth, dv = rng.random(3) * 0.1, rng.random(3)
        a.add_process_noise(rows, dth, dv)
        b.add_process_noise_rows(rows, dth, dv)
        _compare(a, b)


def test_zero_polar_is_the_polar_conversion_of_new_filters():
    """RowBuffers.zero_polar (a birth's |v|, atan2 and polar Jacobians) against numpy's hypot, arctan2 and
    _polar_jacobians of new start-up filters (x = [z, 0, 0]), bit for bit, for growing k."""
    rng = np.random.default_rng(3)
    rb = RowBuffers(4)
    for k in (1, 3, 4, 9, 2):
        xc = np.zeros((k, 4))
        xc[:, :2] = rng.normal(scale=100.0, size=(k, 2))
        speed = np.hypot(xc[:, 2], xc[:, 3])
        zero, J = rb.zero_polar(k)
        for a, b in ((zero, speed), (zero, np.arctan2(xc[:, 3], xc[:, 2])), (J, _polar_jacobians(xc, speed))):
            assert a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()
        assert J.flags.c_contiguous
