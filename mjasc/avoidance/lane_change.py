"""Lane change: step sideways off the mission path while a threat passes along it, then step back.

The potential-field detour (:mod:`~mjasc.avoidance.replanning`) goes *around* a static virtual
obstacle: the area the threat sweeps over the obstruction interval. That area cannot be gone around
when it covers the vessel's own position for the whole interval — a vessel coming up from astern on
(nearly) the same line, which is being overtaken, or one coming head-on whose lane the vessel is
in. Slowing down does not help either (an overtaking vessel closes all the faster; the thesis's
"always yield" slowed the vessel into the collision in the campaign's ``overtaken`` family). What
clears such a threat is to leave its lane: a **parallel offset** of the mission path.

Geometry (world ENU, metres; e is the signed cross-track offset from the mission path, positive
to port/left of the direction of travel):

* every conflicting track's predicted centres c_k over [now, t_f + hold] that project onto the
  stretch of the mission path the lane covers give e_k; the lane's offset o must keep
  |o − e_k| ≥ D = R_col + ``replan_margin_m`` + ``correction_margin_m`` for every k, so
  o_port = max(max_k e_k + D, 0) or o_starboard = min(min_k e_k − D, 0);
* the side needing the smaller |o| is taken, starboard on a tie within 1 m (COLREG rule 8's
  "readily apparent" action, and rules 14–15's turn to starboard); a side whose lane comes closer
  than the static inflation to a mapped static polygon is refused; |o| is at most ``max_offset_m``;
* the offset ramps in from the vessel's present cross-track offset e_0 with a smoothstep over
  L_in = clip(4|o − e_0|, 10 m, what the vessel sails before the obstruction starts), holds until
  the vessel's planned γ at t_f plus ``goal_margin_m``, and ramps out over L_out = max(4|o|, 10 m).

**Crossing threats.** A lane leaves the track of a threat that moves along the path. A threat
crossing it (its predicted course more than ``CROSSING_DEG`` = 45° off the path's line, either way)
sweeps across every parallel lane too: its offsets span the lane's whole width, and when its
obstruction is short the offset is small enough to take but ramps in over a few metres, a lane that
races the threat across its own track. No lane is planned for such a threat; the vessel slows or
stops instead (the decision's emergency stop). (``tasks/shared_perception_occluded.toml`` without
sharing: a ship emerging from behind an island 12 m off the path, crossing it at 1.2 m/s; the lane
change to starboard ran alpha down the ship's track and it was hit.)

The result is a :class:`~mjasc.avoidance.replanning.Detour` (``field`` None): the vessel's
prediction then runs along it exactly as along a streamline, and the usual end-of-detour logic
returns it to the mission path.

**Held lane** (``hold_past_end``: a station-keeping leg, whose line runs through a moving station
and whose end is no destination). When the obstruction outlasts the mission path — the vessel, at
its planned speed, would reach the path's end before t_f — and the path ends inside the threat's
swept area, stepping back onto it would sail into the threat. The path is then continued straight
along its last course for the whole hold
(to the vessel's planned γ at t_f plus ``goal_margin_m``, at least ``_MIN_ROOM_M`` past the
vessel), the offset is reached within it and held to its end without stepping back, threat
centres up to the clearance beyond that end count too, and the detour is not left before t_f
(``Detour.hold_until_s``). (tests/cas_regressions/target_tracking_current_16.toml: a
station-keeping leader 9 m from the end of its line, a ferry coming down the line.)
"""

from __future__ import annotations

import numpy as np

from mjasc.core.geometry import points_near_polygon
from mjasc.guidance.paths import Path

__all__ = ["lane_offsets", "plan_lane_change"]

#: Starboard is preferred unless port needs this much less offset [m].
_STARBOARD_BIAS_M = 1.0
#: The least room [m] a held lane (module docstring) gets to step aside in past the vessel.
_MIN_ROOM_M = 10.0
#: A threat whose predicted course is further than this off the path's line (and than this from its
#: reverse) crosses the path: no lane leaves its track [deg] (module docstring).
CROSSING_DEG = 45.0
#: ... counted only when its predicted centres move more than this over the prediction [m].
_CROSSING_MIN_M = 2.0


