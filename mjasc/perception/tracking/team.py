"""Recognising team mates among a vessel's tracks from their broadcasts (:mod:`mjasc.perception.tracking`,
item 7).

Team mates are tracked like anything else; the team's broadcast positions ``{name: (t_b,
position)}`` (world ENU [m], broadcast time t_b [s]) come over the comms link, and each confirmed
track is matched against them by a global nearest neighbour (``scipy.optimize.linear_sum_assignment``
on the distances, gate ``team_match_distance_m``), comparing the broadcast with the track's position
extrapolated back to t_b along its velocity; broadcasts older than ``team_max_age_s`` are not used.
A match sets ``TrackEstimate.team_member``.

Each vessel (owner) of a fleet's tracker has its own broadcasts (what its own link delivered) and
matches only its own tracks: one pass over every vessel's (track, broadcast) pairs, a
``linear_sum_assignment`` only for a vessel where a track or a broadcast has two candidates
(:func:`mjasc.perception.tracking.association.gnn_assign_blocks`).

The match is one compiled call writing into buffers the matcher keeps
(:func:`~mjasc.perception.tracking.team_kernels.team_match_into`, :class:`~mjasc.perception.tracking.team_kernels.TeamBuffers`):
every vessel's (track, broadcast) blocks and pairs, the tracks' velocities and the pairs' distances, and the
assignment of every vessel whose block is easy (:mod:`mjasc.perception.tracking.team_kernels`).
"""

from __future__ import annotations

import numpy as np

from mjasc.perception.tracking.association import gnn_assign_blocks
from mjasc.perception.tracking.config import TrackingConfig
from mjasc.perception.tracking.team_kernels import TeamBuffers, grown_team, matched_rows, team_match_into
from mjasc.perception.tracking.track_columns import TrackColumns, column

__all__ = ["TeamMatcher"]


