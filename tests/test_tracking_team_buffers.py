"""TeamMatcher's compiled calls written into its buffers (team_plan_into, team_assign_into) against the
returning forms (team_plan_packed, team_assign_packed), bit for bit, at every match of real runs; and the
buffers' growth."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import mjasc
from mjasc.perception.tracking import team as team_mod
from mjasc.perception.tracking.team import TeamBuffers, grown_team, team_assign_packed, team_plan_packed
from mjasc.runs.runner import Runner

_ROOT = __import__("pathlib").Path(__file__).resolve().parents[1]


def _same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


@pytest.mark.parametrize("name, duration", [("demo", 30.0), ("thesis_6_4_crossing", 20.0)])
def test_team_buffers_on_a_real_run(monkeypatch, name, duration):
    seen = {"plan": 0, "assign": 0, "matched": 0}
    plan_into, assign_into = team_mod.team_plan_into, team_mod.team_assign_into

    def plan(confirmed, owner, t_s, b_owner, t_b, max_age, no, states, wrap, ints, blocks, pq, x):
        got = plan_into(confirmed, owner, t_s, b_owner, t_b, max_age, no, states, wrap, ints, blocks, pq, x)
        A, B, npairs, ok = got
        want = team_plan_packed(confirmed, owner, t_s, b_owner, t_b, max_age, no, states, wrap)
        assert (A, B, npairs) == (want[4], want[5], want[2].shape[1])
        if ok:
            _same(ints[:want[0].size], want[0])
            _same(blocks[:4 * no].reshape(4, no), want[1])
            _same(pq[:3 * npairs].reshape(3, npairs), want[2])
            _same(x[:A], want[3])
            seen["plan"] += 1
        return got

    def assign(pq, blocks, start, bsel, c, x, cos_th, sin_th, t_s, t_b, p_b, far, gate, dist, inside, hits):
        got = assign_into(pq, blocks, start, bsel, c, x, cos_th, sin_th, t_s, t_b, p_b, far, gate, dist, inside, hits)
        n_in, h, m = got
        want = team_assign_packed(pq, blocks, start, bsel, c, x, cos_th, sin_th, t_s, t_b, p_b, far, gate)
        n = want[0].size
        assert n_in == want[2] and h == want[4] and h + 2 * m == want[3].size
        for a, b in ((dist[:n], want[0]), (inside[:n], want[1]), (hits[:h + 2 * m], want[3])):
            _same(a, b)
        seen["assign"] += 1
        seen["matched"] += m > 0
        return got

    monkeypatch.setattr(team_mod, "team_plan_into", plan)
    monkeypatch.setattr(team_mod, "team_assign_into", assign)
    sc = mjasc.load_scenario(_ROOT / "tasks" / f"{name}.toml").with_overrides(duration_s=duration)
    sc = replace(sc, outputs=replace(sc.outputs, recording=False, video=False))
    Runner(sc, out_dir=None).run()
    assert seen["plan"] > 50 and seen["assign"] > 20 and seen["matched"] > 10


def test_team_buffers_grow_and_keep_their_room():
    b = grown_team(None, 5, 3, 15, 4)
    assert b.fits(5, 3, 15, 4) and b.pq.size == 3 * b.n_pairs and b.blocks.size == 4 * b.n_owners
    assert grown_team(b, 5, 3, 15, 4) is b
    c = grown_team(b, 1, 1, b.n_pairs + 1, 2)
    assert c is not b and c.fits(b.n_a, b.n_b, b.n_pairs + 1, b.n_owners)
    assert TeamBuffers().fits(0, 0, 0, 0) and not TeamBuffers().fits(0, 0, 0, 1)
