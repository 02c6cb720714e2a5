"""The fleet tracker's compiled bookkeeping (:mod:`mjasc.perception.tracking.step_kernels`,
:mod:`~mjasc.perception.tracking.step_gathers`) against
the numpy forms it replaced, bit for bit, on random problems shaped like a tick's (a few vessels,
some without tracks or detections, NaN radii, conflicts that need ``linear_sum_assignment``)."""

from __future__ import annotations

import numpy as np
import pytest

from mjasc.perception.tracking.association import block_pairs, gnn_pairs
from mjasc.perception.tracking.step_kernels import (apply_assignment, birth_rows, pair_setup,
                                                    select_detections)


def _starts(counts):
    out = np.zeros(counts.size, dtype=np.int64)
    np.cumsum(counts[:-1], out=out[1:])
    return out


@pytest.mark.parametrize("seed", range(20))
def test_select_detections(seed):
    rng = np.random.default_rng(seed)
    p = int(rng.integers(1, 5))
    m_all = rng.integers(0, 7, size=p)
    M = int(m_all.sum())
    sel = rng.random(M) < 0.7
    cen, var, rad = rng.normal(size=(M, 2)), rng.random(M), rng.random(M)
    occ = rng.random(M) < 0.3
    for use_var in (True, False):
        got = select_detections(m_all.astype(np.int64), sel, cen, var, rad, occ, use_var, 0.25)
        gidx = np.flatnonzero(sel)
        d_pos = np.repeat(np.arange(p), m_all)[gidx]
        want = (d_pos, gidx - _starts(m_all)[d_pos], cen[gidx], var[gidx] if use_var else np.full(gidx.size, 0.25),
                rad[gidx], occ[gidx], np.bincount(d_pos, minlength=p))
        for a, b in zip(got, want):
            assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


def _pairs(rng, p):
    n = int(rng.integers(0, 12))
    rows = np.sort(rng.choice(20, size=n, replace=False)).astype(np.int64)
    rpos = rng.integers(0, p, size=n).astype(np.int64)
    m_q = rng.integers(0, 5, size=p).astype(np.int64)
    return rows, rpos, m_q


@pytest.mark.parametrize("seed", range(30))
def test_pair_setup(seed):
    rng = np.random.default_rng(seed)
    p = int(rng.integers(1, 5))
    rows, rpos, m_q = _pairs(rng, p)
    M = int(m_q.sum())
    radius = rng.random(20) * 3
    radius[rng.random(20) < 0.1] = np.nan
    var, rad, occ = rng.random(M), rng.random(M) * 3, rng.random(M) < 0.4
    got = pair_setup(rows, rpos, p, m_q, radius, var, rad, occ)
    n_q = np.bincount(rpos, minlength=p)
    grouped = rows[np.argsort(rpos, kind="stable")]
    q, i, j, start = block_pairs(n_q, m_q)
    gi = _starts(n_q)[q] + i
    db = _starts(m_q)[q] + j
    ta = grouped[gi]
    var_p = var[db] + occ[db] * np.maximum(radius[ta] - rad[db], 0.0) ** 2
    for a, b in zip(got, (n_q, grouped, q, i, j, start, gi, db, ta, var_p)):
        assert a.shape == b.shape and a.tobytes() == b.astype(a.dtype).tobytes()


def _assign_numpy(inside, cost, q, i, j, start, n_a, n_b):
    """The numpy form of gnn_assign_blocks."""
    ins = np.flatnonzero(inside)
    if ins.size == 0:
        return ins
    qa = q[ins]
    total = int(start[-1])
    row_key = start[qa] + i[ins] * n_b[qa]
    col_key = start[qa] + j[ins]
    dup = (np.bincount(row_key, minlength=total)[row_key] > 1) | (np.bincount(col_key, minlength=total)[col_key] > 1)
    if not dup.any():
        return ins
    hard = np.unique(qa[dup])
    out = [ins[~np.isin(qa, hard)]]
    for b in hard.tolist():
        na, nb, s0 = int(n_a[b]), int(n_b[b]), int(start[b])
        blk = slice(s0, s0 + na * nb)
        out.append(s0 + gnn_pairs(inside[blk].reshape(na, nb), cost[blk].reshape(na, nb)))
    return np.sort(np.concatenate(out))


