"""The fused association kernels (:mod:`mjasc.perception.tracking.step_fusions`) against the calls
they replace, bit for bit: on every step of a real run (the 3-vessel crossing scene: the tracker's
association checked against pair_setup → prediction_fields → predicted_positions →
indexed_pair_costs → gnn_assign_blocks → apply_assignment on the same inputs), and
:func:`assign_pairs` on random problems whose gates overlap (the blocks left to
``linear_sum_assignment``)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import mjasc
from mjasc.perception.tracking import fleet as fleet_mod
from mjasc.perception.tracking.association import (gnn_assign_blocks, indexed_pair_costs,
                                                   predicted_positions)
from mjasc.perception.tracking.pair_kernels import block_pairs_flat
from mjasc.perception.tracking.step_fusions import (DB, GI, I, J, Q, TA, assign_pairs, predicted_pairs,
                                                   predicted_pairs_packed)
from mjasc.perception.tracking.step_kernels import admissible_pairs, apply_assignment, pair_setup
from mjasc.runs.runner import Runner

_ROOT = __import__("pathlib").Path(__file__).resolve().parents[1]


def _same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def _reference(ft, rows, rpos, row_pos, owners, t_o, z, var, rad, occ, m_q, claimed, assigned, var_row):
    """The association of FleetTracker._update before the fusion, on copies of its in-place arrays."""
    a2, v2, c2 = assigned.copy(), var_row.copy(), claimed.copy()
    n_q, grouped, q, i, j, start, gi, db, ta, var_p = pair_setup(rows, rpos, owners.size, m_q, ft.cols.radius, var,
                                                                  rad, occ)
    got = (n_q, grouped, q, i, j, start, gi, db, ta, var_p)
    hit = None
    if q.size:
        fields = ft.bank.prediction_fields(grouped)
        zhat, S = predicted_positions(*fields, t_o[row_pos[grouped]])
        d2, cost = indexed_pair_costs(zhat, S, gi, z, db, var_p)
        inside = d2 <= ft._gate
        sel = gnn_assign_blocks(inside, cost, q, i, j, start, n_q, m_q)
        hit, d2_hit = apply_assignment(sel, inside, ta, db, var_p, d2, a2, v2, c2)
        hit = (hit, d2_hit, t_o[row_pos[hit]])
    return got, hit, a2, v2, c2


def test_fused_association_on_a_real_run(monkeypatch):
    orig = fleet_mod.FleetTracker._update
    n_checked = [0]

    def checked(self, rows, rpos, all_due, row_pos, owners, t_o, z, var, rad, occ, idx, d_pos, m_q, dets, points,
                claimed, assigned, var_row, labels=None):
        ref = None
        if z.shape[0]:
            ref = _reference(self, rows, rpos, row_pos, owners, t_o, z, var, rad, occ, m_q, claimed, assigned,
                             var_row)
            arrays = self.bank.prediction_arrays()
            n_q, start, pairs, var_p, *_ = predicted_pairs(rows, rpos, owners.size, m_q, self.cols.radius, var, rad,
                                                           occ, *arrays, t_o, row_pos)
            full = predicted_pairs(rows, rpos, owners.size, m_q, self.cols.radius, var, rad, occ, *arrays, t_o, row_pos)
            blocks, *packed, arcs = predicted_pairs_packed(rows, rpos, owners.size, m_q, self.cols.radius, var, rad,
                                                           occ, *arrays, t_o, row_pos)  # (what the step calls)
            for a, b in zip((blocks[:owners.size], blocks[owners.size:], *packed, *arcs), full):
                _same(a, b)
            g = ref[0]
            _same(n_q, g[0])
            _same(start, g[5])
            for r, k in ((Q, 2), (I, 3), (J, 4), (GI, 6), (DB, 7), (TA, 8)):
                _same(pairs[r], g[k])
            _same(var_p, g[9])
        seen = []  # (the hit rows, their d² and times: to the detector, or — no hard block — its end after the
        # association's call made the detection, their d² in the association's buffers)
        man = self.manoeuvres
        det, added = man.detect, man.noise_added
        man.detect = lambda hit, d2, gate, t, bank: (seen.append((hit, d2, t)), det(hit, d2, gate, t, bank))
        man.noise_added = lambda hit, t, bank, *rest: (seen.append((hit, self._assoc.vals[:hit.size], t)),
                                                       added(hit, t, bank, *rest))
        try:
            orig(self, rows, rpos, all_due, row_pos, owners, t_o, z, var, rad, occ, idx, d_pos, m_q, dets, points,
                 claimed, assigned, var_row, labels)
        finally:
            del man.detect, man.noise_added
        if ref is not None:
            _, hit, a2, v2, c2 = ref
            _same(assigned, a2)
            _same(var_row, v2)
            _same(claimed, c2)
            if hit is None:
                assert not seen
            else:
                for x, y in zip(seen[0], hit):
                    _same(x, y)
                n_checked[0] += 1

    monkeypatch.setattr(fleet_mod.FleetTracker, "_update", checked)
    sc = mjasc.load_scenario(_ROOT / "tasks" / "thesis_6_4_crossing.toml").with_overrides(duration_s=20.0)
    sc = replace(sc, outputs=replace(sc.outputs, recording=False, video=False))
    Runner(sc, out_dir=None).run()
    assert n_checked[0] > 50


def _assignment_problem(seed):
    """A random association problem: vessels' blocks of tracks × detections, their pairs, d², log det,
    variances, per-vessel times and the rows' vessel positions (the inputs of assign_pairs)."""
    rng = np.random.default_rng(seed)
    p = int(rng.integers(1, 4))
    n_q = rng.integers(0, 5, size=p).astype(np.int64)
    m_q = rng.integers(0, 5, size=p).astype(np.int64)
    q, i, j, start, gi, db = block_pairs_flat(n_q, m_q)
    n = int(n_q.sum()) + 3
    M = int(m_q.sum())
    ta = rng.permutation(n)[:n_q.sum()][gi] if gi.size else gi.copy()
    pairs = np.stack([q, i, j, gi, db, ta]).astype(np.int64)
    d2 = rng.random(gi.size) * 20.0
    log_det = np.log(rng.random(gi.size) + 0.1)
    var_p = rng.random(gi.size)
    t_o = rng.random(p) + 10.0
    row_pos = rng.integers(0, p, size=n).astype(np.int64)
    return n_q, m_q, q, i, j, start, db, ta, pairs, n, M, d2, log_det, var_p, t_o, row_pos


