"""The compiled per-cluster disc estimate (mjasc.perception.detection_kernels.cluster_discs) against
the numpy form detect_many had (kept here as the reference), bit for bit: random clusters of 1 to
300 returns from several scans, with repeated points, a return at the sensor, NaN returns and
damped Gauss–Newton steps on degenerate clusters."""

import numpy as np
import pytest

from mjasc.core.compiled import pairwise_sum as _pairwise_sum
from mjasc.perception.detection_kernels import _DAMP, _REFINE, cluster_discs, kept_detections


def _numpy_discs(P, rho, starts, counts, cs, origins, dth, edge_lost, min_rad, edge_var, sig2, floor2):
    """detect_many's numpy form (per-scan constants taken per cluster)."""
    K = P.shape[0]
    lab = np.repeat(np.arange(starts.size), counts)
    ends = starts + counts - 1
    o = origins[cs]
    pf, pl = P[starts], P[ends]
    width = np.hypot(*(pl - pf).T)
    rho_mean = np.add.reduceat(rho, starts) / counts
    spacing = rho_mean * dth[cs]
    r_w = np.maximum(0.5 * (width + spacing * (1.0 + 2.0 * edge_lost[cs])), min_rad[cs])
    mid = 0.5 * (pf + pl)
    los = mid - o
    los_n = np.hypot(*los.T)
    u = los / np.where(los_n > 0, los_n, 1.0)[:, None]
    rel = P - o[lab]
    u_l = u[lab]
    d = rel[:, 0] * u_l[:, 0] + rel[:, 1] * u_l[:, 1]
    pm = P - mid[lab]
    y = pm[:, 0] * -u_l[:, 1] + pm[:, 1] * u_l[:, 0]
    behind = np.sqrt(np.maximum(r_w[lab] ** 2 - y * y, 0.0))
    wgt = behind + 1e-3 * r_w[lab]
    D = np.add.reduceat(wgt * (d + behind), starts) / np.add.reduceat(wgt, starts)
    centres = o + D[:, None] * u
    for _ in range(_REFINE):
        dv = centres[lab] - P
        dist = np.hypot(*dv.T)
        J = dv / np.maximum(dist, 1e-9)[:, None]
        e = dist - r_w[lab]
        a11 = np.add.reduceat(J[:, 0] ** 2, starts) + _DAMP * counts
        a12 = np.add.reduceat(J[:, 0] * J[:, 1], starts)
        a22 = np.add.reduceat(J[:, 1] ** 2, starts) + _DAMP * counts
        g1 = np.add.reduceat(J[:, 0] * e, starts)
        g2 = np.add.reduceat(J[:, 1] * e, starts)
        det_ = a11 * a22 - a12 * a12
        step_c = np.empty_like(centres)
        step_c[:, 0] = (a22 * g1 - a12 * g2) / det_
        step_c[:, 1] = (a11 * g2 - a12 * g1) / det_
        centres = centres - step_c
    far = np.maximum.reduceat(np.hypot(*(P - centres[lab]).T), starts)
    radii = np.maximum(r_w, far)
    var = spacing**2 * (1.0 / 12.0 + edge_var[cs]) + sig2[cs] / counts + floor2[cs]
    assert K == int(counts.sum())
    return centres, radii, var


def _clusters(rng):
    S = int(rng.integers(1, 5))
    origins = rng.uniform(-500.0, 500.0, (S, 2))
    m = int(rng.integers(1, 12))
    counts = rng.choice([1, 2, 3, 7, 8, 9, 16, 17, 40, 129, 300], size=m).astype(np.int64)
    cs = np.sort(rng.integers(0, S, m))
    P, rho = [], []
    for c in range(m):
        o = origins[cs[c]]
        a0, r0 = rng.uniform(-np.pi, np.pi), rng.uniform(2.0, 150.0)
        a = a0 + np.arange(counts[c]) * rng.uniform(1e-4, 0.02)
        r = r0 + rng.normal(0.0, rng.choice([0.0, 0.05, 2.0]), counts[c])
        p = o + r[:, None] * np.stack([np.cos(a), np.sin(a)], axis=-1)
        kind = rng.random()
        if kind < 0.1:
            p[:] = p[0]  # all returns at one point
        elif kind < 0.15:
            p[0] = o  # a return at the sensor itself
        elif kind < 0.2:
            p[rng.integers(0, counts[c])] = np.nan
        P.append(p)
        rho.append(np.abs(r))
    P, rho = np.concatenate(P), np.concatenate(rho)
    starts = np.zeros(m, dtype=np.int64)
    np.cumsum(counts[:-1], out=starts[1:])
    per_scan = [rng.choice(v, S) for v in ([2 * np.pi / 720, 0.01], [0.0, 0.02, 0.43], [0.0, 0.3], [0.0, 0.02, 0.6],
                                          [0.0, 0.0025], [0.0025, 0.0])]
    return P, rho, starts, counts, cs, origins, *[np.asarray(v, dtype=float) for v in per_scan]


