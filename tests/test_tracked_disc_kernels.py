"""The compiled tracked-disc loops (mjasc.perception.tracked_disc_kernels) against the numpy form of
the tracked discs (mjasc.perception.tracked_discs.disc_margin and the centres along the arc), bit for bit: random
tracks with coasting and future times, zero, huge, NaN and indefinite covariances."""

import numpy as np
import pytest

from mjasc.perception.tracked_discs import DISC_MARGIN_M, DISC_MARGIN_MAX_M, disc_margin
from mjasc.perception.tracked_disc_kernels import disc_courses, disc_geometry, disc_rows, disc_rows_at, disc_table


def _numpy_discs(t_s, t, pos, th, v, w, P, radius):
    """The tracked discs after ``IMMBank.estimate_fields``: centres one arc step ahead, radius + disc_margin."""
    dt = np.maximum(t_s - t, 0.0)
    th = th + 0.5 * dt * w
    step = dt * v
    c = np.empty((t.size, 2))
    c[:, 0] = pos[:, 0] + step * np.cos(th)
    c[:, 1] = pos[:, 1] + step * np.sin(th)
    return c, radius + disc_margin(P)


def _same(a, b):
    assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


@pytest.mark.parametrize("seed", range(30))
def test_tracked_disc_kernels_equal_the_numpy_form(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(0, 40))
    t = rng.uniform(0.0, 100.0, n)
    t_s = t + rng.choice([-1.0, 0.0, 0.2, 3.0], n) * rng.random(n)
    pos = rng.uniform(-500.0, 500.0, (n, 2))
    th, v, w = rng.uniform(-np.pi, np.pi, n), rng.uniform(0.0, 8.0, n), rng.normal(0.0, 0.1, n)
    L = rng.normal(0.0, rng.choice([0.0, 0.1, 3.0, 1e3]), (n, 2, 2))
    P = L @ L.transpose(0, 2, 1)
    if n:
        P[rng.random(n) < 0.1] = np.nan
        P[rng.random(n) < 0.1, 0, 1] = 5.0  # indefinite
        t_s[rng.random(n) < 0.05] = np.nan
    radius = rng.uniform(0.5, 10.0, n)
    with np.errstate(invalid="ignore"):
        c_ref, r_ref = _numpy_discs(t_s, t, pos, th, v, w, P, radius)
        dt, mid = disc_courses(t_s, t, th, w)
        c, r = disc_geometry(pos, dt, v, np.cos(mid), np.sin(mid), radius, P, DISC_MARGIN_M, DISC_MARGIN_MAX_M)
    _same(c, c_ref)
    _same(r, r_ref)
    confirmed, static, moved = (rng.random(n) < 0.6 for _ in range(3))
    owner = rng.integers(0, 5, n)
    t_own = np.where(rng.random(5) < 0.3, np.nan, rng.uniform(0.0, 10.0, 5))
    want = np.flatnonzero(confirmed & (~static | moved) & ~np.isnan(t_own[owner]))
    _same(disc_rows(confirmed, static, moved, owner, t_own), want)