@pytest.mark.parametrize("seed", range(40))
def test_admissible_pairs_and_assignment(seed):
    from mjasc.perception.tracking.association import gnn_assign_blocks

    rng = np.random.default_rng(seed)
    p = int(rng.integers(1, 5))
    n_a = rng.integers(0, 5, size=p).astype(np.int64)
    n_b = rng.integers(0, 5, size=p).astype(np.int64)
    q, i, j, start = block_pairs(n_a, n_b)
    inside = rng.random(q.size) < (0.15 if seed % 2 else 0.5)
    cost = rng.random(q.size)
    want = _assign_numpy(inside, cost, q, i, j, start, n_a, n_b)
    got = gnn_assign_blocks(inside, cost, q, i, j, start, n_a, n_b)
    assert got.dtype == want.dtype and got.tobytes() == want.tobytes()
    # written back
    ta = rng.permutation(30)[: max(q.size, 1)][: q.size].astype(np.int64)
    ta = np.sort(rng.choice(60, size=q.size, replace=False)).astype(np.int64) if q.size else ta
    M = int(n_b.sum())
    db = (_starts(n_b)[q] + j).astype(np.int64)
    var_p, d2 = rng.random(q.size), rng.random(q.size)
    assigned, var_row, claimed = np.full(60, -1), np.full(60, 0.5), np.zeros(M, dtype=bool)
    a2, v2, c2 = assigned.copy(), var_row.copy(), claimed.copy()
    hit, d2g = apply_assignment(got, inside, ta, db, var_p, d2, assigned, var_row, claimed)
    c2 |= np.bincount(db[inside], minlength=M) > 0
    h2 = ta[got]
    a2[h2] = db[got]
    v2[h2] = var_p[got]
    assert hit.tobytes() == h2.tobytes() and d2g.tobytes() == d2[got].tobytes()
    assert assigned.tobytes() == a2.tobytes() and var_row.tobytes() == v2.tobytes() and claimed.tobytes() == c2.tobytes()


@pytest.mark.parametrize("seed", range(20))
def test_fade_nis(seed):
    from mjasc.perception.tracking.manoeuvre import fade_nis

    rng = np.random.default_rng(seed)
    n = 15
    nis, man = rng.random(n) * 10, rng.random(n) < 0.5
    rows = np.sort(rng.choice(n, size=int(rng.integers(0, n)), replace=False)).astype(np.int64)
    d2 = rng.random(rows.size) * 20
    d2[rng.random(rows.size) < 0.1] = np.nan
    gate, a, start, end = 9.21, 0.8, 6.0, 3.0
    nis2, man2 = nis.copy(), man.copy()
    hot = np.empty(rows.size, dtype=bool)
    n_hot = fade_nis(rows, d2, gate, a, start, end, nis, man, hot)
    eps = np.minimum(d2, gate)
    v = a * nis2[rows] + (1.0 - a) * eps
    nis2[rows] = v
    m = np.where(man2[rows], v >= end, v > start)
    man2[rows] = m
    assert nis.tobytes() == nis2.tobytes() and man.tobytes() == man2.tobytes()
    assert hot.tobytes() == m.tobytes() and n_hot == int(m.sum())


@pytest.mark.parametrize("seed", range(20))
def test_measurements(seed):
    from mjasc.perception.imm.bank_kernels import measurements

    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 12))
    z = rng.normal(size=(n, 2))
    z[rng.random((n, 2)) < 0.1] = np.nan
    z[rng.random((n, 2)) < 0.05] = np.inf
    measured = rng.random(n) < 0.8
    mv = rng.normal(size=n)
    mv[rng.random(n) < 0.1] = np.nan
    for per_row in (True, False):
        m = mv.copy()
        finite, use = np.empty(n, dtype=bool), np.empty(n, dtype=bool)
        every = measurements(z, measured, m, per_row, 0.25, finite, use)
        f2 = np.isfinite(z).all(axis=1)
        assert finite.tobytes() == f2.tobytes() and use.tobytes() == (measured & f2).tobytes()
        assert every == bool((measured & f2).all())
        want = np.where(np.isfinite(mv) & (mv > 0), mv, 0.25) if per_row else mv
        assert m.tobytes() == want.tobytes()