def _ends_inside(mission: Path, t: float, conflicts) -> bool:
    """Whether a threat's predicted centre comes within its collision distance of the path's end
    from time t on: the path ends inside the threat's swept area."""
    end = mission.point(mission.length)
    for c in conflicts:
        keep = c.times >= t - 1e-9
        pts = np.asarray(c.obstacle_positions, dtype=float)[keep]
        if pts.size and float(np.min(np.hypot(*(pts - end).T))) <= c.collision_distance_m:
            return True
    return False


def _extended(mission: Path, length_m: float) -> Path:
    """``mission`` continued straight along its final course by ``length_m`` [m]."""
    end = mission.point(mission.length)
    th = float(mission.tangent_angle(mission.length))
    return mission.concatenate(Path.line(end, end + length_m * np.array([np.cos(th), np.sin(th)])))


def _signed_offsets(mission: Path, points: np.ndarray, g_lo: float, g_hi: float):
    """(γ (n,), signed cross-track offset e (n,) [m], port positive) of ``points`` against the
    stretch [g_lo, g_hi] of ``mission``."""
    g, d = mission.closest_points(points, g_lo, g_hi)
    th = mission.tangent_angle(g)
    rel = points - mission.point(g)
    side = -rel[:, 0] * np.sin(th) + rel[:, 1] * np.cos(th)
    return g, np.where(side >= 0.0, d, -d)


def lane_offsets(e_threat: np.ndarray, clearance_m: float) -> tuple[float, float]:
    """The least port (≥ 0) and starboard (≤ 0) offsets [m] that keep ``clearance_m`` from every
    threat offset in ``e_threat`` (any shape; empty → 0, 0)."""
    e = np.asarray(e_threat, dtype=float).ravel()
    if e.size == 0:
        return 0.0, 0.0
    return max(float(e.max()) + clearance_m, 0.0), min(float(e.min()) - clearance_m, 0.0)


def _ramp(x):
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def _crossing(mission: Path, g_now_m: float, conflicts, team_ids=frozenset()) -> tuple[int, float] | None:
    """The first conflict whose threat crosses the path — its predicted centres move more than
    ``_CROSSING_MIN_M`` over the prediction, on a course between ``CROSSING_DEG`` and 180° −
    ``CROSSING_DEG`` off the path's line at the vessel — as (track id, that angle [deg]); None when
    every threat moves along the path (or hardly moves). Team mates (track ids in ``team_ids``) do
    not count: their predicted centres follow their broadcast plans, which resume the mission after
    a stop, and two team mates deployed across each other's transits, each refusing the lane
    because of the other's plan, stopped side by side and drifted together (the go-to-formation
    deployments' run 5); right of way settles team mates."""
    th = float(mission.tangent_angle(np.array([g_now_m]))[0])
    lo, hi = np.radians(CROSSING_DEG), np.radians(180.0 - CROSSING_DEG)
    for c in conflicts:
        if c.track_id in team_ids:
            continue
        pts = np.asarray(c.obstacle_positions, dtype=float)
        if len(pts) < 2:
            continue
        d = pts[-1] - pts[0]
        if np.hypot(*d) <= _CROSSING_MIN_M:
            continue
        off = abs((np.arctan2(d[1], d[0]) - th + np.pi) % (2.0 * np.pi) - np.pi)
        if lo < off < hi:
            return int(c.track_id), float(np.degrees(off))
    return None