class TeamMatcher:
    """Per vessel (owner) the team's latest broadcasts, and per track (rows aligned with the bank's)
    the name of the team mate it was matched to (None: not a team mate), a column of a
    :class:`~mjasc.perception.tracking.track_columns.TrackColumns` (``columns``: a tracker's store;
    None: a store of its own)."""

    def __init__(self, config: TrackingConfig, columns: TrackColumns | None = None):
        self.config = config
        self.cols = TrackColumns(config.confirm_hits <= 1) if columns is None else columns
        self._team: dict[int, tuple] = {}  # owner → (names, t_b (k,) [s], positions (k, 2) [m])
        self._flat = None  # every owner's broadcasts as arrays (owner, name, t_b, position), built when used
        self._start: dict[int, int] = {}  # owner → its first row in those arrays
        self._max_age, self._gate = float(config.team_max_age_s), float(config.team_match_distance_m)
        self._far = (2.0 * self._gate) ** 2  # [m²] (a pair farther apart than twice the gate: +inf, not computed)
        self._bufs = TeamBuffers()  # the match's buffers (grown when too small)

    # the store's column of matched names (a view: stale after a birth or drop)
    _team_of = column("team")

    def set_positions(self, owner: int, positions: dict) -> None:
        """``{name: (t_b [s], position (2,) [m])}``: the team's latest broadcast positions, as
        vessel ``owner`` received them."""
        names = list(positions)  # (the names as given: str(name) below unless they are the same mates)
        vals = list(positions.values())
        owner = int(owner)
        team = self._team
        old = team[owner] if owner in team else None
        flat = self._flat
        if flat is not None and old is not None and old[0] == names and vals:
            # the same mates: new values written in place (the flat arrays' rows are this owner's arrays)
            a, k = self._start[owner], len(vals)
            tb, pb = flat[2][a:a + k], flat[3][a:a + k]
            tb[...] = [v[0] for v in vals]  # (numpy's conversion, as np.array(..., dtype=float) makes it)
            pb[...] = [v[1] for v in vals]
            team[owner] = (old[0], tb, pb)
            return
        names = [str(k) for k in names]
        tb, pb = np.array([v[0] for v in vals], dtype=float), np.array([v[1] for v in vals], dtype=float).reshape(-1, 2)
        self._team[owner] = (names, tb, pb)
        self._flat = None

    def append(self, k: int = 1) -> None:
        """k new tracks, no team mates (new rows of the store: :meth:`TrackColumns.append`)."""
        self.cols.append(0.0, np.zeros(k))

    def keep(self, keep: np.ndarray) -> None:
        """Keep the rows where ``keep`` (n,) is True (:meth:`TrackColumns.keep`)."""
        self.cols.keep(keep)

    def members(self, rows=slice(None)) -> list:
        """Per track (of ``rows``), the matched team mate's name or None."""
        return self.cols.team[rows].tolist()

    def _arrays(self):
        """Every owner's broadcasts in one set of arrays, owners in order: (owner (B,), names (B,),
        t_b (B,) [s], position (B, 2) [m]). Built again only when an owner's set of mates changes
        (:meth:`set_positions` writes new values of the same mates in place)."""
        if self._flat is None:
            teams = sorted(self._team.items())
            sizes = np.array([len(t[0]) for _, t in teams], dtype=np.int64)
            self._start = dict(zip([o for o, _ in teams], (np.cumsum(sizes) - sizes).tolist()))
            self._flat = (np.repeat(np.array([o for o, _ in teams], dtype=np.int64), [len(t[0]) for _, t in teams]),
                          [name for _, t in teams for name in t[0]],
                          np.concatenate([t[1] for _, t in teams]), np.concatenate([t[2] for _, t in teams]))
        return self._flat

    def match(self, rows, owner, t_s, states: np.ndarray, confirmed: np.ndarray, n_owners: int,
              wrapped: bool = True) -> None:
        """Match the confirmed ones of tracks ``rows`` (indices, bank order, or ``slice(None)``: every row; their vessel ``owner``
        (k,), ``states`` (k, 4) [x, y, θ, V] (θ in (−π, π], or unwrapped when not ``wrapped``: wrapped
        here as the bank's ``states`` does), ``confirmed`` (k,) bool) at their vessel's time
        t_s ((n_owners,) [s], NaN for vessels not matched now) against that vessel's broadcasts."""
        team_of = self.cols.team
        team_of[rows] = None
        if not self._team or owner.size == 0:
            return
        b_owner, names, tb, pb = self._arrays()
        # (the plan, cos θ, sin θ and the assignment in one call, written into the matcher's buffers)
        bf, no, wrap = self._bufs, n_owners, not wrapped
        args = (confirmed, owner, t_s, b_owner, tb, pb, self._max_age, no, states, wrap, self._far, self._gate)
        A, B, npairs, ok, n_in, n_hard, m = team_match_into(*args, bf.ints, bf.blocks, bf.pq, bf.x, bf.dist,
                                                            bf.inside, bf.hits)
        if not ok:  # (too small: larger buffers, the same call again)
            bf = self._bufs = grown_team(bf, owner.size, b_owner.size, npairs, no)
            A, B, npairs, ok, n_in, n_hard, m = team_match_into(*args, bf.ints, bf.blocks, bf.pq, bf.x, bf.dist,
                                                                bf.inside, bf.hits)
        if not n_in:
            return
        hits = bf.hits
        ta, tb_i = hits[n_hard:n_hard + m], hits[n_hard + m:n_hard + 2 * m]
        if n_hard:  # (a track or a broadcast with two candidates: that vessel's block to linear_sum_assignment)
            ints = bf.ints
            c, bsel, start = ints[:A], ints[A:A + B], ints[A + B:A + B + no + 1]
            q, i, j = bf.pq[:3 * npairs].reshape(3, npairs)
            n_a, n_b, a_start, b_start = bf.blocks[:4 * no].reshape(4, no)
            got = gnn_assign_blocks(bf.inside[:npairs], bf.dist[:npairs], q, i, j, start, n_a, n_b)
            ta, tb_i = matched_rows(got, q, i, j, a_start, b_start, c, bsel)
        # (each matched row's name, one by one: a few rows, cheaper than an object array made for them)
        for k, b in zip((ta if isinstance(rows, slice) else rows[ta]).tolist(), tb_i.tolist()):
            team_of[k] = names[b]
