"""The compiled clustering of detect_many (mjasc.perception.cluster_kernels) against the numpy form it
had (kept here as the reference): the same breaks, rotation, clusters and hidden edges, on random
stacks of scans (full and partial fans, 0 to 400 returns, grazed walls, repeated and NaN returns,
scans with different beams and configs)."""

import math

import numpy as np
import pytest

from mjasc.perception.cluster_kernels import (_OCCLUDER_MARGIN_M, _WALL_SIN_TOL, _WALL_STEP_MAX_M, _WALL_STEP_RATIO,
                                              cluster_order, occluded_edges)
from mjasc.perception.detection_kernels import cluster_discs, detect_clusters, kept_detections, unpack_detections


def _numpy_wall_continues(P, gaps, step, nxt, prv, sigma, gap_max):
    seg = P[nxt] - P
    length = np.maximum(step, 1e-9)
    unit = seg / length[:, None]
    tol = np.minimum(1.0, 3.0 * sigma * (1.0 / length + 1.0 / length[prv])) + _WALL_SIN_TOL
    cross_back = np.abs(unit[prv, 0] * unit[:, 1] - unit[prv, 1] * unit[:, 0])
    per_beam = length / np.maximum(gaps, 1)
    similar = np.maximum(per_beam, per_beam[prv]) <= _WALL_STEP_RATIO * np.minimum(per_beam, per_beam[prv]) + 6.0 * sigma
    bridged = gaps <= gap_max
    up = unit[prv]
    back = bridged & bridged[prv] & (up[:, 0] * unit[:, 0] + up[:, 1] * unit[:, 1] > 0) & (cross_back < tol) & similar
    fwd = back[nxt]
    return (back | fwd) & bridged & (step <= _WALL_STEP_MAX_M)


def _numpy_clusters(beams, P, rho, ret_off, n_beams, d0, lam, dth, gap, sig, full):
    """detect_many's numpy form (per-scan constants as (S,) arrays, taken per return)."""
    S = ret_off.size - 1
    k_s = np.diff(ret_off)
    K = int(ret_off[-1])
    idx = np.arange(K)
    sid = np.repeat(np.arange(S), k_s)
    first, last = ret_off[sid], ret_off[sid + 1] - 1
    local, k_r = idx - first, k_s[sid]
    at_last = idx == last
    nxt = np.where(at_last, first, idx + 1)
    gaps = beams[nxt] - beams + np.where(at_last, n_beams[sid], 0)
    step = np.hypot(*(P[nxt] - P).T)
    thr = d0[sid] + lam[sid] * np.minimum(rho, rho[nxt]) * gaps * dth[sid]
    brk = (gaps > gap[sid]) | (step > thr)
    if (k_s >= 3).any() and brk.any():
        prv = np.where(local == 0, last, idx - 1)
        wall = _numpy_wall_continues(P, gaps, step, nxt, prv, sig[sid], gap[sid])
        brk &= ~(wall & (k_r >= 3))
    brk |= at_last & ~np.logical_and(full[sid], k_r > 1)
    bi = np.append(np.flatnonzero(brk), K)
    first_brk = bi[np.searchsorted(bi, ret_off[:-1])]
    shift = np.where(first_brk < ret_off[1:], first_brk - ret_off[:-1] + 1, 0)
    order = first + (local + shift[sid]) % k_r
    brk = brk[order]
    is_start = local == 0
    is_start[1:] |= brk[:-1]
    starts = np.flatnonzero(is_start)
    counts = np.diff(np.append(starts, K))
    return order, starts, counts, sid[starts]


def _numpy_occluded(beams, rho, starts, ends, cs, beam_off, n_beams, gap_max_s, full_s, hit_all, ranges_all):
    gap_max = gap_max_s[cs]
    g = int(gap_max.max())
    off = np.arange(1, g + 1)
    n, fc = n_beams[cs], full_s[cs]
    n_col = n[:, None]
    within = off[None, :] <= gap_max[:, None]
    base = beam_off[cs][:, None]
    occ = np.zeros(starts.size, dtype=bool)
    for edge, sign in ((starts, -1), (ends, 1)):
        nb = beams[edge][:, None] + sign * off[None, :]
        occ |= ~fc & ((nb[:, 0] < 0) | (nb[:, 0] >= n))
        nb = np.where(fc[:, None], nb % n_col, np.clip(nb, 0, n_col - 1))
        nb += base
        nearer = hit_all[nb] & (ranges_all[nb] < rho[edge][:, None] - _OCCLUDER_MARGIN_M) & within
        occ |= nearer.any(axis=1)
    return occ