@pytest.mark.parametrize("seed", range(30))
def test_team_blocks(seed):
    from mjasc.perception.tracking.team_kernels import team_blocks

    rng = np.random.default_rng(seed)
    n_owners = int(rng.integers(1, 4))
    k = int(rng.integers(0, 10))
    owner = rng.integers(0, n_owners, size=k).astype(np.int64)
    confirmed = rng.random(k) < 0.6
    B = int(rng.integers(0, 6))
    b_owner = np.sort(rng.integers(0, n_owners, size=B)).astype(np.int64)
    t_b = rng.random(B) * 5
    t_s = rng.random(n_owners) * 5
    t_s[rng.random(n_owners) < 0.2] = np.nan
    got = team_blocks(confirmed, owner, t_s, b_owner, t_b, 2.0, n_owners)
    fresh = t_s[b_owner] - t_b <= 2.0
    c = np.flatnonzero(confirmed)
    if not fresh.any() or c.size == 0:
        assert got[0].size == 0 or got[1].size == 0
        return
    c = c[np.argsort(owner[c], kind="stable")]
    bsel = np.flatnonzero(fresh)
    n_a = np.bincount(owner[c], minlength=n_owners)
    n_b = np.bincount(b_owner[bsel], minlength=n_owners)
    for a, b in zip(got, (c, bsel, n_a, n_b, np.cumsum(n_a) - n_a, np.cumsum(n_b) - n_b)):
        assert a.tobytes() == b.astype(np.int64).tobytes()


def _births_numpy(claimed, rows, rpos, d_pos, z, var, rad, x, radius, owners, t_o, next_local):
    """The numpy form of the births' selection and numbering (FleetTracker._births before birth_rows)."""
    p = owners.size
    free = ~claimed
    if rows.size:
        n_q = np.bincount(rpos, minlength=p)
        grouped = rows[np.argsort(rpos, kind="stable")]
        fidx = np.flatnonzero(free)
        m_f = np.bincount(d_pos[fidx], minlength=p)
        q, i, j, start = block_pairs(n_q, m_f)
        if q.size:
            ta, fb = grouped[_starts(n_q)[q] + i], fidx[_starts(m_f)[q] + j]
            pos = x[ta]
            dist = np.hypot(z[fb, 0] - pos[:, 0], z[fb, 1] - pos[:, 1])
            free[fb[dist <= radius[ta] + rad[fb]]] = False
    new = np.flatnonzero(free)
    k = new.size
    bp = d_pos[new]
    own = owners[bp]
    first = np.searchsorted(bp, bp)
    local = next_local[own] + (np.arange(k) - first)
    born = np.bincount(bp, minlength=p)
    next_local[owners] += born
    return new, bp, own, local, born, t_o[bp], z[new], var[new], rad[new]


@pytest.mark.parametrize("seed", range(30))
def test_birth_rows(seed):
    rng = np.random.default_rng(seed)
    n_owners = 4
    p = int(rng.integers(1, 4))
    owners = np.sort(rng.choice(n_owners, size=p, replace=False)).astype(np.int64)
    m_q = rng.integers(0, 6, size=p)
    d_pos = np.repeat(np.arange(p), m_q).astype(np.int64)
    M = d_pos.size
    z, var, rad = rng.normal(scale=5, size=(M, 2)), rng.random(M), rng.random(M) * 2
    rad[rng.random(M) < 0.1] = np.nan
    claimed = rng.random(M) < 0.3
    n = int(rng.integers(0, 10))
    x, radius = rng.normal(scale=5, size=(n, 4)), rng.random(n) * 3
    rows = np.sort(rng.choice(n, size=int(rng.integers(0, n + 1)), replace=False)).astype(np.int64)
    rpos = rng.integers(0, p, size=rows.size).astype(np.int64)
    t_o = rng.random(p)
    nl = rng.integers(0, 9, size=n_owners).astype(np.int64)
    nl2 = nl.copy()
    got = birth_rows(claimed, rows, rpos, d_pos, z, var, rad, x, radius, owners, t_o, nl)
    want = _births_numpy(claimed, rows, rpos, d_pos, z, var, rad, x, radius, owners, t_o, nl2)
    for a, b in zip(got, want):
        assert a.shape == b.shape and a.tobytes() == b.astype(a.dtype).tobytes()
    assert nl.tobytes() == nl2.tobytes()


