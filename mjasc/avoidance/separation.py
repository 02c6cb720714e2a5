"""Two team mates stopped inside each other's collision distance move apart (a deadlock's way out).

Right of way settles team mates: the give-way vessel yields or stops, the stand-on one keeps its
speed. Deployed (or drifted) closer than the collision distance, with paths that each run through
the other, every prediction finds the conflict at its first instant — nothing a speed plan, a lane
or a potential-field detour does can clear a conflict that is already there (the planner refuses
"track … is already at the vessel") — so both vessels stop, each in the other's way, and stay
stopped (a go-to-formation deployment: alpha and charlie deployed 4.5 m apart across each other's
transits stopped at 0.6 s and were still stopped at the end of the 320 s run; a pair at the
§6.4.3 bottleneck's gap from 116 s to the end).

The way out. A vessel is *stuck* with a team mate when both are stopped (own speed over ground and
the team mate's broadcast velocity below :data:`STOPPED_M_S`) and the team mate's centre is inside
their collision distance, at every one of its predictions (about one a second while it is
stopped: the time is counted at predictions). Once it has been stuck for ``deadlock_s`` (45 s:
longer than the waits that end by themselves — in the bottleneck two team mates stopped side by
side in the gap for up to 29 s before right of way let one go, and moving apart at 10 s sent one of
them later into an island), it sails straight away from the nearest such team mate — the first of
the directions away, turned by up to ±90°, whose leg keeps clear of the mapped statics (grown by the
static inflation) and ends no nearer to any other team mate than it is now, or outside the
collision distance — to the collision distance plus ``2·replan_margin_m`` from that team mate's
centre; then it goes back onto its mission path where it left it and the usual rules go on. While
it sails the leg, conflicts with team mates from which the leg opens the range (closest approach
now) are not acted on. One moves at a time: a vessel whose stuck team mates include an earlier name
waits ``2·deadlock_s`` (names in Python's string order: capitals first; the staggering assumes the
same ``deadlock_s`` on both vessels, well above a second) — a hull turning in place sweeps its
ends round, and two turning side by side touched. A vessel stopped again on its leg, still stuck,
looks again after another ``deadlock_s``; so does one whose every way out is blocked (counted as
``separate_refused``). World frame ENU, SI units.
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.avoidance.replanning import Detour
from mjasc.core.geometry import points_near_polygon
from mjasc.guidance.paths import Path

__all__ = ["STOPPED_M_S", "mate_speed_m_s", "stuck_with", "separation_turn", "separation_detour"]

#: A vessel (or a team mate's broadcast velocity) slower than this is stopped [m/s].
STOPPED_M_S = 0.1
_TURNS_DEG = (0.0, 30.0, -30.0, 60.0, -60.0, 90.0, -90.0)


def mate_speed_m_s(track) -> float:
    """A team mate's speed over ground [m/s]: its broadcast velocity when it is predicted from its
    plan (a planned track's ``speed_m_s`` is the plan's largest), else the track's speed."""
    intention = getattr(track, "intention", None)
    if intention is not None:
        v = intention.velocity_m_s
        return math.hypot(float(v[0]), float(v[1]))
    return float(track.speed_m_s)


def stuck_with(t: float, position_m, own_speed_m_s: float, conflicts, by_id: dict, since: dict) -> dict:
    """Track id → since when [s] this vessel, stopped at ``position_m``, has had that stopped team
    mate's centre inside the collision distance of their predicted conflict, carrying the times of
    ``since`` (the previous prediction's answer) on; the others are dropped."""
    out = {}
    if own_speed_m_s >= STOPPED_M_S:
        return out
    x, y = float(position_m[0]), float(position_m[1])
    for c in conflicts:
        track = by_id.get(c.track_id)
        if track is None or getattr(track, "team_member", None) is None or not c.collision:
            continue
        p = track.position_m
        if math.hypot(float(p[0]) - x, float(p[1]) - y) < c.collision_distance_m and \
                mate_speed_m_s(track) < STOPPED_M_S:
            out[c.track_id] = since.get(c.track_id, t)
    return out


def separation_turn(name: str, mate_names) -> int:
    """How many ``deadlock_s`` a vessel named ``name`` waits before it moves away from the team mates
    it is stuck with (``mate_names``): 1 when its name comes before all of theirs, else 2 (one
    moves at a time)."""
    return 1 if all(str(name) < str(m) for m in mate_names) else 2


def separation_detour(t: float, position_m, mate_position_m, reach_m: float, mission_gamma_m: float, static_polygons,
                      static_inflation_m: float, other_mates_m=(), clearance_m: float = 0.0):
    """The leg straight away from a team mate at ``mate_position_m`` to ``reach_m`` [m] from its
    centre, as a :class:`~mjasc.avoidance.replanning.Detour` whose end goes back to the mission path
    where the vessel left it (its mission γ stays at ``mission_gamma_m`` [m]); the first direction
    of :data:`_TURNS_DEG` whose leg keeps ``static_inflation_m`` [m] off every polygon of
    ``static_polygons`` and ends no nearer to each of ``other_mates_m`` (positions, [m]) than the
    vessel is now, or at least ``clearance_m`` [m] from it. A reason (str) when none does."""
    p = np.asarray(position_m, dtype=float)
    q = np.asarray(mate_position_m, dtype=float)
    statics = [np.asarray(s, dtype=float) for s in static_polygons or ()]
    others = [np.asarray(o, dtype=float) for o in other_mates_m]
    now = [float(np.hypot(*(o - p))) for o in others]
    away = p - q
    base = math.atan2(away[1], away[0]) if float(np.hypot(*away)) > 1e-6 else 0.0
    blocked_by_mates = False
    for turn in _TURNS_DEG:
        a = base + math.radians(turn)
        escape = q + reach_m * np.array([math.cos(a), math.sin(a)])
        if any(float(np.hypot(*(o - escape))) < min(d, clearance_m) for o, d in zip(others, now)):
            blocked_by_mates = True
            continue
        leg = np.linspace(p, escape, max(int(np.ceil(np.hypot(*(escape - p)) / 0.5)), 1) + 1)
        if any(points_near_polygon(leg, s, static_inflation_m) for s in statics):
            continue
        lane = Path.from_points(np.array([p, escape]))
        g = float(mission_gamma_m)
        return Detour(lane, lane.length, g, g, np.array([p, escape]), (), None, t)
    return "every way out meets " + ("a mapped static obstacle or another team mate" if blocked_by_mates
                                     else "a mapped static obstacle")