def _scans(rng):
    S = int(rng.integers(1, 5))
    n_beams = rng.choice([1, 2, 3, 16, 360, 720], S).astype(np.int64)
    full = rng.random(S) < 0.6
    dth = np.where(full, 2.0 * math.pi / n_beams, rng.uniform(0.002, 0.02, S))
    d0, lam = rng.choice([0.0, 1.0], S), rng.choice([0.0, 3.0], S)
    gap = rng.integers(1, 6, S).astype(np.int64)
    sig = rng.choice([0.0, 0.05, 0.5], S)
    hits, ranges, beams, P = [], [], [], []
    for s in range(S):
        n = int(n_beams[s])
        h = rng.random(n) < rng.choice([0.0, 0.05, 0.5, 0.95, 1.0])
        r = np.full(n, 150.0)
        ang = -0.5 * n * dth[s] + (np.arange(n) + 0.5) * dth[s]
        kind = rng.random()
        if kind < 0.3:  # a wall at grazing incidence: x = 20
            r[:] = np.where(np.abs(np.cos(ang)) > 0.1, 20.0 / np.abs(np.cos(ang)), 150.0)
        else:  # objects: runs of similar ranges
            r[:] = np.repeat(rng.uniform(2.0, 140.0, n // 8 + 1), 8)[:n] + rng.normal(0.0, sig[s] + 1e-3, n)
        r = np.where(h, np.minimum(r, 150.0), 150.0)
        b = np.flatnonzero(h)
        p = r[b, None] * np.stack([np.cos(ang[b]), np.sin(ang[b])], axis=-1)
        if b.size and rng.random() < 0.1:
            p[rng.integers(0, b.size)] = np.nan
        if b.size > 2 and rng.random() < 0.1:
            p[1] = p[0]
        hits.append(h)
        ranges.append(r)
        beams.append(b)
        P.append(p.reshape(-1, 2))
    k_s = np.array([b.size for b in beams], dtype=np.int64)
    ret_off = np.zeros(S + 1, dtype=np.int64)
    np.cumsum(k_s, out=ret_off[1:])
    beam_off = np.zeros(S + 1, dtype=np.int64)
    np.cumsum(n_beams, out=beam_off[1:])
    beams_c = np.concatenate(beams).astype(np.int64)
    ranges_all, hit_all = np.concatenate(ranges), np.concatenate(hits)
    rho = ranges_all[np.repeat(beam_off[:-1], k_s) + beams_c]
    return (beams_c, np.concatenate(P), rho, ret_off, n_beams, d0, lam, dth, gap, sig, full), beam_off, hit_all, \
        ranges_all


@pytest.mark.parametrize("seed", range(80))
def test_clusters_and_hidden_edges_equal_the_numpy_form(seed):
    args, beam_off, hit_all, ranges_all = _scans(np.random.default_rng(seed))
    if args[0].size == 0:
        return
    with np.errstate(all="ignore"):
        ref = _numpy_clusters(*args)
    got = cluster_order(*args)
    for a, b in zip(got, ref):
        assert a.dtype == b.dtype and a.tobytes() == b.tobytes()
    beams, _, rho, _, n_beams, _, _, _, gap, _, full = args
    order, starts, counts, cs = got
    want = _numpy_occluded(beams[order], rho[order], starts, starts + counts - 1, cs, beam_off, n_beams, gap, full,
                           hit_all, ranges_all)
    occ = occluded_edges(beams[order], rho[order], starts, counts, cs, beam_off, n_beams, gap, full, hit_all,
                         ranges_all)
    assert occ.tobytes() == want.tobytes()


@pytest.mark.parametrize("seed", range(30))
def test_detect_clusters_is_the_steps_in_sequence(seed):
    """detection_kernels.detect_clusters (one call) equals cluster_order, cluster_discs,
    occluded_edges and kept_detections called one after the other, as detect_many called them."""
    rng = np.random.default_rng(1000 + seed)
    args, beam_off, hit_all, ranges_all = _scans(rng)
    if args[0].size == 0:
        return
    beams, P, rho, ret_off, n_beams, d0, lam, dth, gap, sig, full = args
    S = n_beams.size
    origins = rng.uniform(-5.0, 5.0, (S, 2))
    yaw = rng.uniform(-4.0, 4.0, S)
    cos_h, sin_h = np.cos(yaw), np.sin(yaw)
    edge_lost, edge_var = rng.uniform(0.0, 0.5, S), rng.uniform(0.0, 0.5, S)
    min_rad, sig2, floor2 = rng.uniform(0.0, 0.5, S), sig**2, np.full(S, 0.0025)
    min_pts, max_tr = rng.integers(1, 4, S).astype(np.int64), rng.uniform(2.0, 10.0, S)
    with np.errstate(all="ignore"):
        order, starts, counts, cs = cluster_order(*args)
        centres, radii, var = cluster_discs(P[order], rho[order], starts, counts, cs, origins, dth, edge_lost,
                                            min_rad, edge_var, sig2, floor2)
        occ = occluded_edges(beams[order], rho[order], starts, counts, cs, beam_off, n_beams, gap, full, hit_all,
                             ranges_all)
        want = kept_detections(order, counts, cs, centres, radii, var, occ, origins, cos_h, sin_h, min_pts, max_tr)
        packed = detect_clusters(*args, beam_off, hit_all, ranges_all, origins, cos_h, sin_h, edge_lost, min_rad,
                                 edge_var, sig2, floor2, min_pts, max_tr)
    got = unpack_detections(*packed, beams.shape[0])
    assert len(got) == len(want)
    for a, b in zip(got, want):
        assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