@pytest.mark.parametrize("seed", range(60))
def test_cluster_discs_equal_the_numpy_form(seed):
    args = _clusters(np.random.default_rng(seed))
    with np.errstate(all="ignore"):
        ref = _numpy_discs(*args)
    got = cluster_discs(*args)
    for a, b in zip(got, ref):
        assert a.shape == b.shape and a.dtype == b.dtype
        assert a.tobytes() == b.tobytes()


@pytest.mark.parametrize("n", list(range(1, 40)) + [127, 128, 129, 255, 256, 257, 1000, 5000])
def test_pairwise_sum_is_numpys_reduceat(n):
    rng = np.random.default_rng(n)
    a = rng.standard_normal(n + 3) * 10.0 ** rng.uniform(-8, 8, n + 3)
    starts = np.array([0, 2], dtype=np.int64)
    ref = np.add.reduceat(a[1:], [0])[0], np.add.reduceat(a, starts)[1]
    assert a[1] + _pairwise_sum(a, 2, n + 1) == ref[0]
    assert a[2] + _pairwise_sum(a, 3, n) == ref[1]


def _numpy_kept(order, counts, cs, centres, radii, var, occluded, origins, cos_h, sin_h, min_pts, max_tr):
    """detect_many's numpy form of its last step (per-scan constants as (S,) arrays)."""
    S, K = origins.shape[0], order.size
    lab = np.repeat(np.arange(counts.size), counts)
    keep = counts >= min_pts[cs]
    det_off = np.zeros(S + 1, dtype=np.int64)
    np.cumsum(np.bincount(cs[keep], minlength=S), out=det_off[1:])
    new_index = np.cumsum(keep) - 1
    new_index -= det_off[cs]
    labels = np.full(K, -1)
    labels[order] = np.where(keep[lab], new_index[lab], -1)
    centres, radii, var, counts, occluded, cs = (a[keep] for a in (centres, radii, var, counts, occluded, cs))
    rel_c = centres - origins[cs]
    ch, sh = cos_h[cs], sin_h[cs]
    body = np.empty_like(rel_c)
    body[:, 0] = ch * rel_c[:, 0] + sh * rel_c[:, 1]
    body[:, 1] = -sh * rel_c[:, 0] + ch * rel_c[:, 1]
    return centres, body, radii, var, counts, np.hypot(*rel_c.T), radii > max_tr[cs], occluded, labels, det_off


@pytest.mark.parametrize("seed", range(40))
def test_kept_detections_equal_the_numpy_form(seed):
    rng = np.random.default_rng(seed)
    P, rho, starts, counts, cs, origins, *_ = _clusters(rng)
    S, m, K = origins.shape[0], counts.size, P.shape[0]
    order = np.concatenate([s + rng.permutation(n) for s, n in zip(starts, counts)])  # a rotation stands in
    centres = rng.uniform(-100.0, 100.0, (m, 2))
    centres[rng.random(m) < 0.1] = np.nan
    radii, var = rng.uniform(0.0, 12.0, m), rng.uniform(0.0, 1.0, m)
    occluded = rng.random(m) < 0.3
    heading = rng.uniform(-4.0, 4.0, S)
    cos_h, sin_h = np.array([np.cos(h) for h in heading]), np.array([np.sin(h) for h in heading])
    min_pts = rng.integers(1, 4, S).astype(np.int64)
    max_tr = rng.choice([2.0, 8.0], S)
    args = (order, counts, cs, centres, radii, var, occluded, origins, cos_h, sin_h, min_pts, max_tr)
    want = _numpy_kept(*args)
    got = kept_detections(*args)
    assert K == order.size
    for a, b in zip(got, want):
        assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