def test_management_append_matches_concatenation():
    from mjasc.perception.tracking import TrackingConfig
    from mjasc.perception.tracking.management import TrackManagement

    rng = np.random.default_rng(1)
    for hits in (1, 3):
        m = TrackManagement(TrackingConfig(confirm_hits=hits))
        want = {name: getattr(m, name).copy() for name in TrackManagement._ROWS}
        for step in range(6):
            k = int(rng.integers(1, 4))
            t, r = (rng.random(k) if step % 2 else float(rng.random())), rng.random(k)
            m.append(t, r)
            tk = np.broadcast_to(np.asarray(t, dtype=float), (k,))
            one, no = np.ones(k, dtype=np.int64), np.zeros(k, dtype=bool)
            add = {"_hist": one, "_scans": one, "_n_upd": one, "_confirmed": no | (hits <= 1), "_static": no,
                   "_born": tk, "_last": tk, "_radius": r, "_anchor": np.zeros((k, 2)), "_anchored": no, "_moved": no}
            want = {name: np.concatenate([want[name], add[name]]) for name in want}
            for name in TrackManagement._ROWS:
                a, b = getattr(m, name), want[name]
                assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
            keep = rng.random(m._hist.size) < 0.7
            m.keep(keep)
            want = {name: want[name][keep] for name in want}


@pytest.mark.parametrize("seed", range(20))
def test_confirmed_by_owner(seed):
    from mjasc.perception.tracking.association import group_starts
    from mjasc.perception.tracking.step_kernels import confirmed_by_owner

    rng = np.random.default_rng(seed)
    n_owners = int(rng.integers(1, 5))
    n = int(rng.integers(0, 20))
    owner = rng.integers(0, n_owners, size=n).astype(np.int64)
    confirmed = rng.random(n) < 0.6
    rows, first = confirmed_by_owner(confirmed, owner, n_owners)
    want = np.flatnonzero(confirmed)
    own = owner[want]
    order = np.argsort(own, kind="stable")
    want, own = want[order], own[order]
    assert rows.tobytes() == want.tobytes()
    u, cut = group_starts(own)
    f = first.tolist()
    spans = {o: (a, b) for o, (a, b) in enumerate(zip(f, f[1:])) if b > a}
    assert spans == dict(zip(u.tolist(), zip(cut.tolist(), cut[1:].tolist() + [own.size])))


@pytest.mark.parametrize("seed", range(10))
def test_note_moved_matches_numpy_form(seed):
    from mjasc.perception.tracking import TrackingConfig
    from mjasc.perception.tracking.management import MOVED_M, TrackManagement

    rng = np.random.default_rng(seed)
    n = 12
    m = TrackManagement(TrackingConfig())
    m.append(np.zeros(n), np.ones(n))
    anchor, anchored, moved = np.zeros((n, 2)), np.zeros(n, dtype=bool), np.zeros(n, dtype=bool)
    for _ in range(8):
        m._confirmed |= rng.random(n) < 0.3
        x = rng.normal(scale=3.0, size=(n, 4))
        x[rng.random(n) < 0.1, 0] = np.nan
        m.note_moved(x)
        positions = x[:, :2]
        new = m._confirmed & ~anchored
        anchor[new] = positions[new]
        anchored |= new
        d = positions - anchor
        moved |= anchored & (np.hypot(d[:, 0], d[:, 1]) >= MOVED_M)
        assert m._anchor.tobytes() == anchor.tobytes() and m._anchored.tobytes() == anchored.tobytes()
        assert m._moved.tobytes() == moved.tobytes()


