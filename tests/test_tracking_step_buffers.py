"""The association written into a fleet tracker's buffers in one call (mjasc.perception.tracking.step_buffers:
gated_assignment_into) against the returning fused kernels (step_fusions, pair_kernels) with numpy's cos,
sin, J P Jᵀ and log between them, bit for bit, at every step of real runs (the tracker's call checked in
place, the in-place arrays on copies); J P Jᵀ against numpy's on random stacks; and the buffers' growth."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import mjasc
from mjasc.perception.tracking import fleet as fleet_mod
from mjasc.perception.tracking.pair_kernels import position_jacobians
from mjasc.core.small_products import sandwich_into
from mjasc.perception.tracking.manoeuvre import manoeuvre_noise
from mjasc.perception.tracking.step_buffers import AssociationBuffers, gated_assignment_into, grown
from mjasc.perception.tracking.step_fusions import assign_pairs_packed, pair_gates, predicted_pairs_packed
from mjasc.runs.runner import Runner

_ROOT = __import__("pathlib").Path(__file__).resolve().parents[1]


def _same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def _numpy_form(args, p, z, gate, assigned, var_row, claimed):
    """The association as the tracker had it before :func:`gated_assignment_into`: the returning kernels
    with numpy's cos, sin, ``J P Jᵀ`` and log between them (assigned, var_row, claimed changed in place)."""
    blocks, pairs, var_p, xs, P, arcs = predicted_pairs_packed(*args)
    if var_p.size == 0:
        return blocks, pairs, var_p, xs, P, arcs, None
    dt, th, dv = arcs
    zhat, Jac = position_jacobians(xs, dt, dv, np.cos(th), np.sin(th))
    S = Jac @ P @ Jac.transpose(0, 2, 1)
    still = xs[:, 3] == 0.0  # no course: var(V)·dt² on y too
    S[still, 1, 1] += dt[still] ** 2 * P[still, 3, 3]
    d2, det = pair_gates(pairs, zhat, S, z, var_p)
    log_det = np.log(det)
    packed = assign_pairs_packed(d2, log_det, gate, pairs, blocks[p:], args[3], var_p, assigned,
                                 var_row, claimed, args[14], args[15])
    return blocks, pairs, var_p, xs, P, arcs, (zhat, Jac, S, d2, det, log_det, packed)


