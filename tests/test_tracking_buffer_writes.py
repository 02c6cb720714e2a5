"""The fleet step's kernels that write straight into the step's buffers against the form they replaced —
the returning kernel's arrays copied into the buffers — bit for bit (np.array_equal): every_drops_into
(mjasc.perception.tracking.loss_kernels) against every_drop_rows' arrays packed by numpy, on random rows (clustered tracks,
ties, buffers too small) and on every drop of a real run (the demo's first 40 s: clutter born and dropped
nearly every step, tracks lost and merged); step_inputs_into (mjasc.perception.tracking.step_gathers)
against step_inputs on random detections (its real-run check: tests/test_tracking_step_inputs.py)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from mjasc.perception.tracking import TrackingConfig
from mjasc.perception.tracking.loss_kernels import every_drop_rows, every_drops_into
from mjasc.perception.tracking.management import TrackManagement
from mjasc.perception.tracking.step_gathers import step_inputs, step_inputs_into


def _same(a, b) -> bool:
    """np.array_equal with NaN equal to NaN, and the same bytes (the same bits, -0.0 and NaNs too)."""
    return np.array_equal(a, b, equal_nan=a.dtype.kind == "f") and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def _packed(args):
    """every_drop_rows(args) packed as every_drops_into packs it, in numpy: (drop, ints, vals (3, L), L, g,
    the number dropped) — ints: the confirmed lost rows, their codes, the merges' go and kept rows."""
    drop, code, lam, since, rng, go, kept = every_drop_rows(*args)
    lost = np.flatnonzero((code != 0) & args[9])  # (args[9]: the rows' confirmed flags)
    ints = np.concatenate([lost, code[lost].astype(np.int64), go, kept]).astype(np.int64)
    vals = np.stack([lam[lost], since[lost], rng[lost]])
    return drop, ints, vals, lost.size, go.size, int(np.count_nonzero(drop))


def _drops_checked(args, room=None):
    """every_drops_into(args) into fresh buffers (n rows, or ``room`` rows of ints and vals) against
    every_drop_rows(args) packed (:func:`_packed`; nothing written to ints and vals without room)."""
    n = args[0].size
    drop, ints, vals = np.ones(n + 3, dtype=bool), np.full(4 * n if room is None else room, -7), np.full(
        3 * n if room is None else room, np.pi)
    d_, i_, v_, L_, g_, nd_ = _packed(args)
    L, g, n_drop = every_drops_into(*args, drop, ints, vals)
    assert (L, n_drop) == (L_, nd_)
    assert _same(drop[:n], d_) and drop[n:].all()
    if g < 0:
        assert i_.size > ints.size or v_.size > vals.size
        return
    assert g == g_
    assert _same(ints[:i_.size], i_) and (ints[i_.size:] == -7).all()
    assert _same(vals[:3 * L], v_.reshape(-1)) and (vals[3 * L:] == np.pi).all()
    return L, g


@pytest.mark.parametrize("seed", range(12))
def test_every_drops_into_equals_the_rows_packed_on_random_rows(seed):
    rng = np.random.default_rng(seed)
    mg = TrackManagement(TrackingConfig())
    n = int(rng.integers(0, 60))
    mg.append(rng.uniform(0, 5, size=n), rng.uniform(0.5, 3, size=n))
    cfg = mg.config
    mg._hist[:] = rng.integers(0, 1 << cfg.confirm_window, size=n)
    mg._scans[:] = rng.integers(1, 10, size=n)
    mg._n_upd[:] = rng.integers(1, 4, size=n)
    mg._confirmed[:] = rng.random(n) < 0.6
    mg._last[:] = rng.uniform(0, 10, size=n)
    A = rng.normal(size=(n, 4, 4)) * rng.uniform(0.1, 8.0, size=(n, 1, 1))
    Pc = A @ np.swapaxes(A, 1, 2)
    centres = rng.uniform(-60, 60, size=(5, 2))
    x = np.concatenate([centres[rng.integers(0, 5, n)] + rng.normal(size=(n, 2)) * 1.5, rng.normal(size=(n, 2))],
                       axis=1)
    no = 3
    group = rng.integers(0, no, size=n)
    pos_of = np.arange(no)
    t_o = rng.uniform(8, 12, size=no)
    org = np.where(rng.random((no, 1)) < 0.2, np.nan, rng.uniform(-5, 5, size=(no, 2)))
    mr = rng.uniform(20, 100, size=no)
    args = mg.drop_args(group, pos_of, t_o, x, Pc, org, mr)
    got = _drops_checked(args)
    if got is not None and sum(got):  # (too little room for what was found: g = −1, drop still written)
        _drops_checked(args, room=max(0, 2 * got[0] + 2 * got[1] - 1))


def test_every_drops_into_equals_the_rows_packed_on_a_run(monkeypatch):
    import mjasc
    from mjasc.perception.imm.row_fields import combine_covariance_rows
    from mjasc.perception.tracking import fleet_rows
    from mjasc.perception.tracking.track_columns import CONFIRMED, HIST, LAST, N_UPD, OWNER, RADIUS, SCANS
    from mjasc.runs.runner import Runner

    real = fleet_rows.drops_births_into
    seen = [0, 0]

    def checked(*a):  # (every_drops_into's arguments as drops_births_into reads them from the bank and the tables)
        n, pos_of, t_o, org, mr = a[:5]
        consts, stale, (s, P, mu, x), (Pc, active), (f, i, b) = a[5:12], a[15], a[16:20], (a[26], a[29]), a[33:36]
        Pc = Pc[:n].copy()
        if stale:
            combine_covariance_rows(s[:n], P[:n], mu[:n], active[:n], Pc)
        got = _drops_checked((i[OWNER, :n], pos_of, t_o, x[:n], Pc, org, mr, i[HIST, :n], i[SCANS, :n],
                              b[CONFIRMED, :n], f[LAST, :n], i[N_UPD, :n], f[RADIUS, :n], *consts))
        seen[0] += 1
        seen[1] += got is not None and sum(got) > 0
        return real(*a)

    monkeypatch.setattr(fleet_rows, "drops_births_into", checked)
    sc = mjasc.load_scenario("demo").with_overrides(duration_s=40.0)
    sc = replace(sc, outputs=replace(sc.outputs, recording=False, video=False))
    Runner(sc, out_dir=None, progress=False).run()
    assert seen[0] > 100 and seen[1] > 0