@pytest.mark.parametrize("seed", range(10))
def test_counts_and_measurement_rows(seed):
    from mjasc.perception.tracking.step_kernels import (add_counts, count_scans, count_used, measurement_rows,
                                                        measurement_rows_into)

    rng = np.random.default_rng(seed)
    n_owners, p = 6, int(rng.integers(1, 6))
    owners = rng.permutation(n_owners)[:p].astype(np.int64)
    counts = rng.integers(0, 50, size=(n_owners, 7)).astype(np.int64)
    want = counts.copy()
    m_q = rng.integers(0, 9, size=p).astype(np.int64)
    count_scans(counts, owners, 4, 5, m_q)
    want[owners, 4] += 1
    want[owners, 5] += m_q
    born = rng.integers(0, 3, size=p).astype(np.int64)
    add_counts(counts, owners, 0, born)
    want[owners, 0] += born
    n = int(rng.integers(0, 12))
    pos_of = np.full(n_owners, -1)
    pos_of[owners] = np.arange(p)
    owner_of_row = owners[rng.integers(0, p, size=n)] if n else np.zeros(0, dtype=np.int64)
    row_pos = pos_of[owner_of_row]
    rows = np.flatnonzero(rng.random(n) < 0.7)
    used = rng.random(n) < 0.6
    count_used(counts, owners, 6, row_pos, rows, used)
    want[owners, 6] += np.bincount(row_pos[rows[used[rows]]], minlength=p)
    assert counts.tobytes() == want.tobytes()

    M = int(rng.integers(0, 8))
    z = rng.normal(size=(M, 2))
    assigned = rng.integers(-1, M, size=n).astype(np.int64) if M else np.full(n, -1, dtype=np.int64)
    zr, meas = measurement_rows(assigned, z)
    meas_ref = assigned >= 0
    zr_ref = np.empty((n, 2))
    zr_ref.fill(np.nan)
    zr_ref[meas_ref] = z[assigned[meas_ref]]
    assert meas.tobytes() == meas_ref.tobytes()
    assert np.array_equal(zr, zr_ref, equal_nan=True) and zr.dtype == zr_ref.dtype and zr.shape == zr_ref.shape
    zr_b, meas_b = np.full((n + 3, 2), 7.0), np.zeros(n + 3, dtype=bool)  # (into the caller's buffers)
    measurement_rows_into(assigned, z, zr_b, meas_b)
    assert zr_b[:n].tobytes() == zr.tobytes() and meas_b[:n].tobytes() == meas.tobytes()


@pytest.mark.parametrize("seed", range(10))
def test_last_assignments(seed):
    from mjasc.perception.tracking.association import group_starts
    from mjasc.perception.tracking.step_kernels import last_assignments

    rng = np.random.default_rng(seed)
    n, p, M = int(rng.integers(0, 15)), int(rng.integers(1, 5)), int(rng.integers(1, 9))
    row_pos = rng.integers(-1, p, size=n)
    rows = np.flatnonzero(row_pos >= 0) if seed % 2 else np.arange(n)
    row_pos[rows] = np.maximum(row_pos[rows], 0)
    hit = rng.random(n) < 0.6
    local_id = rng.integers(0, 100, size=n)
    idx = rng.integers(0, 30, size=M)
    assigned = np.where(hit, rng.integers(0, M, size=n), -1)
    ids, det, first = last_assignments(rows, hit, row_pos, local_id, idx, assigned, p)
    want = {}
    got = rows[hit[rows]]
    if got.size:  # the numpy form (FleetTracker._update before)
        got = got[np.argsort(row_pos[got], kind="stable")]
        qs, cut = group_starts(row_pos[got])
        ids_r, det_r = local_id[got], idx[assigned[got]]
        for q, a, b in zip(qs.tolist(), cut.tolist(), cut[1:].tolist() + [got.size]):
            want[q] = (ids_r[a:b], det_r[a:b])
    f = first.tolist()
    have = {q: (ids[f[q]:f[q + 1]], det[f[q]:f[q + 1]]) for q in range(p) if f[q + 1] > f[q]}
    assert have.keys() == want.keys()
    for q in want:
        for a, b in zip(have[q], want[q]):
            assert a.dtype == b.dtype and a.tobytes() == b.tobytes()


@pytest.mark.parametrize("seed", range(10))
def test_team_matched_rows(seed):
    from mjasc.perception.tracking.association import block_pairs
    from mjasc.perception.tracking.team_kernels import matched_rows

    rng = np.random.default_rng(seed)
    n_a, n_b = rng.integers(0, 4, size=3), rng.integers(0, 3, size=3)
    q, i, j, start = block_pairs(n_a, n_b)
    a_start, b_start = _starts(n_a), _starts(n_b)
    c = rng.permutation(int(n_a.sum()) + 3)[: int(n_a.sum())].astype(np.int64)
    bsel = rng.permutation(int(n_b.sum()) + 2)[: int(n_b.sum())].astype(np.int64)
    got = np.flatnonzero(rng.random(q.size) < 0.5)
    ta, tb = matched_rows(got, q, i, j, a_start, b_start, c, bsel)
    qg = q[got]  # the numpy form (TeamMatcher.match before)
    ta_r, tb_r = c[a_start[qg] + i[got]], bsel[b_start[qg] + j[got]]
    assert ta.dtype == ta_r.dtype and ta.tobytes() == ta_r.tobytes()
    assert tb.dtype == tb_r.dtype and tb.tobytes() == tb_r.tobytes()