@pytest.mark.parametrize("name, duration", [("thesis_6_4_crossing", 20.0), ("demo", 20.0)])
def test_gated_assignment_on_a_real_run(monkeypatch, name, duration):
    """The one-call association writes, bit for bit, what the numpy form computes, at every step."""
    seen = {"calls": 0, "pairs": 0, "hard": 0}
    into = gated_assignment_into

    def checked(*args):
        head, (z, gate, assigned, var_row, claimed), bufs = args[:16], args[16:21], args[21:]
        a2, v2, c2 = assigned.copy(), var_row.copy(), claimed.copy()
        got = into(*args)
        npairs, k, ok, h, m = got
        if not ok:
            return got
        p = head[2]
        blocks, pairs, var_p, xs, P, arcs, rest = _numpy_form(head, p, z, gate, a2, v2, c2)
        assert (npairs, k) == (var_p.size, xs.shape[0])
        (b_blocks, b_pairs, b_var_p, b_xs, b_P, b_arcs, b_cs, b_zhat, b_J, b_S, b_d2, b_det, b_log_det, b_inside,
         b_cost, b_rows, b_vals) = bufs
        _same(b_blocks[:2 * p + 1], blocks)
        _same(b_pairs[:6 * npairs].reshape(6, npairs), pairs)
        _same(b_var_p[:npairs], var_p)
        _same(b_xs[:k], xs)
        _same(b_P[:k], P)
        _same(b_arcs[:3 * k].reshape(3, k), arcs)
        seen["calls"] += 1
        if rest is None:
            assert h == m == 0
            return got
        zhat, Jac, S, d2, det, log_det, packed = rest
        for a, b in ((b_cs[:k], np.cos(arcs[1])), (b_cs[k:2 * k], np.sin(arcs[1])), (b_zhat[:k], zhat),
                     (b_J[:k], Jac), (b_S[:k], S), (b_d2[:npairs], d2), (b_det[:npairs], det),
                     (b_log_det[:npairs], log_det), (b_inside[:npairs], packed[0]), (b_cost[:npairs], packed[1]),
                     (b_rows[:h + m], packed[2]), (b_vals[:2 * m].reshape(2, m), packed[3]), (assigned, a2),
                     (var_row, v2), (claimed, c2)):
            _same(a, b)
        assert h == packed[4]
        seen["pairs"] += 1
        seen["hard"] += h > 0
        return got

    def checked_manoeuvres(*args):  # (what the tracker calls: the association, then the hit rows' manoeuvres —
        got = checked(*args[:38])  # gated_manoeuvres_into's two calls: tests/test_tracking_manoeuvre_noise.py)
        npairs, k, ok, h, m = got
        detect, a, start, end, nis, man, P_bank, qh, qv, warm = args[38:]
        if not detect or not ok or npairs == 0 or h > 0:
            return (*got, -1, 0)
        out_rows, vals = args[36], args[37]
        return (*got, *manoeuvre_noise(out_rows[:m], vals[:m], args[17], a, start, end, nis, man, vals[m:2 * m],
                                       args[9], P_bank, args[12], qh, qv, warm))

    monkeypatch.setattr(fleet_mod, "gated_manoeuvres_into", checked_manoeuvres)
    sc = mjasc.load_scenario(_ROOT / "tasks" / f"{name}.toml").with_overrides(duration_s=duration)
    sc = replace(sc, outputs=replace(sc.outputs, recording=False, video=False))
    Runner(sc, out_dir=None).run()
    assert seen["calls"] > 50 and seen["pairs"] > 50


def test_sandwich_of_jacobians_is_numpys_product_on_random_stacks():
    """J P Jᵀ summed as OpenBLAS's dgemm sums it: numpy's stacked products' bits on random stacks of
    every scale (and covariance-shaped P), zeros and ones of the Jacobians' shape included."""
    rng = np.random.default_rng(9)
    for it in range(400):
        k = int(rng.integers(1, 30))
        J = rng.normal(size=(k, 2, 4)) * 10.0 ** rng.uniform(-4, 4, size=(k, 2, 4))
        if it % 2:
            J[:, 0, 0] = J[:, 1, 1] = 1.0
            J[:, 0, 1] = J[:, 1, 0] = 0.0
        A = rng.normal(size=(k, 4, 4)) * 10.0 ** rng.uniform(-3, 3, size=(k, 1, 1))
        P = A @ A.transpose(0, 2, 1) if it % 3 else A
        if it % 4 == 0:  # (exact zeros of both signs: a sum of −0 products is +0, as OpenBLAS's)
            J = np.where(rng.random(J.shape) < 0.3, -0.0, np.where(rng.random(J.shape) < 0.3, 0.0, J))
            P = np.where(rng.random(P.shape) < 0.3, -0.0, np.where(rng.random(P.shape) < 0.3, 0.0, P))
        S = np.empty((k + 2, 2, 2))
        sandwich_into(J, P, k, S)
        _same(S[:k], J @ P @ J.transpose(0, 2, 1))


def test_buffers_grow_and_keep_their_room():
    b = grown(None, 10, 4, 2)
    assert b.fits(10, 4, 2) and b.pairs.size == 6 * b.n_pairs and b.arcs.size == 3 * b.n_rows
    assert grown(b, 10, 4, 2) is b
    c = grown(b, b.n_pairs + 1, 1, 1)
    assert c is not b and c.fits(b.n_pairs + 1, b.n_rows, b.p)
    assert AssociationBuffers().fits(0, 0, 0) and not AssociationBuffers().fits(1, 0, 0)
    assert len(c.association) == 17 and c.association[0] is c.blocks and c.association[-1] is c.vals
