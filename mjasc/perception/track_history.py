"""The confirmed tracks' history a vessel's perception keeps on request (``Perception.keep_history``:
the tracking figures, tests): one row per confirmed track per tracking step,
``(t [s], id, x [m], y [m], heading [rad], speed [m/s], turn rate [rad/s], team mate or None, static)``
in world ENU.
"""

from __future__ import annotations

import numpy as np

__all__ = ["history_rows", "plugin_history_rows", "history_arrays", "HISTORY_COLUMNS"]

#: The numeric columns of :func:`history_arrays` (the first seven of a row).
HISTORY_COLUMNS = ("t", "id", "x", "y", "heading", "speed", "omega")


def history_rows(tracker) -> list[tuple]:
    """The rows of a built-in tracker's (:class:`~mjasc.perception.tracking.tracker.MultiTargetTracker`)
    confirmed tracks now, in bank order."""
    if len(tracker) == 0:
        return []
    bank = tracker.bank
    x, w, ids, t = bank.states, bank.turn_rates, bank.track_ids, bank.times_s
    conf, team, static = tracker.confirmed, tracker.team_members, tracker.static
    return [(float(t[k]), int(ids[k]), *map(float, x[k]), float(w[k]), team[k], bool(static[k]))
            for k in np.flatnonzero(conf)]


def plugin_history_rows(tracks) -> list[tuple]:
    """The rows of a plugin tracker's confirmed tracks (:class:`~mjasc.core.estimates.TrackEstimate`)."""
    return [(e.time_s, e.track_id, *map(float, e.position_m), e.heading_rad, e.speed_m_s, e.turn_rate_rad_s,
             e.team_member, e.is_static) for e in tracks]


def history_arrays(rows: list) -> dict:
    """The rows' numeric columns as arrays (:data:`HISTORY_COLUMNS`; ``id`` as int)."""
    if not rows:
        return {c: np.zeros(0) for c in HISTORY_COLUMNS}
    a = np.array([row[:7] for row in rows], dtype=float)
    out = {c: a[:, i] for i, c in enumerate(HISTORY_COLUMNS)}
    out["id"] = out["id"].astype(int)
    return out
