"""Two team mates stopped inside each other's collision distance move apart (a deadlock's way out).

Right of way settles team mates: the give-way vessel yields or stops, the stand-on one keeps its
speed. Deployed (or drifted) closer than the collision distance, with paths that each run through
the other, every prediction finds the conflict at its first instant — nothing a speed plan, a lane
or a potential-field detour does can clear a conflict that is already there (the planner refuses
"track … is already at the vessel") — so both vessels stop, each in the other's way, and stay
stopped (a go-to-formation deployment: alpha and charlie deployed 2.6 m apart across each other's
transits stopped at 0.6 s and were still stopped at the end of the 320 s run).

The way out: once a vessel has been stopped for ``deadlock_s`` (45 s: longer than the waits
that end by themselves — in the §6.4.3 bottleneck two team mates stopped side by side in the gap
for up to 29 s before right of way let one go, and moving apart at 10 s sent one of them later
into an island) with a stopped team mate's centre inside their collision distance —
``2·deadlock_s`` for the later name of the two, so that one moves at a time (a hull turning in
place sweeps its ends round: two turning side by side touched) — it sails straight away from that team mate (the first of the directions away, turned by up to
±90° from it, whose leg keeps clear of the mapped statics) to the collision distance plus
``2·replan_margin_m`` from its centre, then goes back onto its mission path where it left it;
while it sails the leg, the conflict with that team mate is not acted on as long as the range
opens (its closest approach is now). From there the usual rules go on (a conflict ahead is
predicted and answered by right of way; a re-plan around a stopped team mate is possible again).
Only in open water: with mapped structure (a static polygon or a static track's outline) within
the leg's reach of the vessel it stays stopped — in the §6.4.3 bottleneck's gap two stopped team
mates turning away from each other touched, and one then sailed into an island — and asks again
after another ``deadlock_s``. World frame ENU, SI units.
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.geometry import distance_to_polygon, point_in_polygon
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


def separation_turn(name: str, mate_name: str) -> int:
    """How many ``deadlock_s`` a vessel named ``name`` waits before it moves away from the team mate
    ``mate_name``: 1 for the earlier name of the two, 2 for the later (one moves at a time)."""
    return 1 if str(name) < str(mate_name) else 2


def separation_detour(t: float, position_m, mate_position_m, reach_m: float, mission_gamma_m: float, static_polygons,
                      static_inflation_m: float):
    """The leg straight away from a team mate at ``mate_position_m`` to ``reach_m`` [m] from its
    centre, as a :class:`~mjasc.avoidance.replanning.Detour` whose end goes back to the mission path
    where the vessel left it (its mission γ stays at ``mission_gamma_m`` [m]); or a reason (str): mapped structure
    (``static_polygons``) within ``reach_m`` of the vessel (open water only), or every direction
    away meeting it grown by ``static_inflation_m``."""
    from mjasc.avoidance.replanning import Detour

    p = np.asarray(position_m, dtype=float)
    q = np.asarray(mate_position_m, dtype=float)
    statics = [np.asarray(s, dtype=float) for s in static_polygons or ()]
    if any(point_in_polygon(p[None], s)[0] or float(distance_to_polygon(p[None], s)[0]) < reach_m for s in statics):
        return f"mapped structure within {reach_m:.1f} m: no way out but in open water"
    away = p - q
    norm = float(np.hypot(*away))
    base = math.atan2(away[1], away[0]) if norm > 1e-6 else 0.0
    for turn in _TURNS_DEG:
        a = base + math.radians(turn)
        escape = q + reach_m * np.array([math.cos(a), math.sin(a)])
        leg = np.linspace(p, escape, max(int(np.ceil(np.hypot(*(escape - p)) / 0.5)), 1) + 1)
        if any(np.any(point_in_polygon(leg, s)) or float(np.min(distance_to_polygon(leg, s))) < static_inflation_m
               for s in statics):
            continue
        lane = Path.from_points(np.array([p, escape]))
        g = float(mission_gamma_m)
        return Detour(lane, lane.length, g, g, np.array([p, escape]), (), None, t)
    return "every way out meets a mapped static obstacle"
