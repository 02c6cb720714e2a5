"""The association written into a fleet tracker's buffers (mjasc.perception.tracking.step_buffers)
against the returning fused kernels (step_fusions, pair_kernels), bit for bit, at every step of real
runs (the tracker's calls checked in place: each buffer kernel against its returning form on the same
inputs, the in-place arrays on copies); and the buffers' growth."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import mjasc
from mjasc.perception.tracking import fleet as fleet_mod
from mjasc.perception.tracking.pair_kernels import position_jacobians
from mjasc.perception.tracking.step_buffers import AssociationBuffers, grown
from mjasc.perception.tracking.step_fusions import assign_pairs_packed, pair_gates, predicted_pairs_packed
from mjasc.runs.runner import Runner

_ROOT = __import__("pathlib").Path(__file__).resolve().parents[1]


def _same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


@pytest.mark.parametrize("name, duration", [("thesis_6_4_crossing", 20.0), ("demo", 20.0)])
def test_association_buffers_on_a_real_run(monkeypatch, name, duration):
    seen = {"pp": 0, "pj": 0, "pg": 0, "ap": 0, "hard": 0}
    pp_into, pj_into = fleet_mod.predicted_pairs_into, fleet_mod.position_jacobians_into
    pg_into, ap_into = fleet_mod.pair_gates_into, fleet_mod.assign_pairs_into

    def pp(*args):
        got = pp_into(*args)
        npairs, k, ok = got
        want = predicted_pairs_packed(*args[:16])
        assert (npairs, k) == (want[2].size, want[3].shape[0])
        if ok:
            blocks, pairs, var_p, xs, P, arcs = args[16:]
            p = args[2]
            _same(blocks[:2 * p + 1], want[0])
            _same(pairs[:6 * npairs].reshape(6, npairs), want[1])
            _same(var_p[:npairs], want[2])
            _same(xs[:k], want[3])
            _same(P[:k], want[4])
            _same(arcs[:3 * k].reshape(3, k), want[5])
            seen["pp"] += 1
        return got

    def pj(xs, dt, dv, c, s, zhat, J):
        pj_into(xs, dt, dv, c, s, zhat, J)
        k = xs.shape[0]
        for a, b in zip((zhat[:k], J[:k]), position_jacobians(xs, dt, dv, c, s)):
            _same(a, b)
        seen["pj"] += 1

    def pg(pairs, zhat, S, z, var_p, d2, det):
        pg_into(pairs, zhat, S, z, var_p, d2, det)
        n = var_p.size
        for a, b in zip((d2[:n], det[:n]), pair_gates(pairs, zhat, S, z, var_p)):
            _same(a, b)
        seen["pg"] += 1

    def ap(d2, log_det, gate, pairs, start, n_b, var_p, assigned, var_row, claimed, t_o, row_pos, inside, cost, rows,
           vals):
        a2, v2, c2 = assigned.copy(), var_row.copy(), claimed.copy()
        want = assign_pairs_packed(d2, log_det, gate, pairs, start, n_b, var_p, a2, v2, c2, t_o, row_pos)
        h, m = ap_into(d2, log_det, gate, pairs, start, n_b, var_p, assigned, var_row, claimed, t_o, row_pos, inside,
                       cost, rows, vals)
        n = d2.size
        assert h == want[4] and h + m == want[2].size
        for a, b in ((inside[:n], want[0]), (cost[:n], want[1]), (rows[:h + m], want[2]),
                     (vals[:2 * m].reshape(2, m), want[3]), (assigned, a2), (var_row, v2), (claimed, c2)):
            _same(a, b)
        seen["ap"] += 1
        seen["hard"] += h > 0
        return h, m

    for nm, f in (("predicted_pairs_into", pp), ("position_jacobians_into", pj), ("pair_gates_into", pg),
                  ("assign_pairs_into", ap)):
        monkeypatch.setattr(fleet_mod, nm, f)
    sc = mjasc.load_scenario(_ROOT / "tasks" / f"{name}.toml").with_overrides(duration_s=duration)
    sc = replace(sc, outputs=replace(sc.outputs, recording=False, video=False))
    Runner(sc, out_dir=None).run()
    assert seen["pp"] > 50 and seen["pj"] > 50 and seen["pg"] > 50 and seen["ap"] > 50


def test_buffers_grow_and_keep_their_room():
    b = grown(None, 10, 4, 2)
    assert b.fits(10, 4, 2) and b.pairs.size == 6 * b.n_pairs and b.arcs.size == 3 * b.n_rows
    assert grown(b, 10, 4, 2) is b
    c = grown(b, b.n_pairs + 1, 1, 1)
    assert c is not b and c.fits(b.n_pairs + 1, b.n_rows, b.p)
    assert AssociationBuffers().fits(0, 0, 0) and not AssociationBuffers().fits(1, 0, 0)
