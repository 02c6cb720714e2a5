"""Triage: what one vessel can do about each conflict of a prediction (docs/avoidance.md, Decisions).

:func:`triage` takes the conflicts with a predicted collision and sorts each into what answers it,
by the rules in this order:

* **Traffic rule** (``traffic_rule = "colreg"``, strangers only): a stand-on vessel (crossing from
  port, being overtaken) keeps course and speed until the collision is ``stand_on_s`` away; head-on
  → a lane change to starboard (:attr:`Triage.starboard`); crossing give-way → slow down and pass
  astern, never ahead (else go around).
* **Re-plan** (decision σ = REPLAN, strangers): go around the conflict's SVO
  (:attr:`Triage.svos`, :attr:`Triage.go_around`).
* **A stranger overtaking from abaft the beam**: leave its lane (go around; :attr:`Triage.overtaken`
  — the caller speeds up or stops when no lane can be left). Slowing down would let it close faster.
* **Right of way between team mates** (:func:`~mjasc.avoidance.right_of_way.gives_way`): the
  stand-on vessel keeps its speed until ``last_resort_s``; at the last resort, with the give-way
  vessel coming up from abaft its beam (:func:`closing_from_astern`), it may only speed up. A team
  mate that already gives way to this vessel (its fresh broadcast says so: ``mates_giving_way``)
  makes it the stand-on vessel whatever the geometry says now (each vessel decides from its own
  view at its own time, and a decision taken seconds after the mate's, on a geometry the mate's
  yield has changed, could make both give way and both crawl through the crossing) — unless it is
  itself already yielding to that mate, or that mate is stopped forward of its beam
  (:func:`stopped_ahead`): a give-way vessel that has taken all way off there is in the way, and
  standing on toward it sailed into it (thesis §6.4.3 under 30 % dropout and packet loss, seeds 70
  and 234), so the vessel gives way as the geometry says. The
  other way round, two team mates that both find themselves stand-on (each reads the other's
  course against its own bow: in a cross current a crabbing pair can; or one reads the other abaft
  its beam, rule 13, and the other reads it on its port bow, rule 15) and both say so in their
  broadcasts (``mates_standing_on``; a vessel standing on at the last resort toward a mate coming
  up from abaft its beam says so too): the one whose name sorts after the other's gives way.
* **Velocity correction** (:func:`~mjasc.avoidance.decision.velocity_correction_for`): yield, or pass
  first (a pass already running goes on while feasible). Neither → :attr:`Triage.unresolved`, and
  the vessel goes around the track's swept area — except a give-way vessel around a team mate, which
  stops instead (in the §6.4.3 bottleneck such detours began with a U-turn the hull could not sail).

Static conflicts are always gone around. Pure: the stats to count and the events to emit come back
in :attr:`Triage.notes`, and each conflict's answer as a short text in :attr:`Triage.roles` (the
recording's threat panel shows it); world frame ENU, SI units, absolute times [s].
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from mjasc.avoidance.decision import Correction, velocity_correction_for
from mjasc.avoidance.prediction import Decision, PredictedConflict
from mjasc.avoidance.replanning import swept_area
from mjasc.avoidance.right_of_way import OVERTAKING_BEARING_RAD, gives_way, relative_bearing
from mjasc.avoidance.separation import STOPPED_M_S, mate_speed_m_s
from mjasc.evaluation.colreg import ColregConfig, classify

__all__ = ["Triage", "triage", "swept", "stopped_ahead", "overtaking_us", "closing_from_astern", "colreg_role"]

#: The roles of a conflict the prediction found: risk of collision is established (a manoeuvring
#: target's predicted path may meet the vessel where straight lines pass wide), so classify's
#: straight-line CPA gate (``risk_cpa_m``) is opened wide.
_PREDICTED_RISK = ColregConfig(risk_cpa_m=1e12)


@dataclass
class Triage:
    """One prediction's conflicts sorted by what answers them (module docstring)."""

    candidates: list[Correction] = field(default_factory=list)  # velocity corrections that clear a conflict
    svos: list[tuple] = field(default_factory=list)  # (polygon, conflict) to go around
    unresolved: list[PredictedConflict] = field(default_factory=list)  # neither yield nor pass
    starboard: list[PredictedConflict] = field(default_factory=list)  # head-on under COLREG: lane change
    go_around: list[PredictedConflict] = field(default_factory=list)  # σ chose a re-plan (long obstructions)
    overtaken: list[PredictedConflict] = field(default_factory=list)  # strangers from abaft the beam
    notes: list[tuple[str | None, str]] = field(default_factory=list)  # (stat to count or None, event)
    roles: dict = field(default_factory=dict)  # track id → its COLREG / team role and answer (text)
    no_pass: set = field(default_factory=set)  # track ids a pass first would break the COLREG role toward
    # (crossing give-way: never ahead, rule 15; stand-on before stand_on_s: keep the speed, rule 17)
    give_way_mates: set = field(default_factory=set)  # track ids of team mates this vessel gives way to
    stand_on_mates: set = field(default_factory=set)  # names of team mates it stands on toward (before the last
    # resort, and at it toward a give-way mate coming up from abaft the beam: it keeps its speed or speeds up)