@pytest.mark.parametrize("seed", range(30))
def test_assign_pairs_random(seed):
    n_q, m_q, q, i, j, start, db, ta, pairs, n, M, d2, log_det, var_p, t_o, row_pos = _assignment_problem(seed)
    gate = 9.21
    a1, v1, c1 = np.full(n, -1, dtype=np.int64), np.full(n, 0.25), np.zeros(M, dtype=bool)
    a2, v2, c2 = a1.copy(), v1.copy(), c1.copy()
    inside, cost, hard, hit, d2g, t_hit = assign_pairs(d2, log_det, gate, pairs, start, m_q, var_p, a1, v1, c1, t_o,
                                                       row_pos)
    inside_w, cost_w = d2 <= gate, d2 + log_det
    _same(inside, inside_w)
    _same(cost, cost_w)
    easy, hard_w = admissible_pairs(inside_w, q, i, j, start, m_q)
    _same(hard, hard_w)
    if hard.size:
        assert hit.size == 0 and (a1 == -1).all() and not c1.any()
        return
    hit_w, d2_w = apply_assignment(gnn_assign_blocks(inside_w, cost_w, q, i, j, start, n_q, m_q), inside_w, ta, db,
                                   var_p, d2, a2, v2, c2)
    for x, y in ((hit, hit_w), (d2g, d2_w), (t_hit, t_o[row_pos[hit_w]]), (a1, a2), (v1, v2), (c1, c2)):
        _same(x, y)