def plan_lane_change(t: float, start, mission: Path, g_now_m: float, speed_m_s: float, conflicts, static_polygons,
                     cfg, static_inflation_m: float, max_offset_m: float = 30.0, starboard_only: bool = False,
                     hold_past_end: bool = False, team_ids=frozenset()):
    """The lane change for ``conflicts`` (:class:`~mjasc.avoidance.prediction.PredictedConflict`
    with a collision, dynamic tracks), or the reason there is none (a string).

    start (2,): the vessel's position [m]; mission: its mission path, on which it is at
    ``g_now_m``; speed_m_s: its planned speed [m/s]; static_polygons: mapped static polygons
    (grown here by ``static_inflation_m``); cfg: the
    :class:`~mjasc.avoidance.config.AvoidanceConfig`; starboard_only: only a starboard offset
    (COLREG rule 14, head-on: both alter course to starboard); hold_past_end: the path's end is
    no destination (a station-keeping leg's line through a moving station): the lane may be held
    past it (module docstring). A held lane that cannot be taken — its continuation meets mapped
    structure, say — leaves the lane that steps back at the path's end, as without the hold.
    team_ids: the conflicts' track ids that are team mates (never a crossing threat here)."""
    crossing = _crossing(mission, g_now_m, conflicts, team_ids)
    if crossing is not None:
        return f"track {crossing[0]} crosses the path ({crossing[1]:.0f}° off its line): no lane leaves its track"
    args = (t, start, mission, g_now_m, speed_m_s, conflicts, static_polygons, cfg, static_inflation_m,
            max_offset_m, starboard_only)
    out, held = _plan(*args, hold=hold_past_end)
    return _plan(*args, hold=False)[0] if held and isinstance(out, str) else out


def _plan(t, start, mission, g_now_m, speed_m_s, conflicts, static_polygons, cfg, static_inflation_m, max_offset_m,
          starboard_only, hold) -> tuple:
    """:func:`plan_lane_change`'s answer, with a held lane where the obstruction outlasts the path
    when ``hold``; and whether the lane was a held one."""
    start = np.asarray(start, dtype=float)
    v = max(float(speed_m_s), 0.3)
    g_now = float(g_now_m)
    t_f = max((c.t_f if np.isfinite(c.t_f) else c.t_i + cfg.obstruction_threshold_s) for c in conflicts)
    t_i = min(c.t_i for c in conflicts)
    mission_end = mission.length
    held = hold and g_now + v * max(t_f - t, 0.0) >= mission_end and _ends_inside(mission, t, conflicts)
    if held:  # the lane runs on past the path's end, straight, for the whole hold (module docstring)
        mission = _extended(mission, max(g_now + v * max(t_f - t, 0.0) + cfg.goal_margin_m - mission_end,
                                         _MIN_ROOM_M - (mission_end - g_now)))
    g_hold_end = min(g_now + v * max(t_f - t, 0.0) + cfg.goal_margin_m, mission.length)
    l_out_max = 10.0 + 4.0 * max_offset_m
    g_hi = min(g_hold_end + l_out_max, mission.length)
    if g_hi - g_now < 5.0:
        return "too close to the end of the mission path for a lane change", held
    d_clear = max(c.collision_distance_m for c in conflicts) + cfg.replan_margin_m + cfg.correction_margin_m
    # a held lane's end is where the vessel waits: threat centres up to d_clear beyond it count too
    # (measured against the path continued straight: clamped to its end they would not)
    beyond = d_clear if held else 0.0
    geo = _extended(mission, beyond) if held else mission
    threat = []
    for c in conflicts:
        keep = (c.times >= t - 1e-9) & (c.times <= t_f + 5.0)
        pts = np.asarray(c.obstacle_positions, dtype=float)[keep]
        if pts.size == 0:
            continue
        g, e = _signed_offsets(geo, pts, g_now, g_hi + beyond)
        inside = (g > g_now + 1e-6) & (g < g_hi + beyond - 1e-6)  # threat centres alongside the lane
        threat.append(e[inside])
    e_threat = np.concatenate(threat) if threat else np.zeros(0)
    _, e_now = _signed_offsets(mission, start[None], max(g_now - 5.0, 0.0), min(g_now + 5.0, mission.length))
    e0 = float(e_now[0])
    port, starboard = lane_offsets(e_threat, d_clear)
    sides = [starboard, port] if abs(starboard) <= abs(port) + _STARBOARD_BIAS_M else [port, starboard]
    if starboard_only:
        sides = [starboard]
    statics = [np.asarray(p, dtype=float) for p in static_polygons or ()]
    reasons, late = [], []
    for o in sides:
        if abs(o) > max_offset_m:
            reasons.append(f"{'port' if o > 0 else 'starboard'} offset {abs(o):.1f} m > {max_offset_m:g} m")
            continue
        l_in = float(np.clip(4.0 * abs(o - e0), 10.0, max(v * (t_i - t) * 0.8, 10.0)))
        if held:  # the offset is reached by the path's end (a short line: a station's)
            l_in = min(l_in, mission.length - g_now)
        l_out = max(4.0 * abs(o), 10.0)
        g_end = min(max(g_hold_end, g_now + l_in) + l_out, mission.length)
        g = np.linspace(g_now, g_end, max(int(np.ceil(g_end - g_now)), 1) + 1)  # about every metre
        s = g - g_now
        offset = e0 + (o - e0) * _ramp(s / l_in)
        if g_end < mission.length - 1e-6:  # step back onto the mission path before its goal
            offset = offset * (1.0 - _ramp((s - (g_end - g_now - l_out)) / l_out))
        th = mission.tangent_angle(g)
        pts = mission.point(g) + offset[:, None] * np.stack([-np.sin(th), np.cos(th)], axis=1)
        pts[0] = start
        blocked = next((p for p in statics if points_near_polygon(pts, p, static_inflation_m)), None)
        if blocked is not None:
            reasons.append(f"the {'port' if o > 0 else 'starboard'} lane meets a static obstacle")
            continue
        keep = np.concatenate([np.hypot(*np.diff(pts, axis=0).T) > 0.05, [True]])  # the end joins the mission
        pts = pts[keep]
        lane = Path.from_points(pts)
        margin = _timed_margin(lane, v, t, conflicts)
        if margin < 0.0:  # the threat arrives before the vessel is out of its lane
            reasons.append(f"the {'port' if o > 0 else 'starboard'} lane is reached too late "
                           f"({-margin:.1f} m short)")
            late.append((margin, lane, pts, g_end))
            continue
        return _detour(lane, mission, g_now, g_end, pts, t, t_f if held else -np.inf, mission_end), held
    if late:  # none is clear in time: the one that comes closest to it, if it beats staying on the path
        margin, lane, pts, g_end = max(late, key=lambda x: x[0])
        if margin > max(c.min_distance_m - c.collision_distance_m for c in conflicts) + 1.0:
            return _detour(lane, mission, g_now, g_end, pts, t, t_f if held else -np.inf, mission_end), held
    return "no lane change: " + "; ".join(reasons), held