@pytest.mark.parametrize("seed", range(12))
def test_step_inputs_into_equals_step_inputs_on_random_detections(seed):
    rng = np.random.default_rng(seed)
    no = int(rng.integers(1, 5))
    owners = np.sort(rng.choice(no, size=int(rng.integers(1, no + 1)), replace=False)).astype(np.int64)
    p = owners.size
    pos_of = np.full(no, -1)
    pos_of[owners] = np.arange(p)
    m_all = rng.integers(0, 6, size=p).astype(np.int64)
    S = int(m_all.sum())
    sel = rng.random(S) < 0.7
    cen, var, rad = rng.normal(size=(S, 2)) * 30, rng.uniform(0.1, 2, size=S), rng.uniform(0.5, 4, size=S)
    occ = rng.random(S) < 0.2
    n = int(rng.integers(0, 20))
    owner = rng.integers(0, no, size=n).astype(np.int64)
    every = bool(p == no)
    t_o = rng.uniform(0, 10, size=p)
    counts = rng.integers(0, 9, size=(no, 6)).astype(np.int64)
    for use_var in (True, False):
        c_ref = counts.copy()
        ints_, z_, floats_, flags_, all_due_, k_ = step_inputs(m_all, sel, cen, var, rad, occ, use_var, owner, pos_of,
                                                                every, owners, t_o, no, c_ref, 1, 2, 0.25)
        ints, z = np.full(2 * S + p + 4 * n + 5, -7), np.full((S + 2, 2), np.pi)
        floats, flags = np.full(2 * S + no + n + 3, np.pi), np.ones(2 * S + 1, dtype=bool)
        M, all_due, k = step_inputs_into(m_all, sel, cen, var, rad, occ, use_var, owner, pos_of, every, owners, t_o,
                                         no, counts, 1, 2, 0.25, ints, z, floats, flags)
        assert (M, all_due, k) == (z_.shape[0], all_due_, k_) and np.array_equal(counts, c_ref)
        for buf, want, fill in ((ints, ints_, -7), (z.reshape(-1), z_.reshape(-1), np.pi), (floats, floats_, np.pi),
                                (flags, flags_, True)):
            assert _same(buf[:want.size], want) and (buf[want.size:] == fill).all()


@pytest.mark.parametrize("seed", range(6))
def test_position_jacobians_and_gate_terms_into_equal_their_numpy_forms(seed):
    """position_jacobians_into and gate_terms_into (mjasc.perception.tracking.pair_kernels: what the association
    buffers are written by) into buffers full of other values, against the numpy forms of ẑ, J, d² and det."""
    from mjasc.perception.tracking.pair_kernels import gate_terms_into, position_jacobians_into

    rng = np.random.default_rng(seed)
    k, M = int(rng.integers(0, 12)), int(rng.integers(1, 8))
    x, dt, dv, th = rng.normal(size=(k, 4)) * 20, rng.uniform(0, 1, k), rng.normal(size=k), rng.uniform(-4, 4, k)
    c, s = np.cos(th), np.sin(th)
    zhat, J = np.full((k + 2, 2), np.pi), np.full((k + 2, 2, 4), np.pi)
    position_jacobians_into(x, dt, dv, c, s, zhat, J)
    want_z = np.stack([x[:, 0] + dv * c, x[:, 1] + dv * s], axis=-1)
    want_J = np.zeros((k, 2, 4))
    want_J[:, 0, 0] = want_J[:, 1, 1] = 1.0
    want_J[:, 0, 2], want_J[:, 0, 3], want_J[:, 1, 2], want_J[:, 1, 3] = -dv * s, dt * c, dv * c, dt * s
    assert _same(zhat[:k], want_z) and _same(J[:k], want_J) and (zhat[k:] == np.pi).all() and (J[k:] == np.pi).all()
    if k == 0:
        return
    P = int(rng.integers(0, 3 * k + 1))
    g, db = rng.integers(0, k, P), rng.integers(0, M, P)
    A = rng.normal(size=(k, 2, 2))
    S, z, var = A @ np.swapaxes(A, 1, 2), rng.normal(size=(M, 2)) * 20, rng.uniform(0.1, 2, P)
    d2, det = np.full(P + 1, np.pi), np.full(P + 1, np.pi)
    gate_terms_into(g, want_z, S, db, z, var, d2, det)
    a, b, d = S[g, 0, 0] + var, S[g, 0, 1], S[g, 1, 1] + var
    dk = a * d - b * b
    y0, y1 = z[db, 0] - want_z[g, 0], z[db, 1] - want_z[g, 1]
    assert _same(d2[:P], (d * y0 * y0 - 2.0 * b * y0 * y1 + a * y1 * y1) / dk) and _same(det[:P], dk)
    assert d2[P] == np.pi and det[P] == np.pi
