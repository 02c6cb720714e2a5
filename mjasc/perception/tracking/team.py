"""Recognising team mates among a vessel's tracks from their broadcasts (:mod:`mjasc.perception.tracking`,
item 7).

Team mates are tracked like anything else; the team's broadcast positions ``{name: (t_b,
position)}`` (world ENU [m], broadcast time t_b [s]) come over the comms link, and each confirmed
track is matched against them by a global nearest neighbour (``scipy.optimize.linear_sum_assignment``
on the distances, gate ``team_match_distance_m``), comparing the broadcast with the track's position
extrapolated back to t_b along its velocity; broadcasts older than ``team_max_age_s`` are not used.
A match sets ``TrackEstimate.team_member``.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

from mjasc.perception.tracking.association import BIG_COST
from mjasc.perception.tracking.config import TrackingConfig

__all__ = ["TeamMatcher"]


class TeamMatcher:
    """The team's latest broadcasts and, per track (rows aligned with the bank's), the name of the
    team mate it was matched to (None: not a team mate)."""

    def __init__(self, config: TrackingConfig):
        self.config = config
        self._team: dict[str, tuple[float, np.ndarray]] = {}
        self._team_of: list[str | None] = []

    def set_positions(self, positions: dict) -> None:
        """``{name: (t_b [s], position (2,) [m])}``: the team's latest broadcast positions."""
        self._team = {str(k): (float(v[0]), np.asarray(v[1], dtype=float).reshape(2)) for k, v in positions.items()}

    def append(self) -> None:
        self._team_of.append(None)

    def keep(self, keep: np.ndarray) -> None:
        """Keep the rows where ``keep`` (n,) is True."""
        self._team_of = [x for x, k in zip(self._team_of, keep) if k]

    @property
    def members(self) -> list:
        """Per track, the matched team mate's name or None."""
        return list(self._team_of)

    def match(self, t_s: float, states: np.ndarray, confirmed: np.ndarray) -> None:
        """Match the confirmed tracks (``states`` (n, 4) [x, y, θ, V], ``confirmed`` (n,) bool) at
        t_s [s] against the broadcasts."""
        n = states.shape[0]
        self._team_of = [None] * n
        if not self._team or n == 0:
            return
        cfg = self.config
        names = [k for k, (tb, _) in self._team.items() if t_s - tb <= cfg.team_max_age_s]
        rows = np.flatnonzero(confirmed)
        if not names or rows.size == 0:
            return
        x = states[rows]
        vel = x[:, 3, None] * np.stack([np.cos(x[:, 2]), np.sin(x[:, 2])], axis=-1)
        tb = np.array([self._team[k][0] for k in names])
        pb = np.array([self._team[k][1] for k in names])
        back = x[:, None, :2] - vel[:, None, :] * (t_s - tb)[None, :, None]
        dist = np.hypot(*(back - pb[None, :, :]).transpose(2, 0, 1))
        inside = dist <= cfg.team_match_distance_m
        if not inside.any():
            return
        r, c = linear_sum_assignment(np.where(inside, dist, BIG_COST))
        for a, b in zip(r, c):
            if inside[a, b]:
                self._team_of[rows[a]] = names[b]
