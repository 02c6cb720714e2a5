"""The IMM cycle's mixing and combination (mjasc.perception.imm.compiled_cycle: _mix_predict's step 2 and
combine_row's step 6, the sums over the models in the outer loop, one local accumulator per entry) against
the entry-by-entry loops they replaced (each entry's sum over the models in its own inner loop, s_i − s̄
recomputed per entry), bit for bit: every output of imm_cycle and the combined covariances, on random rows and
on every cycle of a real run."""

import math
from dataclasses import replace
from pathlib import Path

import numba
import numpy as np
import pytest

import mjasc
from mjasc.perception.imm import bank_updates
from mjasc.perception.imm.compiled_cycle import _correct, _innovate, combine_covariance, imm_cycle
from mjasc.perception.imm.row_fields import combine_covariance_rows
from mjasc.runs.runner import Runner

_TWO_PI = 2.0 * math.pi


@numba.njit
def _mix_predict_entrywise(k, s, P, mu, markov, dt, dt_omega, q, c, w, s_out, P_out, cbar):
    r = mu.shape[1]
    for j in range(r):
        cb = 0.0
        for i in range(r):
            cb += markov[c, i, j] * mu[k, i]
        cbar[k, j] = cb
        for i in range(r):
            w[j, i] = mu[k, i] / cb * markov[c, i, j]
    T = dt[c]
    for j in range(r):
        s0 = s_out[k, j]
        P0 = P_out[k, j]
        for a in range(4):
            acc = 0.0
            for i in range(r):
                acc += w[j, i] * s[k, i, a]
            s0[a] = acc
        for a in range(4):
            for b in range(a, 4):
                acc, spread = 0.0, 0.0
                for i in range(r):
                    acc += w[j, i] * P[k, i, a, b]
                    spread += (s[k, i, a] - s0[a]) * (w[j, i] * (s[k, i, b] - s0[b]))
                P0[a, b] = acc + spread
        th, v = s0[2], s0[3]
        cos_t, sin_t = math.cos(th), math.sin(th)
        g00, g01, g10, g11 = -sin_t * v * T, cos_t * T, cos_t * v * T, sin_t * T
        s0[0] += g01 * v
        s0[1] += g11 * v
        s0[2] += dt_omega[c, j]
        m00 = P0[0, 2] + g00 * P0[2, 2] + g01 * P0[2, 3]
        m01 = P0[0, 3] + g00 * P0[2, 3] + g01 * P0[3, 3]
        m10 = P0[1, 2] + g10 * P0[2, 2] + g11 * P0[2, 3]
        m11 = P0[1, 3] + g10 * P0[2, 3] + g11 * P0[3, 3]
        a00 = P0[0, 0] + (g00 * P0[0, 2] + g01 * P0[0, 3]) + (m00 * g00 + m01 * g01)
        a01 = P0[0, 1] + (g00 * P0[1, 2] + g01 * P0[1, 3]) + (m00 * g10 + m01 * g11)
        a11 = P0[1, 1] + (g10 * P0[1, 2] + g11 * P0[1, 3]) + (m10 * g10 + m11 * g11)
        P0[0, 0], P0[0, 1], P0[1, 1] = a00, a01, a11
        P0[0, 2], P0[0, 3], P0[1, 2], P0[1, 3] = m00, m01, m10, m11
        P0[2, 2] += q[c, 0]
        P0[3, 3] += q[c, 1]
        for a in range(4):
            for b in range(a + 1, 4):
                P0[b, a] = P0[a, b]


@numba.njit
def _imm_cycle_entrywise(s, P, mu, markov, dt, dt_omega, q, z, var, use, floor, gate, s_out, P_out, mu_out, x_out,
                         d2_min):
    """imm_cycle with the entry-by-entry mixing (the rest as there)."""
    n, r = mu.shape
    w = np.empty((r, r))
    d2, det = np.empty(r), np.empty(r)
    th_pred = np.empty(r)
    for k in range(n):
        c = k if dt.shape[0] > 1 else 0
        _mix_predict_entrywise(k, s, P, mu, markov, dt, dt_omega, q, c, w, s_out, P_out, mu_out)
        cbar = mu_out[k]
        lo = np.nan
        if use[k if use.shape[0] > 1 else 0]:
            z0, z1, sig2 = z[k, 0], z[k, 1], var[k if var.shape[0] > 1 else 0]
            for j in range(r):
                d2[j] = _innovate(s_out[k, j], P_out[k, j], z0, z1, sig2)[6]
                lo = d2[j] if j == 0 else min(lo, d2[j])
            if lo <= gate:
                for j in range(r):
                    sj, Pj = s_out[k, j], P_out[k, j]
                    th_pred[j] = sj[2]
                    r0, r1, S00, S01, S11, dj, _ = _innovate(sj, Pj, z0, z1, sig2)
                    det[j] = dj
                    _correct(sj, Pj, r0, r1, S00, S01, S11, dj)
                    if sj[3] < 0.0:
                        sj[2] = th_pred[j] + (math.pi - (math.pi - (sj[2] + math.pi - th_pred[j])) % _TWO_PI)
                        sj[3] = -sj[3]
                        for a in range(3):
                            Pj[3, a] = -Pj[3, a]
                            Pj[a, 3] = -Pj[a, 3]
                total = 0.0
                for j in range(r):
                    cbar[j] = math.sqrt(math.exp(lo - d2[j]) / det[j]) * cbar[j]
                    total += cbar[j]
                low, total2 = total * floor, 0.0
                for j in range(r):
                    cbar[j] = max(cbar[j], low)
                    total2 += cbar[j]
                for j in range(r):
                    cbar[j] /= total2
        d2_min[k] = lo
        for a in range(4):
            acc = 0.0
            for j in range(r):
                acc += cbar[j] * s_out[k, j, a]
            x_out[k, a] = acc


