"""sense_kernels.sort_returns against the numpy form of the sensing pass it replaced (targets, wall
fragments on mapped cells, the map's new returns, non-finite targets), bit for bit, on random
stacked scans and on the scans of a shipped scenario."""

from __future__ import annotations

import numpy as np
import pytest

from mjasc.perception.fleet import FLAT_M, _starts, inside_owned, thickness
from mjasc.perception.owned_discs import inside_discs
from mjasc.perception.sense_kernels import sort_returns, tracked_in_walls


def _numpy_form(labels, ret_off, det_off, extended, n_points, centres, radii, variances, points, occ, sigma, dc, dr,
                d_k, slot):
    """The sensing pass's numpy form (fleet.py before sense_kernels)."""
    S = ret_off.size - 1
    index = np.arange(S)
    ret_k = np.repeat(index, np.diff(ret_off))
    n_det = np.diff(det_off)
    det_k = np.repeat(index, n_det)
    lab = np.where(labels >= 0, labels + det_off[:-1][ret_k], -1)
    M = int(n_det.sum())
    targets = ~extended
    p_static, m_static = np.zeros((0, 2)), np.zeros(0, dtype=np.int64)
    if M:
        good = lab >= 0
        if occ is not None and targets.any():
            frac = np.bincount(lab[good], weights=occ[good], minlength=M) / np.maximum(n_points, 1)
            on_map = targets & (frac >= 0.5) & ~inside_owned(centres, det_k, dc, dr, d_k)
            if on_map.any():
                on_map &= thickness(points, lab, M) <= FLAT_M + 2.0 * sigma[det_k]
            targets &= ~on_map
        good_static = good & ~targets[np.maximum(lab, 0)]
        if good_static.any():
            p, pk = points[good_static], ret_k[good_static]
            away = ~inside_owned(p, pk, dc, dr, d_k)
            p_static, m_static = p[away], slot[pk[away]]
    finite = np.isfinite(centres).all(axis=1) & np.isfinite(radii) & np.isfinite(variances)
    stats = np.zeros((S, 4), dtype=np.int64)
    stats[:, 0] = np.diff(ret_off)
    stats[:, 1] = n_det
    for s in range(S):
        t, f = targets[det_off[s]:det_off[s + 1]], finite[det_off[s]:det_off[s + 1]]
        stats[s, 3] = np.count_nonzero(t & ~f)
        stats[s, 2] = np.count_nonzero(t & f)
    return targets & finite, p_static, m_static, stats


def _case(rng):
    S = int(rng.integers(1, 5))
    n_det = rng.integers(0, 6, S)
    det_off = np.zeros(S + 1, dtype=np.int64)
    np.cumsum(n_det, out=det_off[1:])
    M = int(det_off[-1])
    labels, pts = [], []
    n_points = np.zeros(M, dtype=np.int64)
    centres = rng.uniform(-50.0, 50.0, (M, 2))
    for s in range(S):
        k = int(rng.integers(0, 40))
        lab = rng.integers(-1, n_det[s], k) if n_det[s] else np.full(k, -1)
        labels.append(lab)
        for i, d in enumerate(lab):
            if d >= 0:
                n_points[det_off[s] + d] += 1
        # returns near their detection's centre, along a line (a wall fragment) or round a disc
        base = np.where(lab[:, None] >= 0, centres[np.maximum(det_off[s] + lab, 0)], 0.0) if M else np.zeros((k, 2))
        flat = rng.random() < 0.5
        t = rng.uniform(-2.0, 2.0, k)
        off = np.stack([t, 0.02 * rng.standard_normal(k)] if flat else [np.cos(t), np.sin(t)], axis=-1)
        pts.append(base + off)
    ret_off = np.zeros(S + 1, dtype=np.int64)
    np.cumsum([x.size for x in labels], out=ret_off[1:])
    labels = np.concatenate(labels).astype(np.int64)
    points = np.concatenate(pts).reshape(-1, 2)
    extended = rng.random(M) < 0.3
    radii = rng.uniform(0.3, 9.0, M)
    variances = rng.uniform(0.001, 0.1, M)
    if M and rng.random() < 0.3:
        bad = rng.integers(0, M)
        [centres, radii, variances][int(rng.integers(0, 3))].reshape(M, -1)[bad, 0] = np.nan
    occ = (rng.random(points.shape[0]) < rng.choice([0.2, 0.7, 1.0])) if rng.random() < 0.7 else None
    sigma = rng.choice([0.0, 0.05, 0.3], S)
    q = int(rng.integers(0, 6))
    d_k = np.sort(rng.integers(0, S, q)).astype(np.int64)
    dc = rng.uniform(-50.0, 50.0, (q, 2))
    if q and M:
        dc[0] = centres[int(rng.integers(0, M))]
    dr = rng.uniform(0.5, 20.0, q)
    slot = rng.permutation(S + 2)[:S].astype(np.int64)
    return (labels, ret_off, det_off, extended, n_points, centres, radii, variances, points, occ, sigma, dc, dr, d_k,
            slot)