def _detour(lane: Path, mission: Path, g_now: float, g_end: float, pts: np.ndarray, t: float, hold_until_s: float,
            mission_end: float):
    """The lane as a :class:`~mjasc.avoidance.replanning.Detour` (``mission`` possibly continued
    past its end ``mission_end`` [m]). A held lane (the obstruction outlasts the mission path: a
    station-keeping leg's short line) ends beside the path's end, out of the threat's lane, and is
    not left before ``hold_until_s`` = t_f: back on the mission path earlier the vessel would make
    for the path's end inside the swept area (a station-keeping leader rejoined at its station in
    a crossing ferry's track and was hit: tests/cas_regressions/target_tracking_current_16.toml)."""
    from mjasc.avoidance.replanning import Detour

    if g_end < mission.length - 1e-6:
        return Detour(lane.concatenate(mission.sub_path(g_end, mission.length)), lane.length, g_now, g_end, pts, (),
                      None, t)
    return Detour(lane, lane.length, g_now, min(g_end, mission_end), pts, (), None, t,
                  hold_until_s=float(hold_until_s))


def _timed_margin(lane: Path, speed_m_s: float, t: float, conflicts) -> float:
    """The least (distance − collision distance) [m] between the vessel sailing ``lane`` at
    ``speed_m_s`` from time ``t`` and every conflict's predicted track centres on its time grid."""
    worst = np.inf
    for c in conflicts:
        keep = c.times >= t - 1e-9
        ts = c.times[keep]
        if ts.size == 0:
            continue
        own = lane.point(np.clip(speed_m_s * (ts - t), 0.0, lane.length))
        d = np.hypot(*(own - np.asarray(c.obstacle_positions, dtype=float)[keep]).T)
        worst = min(worst, float(np.min(d)) - c.collision_distance_m)
    return worst