@pytest.mark.parametrize("seed", range(20))
def test_cycled_rows(seed):
    """cycled_rows against the numpy form of FleetTracker._update after the cycle (count_used, the rows'
    times, speeds, used and assigned, hit = used & meas, the rows of vessels with returns and their
    hit, speeds and positions)."""
    from mjasc.perception.tracking.step_gathers import cycled_rows

    rng = np.random.default_rng(seed)
    p = int(rng.integers(1, 5))
    n_owners = p + int(rng.integers(0, 3))
    owners = rng.permutation(n_owners)[:p].astype(np.int64)
    n = int(rng.integers(0, 15))
    row_pos = rng.integers(-1, p, size=n)
    all_due = seed % 3 == 0
    if all_due:
        row_pos = rng.integers(0, p, size=n)
    rows = np.arange(n) if all_due else np.flatnonzero(row_pos >= 0)
    t_o = rng.uniform(0, 10, p)
    used, meas = rng.random(n) < 0.6, rng.random(n) < 0.7
    x = rng.normal(size=(n, 4))
    with_pts = rng.random(p) < 0.7
    assigned = np.where(meas, rng.integers(0, 5, n), -1)
    counts = rng.integers(0, 9, size=(n_owners, 7))
    want_counts = counts.copy()
    want_counts[owners, 6] += np.bincount(row_pos[rows[used[rows]]], minlength=p)
    got = cycled_rows(rows, row_pos, t_o, used, meas, x, with_pts, counts, owners, 6, assigned)
    sel = slice(None) if all_due else rows
    hit = used & meas
    rpos = row_pos[rows]
    orows = rows if with_pts.all() else rows[with_pts[rpos]]
    want = (t_o[row_pos[rows]], x[:, 3].copy()[sel], used[sel], assigned[sel], hit, orows, hit[orows], x[orows, 3],
            x[orows, :2])
    for a, b in zip(got, want):
        assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
    assert np.array_equal(counts, want_counts)


@pytest.mark.parametrize("seed", range(30))
def test_team_pairs_and_distances(seed):
    """team_pairs and team_distances against the numpy form of TeamMatcher.match before them (team_blocks,
    block_pairs_loop, the states gathered, V·cos θ and V·sin θ, broadcast_distances, the gate)."""
    from mjasc.perception.tracking.pair_kernels import block_pairs_loop, broadcast_distances
    from mjasc.perception.tracking.team_kernels import team_blocks, team_distances, team_pairs

    rng = np.random.default_rng(seed)
    n_owners = int(rng.integers(1, 4))
    k = int(rng.integers(0, 10))
    owner = rng.integers(0, n_owners, size=k).astype(np.int64)
    confirmed = rng.random(k) < 0.6
    states = np.column_stack([rng.uniform(-30, 30, (k, 2)), rng.uniform(-np.pi, np.pi, k), rng.uniform(0, 5, k)])
    B = int(rng.integers(0, 6))
    b_owner = np.sort(rng.integers(0, n_owners, size=B)).astype(np.int64)
    t_b = rng.random(B) * 5
    p_b = rng.uniform(-30, 30, (B, 2))
    t_s = rng.random(n_owners) * 5
    t_s[rng.random(n_owners) < 0.2] = np.nan
    got = team_pairs(confirmed, owner, t_s, b_owner, t_b, 2.0, n_owners, states)
    want = team_blocks(confirmed, owner, t_s, b_owner, t_b, 2.0, n_owners)
    for a, b in zip(got[:6], want):
        assert a.tobytes() == b.tobytes()
    c, bsel, n_a, n_b, a_start, b_start = want
    if c.size == 0 or bsel.size == 0:
        return
    q, i, j, start = block_pairs_loop(n_a, n_b)
    for a, b in zip(got[6:10], (q, i, j, start)):
        assert a.tobytes() == b.tobytes()
    x = states[c]
    assert got[10].tobytes() == x.tobytes()
    vx, vy = x[:, 3] * np.cos(x[:, 2]), x[:, 3] * np.sin(x[:, 2])
    gate = 12.0
    dist = broadcast_distances(q, i, j, a_start, b_start, bsel, x, vx, vy, t_s, t_b, p_b, (2.0 * gate) ** 2)
    th = got[10][:, 2]
    d, inside, n_in = team_distances(q, i, j, a_start, b_start, bsel, got[10], np.cos(th), np.sin(th), t_s, t_b, p_b,
                                     (2.0 * gate) ** 2, gate)
    assert d.tobytes() == dist.tobytes() and np.array_equal(inside, dist <= gate)
    assert n_in == np.count_nonzero(dist <= gate)


