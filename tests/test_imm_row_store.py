"""The IMM bank's row store (tracks in capacity-sized cycle buffers; births into spare rows, drops
compacted into the other side) and the compiled start-up hand-over (cv_to_polar): the same bits as
the plain forms they replaced."""

from __future__ import annotations

import math

import numpy as np

from mjasc.perception.imm import IMMBank
from mjasc.perception.imm.startup import cv_to_polar

_UNIFORM_ANGLE_VAR = math.pi**2 / 3.0


def cv_to_polar_numpy(xc, Pc):
    """The all-numpy form of :func:`cv_to_polar` (the reference)."""
    k = xc.shape[0]
    vx, vy = xc[:, 2], xc[:, 3]
    speed = np.hypot(vx, vy)
    moving = speed > 0
    if moving.all():
        ux, uy, inv_v = vx / speed, vy / speed, 1.0 / speed
    else:
        safe = np.where(moving, speed, 1.0)
        ux = np.where(moving, vx / safe, 1.0)
        uy = np.where(moving, vy / safe, 0.0)
        inv_v = np.where(moving, 1.0 / safe, 1e150)
    J = np.zeros((k, 4, 4))
    J[:, 0, 0] = J[:, 1, 1] = 1.0
    J[:, 2, 2], J[:, 2, 3] = -uy * inv_v, ux * inv_v
    J[:, 3, 2], J[:, 3, 3] = ux, uy
    P = J @ Pc @ np.swapaxes(J, 1, 2)
    scale = np.sqrt(np.minimum(1.0, _UNIFORM_ANGLE_VAR / P[:, 2, 2]))
    P[:, 2, :] *= scale[:, None]
    P[:, :, 2] *= scale[:, None]
    s = np.empty((k, 4))
    s[:, :2] = xc[:, :2]
    s[:, 2] = np.arctan2(vy, vx)
    s[:, 3] = speed
    return s, 0.5 * (P + np.swapaxes(P, 1, 2))


def test_cv_to_polar_equals_numpy_form_bit_for_bit():
    rng = np.random.default_rng(3)
    for k in (1, 2, 7, 40):
        xc = rng.normal(size=(k, 4)) * [50.0, 50.0, 2.0, 2.0]
        if k > 1:
            xc[0, 2:] = 0.0  # a new track: v = 0
            xc[1, 2:] = (1e-9, -3e-9)
        A = rng.normal(size=(k, 4, 4))
        Pc = A @ np.swapaxes(A, 1, 2) * rng.uniform(0.01, 5.0, size=(k, 1, 1))
        if k > 2:
            Pc[2] = np.diag([0.1, 0.1, 4.0, 4.0])  # a start-up filter's first covariance
        s, P = cv_to_polar(xc, Pc.copy())
        s_ref, P_ref = cv_to_polar_numpy(xc, Pc.copy())
        assert s.tobytes() == s_ref.tobytes()
        assert P.tobytes() == P_ref.tobytes()


class _FreshArrays(IMMBank):
    """A bank that keeps its state in arrays of their own after every change (the form before
    the row store: a new array per birth and drop)."""

    def _detach(self):
        for name in ("_s", "_P", "_mu", "_x"):
            setattr(self, name, getattr(self, name).copy())
        self._side = None
        self._cyc = None

    def add_tracks(self, *a, **k):
        ids = super().add_tracks(*a, **k)
        self._detach()
        return ids

    def keep_rows(self, keep):
        self._detach()
        super().keep_rows(keep)

    def update(self, *a, **k):
        used = super().update(*a, **k)
        self._detach()
        return used


