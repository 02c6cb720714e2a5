"""TeamMatcher's compiled call (team_match_into) against the calls it replaced — team_plan_into, numpy's cos
and sin, team_assign_into — and those calls written into buffers against the returning forms
(team_plan_packed, team_assign_packed), bit for bit, at every match of real runs; and the buffers' growth."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

import mjasc
from mjasc.perception.tracking import team as team_mod
from mjasc.perception.tracking.team_kernels import (TeamBuffers, grown_team, team_assign_into, team_assign_packed,
                                                    team_plan_into, team_plan_packed)
from mjasc.runs.runner import Runner

_ROOT = __import__("pathlib").Path(__file__).resolve().parents[1]


def _same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def separate_match(confirmed, owner, t_s, b_owner, t_b, p_b, max_age, no, states, wrap, far, gate, ints, blocks, pq,
                   x, dist, inside, hits, seen=None):
    """The calls team_match_into replaced, as TeamMatcher.match made them (the reference), each ``_into`` call
    checked against its returning form."""
    A, B, npairs, ok = team_plan_into(confirmed, owner, t_s, b_owner, t_b, max_age, no, states, wrap, ints, blocks, pq,
                                      x)
    want = team_plan_packed(confirmed, owner, t_s, b_owner, t_b, max_age, no, states, wrap)
    assert (A, B, npairs) == (want[4], want[5], want[2].shape[1])
    if ok:
        _same(ints[:want[0].size], want[0])
        _same(blocks[:4 * no].reshape(4, no), want[1])
        _same(pq[:3 * npairs].reshape(3, npairs), want[2])
        _same(x[:A], want[3])
    if not ok or A == 0 or B == 0:
        return A, B, npairs, ok, 0, 0, 0
    th = x[:A, 2]
    cos_th, sin_th = np.cos(th), np.sin(th)
    # (the fused kernel's math.cos and math.sin give numpy's bits here: docs/architecture.md, "Compiled kernels")
    _same(cos_th, [math.cos(v) for v in th.tolist()])
    _same(sin_th, [math.sin(v) for v in th.tolist()])
    args = (pq[:3 * npairs].reshape(3, npairs), blocks[:4 * no].reshape(4, no), ints[A + B:A + B + no + 1],
            ints[A:A + B], ints[:A], x[:A], cos_th, sin_th, t_s, t_b, p_b, far, gate)
    n_in, h, m = team_assign_into(*args, dist[:npairs], inside[:npairs], hits)
    want = team_assign_packed(*args)
    assert n_in == want[2] and h == want[4] and h + 2 * m == want[3].size
    for a, b in ((dist[:npairs], want[0]), (inside[:npairs], want[1]), (hits[:h + 2 * m], want[3])):
        _same(a, b)
    if seen is not None:
        seen["assign"] += 1
        seen["matched"] += m > 0
    return A, B, npairs, ok, n_in, h, m


@pytest.mark.parametrize("name, duration", [("demo", 30.0), ("thesis_6_4_crossing", 20.0)])
def test_team_match_into_on_a_real_run(monkeypatch, name, duration):
    seen = {"match": 0, "assign": 0, "matched": 0}
    match_into = team_mod.team_match_into

    def match(*args):
        lead, bufs = args[:12], args[12:]
        ref = [b.copy() for b in bufs]
        got = match_into(*args)
        want = separate_match(*lead, *ref, seen=seen)
        assert got == want
        A, B, npairs, ok, n_in, h, m = got
        if ok:
            no = lead[7]
            for a, b, k in zip(bufs, ref, (A + B + no + 1, 4 * no, 3 * npairs, A, npairs, npairs, h + 2 * m)):
                _same(a[:k], b[:k])
            seen["match"] += 1
        return got

    monkeypatch.setattr(team_mod, "team_match_into", match)
    sc = mjasc.load_scenario(_ROOT / "tasks" / f"{name}.toml").with_overrides(duration_s=duration)
    sc = replace(sc, outputs=replace(sc.outputs, recording=False, video=False))
    Runner(sc, out_dir=None).run()
    assert seen["match"] > 50 and seen["assign"] > 20 and seen["matched"] > 10


def test_team_match_into_on_random_inputs():
    rng = np.random.default_rng(11)
    for trial in range(200):
        no, n = int(rng.integers(1, 5)), int(rng.integers(0, 30))
        confirmed, owner = rng.random(n) < 0.7, np.sort(rng.integers(0, no, n))
        states = np.column_stack([rng.normal(0, 80, (n, 2)), rng.normal(0, 20, n), rng.uniform(0, 6, n)])
        per = rng.integers(0, 4, no)
        b_owner = np.repeat(np.arange(no), per)
        B = b_owner.size
        t_s = rng.uniform(9, 10, no)
        t_b = rng.uniform(0, 10, B)  # (some older than max_age: not fresh)
        p_b = (states[rng.integers(0, n, B), :2] if n else np.zeros((B, 2))) + rng.normal(0, 3, (B, 2))
        wrap = bool(rng.random() < 0.5)
        lead = (confirmed, owner, t_s, b_owner, t_b, p_b, 5.0, no, states, wrap, 400.0, 10.0)
        bf = grown_team(None, n, B, n * B, no)
        bufs = (bf.ints, bf.blocks, bf.pq, bf.x, bf.dist, bf.inside, bf.hits)
        ref = [b.copy() for b in bufs]
        got = team_mod.team_match_into(*lead, *bufs)
        assert got == separate_match(*lead, *ref)
        A, B_, npairs, ok, n_in, h, m = got
        for a, b, k in zip(bufs, ref, (A + B_ + no + 1, 4 * no, 3 * npairs, A, npairs, npairs, h + 2 * m)):
            _same(a[:k], b[:k])


def test_team_buffers_grow_and_keep_their_room():
    b = grown_team(None, 5, 3, 15, 4)
    assert b.fits(5, 3, 15, 4) and b.pq.size == 3 * b.n_pairs and b.blocks.size == 4 * b.n_owners
    assert grown_team(b, 5, 3, 15, 4) is b
    c = grown_team(b, 1, 1, b.n_pairs + 1, 2)
    assert c is not b and c.fits(b.n_a, b.n_b, b.n_pairs + 1, b.n_owners)
    assert TeamBuffers().fits(0, 0, 0, 0) and not TeamBuffers().fits(0, 0, 0, 1)
