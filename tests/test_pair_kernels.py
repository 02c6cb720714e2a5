"""The compiled pair loops of the tracker (mjasc.perception.tracking.pair_kernels) give the same bits
as the numpy forms they replaced, kept here as the references."""

import numpy as np
import pytest

from mjasc.perception.tracking.association import block_pairs, indexed_pair_costs, pair_costs
from mjasc.perception.tracking.pair_kernels import block_pairs_loop, broadcast_distances, gate_terms


def block_pairs_numpy(n_a, n_b):
    n_a, n_b = np.asarray(n_a, dtype=np.int64), np.asarray(n_b, dtype=np.int64)
    sizes = n_a * n_b
    start = np.zeros(sizes.size + 1, dtype=np.int64)
    np.cumsum(sizes, out=start[1:])
    q = np.repeat(np.arange(sizes.size), sizes)
    loc = np.arange(start[-1]) - start[q]
    nb = n_b[q]
    i = loc // nb
    return q, i, loc - i * nb, start


def pair_costs_numpy(zhat, S, z, var):
    a = S[:, 0, 0] + var
    b = S[:, 0, 1]
    d = S[:, 1, 1] + var
    det = a * d - b * b
    y0, y1 = z[:, 0] - zhat[:, 0], z[:, 1] - zhat[:, 1]
    d2 = (d * y0 * y0 - 2.0 * b * y0 * y1 + a * y1 * y1) / det
    return d2, d2 + np.log(det)


def broadcast_distances_numpy(q, i, j, a_start, b_start, bsel, x, vx, vy, t_s, tb, pb):
    ai = a_start[q] + i
    tb_i = bsel[b_start[q] + j]
    dtb = t_s[q] - tb[tb_i]
    pbt = pb[tb_i]
    return np.hypot(x[ai, 0] - vx[ai] * dtb - pbt[:, 0], x[ai, 1] - vy[ai] * dtb - pbt[:, 1])


SIZES = [([], []), ([0], [0]), ([3], [0]), ([0], [4]), ([1], [1]), ([2, 0, 3], [1, 5, 2]),
         ([5, 5, 0, 1], [0, 2, 7, 1])]


@pytest.mark.parametrize("n_a,n_b", SIZES)
def test_block_pairs_matches_numpy(n_a, n_b):
    got = block_pairs(n_a, n_b)
    ref = block_pairs_numpy(n_a, n_b)
    for g, r in zip(got, ref):
        assert g.dtype == r.dtype and np.array_equal(g, r)


def test_block_pairs_random():
    rng = np.random.default_rng(3)
    for _ in range(50):
        Q = int(rng.integers(0, 12))
        n_a, n_b = rng.integers(0, 9, Q), rng.integers(0, 9, Q)
        for g, r in zip(block_pairs_loop(n_a.astype(np.int64), n_b.astype(np.int64)), block_pairs_numpy(n_a, n_b)):
            assert np.array_equal(g, r)