@pytest.mark.parametrize("seed", range(40))
def test_pass_disc_kernels_equal_the_per_tracker_form(seed):
    """disc_rows_at + disc_table (one sensing pass) against disc_rows + tracked_discs' kernels with
    the owners' scan times, then the discs stably sorted by slot (the pass's former form)."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(0, 40))
    n_owners, S = 5, 4
    confirmed, static, moved = (rng.random(n) < 0.6 for _ in range(3))
    owner = rng.integers(0, n_owners, n).astype(np.int64)
    owner_slot = np.full(n_owners, -1, dtype=np.int64)
    scanned = rng.permutation(n_owners)[: int(rng.integers(0, S + 1))]
    owner_slot[scanned] = rng.permutation(S)[: scanned.size]
    slot_time = rng.uniform(0.0, 10.0, S)
    t_own = np.full(n_owners, np.nan)
    t_own[scanned] = slot_time[owner_slot[scanned]]
    sel = disc_rows(confirmed, static, moved, owner, t_own)
    (rows, slots), t_s = disc_rows_at(confirmed, static, moved, owner, owner_slot, slot_time)
    _same(rows, sel)
    _same(t_s, t_own[owner[sel]])
    _same(slots, owner_slot[owner[sel]])
    k = rows.size
    t = rng.uniform(0.0, 10.0, k)
    pos = rng.uniform(-500.0, 500.0, (k, 2))
    th, v, w = rng.uniform(-np.pi, np.pi, k), rng.uniform(0.0, 8.0, k), rng.normal(0.0, 0.1, k)
    L = rng.normal(0.0, 1.0, (k, 2, 2))
    P = L @ L.transpose(0, 2, 1)
    radius_all = rng.uniform(0.5, 10.0, n)
    dt, mid = disc_courses(t_s, t, th, w)
    c_ref, r_ref = disc_geometry(pos, dt, v, np.cos(mid), np.sin(mid), radius_all[rows], P, DISC_MARGIN_M,
                                 DISC_MARGIN_MAX_M)
    order = np.argsort(slots, kind="stable")
    c, r, kk = disc_table(pos, dt, v, np.cos(mid), np.sin(mid), radius_all, rows, P, DISC_MARGIN_M,
                          DISC_MARGIN_MAX_M, slots, S)
    _same(c, c_ref[order])
    _same(r, r_ref[order])
    _same(kk, slots[order])


def _bank_arrays(rng, n, r):
    """Random IMM bank arrays as BankViews.prediction_arrays hands them out: x (n, 4), t (n,), μ (n, r),
    ω (r,), start-up flags (n,), combined covariances (n, 4, 4)."""
    x = np.column_stack([rng.uniform(-500.0, 500.0, (n, 2)), rng.uniform(-20.0, 20.0, n), rng.uniform(0.0, 8.0, n)])
    t = rng.uniform(0.0, 10.0, n)
    mu = rng.dirichlet(np.ones(r), n) if n else np.zeros((0, r))
    omega = rng.normal(0.0, 0.2, r)
    active = rng.random(n) < 0.3
    L = rng.normal(0.0, rng.choice([0.0, 0.1, 3.0]), (n, 4, 4))
    Pc = L @ L.transpose(0, 2, 1)
    if n:
        Pc[rng.random(n) < 0.1] = np.nan
    return x, t, mu, omega, active, Pc


def _composed(confirmed, static, moved, owner, owner_slot, slot_time, bank, radius_all, S):
    """PerceptionFleet._discs' former form of one tracker: disc_rows_at, the bank's estimate_fields
    (row_fields), disc_courses, numpy's cos / sin, disc_table."""
    from mjasc.perception.imm.row_fields import row_fields

    x, t_all, mu, omega, active, Pc = bank
    (rows, slots), t_s = disc_rows_at(confirmed, static, moved, owner, owner_slot, slot_time)
    t, xs, th, w, P = row_fields(rows, x, t_all, mu, omega, active, Pc, False)
    dt, th = disc_courses(t_s, t, th, w)
    return disc_table(xs[:, :2], dt, xs[:, 3], np.cos(th), np.sin(th), radius_all, rows, P, DISC_MARGIN_M,
                      DISC_MARGIN_MAX_M, slots, S)