def test_births_and_drops_between_cycles_give_the_bits_of_fresh_arrays():
    """Random births, drops, coasting, gaps and subset updates: the row store's bank and one that
    makes new arrays every time hold the same bits."""
    rng = np.random.default_rng(11)
    a, b = IMMBank(), _FreshArrays()
    truth = {}
    t = 0.0
    for step in range(120):
        t += 0.2
        n = len(a)
        if n:
            ids = a.track_ids
            z = np.array([truth[i] for i in ids.tolist()]) + rng.normal(scale=0.3, size=(n, 2))
            mask = rng.random(n) < 0.8
            var = rng.uniform(0.05, 0.3, size=n)
            if step % 7 == 3 and n > 2:  # some rows only
                rows = np.flatnonzero(rng.random(n) < 0.5)
                ua = a.update_rows(rows, z[rows], t, mask[rows], var[rows])
                ub = b.update_rows(rows, z[rows], t, mask[rows], var[rows])
                if rows.size:
                    a.predict(t)  # the rest coast to t
                    b.predict(t)
            else:
                ua = a.update(z, t, mask, var)
                ub = b.update(z, t, mask, var)
            assert np.array_equal(ua, ub)
        for i in list(truth):
            truth[i] = truth[i] + rng.normal(scale=0.5, size=2)
        k = int(rng.integers(0, 3))
        if k:
            zk = rng.uniform(-100, 100, size=(k, 2))
            ia = a.add_tracks(zk, t)
            ib = b.add_tracks(zk, t)
            assert np.array_equal(ia, ib)
            truth.update(zip(ia.tolist(), zk))
        if len(a) > 3 and rng.random() < 0.6:
            keep = rng.random(len(a)) < 0.8
            for i in a.track_ids[~keep].tolist():
                del truth[i]
            a.keep_rows(keep)
            b.keep_rows(keep)
        for name in ("_ids", "_s", "_P", "_mu", "_t", "_x", "_n_gated", "_reasons"):
            assert getattr(a, name).tobytes() == getattr(b, name).tobytes(), name
        assert a.state_covariances.tobytes() == b.state_covariances.tobytes()
        assert np.array_equal(a.velocity_initialized, b.velocity_initialized)
    assert a._cyc is not None and a._side is not None  # the row store was used


def test_ready_for_handover_equals_numpy_form():
    from mjasc.perception.imm.startup import ready_for_handover

    rng = np.random.default_rng(5)
    k = 400
    s = rng.normal(size=(k, 4)) * [1, 1, 1, 0.5]
    s[:3, 3] = (0.0, np.nan, 1e-3)
    A = rng.normal(size=(k, 4, 4)) * 0.3
    P = A @ np.swapaxes(A, 1, 2)
    n_meas = rng.integers(1, 6, size=k)
    v2 = s[:, 3] ** 2
    Pv = P[:, 2:, 2:]
    half_tr = 0.5 * (Pv[:, 0, 0] + Pv[:, 1, 1])
    lam_max = half_tr + np.sqrt((0.5 * (Pv[:, 0, 0] - Pv[:, 1, 1])) ** 2 + Pv[:, 0, 1] ** 2)
    want = (v2 >= 4.0 * lam_max) | (n_meas >= 4)
    got = ready_for_handover(s, P, n_meas, 4.0, 4)
    assert np.array_equal(got, want) and 0 < want.sum() < k


def test_rejection_bookkeeping_equals_numpy_form():
    from mjasc.perception.imm.bank_kernels import GATED, NON_FINITE, NOT_MEASURED, rejections

    rng = np.random.default_rng(6)
    n = 300
    for limit in (0, 1, 3):
        measured = rng.random(n) < 0.8
        finite = rng.random(n) < 0.9
        use = measured & finite
        inside = rng.random(n) < 0.7
        ok = use & inside
        n_gated = rng.integers(0, 4, size=n)
        reasons = np.zeros(n, dtype=np.int8)
        reasons[~finite] = NON_FINITE
        gated = use & ~inside
        reasons[gated] = GATED
        reasons[~measured] = NOT_MEASURED
        want_n = np.where(gated, n_gated + 1, np.where(ok, 0, n_gated))
        want_restart = gated & (want_n >= limit) if limit > 0 else np.zeros(n, dtype=bool)
        got_r, got_restart = np.empty(n, dtype=np.int8), np.empty(n, dtype=bool)
        rejections(use, finite, measured, inside, ok, n_gated, limit, got_r, got_restart)
        assert np.array_equal(got_r, reasons) and np.array_equal(n_gated, want_n)
        assert np.array_equal(got_restart, want_restart)



