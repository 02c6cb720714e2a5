"""A vessel's threat panel: the tracks its latest prediction weighed, with CPA, TCPA and its answer.

Everything comes from what the avoidance stage already computed — the latest
:class:`~mjasc.avoidance.system.PredictionRecord` (every track's predicted closest approach, the
conflicts with a collision, the static conflicts) and the triage's answer per track
(:attr:`~mjasc.avoidance.triage.Triage.roles`: COLREG role, team right of way, yield / pass /
re-plan) — never from the truth. CPA [m] is the predicted minimum distance d(t_c) between the
vessel (on its planned motion) and the track; TCPA [s] is t_c minus the prediction's time. The
recording writes the panel as a markdown ``TextDocument`` at ``threats/<vessel>`` whenever its text
changes (:mod:`mjasc.avoidance.recording`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["ThreatRow", "threat_rows", "threat_markdown", "MAX_ROWS"]

#: At most this many tracks are listed (collisions first, then by CPA).
MAX_ROWS = 8


@dataclass(frozen=True)
class ThreatRow:
    """One track of the panel. track_id None: a mapped structure (static-map polygon).
    who: "team mate <name>", "static" or "stranger"; cpa_m: predicted closest distance [m];
    tcpa_s: time from the prediction to the closest approach [s] (NaN for a static conflict);
    limit_m: the collision distance R_vh + R_ob + safety [m] (NaN when not computed);
    collision: CPA below the limit; answer: the triage's answer, or "clear"."""

    track_id: int | None
    who: str
    cpa_m: float
    tcpa_s: float
    limit_m: float
    collision: bool
    answer: str


def threat_rows(record, team: frozenset | set = frozenset()) -> list[ThreatRow]:
    """The panel's rows from a prediction ``record`` (``time_s``, ``all``, ``statics``, ``tracks``,
    ``roles``: the triage's (track id, answer) pairs); ``team``: the team mates' names."""
    roles = dict(getattr(record, "roles", ()))
    rows = []
    for c in record.all:
        track = record.tracks.get(c.track_id)
        mate = getattr(track, "team_member", None)
        who = f"team mate {mate}" if mate in team else ("static" if c.is_static else "stranger")
        answer = roles.get(c.track_id, c.decision.value if c.collision else "clear")
        rows.append(ThreatRow(int(c.track_id), who, float(c.min_distance_m), float(c.t_closest_s - record.time_s),
                              float(c.collision_distance_m), bool(c.collision), answer))
    for s in record.statics:
        rows.append(ThreatRow(None if s.track_id is None else int(s.track_id), "static", float(s.min_distance_m),
                              float("nan"), float("nan"), True,
                              roles.get(s.track_id, "mapped structure: go around") if s.track_id is not None
                              else "mapped structure: go around"))
    rows.sort(key=lambda r: (not r.collision, r.cpa_m if np.isfinite(r.cpa_m) else np.inf))
    return rows[:MAX_ROWS]


def _num(x: float, fmt: str) -> str:
    return format(x, fmt) if np.isfinite(x) else "–"


def threat_markdown(vessel_name: str, record, team, mode: str, correction=None, note: str | None = None) -> str:
    """The panel as markdown: a header with the mode and the running correction, then a table.
    ``note``: what a method without predictions says instead (its latest decision)."""
    lines = [f"**{vessel_name}**: mode **{mode}**"]
    if correction is not None:
        lines.append(f"velocity correction: {correction.label} for track T{correction.track_id}, "
                     f"V_d = {correction.law.desired_speed:.2f} m/s")
    if record is None:
        return "\n\n".join(lines + [note if note is not None else "no prediction yet"]) + "\n"
    rows = threat_rows(record, team)
    lines.append(f"prediction at t = {record.time_s:.1f} s: {sum(r.collision for r in rows)} conflict(s) "
                 f"among {len(record.all) + len(record.statics)} track(s)")
    if not rows:
        return "\n\n".join(lines) + "\n"
    table = ["| track | who | CPA [m] | limit [m] | TCPA [s] | role / decision |", "|---|---|---|---|---|---|"]
    for r in rows:
        name = "map" if r.track_id is None else f"T{r.track_id}"
        mark = "**" if r.collision else ""
        table.append(f"| {mark}{name}{mark} | {r.who} | {mark}{_num(r.cpa_m, '.1f')}{mark} | {_num(r.limit_m, '.1f')} "
                     f"| {_num(r.tcpa_s, '.0f')} | {r.answer} |")
    return "\n\n".join(lines) + "\n\n" + "\n".join(table) + "\n"