@numba.njit
def _combine_entrywise(s, P, mu, out):
    x = np.empty(4)
    r = mu.shape[1]
    for k in range(mu.shape[0]):
        for a in range(4):
            acc = 0.0
            for j in range(r):
                acc += mu[k, j] * s[k, j, a]
            x[a] = acc
        for a in range(4):
            for b in range(a, 4):
                acc, spread = 0.0, 0.0
                for j in range(r):
                    acc += mu[k, j] * P[k, j, a, b]
                    spread += (s[k, j, a] - x[a]) * (mu[k, j] * (s[k, j, b] - x[b]))
                out[k, a, b] = out[k, b, a] = acc + spread


def _combined_same(s, P, mu):
    """combine_covariance and combine_covariance_rows (every row not in start-up) against the entry-by-entry form."""
    want, got, rows = (np.full(mu.shape[:1] + (4, 4), 7.0) for _ in range(3))
    _combine_entrywise(s, P, mu, want)
    combine_covariance(s, P, mu, got)
    combine_covariance_rows(s, P, mu, np.zeros(mu.shape[0], dtype=bool), rows)
    assert got.tobytes() == want.tobytes() and rows.tobytes() == want.tobytes()


def _both(s, P, mu, markov, dt, dt_omega, q, z, var, use, floor, gate):
    """imm_cycle and the entry-by-entry form on the same input: each output pair equal, bit for bit."""
    n, r = mu.shape
    outs = [(np.full((n, r, 4), 7.0), np.full((n, r, 4, 4), 7.0), np.full((n, r), 7.0), np.full((n, 4), 7.0),
             np.full(n, 7.0)) for _ in range(2)]
    imm_cycle(s, P, mu, markov, dt, dt_omega, q, z, var, use, floor, gate, *outs[0])
    _imm_cycle_entrywise(s, P, mu, markov, dt, dt_omega, q, z, var, use, floor, gate, *outs[1])
    for a, b in zip(*outs):
        assert a.tobytes() == b.tobytes()
    _combined_same(s, P, mu)
    _combined_same(*outs[0][:3])


@pytest.mark.parametrize("seed", range(6))
def test_mixing_equals_the_entrywise_loops_on_random_rows(seed):
    rng = np.random.default_rng(seed)
    n, r = 9, 3 + seed
    s = rng.normal(size=(n, r, 4)) * [30.0, 30.0, 1.0, 3.0]
    A = rng.normal(size=(n, r, 4, 4))
    P = A @ A.transpose(0, 1, 3, 2) + 0.1 * np.eye(4)
    mu = rng.random((n, r)) + 1e-3
    mu /= mu.sum(1, keepdims=True)
    per_row = seed % 2 == 0
    m = n if per_row else 1
    markov = rng.random((m, r, r)) + 0.01
    markov /= markov.sum(2, keepdims=True)
    dt = rng.uniform(0.05, 1.0, m)
    dt_omega = dt[:, None] * rng.normal(size=(m, r)) * 0.1
    q = rng.uniform(1e-4, 0.5, (m, 2))
    z = s[:, 0, :2] + rng.normal(size=(n, 2)) * (5.0 if seed % 3 else 200.0)
    var = rng.uniform(0.1, 4.0, n)
    use = rng.random(n) < 0.8
    _both(s, P, mu, markov, dt, dt_omega, q, z, var, use, 1e-4, 9.2)


@pytest.mark.parametrize("name,duration", [("thesis_6_4_crossing", 20.0)])
def test_mixing_equals_the_entrywise_loops_on_a_real_run(monkeypatch, name, duration):
    seen = {"cycles": 0}
    settle = bank_updates.measured_settle

    def checked(*args):
        z, _, mv, per_row, R, finite, use, every_true, s, P, mu, markov, dt, dt_omega, q, floor, gate = args[:17]
        var = np.where(np.isfinite(mv) & (mv > 0), mv, R) if per_row else mv
        _both(s, P, mu, markov, dt, dt_omega, q, np.where(np.isfinite(z), z, 0.0), var, np.isfinite(z).all(1),
              floor, gate)
        seen["cycles"] += 1
        return settle(*args)

    monkeypatch.setattr(bank_updates, "measured_settle", checked)
    root = Path(__file__).resolve().parents[1]
    sc = mjasc.load_scenario(root / "tasks" / f"{name}.toml").with_overrides(duration_s=duration)
    sc = replace(sc, outputs=replace(sc.outputs, recording=False, video=False))
    Runner(sc, out_dir=None).run()
    assert seen["cycles"] >= 100
