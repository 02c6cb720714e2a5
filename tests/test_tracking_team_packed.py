"""TeamMatcher.match's packed kernels (team_plan_packed, team_assign_packed: the states' θ wrapped in the
gathered rows instead of the bank's ``states`` copy, and the arrays packed by type) against team_plan on
the wrapped states and team_assign, bit for bit, on every match of real runs with team mates (the demo,
the crossing)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import mjasc
from mjasc.perception.imm.row_fields import wrapped_states
from mjasc.perception.tracking import team as team_mod
from mjasc.perception.tracking import team_kernels
from mjasc.runs.runner import Runner

_ROOT = __import__("pathlib").Path(__file__).resolve().parents[1]


def _same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


@pytest.mark.parametrize("name, duration", [("demo", 40.0), ("thesis_6_4_crossing", 40.0)])
def test_packed_team_kernels_on_a_real_run(monkeypatch, name, duration):
    plan, assign = team_kernels.team_plan_packed, team_kernels.team_assign_packed
    seen = {"plans": 0, "assigned": 0}

    def checked_plan(confirmed, owner, t_s, b_owner, t_b, max_age, n_owners, states, wrap_theta):
        want = team_kernels.team_plan(confirmed, owner, t_s, b_owner, t_b, max_age, n_owners,
                                  wrapped_states(states) if wrap_theta else states)
        got = plan(confirmed, owner, t_s, b_owner, t_b, max_age, n_owners, states, wrap_theta)
        ints, blocks, pq, x, A, B = got
        c, bsel, wblocks, wpq, start, wx = want
        assert A == c.size and B == bsel.size
        for a, b in ((ints[:A], c), (ints[A:A + B], bsel), (ints[A + B:], start), (blocks, wblocks), (pq, wpq),
                     (x, wx)):
            _same(a, b)
        seen["plans"] += 1
        return got

    def checked_assign(*args):
        dist, inside, n_in, hard, ta, tb = team_kernels.team_assign(*args)
        got = assign(*args)
        hits, h = got[3], got[4]
        _same(got[0], dist)
        _same(got[1], inside)
        assert got[2] == n_in and h == hard.size
        m = ta.size
        for a, b in ((hits[:h], hard), (hits[h:h + m], ta), (hits[h + m:], tb)):
            _same(a, b)
        seen["assigned"] += 1
        return got

    match_into = team_mod.team_match_into

    def checked_match(*args):  # (what match calls: the packed kernels' arrays written into its buffers, then
        got = match_into(*args)  # assigned: tests/test_tracking_team_buffers.py)
        confirmed, owner, t_s, b_owner, t_b, p_b, max_age, no, states, wrap, far, gate, ints, blocks, pq, x = args[:16]
        A, B, npairs, ok = got[:4]
        checked_plan(confirmed, owner, t_s, b_owner, t_b, max_age, no, states, wrap)
        if ok and A and B:
            th = x[:A, 2]
            checked_assign(pq[:3 * npairs].reshape(3, npairs), blocks[:4 * no].reshape(4, no),
                           ints[A + B:A + B + no + 1], ints[A:A + B], ints[:A], x[:A], np.cos(th), np.sin(th), t_s,
                           t_b, p_b, far, gate)
        return got

    monkeypatch.setattr(team_mod, "team_match_into", checked_match)
    sc = mjasc.load_scenario(_ROOT / "tasks" / f"{name}.toml").with_overrides(duration_s=duration)
    sc = replace(sc, outputs=replace(sc.outputs, recording=False, video=False))
    Runner(sc, out_dir=None).run()
    assert seen["plans"] > 50 and seen["assigned"] > 20


def test_set_positions_in_place_equals_rebuilt():
    """TeamMatcher.set_positions writing the same mates' new values into its flat arrays (the owner's arrays
    views of them) against a matcher that rebuilds them every time, over owners whose mates change."""
    from mjasc.perception.tracking.config import TrackingConfig
    from mjasc.perception.tracking.team import TeamMatcher

    rng = np.random.default_rng(5)
    a, b = TeamMatcher(TrackingConfig()), TeamMatcher(TrackingConfig())
    teams = {0: ["b", "c"], 1: ["a", "c"], 2: ["a", "b"]}
    for step in range(60):
        if step == 20:
            teams[1] = ["c"]  # a mate lost: that owner's set changes
        if step == 40:
            teams[1] = ["a", "c", "d"]
        for o, names in teams.items():
            pos = {n: (float(step) * 0.1 - rng.random(), rng.normal(size=2) * 50.0) for n in names}
            a.set_positions(o, pos)
            b.set_positions(o, pos)
            b._flat = None
            if step % 3 == 0:
                fa, fb = a._arrays(), b._arrays()
                _same(fa[0], fb[0])
                assert fa[1] == fb[1]
                _same(fa[2], fb[2])
                _same(fa[3], fb[3])