@pytest.mark.parametrize("seed", range(40))
def test_team_plan_and_assign(seed):
    """team_plan and team_assign against the calls of TeamMatcher.match before them (team_pairs,
    team_distances, gnn_assign_blocks, matched_rows), on random problems (some with a vessel's track
    or broadcast having two candidates)."""
    from mjasc.perception.tracking.team_kernels import matched_rows, team_assign, team_distances, team_pairs, team_plan

    rng = np.random.default_rng(seed)
    n_owners = int(rng.integers(1, 4))
    k = int(rng.integers(0, 10))
    owner = rng.integers(0, n_owners, size=k).astype(np.int64)
    confirmed = rng.random(k) < 0.7
    states = np.column_stack([rng.uniform(-10, 10, (k, 2)), rng.uniform(-np.pi, np.pi, k), rng.uniform(0, 2, k)])
    B = int(rng.integers(0, 6))
    b_owner = np.sort(rng.integers(0, n_owners, size=B)).astype(np.int64)
    t_b = rng.random(B) * 2
    p_b = rng.uniform(-10, 10, (B, 2))
    t_s = rng.random(n_owners) * 2 + 1.0
    want = team_pairs(confirmed, owner, t_s, b_owner, t_b, 2.0, n_owners, states)
    c, bsel, blocks, pq, start, x = team_plan(confirmed, owner, t_s, b_owner, t_b, 2.0, n_owners, states)
    wc, wbsel, n_a, n_b, a_start, b_start, q, i, j, wstart, wx = want
    for a, b in ((c, wc), (bsel, wbsel), (blocks[0], n_a), (blocks[1], n_b), (blocks[2], a_start), (blocks[3], b_start),
                 (pq[0], q), (pq[1], i), (pq[2], j), (start, wstart), (x, wx)):
        _same(a, b)
    if c.size == 0 or bsel.size == 0:
        return
    gate = 8.0
    th = x[:, 2]
    dist, inside, n_in, hard, ta, tb = team_assign(pq, blocks, start, bsel, c, x, np.cos(th), np.sin(th), t_s, t_b,
                                                   p_b, (2.0 * gate) ** 2, gate)
    d_w, in_w, n_w = team_distances(q, i, j, a_start, b_start, bsel, x, np.cos(th), np.sin(th), t_s, t_b, p_b,
                                    (2.0 * gate) ** 2, gate)
    _same(dist, d_w)
    _same(inside, in_w)
    assert n_in == n_w
    if not n_w:
        return
    ta_w, tb_w = matched_rows(gnn_assign_blocks(in_w, d_w, q, i, j, wstart, n_a, n_b), q, i, j, a_start, b_start, c,
                              bsel)
    if hard.size:
        assert ta.size == 0 and tb.size == 0
        ta, tb = matched_rows(gnn_assign_blocks(inside, dist, q, i, j, start, n_a, n_b), q, i, j, a_start, b_start, c,
                              bsel)
    _same(ta, ta_w)
    _same(tb, tb_w)


def test_drops_all_is_drops_of_every_row_on_a_real_run(monkeypatch):
    """TrackManagement.drops_all (the rows' values gathered in its kernel) against drops with the
    values gathered by numpy (the tracker's step before it), at every step of a run."""
    from mjasc.perception.tracking.fleet_rows import FleetRows
    from mjasc.perception.tracking.management import TrackManagement

    orig = TrackManagement.drops_all
    step_form = TrackManagement.drops_every  # (what the step calls: tests/test_tracking_drops_every.py)
    n_checked = [0]

    def checked(self, group, pos_of, t_o, states, covariances, origins_m, max_range_m):
        got = orig(self, group, pos_of, t_o, states, covariances, origins_m, max_range_m)
        rpos = pos_of[group]
        want = self.drops(slice(None), group, t_o[rpos], states[:, :2], covariances[:, :2, :2], origins_m[rpos],
                          max_range_m[group])
        _same(got[0], want[0])
        assert got[1] == want[1] and got[2] == want[2]
        n_checked[0] += 1
        return step_form(self, group, pos_of, t_o, states, covariances, origins_m, max_range_m)

    monkeypatch.setattr(TrackManagement, "drops_every", checked)
    monkeypatch.setattr(FleetRows, "_drops_in_one_call", False)  # (every step's drops through drops_every)
    sc = mjasc.load_scenario(_ROOT / "tasks" / "demo.toml").with_overrides(duration_s=30.0)
    sc = replace(sc, outputs=replace(sc.outputs, recording=False, video=False))
    Runner(sc, out_dir=None).run()
    assert n_checked[0] > 100