@pytest.mark.parametrize("seed", range(40))
def test_pass_discs_equals_the_composed_form(seed):
    """pass_discs (one call, math.cos / math.sin) against the kernels and numpy calls it replaced, bit for bit."""
    from mjasc.perception.tracked_disc_kernels import pass_discs

    rng = np.random.default_rng(seed)
    n = int(rng.integers(0, 40))
    n_owners, S = 5, 4
    confirmed, static, moved = (rng.random(n) < 0.6 for _ in range(3))
    owner = rng.integers(0, n_owners, n).astype(np.int64)
    owner_slot = np.full(n_owners, -1, dtype=np.int64)
    scanned = rng.permutation(n_owners)[: int(rng.integers(0, S + 1))]
    owner_slot[scanned] = rng.permutation(S)[: scanned.size]
    slot_time = rng.uniform(0.0, 12.0, S)
    bank = _bank_arrays(rng, n, int(rng.integers(1, 8)))
    radius_all = rng.uniform(0.5, 10.0, n)
    with np.errstate(invalid="ignore"):
        want = _composed(confirmed, static, moved, owner, owner_slot, slot_time, bank, radius_all, S)
        got = pass_discs(confirmed, static, moved, owner, owner_slot, slot_time, *bank, radius_all, DISC_MARGIN_M,
                         DISC_MARGIN_MAX_M, S)
    for a, b in zip(got, want):
        _same(a, b)


def test_pass_discs_equals_the_composed_form_in_a_run():
    """The same on every sensing pass of a thesis run (its trackers' own arrays)."""
    from pathlib import Path

    import mjasc.perception.tracked_discs as discs_module
    from mjasc.perception.tracked_disc_kernels import pass_discs
    from mjasc.runs.runner import Runner
    from mjasc.runs.scenario import load_scenario

    tasks = Path(__file__).resolve().parents[1] / "tasks"
    calls = []

    def checked(confirmed, static, moved, owner, owner_slot, slot_time, x, t, mu, omega, active, Pc, radius_all,
                margin_m, margin_max_m, S):
        got = pass_discs(confirmed, static, moved, owner, owner_slot, slot_time, x, t, mu, omega, active, Pc,
                         radius_all, margin_m, margin_max_m, S)
        want = _composed(confirmed, static, moved, owner, owner_slot, slot_time, (x, t, mu, omega, active, Pc),
                         radius_all, S)
        for a, b in zip(got, want):
            _same(a, b)
        calls.append(got[0].shape[0])
        return got

    scenario = load_scenario(tasks / "thesis_6_4_crossing.toml").with_overrides(duration_s=60.0)
    original = discs_module.pass_discs
    discs_module.pass_discs = checked
    try:
        Runner(scenario, None, progress=False).run()
    finally:
        discs_module.pass_discs = original
    assert len(calls) > 200 and sum(calls) > 100


@pytest.mark.parametrize("seed", range(10))
def test_tracker_discs_takes_the_same_discs_either_way(seed):
    """tracked_discs.tracker_discs: the one compiled call on the bank's arrays and the path for a bank
    without them (its estimate_fields between the kernels, numpy's cos / sin) give the same bits."""
    from types import SimpleNamespace

    from mjasc.perception.imm.row_fields import row_fields
    from mjasc.perception.tracked_discs import tracker_discs

    rng = np.random.default_rng(100 + seed)
    n, n_owners, S = int(rng.integers(0, 30)), 4, 3
    bank = _bank_arrays(rng, n, 3)
    owner_slot = np.array([0, -1, 2, 1], dtype=np.int64)
    mgmt = SimpleNamespace(_confirmed=rng.random(n) < 0.7, _static=rng.random(n) < 0.3, _moved=rng.random(n) < 0.5,
                           _radius=rng.uniform(0.5, 10.0, n))
    owner = rng.integers(0, n_owners, n).astype(np.int64)
    times = rng.uniform(0.0, 12.0, S)

    def fields(rows):
        t, xs, th, w, P = row_fields(rows, *bank, False)
        return t, xs[:, :2], th, xs[:, 3], w, P

    with_arrays = SimpleNamespace(mgmt=mgmt, owner=owner, bank=SimpleNamespace(prediction_arrays=lambda: bank))
    without = SimpleNamespace(mgmt=mgmt, owner=owner, bank=SimpleNamespace(prediction_arrays=lambda: None,
                                                                           estimate_fields=fields))
    with np.errstate(invalid="ignore"):
        for a, b in zip(tracker_discs(with_arrays, owner_slot, times), tracker_discs(without, owner_slot, times)):
            _same(a, b)
