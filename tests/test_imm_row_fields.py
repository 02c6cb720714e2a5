"""The IMM bank's fields of some rows in one compiled pass (mjasc.perception.imm.row_fields): the same
bits as the numpy forms they replaced, on a bank run through real cycles (start-up rows, hand-overs,
coasting, many turns of the course)."""

from __future__ import annotations

import math

import numpy as np

from mjasc.perception.imm import IMMBank, IMMConfig
from mjasc.perception.imm.compiled_cycle import combine_covariance, turn_rate, wrap
from mjasc.perception.imm.row_fields import row_fields, wrapped_states


def _bank(config=IMMConfig(), n=24, steps=30, seed=5) -> IMMBank:
    """A bank of n turning targets, measured with noise (some rows missed), new tracks on the way."""
    rng = np.random.default_rng(seed)
    bank = IMMBank(config)
    pos = rng.uniform(-200, 200, size=(n, 2))
    course = rng.uniform(-math.pi, math.pi, size=n)
    speed = rng.uniform(0.0, 6.0, size=n)
    bank.add_tracks(pos[: n // 2], 0.0)
    t = 0.0
    for step in range(steps):
        t += 0.5
        course = course + 0.08
        pos = pos + 0.5 * speed[:, None] * np.stack([np.cos(course), np.sin(course)], axis=-1)
        k = len(bank)
        z = pos[:k] + rng.normal(scale=0.5, size=(k, 2))
        bank.update(z, t, rng.uniform(size=k) > 0.15)
        if step % 5 == 0 and len(bank) < n:
            m = min(3, n - len(bank))
            bank.add_tracks(pos[len(bank):len(bank) + m], t)
    return bank


def _estimate_fields_numpy(bank, rows):
    x = bank._x[rows]
    w = np.where(bank._startup.active[rows], 0.0, turn_rate(bank._mu[rows], bank._omega))
    return bank._t[rows], x[:, :2], wrap(x[:, 2]), x[:, 3], w, bank._covariances()[rows, :2, :2]


def _prediction_fields_numpy(bank, rows):
    x = bank._x[rows]
    x[:, 2] = wrap(x[:, 2])
    w = np.where(bank._startup.active[rows], 0.0, turn_rate(bank._mu[rows], bank._omega))
    return x, bank._covariances()[rows], bank._t[rows], w


def _same(a, b):
    assert len(a) == len(b)
    for u, v in zip(a, b):
        assert u.shape == v.shape and u.dtype == v.dtype
        assert np.ascontiguousarray(u).tobytes() == np.ascontiguousarray(v).tobytes()


def test_fields_equal_numpy_forms_bit_for_bit():
    bank = _bank()
    assert bank._startup.active.any() and not bank._startup.active.all()
    n = len(bank)
    rng = np.random.default_rng(1)
    for rows in (np.arange(n), np.arange(n)[::3].copy(), rng.permutation(n)[:5], np.zeros(0, dtype=np.int64)):
        _same(bank.estimate_fields(rows), _estimate_fields_numpy(bank, rows))
        _same(bank.prediction_fields(rows), _prediction_fields_numpy(bank, rows))
    ref = bank._x.copy()
    ref[:, 2] = wrap(ref[:, 2])
    _same((bank.states,), (ref,))


def test_wrap_and_turn_rate_on_extreme_values():
    rng = np.random.default_rng(2)
    n = 400
    x = rng.normal(size=(n, 4)) * 10.0
    x[:, 2] = np.concatenate([rng.uniform(-40, 40, n - 8),
                              [math.pi, -math.pi, 3 * math.pi, -3 * math.pi, 0.0, -0.0, 2 * math.pi, 1e-300]])
    mu = rng.dirichlet(np.ones(7), size=n)
    omega = np.array(IMMConfig().turn_rates_rad_s)
    active = rng.uniform(size=n) < 0.2
    Pc = rng.normal(size=(n, 4, 4))
    t = rng.uniform(0, 100, n)
    rows = np.arange(n)
    tt, xs, th, w, P = row_fields(rows, x, t, mu, omega, active, Pc, True)
    assert th.tobytes() == wrap(x[:, 2]).tobytes()
    assert xs[:, 2].tobytes() == th.tobytes()
    assert w.tobytes() == np.where(active, 0.0, turn_rate(mu, omega)).tobytes()
    assert P.tobytes() == Pc.tobytes() and tt.tobytes() == t.tobytes()
    ref = x.copy()
    ref[:, 2] = wrap(ref[:, 2])
    assert wrapped_states(x).tobytes() == ref.tobytes()


def test_covariances_equal_combine_covariance_of_the_imm_rows():
    bank = _bank(seed=9)
    active = bank._startup.active
    ref = bank._Pc.copy()
    Pc = np.empty_like(ref)
    combine_covariance(bank._s, bank._P, bank._mu, Pc)
    ref[~active] = Pc[~active]
    bank._Pc_stale = True
    assert bank._covariances().tobytes() == ref.tobytes()


def test_many_models_keep_the_numpy_form():
    config = IMMConfig(turn_rates_rad_s=tuple(np.linspace(-0.05, 0.05, 9)))
    bank = _bank(config, seed=3)
    assert not bank._compiled_fields
    rows = np.arange(len(bank))
    _same(bank.estimate_fields(rows), _estimate_fields_numpy(bank, rows))