def swept(track, c: PredictedConflict, t: float, cfg) -> np.ndarray:
    """The area ``track`` sweeps over the conflict's obstruction (from now on; a static one's
    t_f = ∞ is cut at t_i + Δt_threshold), grown by its collision distance: the obstacle a
    re-plan or lane change goes around when the conflict's own SVO is not the one to use."""
    t_f = c.t_f if np.isfinite(c.t_f) else c.t_i + cfg.obstruction_threshold_s
    return swept_area(track, max(c.t_i, t), max(t_f, t + 1.0), c.collision_distance_m)


def stopped_ahead(nav, track) -> bool:
    """The team mate ``track`` is stopped (its broadcast velocity below
    :data:`~mjasc.avoidance.separation.STOPPED_M_S`) forward of the vessel's beam: a give-way
    vessel that has taken all way off there keeps out of nobody's way, and a vessel standing on
    toward it would sail into it."""
    if mate_speed_m_s(track) >= STOPPED_M_S:
        return False
    return bool(np.cos(relative_bearing(nav.position_m, nav.heading_rad, track.position_m)) > 0.0)


def overtaking_us(nav, track) -> bool:
    """The track comes up from abaft the vessel's beam and is faster along the vessel's course:
    it is overtaking (COLREG rule 13), and the vessel slowing down would only close the gap faster."""
    bearing = relative_bearing(nav.position_m, nav.heading_rad, track.position_m)
    if abs(bearing) < OVERTAKING_BEARING_RAD:
        return False
    course = np.array([np.cos(nav.heading_rad), np.sin(nav.heading_rad)])
    v_track = track.speed_m_s * np.array([np.cos(track.heading_rad), np.sin(track.heading_rad)])
    return bool(v_track @ course > float(np.hypot(*np.asarray(nav.velocity_m_s, dtype=float)[:2])))


def closing_from_astern(nav, track, t: float, static_speed_m_s: float) -> bool:
    """The track moves toward the vessel faster than ``static_speed_m_s`` [m/s] at time t [s]: its
    predicted motion over the next second
    (:meth:`~mjasc.core.estimates.TrackEstimate.predict_positions`; a team mate's broadcast plan
    for a :class:`~mjasc.core.estimates.PlannedTrack`, whose ``speed_m_s`` is the plan's largest
    speed, not its speed now), along the line from it to the vessel. The vessel slowing down would
    let it run into the vessel. A team mate stopped or creeping abaft the beam does not: there it
    is the vessel that closes on it."""
    los = np.asarray(nav.position_m, dtype=float)[:2] - np.asarray(track.position_m, dtype=float)[:2]
    dist = float(np.hypot(los[0], los[1]))
    if dist == 0.0:
        return True
    p = np.asarray(track.predict_positions(np.array([t, t + 1.0])), dtype=float)
    v = p[1] - p[0]  # [m/s]
    return bool((v[0] * los[0] + v[1] * los[1]) / dist > static_speed_m_s)