def test_cycled_scan_on_a_real_run(monkeypatch):
    """cycled_scan against cycled_rows, TrackManagement.after_update's scan_rows, the radii of the rows with
    returns and last_assignments (the tracker's calls before it), cycled_scan_packed against it, and
    cycled_scan_grown (what the step calls) against cycled_scan_packed and the outlines' grow_plan of its rows
    with returns — on copies of the arrays they write, at every step of a run."""
    from mjasc.perception.tracking.management import scan_rows
    from mjasc.perception.tracking.outlines import grow_plan
    from mjasc.perception.tracking.step_gathers import cycled_rows
    from mjasc.perception.tracking.step_kernels import last_assignments

    from mjasc.perception.tracking.step_fusions import cycled_scan, cycled_scan_packed

    fused = cycled_scan
    packed = cycled_scan_packed
    grown = fleet_mod.cycled_scan_grown  # (what the step calls)
    n_checked, n_grown = [0], [0]

    def checked(rows, row_pos, t_o, used, meas, x, with_pts, counts, owners, col, assigned, rad, occ, *rest_all):
        rest, (anchor, reset_m, fast, slow) = rest_all[:18], rest_all[18:]
        cols_w = [a.copy() for a in rest[:8]]  # hist, scans, n_upd, last, radius, confirmed, static, born
        consts = rest[8:15]
        local_id, idx, p = rest[15:]
        counts_w = counts.copy()
        t_rows, speeds, u_rows, a_rows, hit, orows, hit_o, speeds_o, pos_o = cycled_rows(
            rows, row_pos, t_o, used, meas, x, with_pts, counts_w, owners, col, assigned)
        new_conf = np.empty(rows.size, dtype=bool)
        scan_rows(rows, t_rows, u_rows, a_rows, rad, occ, speeds, *cols_w, *consts, new_conf)
        want = (new_conf, orows, hit_o, speeds_o, pos_o, cols_w[4][orows],
                *last_assignments(rows, hit, row_pos, local_id, idx, assigned, p))
        cols_f, counts_f = [a.copy() for a in rest[:8]], counts.copy()
        got = fused(rows, row_pos, t_o, used, meas, x, with_pts, counts_f, owners, col, assigned, rad, occ, *cols_f,
                    *rest[8:])
        assert got[1] == np.count_nonzero(new_conf)
        for a, b in zip(got[:1] + got[2:], want):
            _same(a, b)
        for a, b in zip(cols_f, cols_w):
            _same(a, b)
        _same(counts_f, counts_w)
        cols_p, counts_p = [a.copy() for a in rest[:8]], counts.copy()
        out = packed(rows, row_pos, t_o, used, meas, x, with_pts, counts_p, owners, col, assigned, rad, occ, *cols_p,
                     *rest[8:])
        ints, floats, flags, pos_o, n_conf, g, m = out
        k = rows.size
        assert n_conf == got[1] and g == got[2].size and m == got[7].size
        for a, b in zip((flags[:k], ints[:g], flags[k:], floats[0], pos_o, floats[1], ints[g:g + m],
                         ints[g + m:g + 2 * m], ints[g + 2 * m:]), got[:1] + got[2:]):
            _same(a, b)
        # the outlines' plan as TrackOutlines.grow made it from cycled_scan_packed's rows with returns
        anchor_w = anchor.copy()
        if g:
            gi, geo_w, r_w, g2_w = grow_plan(ints[:g], floats[0], pos_o, anchor_w, reset_m, fast, slow, flags[k:],
                                             floats[1])
        else:
            gi, geo_w, r_w, g2_w = ints[:0], np.zeros((0, 3)), 0, 0
        res = grown(rows, row_pos, t_o, used, meas, x, with_pts, counts, owners, col, assigned, rad, occ, *rest_all)
        ints_g, conf_g, geo_g, n_conf_g, g_g, m_g, r_g, g2_g = res
        assert (n_conf_g, g_g, m_g, r_g, g2_g) == (n_conf, g, m, r_w, g2_w)
        _same(conf_g, flags[:k])
        _same(ints_g, np.concatenate([ints, gi]))
        _same(geo_g, geo_w)
        _same(anchor, anchor_w)
        for a, b in zip(rest[:8], cols_w):
            _same(a, b)
        _same(counts, counts_w)
        n_checked[0] += 1
        n_grown[0] += g2_g > 0
        return res

    monkeypatch.setattr(fleet_mod, "cycled_scan_grown", checked)
    sc = mjasc.load_scenario(_ROOT / "tasks" / "demo.toml").with_overrides(duration_s=30.0)
    sc = replace(sc, outputs=replace(sc.outputs, recording=False, video=False))
    Runner(sc, out_dir=None).run()
    assert n_checked[0] > 100 and n_grown[0] > 10


@pytest.mark.parametrize("seed", range(30))
def test_assign_pairs_packed_random(seed):
    """assign_pairs_packed holds assign_pairs' arrays (the hard blocks, the hit rows and their d², times)."""
    from mjasc.perception.tracking.step_fusions import assign_pairs_packed

    n_q, m_q, q, i, j, start, db, ta, pairs, n, M, d2, log_det, var_p, t_o, row_pos = _assignment_problem(seed)
    outs = [(np.full(n, -1, dtype=np.int64), np.full(n, 0.25), np.zeros(M, dtype=bool)) for _ in range(2)]
    want = assign_pairs(d2, log_det, 9.21, pairs, start, m_q, var_p, *outs[0], t_o, row_pos)
    inside, cost, rows, vals, h = assign_pairs_packed(d2, log_det, 9.21, pairs, start, m_q, var_p, *outs[1], t_o,
                                                      row_pos)
    for a, b in zip((inside, cost, rows[:h], rows[h:], vals[0], vals[1]), want):
        _same(a, b)
    for a, b in zip(*outs):
        _same(a, b)
