"""The bank's measured cycle with its front in one compiled call (mjasc.perception.imm.measured_cycle)
against the separate calls it replaces (measurements, imm_cycle, the common-case test, nonzero and
gather_startup_into: the bank's path without row buffers' scratch rows), bit for bit, over clutter-like
runs with births, drops, unmeasured, non-finite and gated rows, restarts, per-row σ² and spread times; and
measured_settle (the front and the settling of a general cycle in one call) against measured_cycle, then
startup_cycle_into or settled_rows_into, at every cycle of a real run."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import mjasc
from mjasc.perception.imm import bank_updates
from mjasc.perception.imm.bank import IMMBank
from mjasc.perception.imm.bank_kernels import settled_rows_into
from mjasc.perception.imm.config import IMMConfig
from mjasc.perception.imm.measured_cycle import measured_cycle, measured_settle
from mjasc.perception.imm.startup_rows import startup_cycle_into
from mjasc.runs.runner import Runner


class _Separate(IMMBank):
    """The measured cycle through the separate calls (IMMBank._cycle)."""

    def _measured_cycle(self, z, t_s, measured, mv, finite, use):
        return self._separate_cycle(z, t_s, measured, mv, finite, use)


def _same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def _compare(a, b):
    for name in ("_ids", "_t", "_x", "_s", "_P", "_mu", "_n_gated", "_reasons"):
        _same(getattr(a, name), getattr(b, name))
    _same(a.state_covariances, b.state_covariances)
    for name in ("active", "x", "P", "n_meas"):
        _same(getattr(a._startup, name), getattr(b._startup, name))
    assert a._startup.n_active == b._startup.n_active
    assert a._t_common == b._t_common


@pytest.mark.parametrize("seed", range(8))
def test_measured_cycle_equals_the_separate_calls(seed):
    rng = np.random.default_rng(seed)
    cfg = IMMConfig() if seed % 3 else IMMConfig(init_max_updates=1, restart_after_gated=2)
    a, b = IMMBank(cfg), _Separate(cfg)
    truth = rng.normal(size=(4, 2)) * 40.0
    vel = rng.normal(size=(4, 2)) * 2.0
    for bank in (a, b):
        bank.append_tracks(truth.copy(), np.zeros(4))
    n_common = n_warm = 0
    t = 0.0
    for step in range(1, 80):
        t = step * 0.2
        if step == 30:  # (the clutter rows dropped: only the targets, measured every cycle)
            keep = np.arange(len(a)) < truth.shape[0]
            for bank in (a, b):
                bank.keep_rows(keep)
        n = len(a)
        z = rng.normal(size=(n, 2)) * 30.0
        k = min(n, truth.shape[0])
        z[:k] = truth[:k] + vel[:k] * t + rng.normal(size=(k, 2)) * 0.3
        quiet = 30 <= step < 45  # (no clutter, every row measured: the common case once handed over)
        if not quiet:
            if step % 9 == 0 and n:
                z[0] += 200.0  # gated
            if step % 13 == 0 and n > 1:
                z[1, 0] = np.nan
        mask = np.ones(n, dtype=bool) if quiet else rng.random(n) < 0.85
        var = rng.uniform(-0.5, 2.0, n) if step % 3 == 0 else None
        n_warm += a._startup.n_active > 0
        pre_warm = a._startup.n_active
        if step % 2:
            ua = a.update_measured(z.copy(), t, mask.copy(), None if var is None else var.copy())
            ub = b.update_measured(z.copy(), t, mask.copy(), None if var is None else var.copy())
        else:
            ua, ub = a.update(z, t, mask, var), b.update(z, t, mask, var)
        n_common += bool(quiet and pre_warm == 0 and ua.all())
        _same(ua, ub)
        _compare(a, b)
        if quiet:
            continue
        if n > k and step % 4:
            keep = np.ones(n, dtype=bool)
            keep[k:] = rng.random(n - k) < 0.5
            for bank in (a, b):
                bank.keep_rows(keep.copy())
            _compare(a, b)
        m = int(rng.integers(0, 4))
        if m:
            zb = rng.normal(size=(m, 2)) * 50.0
            tb = np.full(m, t) if step % 5 else t - rng.uniform(0.0, 0.1, m)
            vb = rng.uniform(0.1, 1.0, m) if step % 2 else None
            for bank in (a, b):
                bank.append_tracks(zb.copy(), tb.copy(), None if vb is None else vb.copy())
            _compare(a, b)
    assert n_common > 3 and (n_warm > 20 or not seed % 3)  # (init_max_updates=1: no start-up rows)


def separate_settle(args):
    """measured_settle's reference: measured_cycle, then the bank's ``_settle`` calls (scratch rows, one call)."""
    front = args[:36]
    (z, measured, mv, per_row, R, finite, use, every_true, s, P, mu, markov, dt, dt_omega, q, floor, gate, s_out,
     P_out, mu_out, x_out, d2_min, n_active, active, cv_x, cv_P, dt_rows, dtm, w_rows, w_x, w_P, w_dt, w_F, w_z, w_use,
     w_var) = front
    q_cv, n_meas, n_gated, limit, inside, ok, reasons, restart, used, snr2, max_updates, Pc, mu0 = args[36:]
    every, common, k = measured_cycle(*front)
    if common:
        return every, True, 0, 0
    if every:
        use = finite = measured = every_true
    if n_active:
        n_restart, off = startup_cycle_into(w_rows[:k], w_x[:k], w_P[:k], w_F[:k], w_dt[:k], q_cv, w_z[:k],
                                            w_var[:k] if per_row else mv, w_use[:k], gate, cv_x, cv_P, n_meas, d2_min,
                                            use, finite, measured, s, P, mu, s_out, P_out, mu_out, n_gated, limit,
                                            inside, ok, reasons, restart, used, snr2, max_updates, active, x_out, Pc,
                                            mu0)
        return every, False, n_restart, off
    none, no = np.zeros(0, dtype=np.int64), np.zeros(0, dtype=bool)
    n_restart = settled_rows_into(d2_min, gate, use, finite, measured, none, no, no, s, P, mu, s_out, P_out, mu_out,
                                  n_gated, limit, inside, ok, reasons, restart, used)
    return every, False, n_restart, 0


@pytest.mark.parametrize("name, duration", [("thesis_6_4_crossing", 30.0), ("demo", 30.0)])
def test_measured_settle_on_a_real_run(monkeypatch, name, duration):
    seen = {"cycles": 0, "settled": 0, "warm": 0}

    def checked(*args):
        ref = [a.copy() if isinstance(a, np.ndarray) else a for a in args]
        got = measured_settle(*args)
        assert got == separate_settle(ref)
        for a, b in zip(args, ref):
            if isinstance(a, np.ndarray):
                _same(a, b)
        seen["cycles"] += 1
        seen["settled"] += not got[1]
        seen["warm"] += args[22] > 0
        return got

    monkeypatch.setattr(bank_updates, "measured_settle", checked)
    root = Path(__file__).resolve().parents[1]
    sc = mjasc.load_scenario(root / "tasks" / f"{name}.toml").with_overrides(duration_s=duration)
    sc = replace(sc, outputs=replace(sc.outputs, recording=False, video=False))
    Runner(sc, out_dir=None).run()
    assert seen["cycles"] > 100 and seen["settled"] > 50 and seen["warm"] > 50
