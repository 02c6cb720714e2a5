"""The compiled kernels of :meth:`mjasc.perception.tracking.team.TeamMatcher.match` (team mates recognised
among a vessel's tracks from their broadcasts): the (track, broadcast) blocks and pairs of every vessel
(:func:`team_blocks`, :func:`team_pairs`, :func:`team_plan`), their distances and easy assignments
(:func:`team_distances`, :func:`team_assign`, :func:`matched_rows`), the same with their arrays packed by type
(:func:`team_plan_packed`, :func:`team_assign_packed`: each array a kernel returns is a Python object made) and
written into the matcher's buffers (:class:`TeamBuffers`, :func:`team_plan_into`, :func:`team_assign_into`),
and the match's one call, :func:`team_match_into`: the plan, the tracks' cos θ and sin θ (``math``'s, the bits of
numpy's ``cos`` and ``sin`` here: docs/architecture.md, "Compiled kernels") and the assignment — what the matcher
called one after the other, with numpy's cosine and sine between them.
tests/test_tracking_team_buffers.py compares it with those calls, bit for bit, on real runs.
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.compiled import kernel
from mjasc.perception.tracking.pair_kernels import block_pairs_loop, broadcast_distances
from mjasc.perception.tracking.step_kernels import admissible_pairs

__all__ = ["team_blocks", "team_pairs", "team_distances", "matched_rows", "team_plan", "team_assign",
           "team_plan_packed", "team_assign_packed", "TeamBuffers", "grown_team", "team_plan_into",
           "team_assign_into", "team_match_into"]

_TWO_PI = 2.0 * math.pi

@kernel
def team_blocks(confirmed, owner, t_s, b_owner, t_b, max_age, n_owners):
    """The (track, broadcast) blocks of :meth:`TeamMatcher.match` in one pass: (c, bsel, n_a, n_b,
    a_start, b_start) — the confirmed tracks (positions in ``confirmed`` (k,)) sorted by their
    vessel ``owner`` (stable), the fresh broadcasts (``t_s[b_owner] − t_b ≤ max_age``; NaN: not
    fresh) in their order (grouped by vessel already), per vessel their counts and first
    positions; c and bsel empty when there is nothing to match. (tests/test_tracking_step_kernels.py
    keeps the numpy form.)"""
    nb = b_owner.size
    fresh = np.empty(nb, dtype=np.int64)
    m = 0
    for b in range(nb):
        if t_s[b_owner[b]] - t_b[b] <= max_age:
            fresh[m] = b
            m += 1
    n_a = np.zeros(n_owners, dtype=np.int64)
    n_b = np.zeros(n_owners, dtype=np.int64)
    a_start = np.zeros(n_owners, dtype=np.int64)
    b_start = np.zeros(n_owners, dtype=np.int64)
    n_c = 0
    for k in range(confirmed.size):
        if confirmed[k]:
            n_c += 1
    if m == 0 or n_c == 0:
        return np.zeros(0, dtype=np.int64), fresh[:0], n_a, n_b, a_start, b_start
    for k in range(confirmed.size):
        if confirmed[k]:
            n_a[owner[k]] += 1
    for a in range(m):
        n_b[b_owner[fresh[a]]] += 1
    for o in range(1, n_owners):
        a_start[o] = a_start[o - 1] + n_a[o - 1]
        b_start[o] = b_start[o - 1] + n_b[o - 1]
    c = np.empty(n_c, dtype=np.int64)
    fill = a_start.copy()
    for k in range(confirmed.size):
        if confirmed[k]:
            o = owner[k]
            c[fill[o]] = k
            fill[o] += 1
    return c, fresh[:m], n_a, n_b, a_start, b_start


@kernel
def team_pairs(confirmed, owner, t_s, b_owner, t_b, max_age, n_owners, states):
    """:func:`team_blocks`, the (track, broadcast) pairs of its blocks
    (:func:`~mjasc.perception.tracking.pair_kernels.block_pairs_loop` of n_a, n_b) and the states
    ``states[c]`` (g, 4) of the confirmed tracks c, in one call: (c, bsel, n_a, n_b, a_start,
    b_start, q, i, j, start, x)."""
    c, bsel, n_a, n_b, a_start, b_start = team_blocks(confirmed, owner, t_s, b_owner, t_b, max_age, n_owners)
    q, i, j, start = block_pairs_loop(n_a, n_b)
    x = np.empty((c.size, 4))
    for a in range(c.size):
        for b in range(4):
            x[a, b] = states[c[a], b]
    return c, bsel, n_a, n_b, a_start, b_start, q, i, j, start, x


@kernel
def team_distances(q, i, j, a_start, b_start, bsel, x, cos_th, sin_th, t_s, t_b, p_b, far_m2, gate):
    """(dist (P,), inside (P,), count inside) of the pairs (q, i, j):
    :func:`~mjasc.perception.tracking.pair_kernels.broadcast_distances` with the tracks' velocities
    ``vx = V·cos θ``, ``vy = V·sin θ`` (x (A, 4), cos_th, sin_th (A,) numpy's), and ``dist ≤ gate``."""
    k = x.shape[0]
    vx = np.empty(k)
    vy = np.empty(k)
    for a in range(k):
        vx[a] = x[a, 3] * cos_th[a]
        vy[a] = x[a, 3] * sin_th[a]
    dist = broadcast_distances(q, i, j, a_start, b_start, bsel, x, vx, vy, t_s, t_b, p_b, far_m2)
    inside = np.empty(dist.size, dtype=np.bool_)
    n_in = 0
    for a in range(dist.size):
        inside[a] = dist[a] <= gate
        n_in += inside[a]
    return dist, inside, n_in


@kernel
def matched_rows(got, q, i, j, a_start, b_start, c, bsel):
    """(ta, tb) of the assigned pairs ``got`` of :meth:`TeamMatcher.match`: the track position
    ``c[a_start[q[got]] + i[got]]`` and the broadcast ``bsel[b_start[q[got]] + j[got]]`` of each."""
    m = got.size
    ta = np.empty(m, dtype=c.dtype)
    tb = np.empty(m, dtype=bsel.dtype)
    for a in range(m):
        g = got[a]
        qg = q[g]
        ta[a] = c[a_start[qg] + i[g]]
        tb[a] = bsel[b_start[qg] + j[g]]
    return ta, tb


@kernel
def team_plan(confirmed, owner, t_s, b_owner, t_b, max_age, n_owners, states):
    """:func:`team_pairs` (arguments as there) with its per-vessel arrays as the rows of one
    (4, n_owners) array (n_a, n_b, a_start, b_start) and its pairs' as those of one (3, P) array
    (q, i, j): (c, bsel, blocks, pq, start, x)."""
    c, bsel, n_a, n_b, a_start, b_start, q, i, j, start, x = team_pairs(confirmed, owner, t_s, b_owner, t_b, max_age,
                                                                        n_owners, states)
    blocks = np.empty((4, n_owners), dtype=np.int64)
    for o in range(n_owners):
        blocks[0, o] = n_a[o]
        blocks[1, o] = n_b[o]
        blocks[2, o] = a_start[o]
        blocks[3, o] = b_start[o]
    pq = np.empty((3, q.size), dtype=np.int64)
    for k in range(q.size):
        pq[0, k] = q[k]
        pq[1, k] = i[k]
        pq[2, k] = j[k]
    return c, bsel, blocks, pq, start, x


@kernel
def team_assign(pq, blocks, start, bsel, c, x, cos_th, sin_th, t_s, t_b, p_b, far_m2, gate):
    """:func:`team_distances` of the pairs of :func:`team_plan` (dist, inside, n_in) and, when some pair
    is inside the gate, :func:`~mjasc.perception.tracking.step_kernels.admissible_pairs`; when no block is
    hard, :func:`matched_rows` of the admissible pairs: (dist, inside, n_in, hard, ta, tb) — hard non-empty
    (or n_in 0): ta and tb empty, the caller assigns."""
    q, i, j = pq[0], pq[1], pq[2]
    a_start, b_start = blocks[2], blocks[3]
    dist, inside, n_in = team_distances(q, i, j, a_start, b_start, bsel, x, cos_th, sin_th, t_s, t_b, p_b, far_m2, gate)
    none = np.zeros(0, dtype=np.int64)
    if not n_in:
        return dist, inside, n_in, none, none, none
    easy, hard = admissible_pairs(inside, q, i, j, start, blocks[1])
    if hard.size:
        return dist, inside, n_in, hard, none, none
    ta, tb = matched_rows(easy, q, i, j, a_start, b_start, c, bsel)
    return dist, inside, n_in, hard, ta, tb


@kernel
def team_plan_packed(confirmed, owner, t_s, b_owner, t_b, max_age, n_owners, states, wrap_theta):
    """:func:`team_plan` (arguments as there; with ``wrap_theta`` the states' θ unwrapped, wrapped in the
    gathered rows as :func:`~mjasc.perception.imm.row_fields.wrapped_states` does) with c, bsel and start
    in one array: (ints (A + B + Q + 1,), blocks, pq, x, A, B)."""
    c, bsel, blocks, pq, start, x = team_plan(confirmed, owner, t_s, b_owner, t_b, max_age, n_owners, states)
    if wrap_theta:
        for a in range(x.shape[0]):
            x[a, 2] = math.pi - (math.pi - x[a, 2]) % _TWO_PI
    A, B = c.size, bsel.size
    ints = np.empty(A + B + start.size, dtype=np.int64)
    for a in range(A):
        ints[a] = c[a]
    for a in range(B):
        ints[A + a] = bsel[a]
    for a in range(start.size):
        ints[A + B + a] = start[a]
    return ints, blocks, pq, x, A, B


@kernel
def team_assign_packed(pq, blocks, start, bsel, c, x, cos_th, sin_th, t_s, t_b, p_b, far_m2, gate):
    """:func:`team_assign` (arguments as there) with hard, ta and tb in one array: (dist, inside, n_in,
    hits (h + 2m,): hard (h,), ta, tb (m,), h)."""
    dist, inside, n_in, hard, ta, tb = team_assign(pq, blocks, start, bsel, c, x, cos_th, sin_th, t_s, t_b, p_b,
                                                   far_m2, gate)
    h, m = hard.size, ta.size
    hits = np.empty(h + 2 * m, dtype=np.int64)
    for a in range(h):
        hits[a] = hard[a]
    for a in range(m):
        hits[h + a] = ta[a]
        hits[h + m + a] = tb[a]
    return dist, inside, n_in, hits, h


class TeamBuffers:
    """Room for ``n_a`` tracks, ``n_b`` broadcasts, ``n_pairs`` pairs and ``n_owners`` vessels."""

    def __init__(self, n_a: int = 0, n_b: int = 0, n_pairs: int = 0, n_owners: int = 0):
        self.n_a, self.n_b, self.n_pairs, self.n_owners = n_a, n_b, n_pairs, n_owners
        self.ints = np.empty(n_a + n_b + n_owners + 1, dtype=np.int64)
        self.blocks = np.empty(4 * n_owners, dtype=np.int64)  # (4, n_owners) row-major
        self.pq = np.empty(3 * n_pairs, dtype=np.int64)  # (3, P) row-major
        self.x = np.empty((n_a, 4))
        self.dist, self.inside = np.empty(n_pairs), np.empty(n_pairs, dtype=bool)
        self.hits = np.empty(n_owners + 2 * n_a, dtype=np.int64)

    def fits(self, n_a: int, n_b: int, n_pairs: int, n_owners: int) -> bool:
        return n_a <= self.n_a and n_b <= self.n_b and n_pairs <= self.n_pairs and n_owners <= self.n_owners


def grown_team(bufs: TeamBuffers | None, n_a: int, n_b: int, n_pairs: int, n_owners: int) -> TeamBuffers:
    """``bufs`` if it has room for these sizes, else buffers with room for half as much again."""
    if bufs is not None and bufs.fits(n_a, n_b, n_pairs, n_owners):
        return bufs
    if bufs is not None:
        n_a, n_b = max(n_a, bufs.n_a), max(n_b, bufs.n_b)
        n_pairs, n_owners = max(n_pairs, bufs.n_pairs), max(n_owners, bufs.n_owners)
    more = lambda m: m + max(16, m // 2)
    return TeamBuffers(more(n_a), more(n_b), more(n_pairs), n_owners)


@kernel
def team_plan_into(confirmed, owner, t_s, b_owner, t_b, max_age, n_owners, states, wrap_theta, ints, blocks, pq, x):
    """:func:`team_plan_packed` (arguments confirmed … wrap_theta as there) written into the buffers ints,
    blocks (4·n_owners, flat), pq (3·cap, flat) and x when they have room: (A, B, number of pairs, written)
    — nothing written when they are too small (sizes returned)."""
    i_, b_, pq_, x_, A, B = team_plan_packed(confirmed, owner, t_s, b_owner, t_b, max_age, n_owners, states,
                                             wrap_theta)
    npairs = pq_.shape[1]
    if i_.size > ints.size or b_.size > blocks.size or 3 * npairs > pq.size or x_.shape[0] > x.shape[0]:
        return A, B, npairs, False
    for a in range(i_.size):
        ints[a] = i_[a]
    for r in range(4):
        for o in range(n_owners):
            blocks[r * n_owners + o] = b_[r, o]
    for r in range(3):
        for c in range(npairs):
            pq[r * npairs + c] = pq_[r, c]
    for a in range(x_.shape[0]):
        for b in range(4):
            x[a, b] = x_[a, b]
    return A, B, npairs, True


@kernel
def team_assign_into(pq, blocks, start, bsel, c, x, cos_th, sin_th, t_s, t_b, p_b, far_m2, gate, dist, inside, hits):
    """:func:`team_assign_packed` (arguments pq … gate as there) written into the first rows of dist,
    inside (P) and hits (h + 2m): (n_in, h, m)."""
    d_, in_, n_in, h_, h = team_assign_packed(pq, blocks, start, bsel, c, x, cos_th, sin_th, t_s, t_b, p_b, far_m2,
                                              gate)
    for a in range(d_.size):
        dist[a] = d_[a]
        inside[a] = in_[a]
    for a in range(h_.size):
        hits[a] = h_[a]
    return n_in, h, (h_.size - h) // 2


@kernel
def team_match_into(confirmed, owner, t_s, b_owner, t_b, p_b, max_age, n_owners, states, wrap_theta, far_m2, gate,
                    ints, blocks, pq, x, dist, inside, hits):
    """:meth:`~mjasc.perception.tracking.team.TeamMatcher.match`'s compiled calls in one:
    :func:`team_plan_into` (confirmed … wrap_theta as there, into ints, blocks, pq, x), then, when it wrote
    and there are tracks and broadcasts (A, B > 0), the tracks' cos θ and sin θ (``math``'s: numpy's bits
    here) and :func:`team_assign_into` of the written rows (t_b, p_b (B, 2) [m], far_m2 and gate as there,
    into dist, inside, hits). Returns (A, B, number of pairs, written, n_in, h, m) — n_in = h = m = 0 when
    nothing was assigned."""
    A, B, npairs, ok = team_plan_into(confirmed, owner, t_s, b_owner, t_b, max_age, n_owners, states, wrap_theta,
                                      ints, blocks, pq, x)
    if not ok or A == 0 or B == 0:
        return A, B, npairs, ok, 0, 0, 0
    cos_th = np.empty(A)
    sin_th = np.empty(A)
    for a in range(A):
        th = x[a, 2]
        cos_th[a] = math.cos(th)
        sin_th[a] = math.sin(th)
    n_in, h, m = team_assign_into(pq[:3 * npairs].reshape((3, npairs)), blocks[:4 * n_owners].reshape((4, n_owners)),
                                  ints[A + B:A + B + n_owners + 1], ints[A:A + B], ints[:A], x[:A], cos_th, sin_th,
                                  t_s, t_b, p_b, far_m2, gate, dist, inside, hits)
    return A, B, npairs, ok, n_in, h, m