def colreg_role(nav, track, traffic_rule: str) -> str | None:
    """The vessel's COLREG role towards a stranger's track (:func:`mjasc.evaluation.colreg.classify`,
    the geometry the evaluation judges by: the vessel's course over ground — its heading only when it
    barely moves — and the track's estimated course), or None under the thesis rule. (The heading is not
    the course: in a cross current the bow is crabbed into the stream, up to tens of degrees at yield
    speeds, and a head-on meeting read as a crossing.)"""
    if traffic_rule != "colreg":
        return None
    v = np.asarray(nav.velocity_m_s, dtype=float)[:2]
    speed = float(np.hypot(v[0], v[1]))
    course = math.atan2(v[1], v[0]) if speed > 0.1 else float(nav.heading_rad)
    role = classify(nav.position_m, course, speed, track.position_m, track.heading_rad, track.speed_m_s,
                    _PREDICTED_RISK)
    return None if role == "none" else role


def triage(t: float, nav, gamma: float, conflicts, statics, by_id: dict, team: set, cfg, speed_max_m_s: float,
           running: Correction | None, mates_giving_way=frozenset(), mates_standing_on=frozenset(),
           own_name: str = "", path_end_m: float = math.inf) -> Triage:
    """Sort ``conflicts`` (with a predicted collision) and ``statics`` (static conflicts) of a
    vessel at ``nav`` and γ = ``gamma`` [m] at time t (module docstring). by_id: track id → track
    as predicted; team: the team mates' names; cfg: the
    :class:`~mjasc.avoidance.config.AvoidanceConfig`; running: the correction running now;
    mates_giving_way / mates_standing_on: the team mates whose fresh broadcast says they give way
    to / stand on toward this vessel (named ``own_name``); path_end_m: the length [m] of the path
    γ runs on (no pass first beyond it: :func:`~mjasc.avoidance.decision.velocity_correction_for`)."""
    out = Triage()
    for c in conflicts:
        track = by_id.get(c.track_id)
        is_team = track is not None and track.team_member in team and not c.is_static
        role = colreg_role(nav, track, cfg.traffic_rule) if not is_team and track is not None and not c.is_static \
            else None
        if role in ("crossing_stand_on", "overtaken") and c.t_closest_s - t > cfg.stand_on_s:
            out.no_pass.add(c.track_id)
            out.roles[c.track_id] = f"stand-on ({role.replace('_stand_on', '')}): keeps course and speed"
            out.notes.append(("stand_on", f"stand-on vessel ({role.replace('_', ' ')}) towards track {c.track_id}: "
                                          f"keeps course and speed (COLREG rule 17) until the collision is "
                                          f"{cfg.stand_on_s:g} s away"))
            continue
        if role == "head_on":
            out.roles[c.track_id] = "head-on: lane change to starboard"
            out.starboard.append(c)
            continue
        if role == "crossing_give_way":  # slow down and pass astern; never cross ahead (rule 15)
            out.no_pass.add(c.track_id)
            corr = velocity_correction_for(t, gamma, c, replace(cfg, allow_pass_first=False), speed_max_m_s)
            if corr is not None:
                out.candidates.append(corr)
            else:
                out.svos.append((swept(track, c, t, cfg), c))
            out.roles[c.track_id] = "give-way (crossing): " + ("slow down, pass astern" if corr is not None
                                                                else "go around")
            continue
        if c.decision == Decision.REPLAN and not is_team:
            out.roles[c.track_id] = "long obstruction: re-plan around it" + (f" ({role.replace('_', ' ')})"
                                                                               if role else "")
            out.svos.append((c.svo_polygon, c))
            if not c.is_static:
                out.go_around.append(c)
            continue
        if not is_team and track is not None and not c.is_static and overtaking_us(nav, track):
            out.svos.append((swept(track, c, t, cfg), c))  # leave its lane: slowing lets it close faster
            out.overtaken.append(c)
            out.roles[c.track_id] = "being overtaken: leave its lane"
            continue
        team_gives_way = is_team and gives_way(nav.position_m, nav.heading_rad, track.position_m,
                                               track.heading_rad, True)
        if team_gives_way and track.team_member in mates_giving_way and not (
                running is not None and running.kind == "yield" and running.track_id == c.track_id):
            if stopped_ahead(nav, track):  # standing on would run into it (module docstring)
                out.notes.append(("stopped_mate_ahead", f"team mate {track.team_member} gives way to this vessel "
                                                        f"(its broadcast) but is stopped ahead: this vessel gives "
                                                        f"way too"))
            else:
                team_gives_way = False  # the mate gives way already: this vessel stands on (module docstring)
                out.notes.append((None, f"team mate {track.team_member} gives way to this vessel (its broadcast): "
                                        f"stand-on"))
        elif is_team and not team_gives_way and track.team_member in mates_standing_on and \
                own_name > track.team_member:
            team_gives_way = True  # both stand on: the later name gives way (module docstring)
            out.notes.append((None, f"team mate {track.team_member} stands on toward this vessel too (its "
                                    f"broadcast): this vessel gives way"))
        if team_gives_way:
            out.give_way_mates.add(c.track_id)
        if is_team and not team_gives_way:
            astern = np.cos(relative_bearing(nav.position_m, nav.heading_rad, track.position_m)) < 0.0
            if c.t_closest_s - t > cfg.last_resort_s:
                out.stand_on_mates.add(track.team_member)
                out.roles[c.track_id] = "team right of way: stand-on, keeps its speed"
                out.notes.append(("stand_on", f"stand-on vessel towards team mate {track.team_member}: "
                                              f"keeps its speed"))
                continue
            if astern and closing_from_astern(nav, track, t, cfg.static_speed_m_s):
                # last resort with the give-way vessel coming up from abaft the beam: never slow down (it still
                # stands on, and says so: a mate that stands on toward it too learns that it gives way)
                out.stand_on_mates.add(track.team_member)
                corr = velocity_correction_for(t, gamma, c, cfg, speed_max_m_s, pass_only=True, path_end_m=path_end_m)
                if corr is not None:
                    out.candidates.append(corr)
                else:
                    out.notes.append(("stand_on", f"stand-on vessel towards team mate {track.team_member} "
                                                  f"(abaft the beam): keeps its speed"))
                out.roles[c.track_id] = "team right of way: stand-on, last resort: " + (
                    "speed up" if corr is not None else "keeps its speed")
                continue
        passing = running is not None and running.kind == "pass" and running.track_id == c.track_id
        corr = velocity_correction_for(t, gamma, c, cfg, speed_max_m_s, passing=passing, path_end_m=path_end_m)
        if corr is not None:
            out.candidates.append(corr)
        else:
            out.unresolved.append(c)
        who = "team right of way: give-way, " if team_gives_way else \
            (f"{role.replace('_', ' ')}: " if role else "")
        out.roles[c.track_id] = who + ({"yield": "yield (slow down)", "pass": "pass first (speed up)"}[corr.kind]
                                       if corr is not None else "unresolved: " + ("stop" if team_gives_way
                                                                                  else "go around"))
        # Neither slowing down nor speeding up works: go around — except a give-way vessel around
        # a team mate (it stops instead).
        if corr is None and track is not None and not team_gives_way:
            out.svos.append((swept(track, c, t, cfg), c))
    for s in statics:
        out.svos.append((s.polygon, s))
        if s.track_id is not None:
            out.roles[s.track_id] = "static: go around its outline"
    return out