def _check(args):
    (labels, ret_off, det_off, extended, n_points, centres, radii, variances, points, occ, sigma, dc, dr, d_k,
     slot) = args
    want = _numpy_form(*args)
    got = sort_returns(labels, ret_off, det_off, extended, n_points, centres, radii, variances, points,
                       np.zeros(0, dtype=bool) if occ is None else occ, sigma, FLAT_M, dc, dr, d_k, slot)
    assert got[0].dtype == bool and np.array_equal(got[0], want[0])
    assert got[1].tobytes() == np.ascontiguousarray(want[1]).reshape(-1, 2).tobytes()
    assert np.array_equal(got[2], want[2])
    assert np.array_equal(got[3], want[3])


@pytest.mark.parametrize("seed", range(300))
def test_sort_returns_matches_numpy_form(seed):
    _check(_case(np.random.default_rng(seed)))


def test_sort_returns_on_a_shipped_scenario():
    """The real sensing pass of the bottleneck (a mapped quay, tracked boats beside it): every tick's
    arguments of sort_returns, checked against the numpy form. The pass runs its map step one step
    at a time (map_pass.map_steps, the same results as the compiled sense_map and sensing pass:
    tests/test_map_pass.py, tests/test_sense_pass.py) so that sort_returns is called from Python."""
    from dataclasses import replace

    import mjasc
    from mjasc.perception import fleet as fleet_module
    from mjasc.perception import map_pass
    from mjasc.runs.runner import Runner

    seen = []
    orig = map_pass.sort_returns

    def spy(labels, ret_off, det_off, extended, n_points, centres, radii, variances, points, occ, sigma, flat_m, dc,
            dr, d_k, slot):
        seen.append(tuple(np.array(a, copy=True) for a in (labels, ret_off, det_off, extended, n_points, centres,
                                                           radii, variances, points, occ, sigma, dc, dr, d_k, slot)))
        return orig(labels, ret_off, det_off, extended, n_points, centres, radii, variances, points, occ, sigma,
                    flat_m, dc, dr, d_k, slot)

    sc = mjasc.load_scenario("thesis_6_4_bottleneck").with_overrides(duration_s=25.0)
    sc = replace(sc, outputs=replace(sc.outputs, recording=False, video=False))
    compiled = fleet_module.sense_map
    map_pass.sort_returns, fleet_module.sense_map = spy, map_pass.map_steps
    fleet_module.PerceptionFleet.map_in_pass = False  # (the map step after the compiled call, in Python)
    try:
        Runner(sc, out_dir=None).run()
    finally:
        map_pass.sort_returns, fleet_module.sense_map = orig, compiled
        fleet_module.PerceptionFleet.map_in_pass = True
    assert len(seen) > 50 and any(a[9].size for a in seen) and any(a[13].size for a in seen)
    for a in seen:
        a = list(a)
        if a[9].size == 0:
            a[9] = None
        _check(tuple(a))


@pytest.mark.parametrize("seed", range(200))
def test_tracked_in_walls_matches_numpy_form(seed):
    """Per scan: a return of an extended detection inside one of the scan's discs (the test
    Perception._split_tracked starts with)."""
    labels, ret_off, det_off, extended, _, _, _, _, points, _, _, dc, dr, d_k, _ = _case(np.random.default_rng(seed))
    got = tracked_in_walls(labels, ret_off, det_off, extended, points, dc, dr, d_k)
    for s in range(ret_off.size - 1):
        lab = labels[ret_off[s]:ret_off[s + 1]]
        ext = extended[det_off[s]:det_off[s + 1]]
        mine = d_k == s
        take = ((lab >= 0) & (ext[np.maximum(lab, 0)] if ext.size else False)
                & inside_discs(points[ret_off[s]:ret_off[s + 1]], dc[mine], dr[mine]))
        assert bool(got[s]) == bool(np.any(take))


def test_starts_unchanged():
    assert _starts(np.array([2, 0, 3])).tolist() == [0, 2, 2]