def cv_predict_numpy(xc, Pc, dt, q):
    """The all-numpy form of :func:`cv_predict` (the reference)."""
    k = dt.shape[0]
    F = np.repeat(np.eye(4)[None], k, axis=0)
    F[:, 0, 2] = F[:, 1, 3] = dt
    xp = (F @ xc[..., None])[..., 0]
    Pp = F @ Pc @ np.swapaxes(F, 1, 2)
    q3, q2, q1 = q * dt**3 / 3.0, q * dt**2 / 2.0, q * dt
    Pp[:, 0, 0] += q3
    Pp[:, 1, 1] += q3
    Pp[:, 0, 2] += q2
    Pp[:, 2, 0] += q2
    Pp[:, 1, 3] += q2
    Pp[:, 3, 1] += q2
    Pp[:, 2, 2] += q1
    Pp[:, 3, 3] += q1
    return xp, Pp


def test_cv_predict_equals_numpy_form_bit_for_bit():
    from mjasc.perception.imm.startup import cv_predict

    rng = np.random.default_rng(5)
    for k in (1, 2, 7, 40, 5000):
        xc = rng.normal(size=(k, 4)) * [50.0, 50.0, 2.0, 2.0]
        A = rng.normal(size=(k, 4, 4))
        Pc = A @ np.swapaxes(A, 1, 2)
        dt = rng.uniform(0.0, 1.0, size=k)
        dt[0] = 0.2
        if k > 40:  # (multiples of a tick and long coasts too)
            dt[: k // 2] = rng.integers(0, 50, size=k // 2) * 0.2
            dt[-10:] = rng.uniform(0.0, 100.0, size=10)
        for q in (0.05, 0.5, 3.0):
            xp, Pp = cv_predict(xc, Pc, dt, q)
            xr, Pr = cv_predict_numpy(xc, Pc, dt, q)
            assert xp.tobytes() == xr.tobytes() and Pp.tobytes() == Pr.tobytes()


def test_warm_rows_equals_numpy_form():
    from mjasc.perception.imm.bank_kernels import warm_rows

    rng = np.random.default_rng(8)
    n, r = 12, 3
    s, P, mu = rng.normal(size=(n, r, 4)), rng.normal(size=(n, r, 4, 4)), rng.random((n, r))
    rows = np.array([1, 4, 5, 9], dtype=np.int64)
    ok_w, use_w = rng.random(4) < 0.5, rng.random(4) < 0.5
    ok, inside = rng.random(n) < 0.5, rng.random(n) < 0.5
    s_new, P_new, mu_new = rng.normal(size=(n, r, 4)), rng.normal(size=(n, r, 4, 4)), rng.random((n, r))
    want = [a.copy() for a in (ok, inside, s_new, P_new, mu_new)]
    want[0][rows] = ok_w
    want[1][rows] = ok_w | ~use_w
    want[2][rows], want[3][rows], want[4][rows] = s[rows], P[rows], mu[rows]
    warm_rows(rows, ok_w, use_w, ok, inside, s, P, mu, s_new, P_new, mu_new)
    for a, b in zip((ok, inside, s_new, P_new, mu_new), want):
        assert a.tobytes() == b.tobytes()


def test_append_started_equals_numpy_form():
    from mjasc.perception.imm import IMMConfig
    from mjasc.perception.imm.startup import StartupFilters

    rng = np.random.default_rng(9)
    for per_row in (False, True):
        f = StartupFilters(IMMConfig())
        ref = {"active": f.active.copy(), "x": f.x.copy(), "P": f.P.copy(), "n_meas": f.n_meas.copy()}
        for _ in range(5):
            k = int(rng.integers(1, 4))
            z = rng.normal(size=(k, 2)) * 20
            mv = rng.random(k) if per_row else None
            x_new, P_new = f.append_started(z, 0.3, mv)
            x = np.zeros((k, 4))
            x[:, :2] = z
            sv2 = f.speed_var0
            P = np.repeat(np.diag([0.3, 0.3, sv2, sv2])[None], k, axis=0)
            if mv is not None:
                P[:, 0, 0] = P[:, 1, 1] = mv
            ref = {"active": np.concatenate([ref["active"], np.ones(k, dtype=bool)]),
                   "x": np.concatenate([ref["x"], x]), "P": np.concatenate([ref["P"], P]),
                   "n_meas": np.concatenate([ref["n_meas"], np.ones(k, dtype=np.int64)])}
            assert x_new.tobytes() == x.tobytes() and P_new.tobytes() == P.tobytes()
            for name, want in ref.items():
                got = getattr(f, name)
                assert got.dtype == want.dtype and got.tobytes() == want.tobytes()
            assert f.n_active == int(f.active.sum())