@pytest.mark.parametrize("seed", range(20))
def test_step_rows(seed):
    """step_rows against the numpy form of the start of FleetTracker.step (the vessels' times, the scans
    counted, the rows' vessel positions and the due rows, the step's fresh arrays)."""
    from mjasc.perception.tracking.step_gathers import step_rows

    rng = np.random.default_rng(seed)
    n_owners = int(rng.integers(1, 6))
    p = int(rng.integers(1, n_owners + 1))
    owners = rng.permutation(n_owners)[:p].astype(np.int64)
    pos_of = np.full(n_owners, -1)
    pos_of[owners] = np.arange(p)
    every = p == n_owners
    n = int(rng.integers(0, 12))
    owner = rng.integers(0, n_owners, n).astype(np.int64)
    t_o = rng.uniform(0, 9, p)
    m_q = rng.integers(0, 5, p)
    M = int(m_q.sum())
    counts = rng.integers(0, 9, (n_owners, 7))
    want_counts = counts.copy()
    want_counts[owners, 4] += 1
    want_counts[owners, 5] += m_q
    got = step_rows(owner, pos_of, every, owners, t_o, n_owners, counts, 4, 5, m_q, M, 0.25)
    t_own = np.empty(n_owners)
    t_own.fill(np.nan)
    t_own[owners] = t_o
    row_pos = pos_of[owner]
    all_due = every or bool((row_pos >= 0).all())
    rows = np.arange(n) if all_due else (row_pos >= 0).nonzero()[0]
    want = (t_own, row_pos, all_due, rows, row_pos[rows], np.zeros(M, dtype=bool), np.full(n, -1, dtype=np.int64),
            np.full(n, 0.25))
    assert got[2] == want[2] and np.array_equal(counts, want_counts)
    for a, b in zip(got[:2] + got[3:], want[:2] + want[3:]):
        assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


@pytest.mark.parametrize("seed", range(30))
def test_births_of(seed):
    """births_of against FleetTracker._births' numpy form before it: the rows of the scanning vessels, birth_rows,
    the births counted and their detections' indices."""
    from mjasc.perception.tracking.step_gathers import births_of

    rng = np.random.default_rng(seed)
    n_owners = int(rng.integers(1, 5))
    p = int(rng.integers(1, n_owners + 1))
    owners = np.sort(rng.permutation(n_owners)[:p]).astype(np.int64)
    pos_of = np.full(n_owners, -1)
    pos_of[owners] = np.arange(p)
    n = int(rng.integers(0, 10))
    owner = rng.integers(0, n_owners, n).astype(np.int64)
    x = rng.uniform(-20, 20, (n, 4))
    radius = rng.uniform(0.2, 4, n)
    m_q = rng.integers(0, 5, p)
    M = int(m_q.sum())
    d_pos = np.repeat(np.arange(p), m_q)
    z, var, rad = rng.uniform(-20, 20, (M, 2)), rng.random(M), rng.uniform(0.2, 3, M)
    claimed = rng.random(M) < 0.3
    idx = rng.integers(0, 50, M)
    t_o = rng.uniform(0, 9, p)
    next_local = rng.integers(0, 9, n_owners)
    counts = rng.integers(0, 9, (n_owners, 7))
    nl_ref, counts_ref = next_local.copy(), counts.copy()
    got = births_of(claimed, owner, pos_of, d_pos, z, var, rad, x, radius, owners, t_o, next_local, idx, counts, 0)
    every = p == n_owners
    rows = np.arange(n) if every else (pos_of[owner] >= 0).nonzero()[0]
    rpos = pos_of[owner if every else owner[rows]]
    new, bp, own, local, born, t_b, zb, var_b, rad_b = birth_rows(claimed, rows, rpos, d_pos, z, var, rad, x, radius,
                                                                  owners, t_o, nl_ref)
    counts_ref[owners, 0] += born
    for a, b in zip(got, (bp, own, local, t_b, zb, var_b, rad_b, idx[new])):
        assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
    assert np.array_equal(counts, counts_ref) and np.array_equal(next_local, nl_ref)
