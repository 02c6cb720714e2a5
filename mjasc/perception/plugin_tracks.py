"""What a vessel's perception does around a plugin tracker (``[vessels.tracking] method`` other
than the built-in ``imm``, :class:`mjasc.perception.pipeline.Perception`): its tracks marked with
the team's broadcasts as the built-in tracker's are (:func:`mark_team`), and read like the built-in
tracker's by the recording (:class:`TracksView`).
"""

from __future__ import annotations

from dataclasses import replace
from types import SimpleNamespace

import numpy as np

from mjasc.perception.tracking.team import TeamMatcher

__all__ = ["TracksView", "mark_team"]


def mark_team(team: TeamMatcher, tracks: tuple, t_s: float) -> tuple:
    """The tracks with ``team_member`` set from the team's broadcasts (``team``, the vessel's
    :class:`~mjasc.perception.tracking.team.TeamMatcher`, refilled with these tracks), as the
    built-in tracker does: each track's position at t_s extrapolated back to the broadcast time
    along its velocity, GNN within ``team_match_distance_m``, broadcasts no older than
    ``team_max_age_s``."""
    n = len(tracks)
    tm = team  # (its rows: these tracks)
    tm.keep(np.zeros(len(tm.members()), dtype=bool))
    tm.append(n)
    t = np.array([max(t_s, e.time_s) for e in tracks])
    pos = np.array([e.predict_positions(np.array([tk]))[0] for e, tk in zip(tracks, t)])
    states = np.column_stack([pos, [e.heading_rad for e in tracks], [e.speed_m_s for e in tracks]])
    tm.match(np.arange(n), np.zeros(n, dtype=np.int64), np.array([float(t_s)]), states, np.ones(n, dtype=bool), 1)
    names = tm.members()
    return tuple(e if e.team_member == nm else replace(e, team_member=nm) for e, nm in zip(tracks, names))


class TracksView:
    """A plugin tracker's confirmed tracks read like the built-in tracker's (what the recording
    draws): every row confirmed, the estimates' ids, states, covariances, radii, flags; no modes."""

    def __init__(self, tracks: tuple):
        n = len(tracks)
        self._tracks = tracks
        self.confirmed = np.ones(n, dtype=bool)
        self.static = np.array([e.is_static for e in tracks], dtype=bool)
        self.radii_m = np.array([e.radius_m for e in tracks], dtype=float)
        self.team_members = [e.team_member for e in tracks]
        states = np.array([[*e.position_m, e.heading_rad, e.speed_m_s] for e in tracks], dtype=float).reshape(n, 4)
        self.bank = SimpleNamespace(
            track_ids=np.array([e.track_id for e in tracks], dtype=np.int64), states=states,
            positions=states[:, :2], times_s=np.array([e.time_s for e in tracks], dtype=float),
            position_covariances=np.array([e.position_covariance for e in tracks], dtype=float).reshape(n, 2, 2),
            turn_rates=np.array([e.turn_rate_rad_s for e in tracks], dtype=float), mode_probabilities=np.zeros((n, 0)))

    def __len__(self) -> int:
        return len(self._tracks)

    def confirmed_fields(self) -> tuple:
        """As :meth:`mjasc.perception.tracking.MultiTargetTracker.confirmed_fields` (every track)."""
        b = self.bank
        return np.arange(len(self._tracks)), b.track_ids, b.states, self.static, self.team_members

    def confirmed_points(self, epoch=None) -> tuple:
        """As :meth:`mjasc.perception.tracking.MultiTargetTracker.confirmed_points` (every track;
        ``epoch`` changes nothing here: a plugin's tracks are one vessel's)."""
        return self.bank.track_ids, self.bank.positions, self.static, self.team_members

    def estimates(self, include_tentative: bool = False) -> list:
        return list(self._tracks)