def _tracks(rng, n):
    zhat = rng.normal(0, 50, (n, 2))
    L = rng.normal(0, 2, (n, 2, 2))
    S = L @ np.swapaxes(L, 1, 2)
    S[: n // 4] = 0.0  # no prediction uncertainty: det from the variance alone
    return zhat, S


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_gate_terms_match_numpy():
    rng = np.random.default_rng(7)
    for n, m in [(1, 1), (4, 3), (17, 11), (60, 40)]:
        zhat, S = _tracks(rng, n)
        z = rng.normal(0, 50, (m, 2))
        z[0] = zhat[0]  # a detection on a prediction: d² = 0
        P = 3 * n * m
        g, db = rng.integers(0, n, P), rng.integers(0, m, P)
        var = rng.uniform(0.0, 4.0, P)
        var[:5] = 0.0
        ref = pair_costs_numpy(zhat[g], S[g], z[db], var)
        got = indexed_pair_costs(zhat, S, g, z, db, var)
        assert np.array_equal(got[0], ref[0], equal_nan=True)
        assert np.array_equal(got[1], ref[1], equal_nan=True)
        d2, det = gate_terms(g, zhat, S, db, z, var)
        assert np.array_equal(d2, ref[0], equal_nan=True)
        # the public per-pair form is the same arithmetic
        assert np.array_equal(pair_costs(zhat[g], S[g], z[db], var)[1], ref[1], equal_nan=True)


def test_gate_terms_singular_gives_numpy_inf_nan():
    zhat, S = np.zeros((1, 2)), np.zeros((1, 2, 2))
    z = np.array([[0.0, 0.0], [1.0, 0.0]])
    g, db, var = np.array([0, 0]), np.array([0, 1]), np.zeros(2)
    with np.errstate(divide="ignore", invalid="ignore"):
        ref = pair_costs_numpy(zhat[g], S[g], z[db], var)
        got = indexed_pair_costs(zhat, S, g, z, db, var)
    assert np.array_equal(got[0], ref[0], equal_nan=True) and np.array_equal(got[1], ref[1], equal_nan=True)


def test_broadcast_distances_match_numpy():
    rng = np.random.default_rng(11)
    for _ in range(30):
        Q = int(rng.integers(1, 8))
        n_a, n_b = rng.integers(0, 6, Q), rng.integers(0, 6, Q)
        A, B = int(n_a.sum()), int(n_b.sum()) + 3
        a_start = np.cumsum(n_a) - n_a
        bsel = np.sort(rng.choice(B, int(n_b.sum()), replace=False)).astype(np.int64)
        b_start = np.cumsum(n_b) - n_b
        x = np.column_stack([rng.normal(0, 100, (A, 2)), rng.uniform(-np.pi, np.pi, A), rng.uniform(0, 5, A)])
        vx, vy = x[:, 3] * np.cos(x[:, 2]), x[:, 3] * np.sin(x[:, 2])
        t_s = rng.uniform(0, 100, Q)
        t_s[0] = np.nan  # a vessel not matched now
        tb, pb = rng.uniform(0, 100, B), rng.normal(0, 100, (B, 2))
        q, i, j, _ = block_pairs(n_a, n_b)
        ref = broadcast_distances_numpy(q, i, j, a_start, b_start, bsel, x, vx, vy, t_s, tb, pb)
        got = broadcast_distances(q, i, j, a_start, b_start, bsel, x, vx, vy, t_s, tb, pb, np.inf)
        assert np.array_equal(got, ref, equal_nan=True)
        gate = 60.0  # beyond twice the gate: +inf; within it (and so at the gate): the same bits
        got = broadcast_distances(q, i, j, a_start, b_start, bsel, x, vx, vy, t_s, tb, pb, (2 * gate) ** 2)
        near = ~(ref > 2 * gate)
        assert np.array_equal(got[near], ref[near], equal_nan=True)
        assert np.all(got[~near] == np.inf)
        assert np.array_equal(got <= gate, ref <= gate)


def merge_candidates_numpy(live, group, positions, rad, fraction):
    """The numpy form of TrackManagement.drops' duplicate search (live already sorted by group)."""
    from mjasc.perception.tracking.association import group_starts
    _, first = group_starts(group[live])
    n_g = np.diff(first, append=live.size)
    q, i, j, start = block_pairs_numpy(n_g, n_g)
    a, b = live[first[q] + i], live[first[q] + j]
    later = i < j
    a, b = a[later], b[later]
    pa, pb = positions[a], positions[b]
    dd = np.hypot(pa[:, 0] - pb[:, 0], pa[:, 1] - pb[:, 1])
    close = dd < fraction * np.maximum(rad[a], rad[b])
    return a[close], b[close]


def test_merge_candidates_match_numpy():
    from mjasc.perception.tracking.pair_kernels import merge_candidates
    rng = np.random.default_rng(5)
    for trial in range(60):
        k = int(rng.integers(0, 30))
        group = np.sort(rng.integers(0, 4, k)) if trial % 2 else rng.integers(0, 4, k)
        positions = rng.normal(0, 4, (k, 2))
        rad = rng.uniform(0.5, 3.0, k)
        if k > 3:
            positions[1] = positions[0]  # coincident
            rad[2] = np.nan
            rad[3] = rad[0]
        live = np.flatnonzero(rng.random(k) < 0.8)
        live = live[np.argsort(group[live], kind="stable")]
        ref = merge_candidates_numpy(live, group, positions, rad, 0.5)
        got = merge_candidates(live, group[live], positions, rad, 0.5)
        assert all(np.array_equal(g, r) and g.dtype == r.dtype for g, r in zip(got, ref))


def _predicted_positions_numpy(states, covariances, times_s, turn_rates, t_s):
    """The numpy form of association.predicted_positions."""
    x = states
    P = covariances
    dt = np.maximum(t_s - times_s, 0.0)
    th_mid = x[:, 2] + 0.5 * dt * turn_rates
    c, s = np.cos(th_mid), np.sin(th_mid)
    dv = dt * x[:, 3]
    zhat = np.empty((x.shape[0], 2))
    zhat[:, 0] = x[:, 0] + dv * c
    zhat[:, 1] = x[:, 1] + dv * s
    J = np.zeros((x.shape[0], 2, 4))
    J[:, 0, 0] = J[:, 1, 1] = 1.0
    J[:, 0, 2], J[:, 0, 3] = -dv * s, dt * c
    J[:, 1, 2], J[:, 1, 3] = dv * c, dt * s
    S = J @ P @ np.swapaxes(J, 1, 2)
    still = x[:, 3] == 0.0  # no course: var(V)·dt² on y too
    S[still, 1, 1] += dt[still] ** 2 * P[still, 3, 3]
    return zhat, S


@pytest.mark.parametrize("seed", range(10))
def test_predicted_positions_matches_numpy_form(seed):
    from mjasc.perception.tracking.association import predicted_positions

    rng = np.random.default_rng(seed)
    k = int(rng.integers(0, 30))
    x = rng.normal(scale=[30, 30, 2, 3], size=(k, 4))
    x[rng.random(k) < 0.3, 3] = 0.0  # tracks with no course yet (one measurement)
    A = rng.normal(size=(k, 4, 4))
    P = A @ np.swapaxes(A, 1, 2)
    t = rng.random(k) * 10
    w = rng.normal(scale=0.1, size=k)
    for t_s in (rng.random(k) * 10 + 5 * rng.random(k), 7.5):
        got = predicted_positions(x, P, t, w, t_s)
        want = _predicted_positions_numpy(x, P, t, w, t_s)
        for a, b in zip(got, want):
            assert a.shape == b.shape and a.tobytes() == b.tobytes()
