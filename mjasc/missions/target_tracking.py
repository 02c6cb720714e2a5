"""Cooperative target tracking: the team keeps stations around a moving target it senses itself.

The target (a boat, a tagged animal: anything that moves) is never read from the simulator.
The **leader** designates it among its own confirmed tracks — the non-team, non-static track
nearest ``target_hint_m`` within ``designation_gate_m`` (heading for the hint until one is), never
one ever labelled a team mate — keeps that track's id, and when the track is lost takes the
nearest track within ``reacquire_gate_m`` of where the target should be now.
It broadcasts its estimate (:class:`~mjasc.missions.legs.TargetEstimate`) with every team
message; the **followers** use the newest estimate they have heard, extrapolated at constant
velocity over the link's delay. An estimate older than ``max_estimate_age_s`` counts as the
target out of track.

Station keeping, per vessel, from the estimate (position p_T, velocity v_T, course χ_T):

    s      = p_T + R(χ_T) o_i                     the station: offset o_i = [ahead, to port] in the target's frame
    path   = the line through s along χ_T         re-drawn every ``replan_period_s`` (in mission mode only),
                                                  ending |v_T| ``line_ahead_s`` + 5 m ahead of s
    e_a    = (s − p) · (cos χ_T, sin χ_T)         along-course station error [m]
    v_s    = |v_T| − ω_T o_port                    the station's along-course speed (ω_T the target's turn
                                                  rate: ṡ = v_T + ω_T J R(χ_T) o, J the 90° rotation)
    v_ref  = clip(v_s + k e_a, 0, v_max)          k = ``speed_gain_1_s``

The path follower's line-of-sight law brings the vessel onto the line, the speed law onto the
station; collision avoidance may override both (a detour, a slow-down) and the mission resumes.
When the target is slower than 0.3 m/s its course is held (a drifting target has none).
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.guidance.paths import Path
from mjasc.missions.config import TrackTargetOptions
from mjasc.missions.legs import MissionBroadcast, MissionLeg, PhaseInputs, TargetEstimate

__all__ = ["designate_target", "station", "TrackTarget"]

_SLOW_M_S = 0.3
"""Below this speed a target's course is not trusted (the last course is kept)."""


def _candidates(report):
    if report is None:
        return []
    return [tr for tr in report.tracks if tr.team_member is None and not tr.is_static]


def designate_target(report, around_m, gate_m: float = math.inf, keep_id: int | None = None,
                     team_ids=frozenset()):
    """The track that is the target: the one with id ``keep_id`` if still tracked, else the
    non-team, non-static confirmed track nearest ``around_m`` (2,) within ``gate_m`` [m] whose id
    is not in ``team_ids`` (tracks once labelled a team mate: when a mate slows down, the label can
    pass to a new track while the old one coasts on, unlabelled, until it is dropped); None."""
    tracks = _candidates(report)
    if keep_id is not None:
        for tr in tracks:
            if tr.track_id == keep_id:
                return tr
    best, best_d = None, gate_m
    for tr in (tr for tr in tracks if tr.track_id not in team_ids):
        d = math.hypot(tr.position_m[0] - around_m[0], tr.position_m[1] - around_m[1])
        if d <= best_d:
            best, best_d = tr, d
    return best


def station(target_m, course_rad: float, offset_m) -> np.ndarray:
    """The station (2,) [m] at ``offset_m`` = [ahead, to port] in the frame of a target at
    ``target_m`` on ``course_rad``."""
    c, s = math.cos(course_rad), math.sin(course_rad)
    return np.array([target_m[0] + c * offset_m[0] - s * offset_m[1], target_m[1] + s * offset_m[0] + c * offset_m[1]])


class TrackTarget:
    """The target-tracking phase of one vessel (see the module docstring)."""

    name = "track_target"

    def __init__(self, index: int, options: TrackTargetOptions, vessel_name: str, offset_m, cruise_speed_m_s: float,
                 top_speed_m_s: float):
        self.index = index
        self.options = options
        self.vessel_name = vessel_name
        self.is_leader = vessel_name == options.leader
        self.offset_m = np.asarray(offset_m, dtype=float)
        self.cruise_m_s = float(cruise_speed_m_s)
        self.top_m_s = float(top_speed_m_s)
        self.estimate: TargetEstimate | None = None
        self.course_rad: float | None = None
        self.t0_s = 0.0
        self._last_t: float | None = None
        self._last_replan_s = -math.inf
        self._speed = self.cruise_m_s
        self._path: Path | None = None
        self.first_estimate_s: float | None = None
        self.in_track_s = 0.0
        self.out_of_track_s = 0.0
        self.longest_gap_s = 0.0
        self._gap_s = 0.0
        self.reacquired = 0
        self.team_track_ids: set[int] = set()  # own tracks ever labelled a team mate (never the target)
        self._errors: list[tuple[float, float, float]] = []  # (station error, along, standoff) after settling
        self.events: list[tuple[float, str]] = []

    def note_team_tracks(self, report) -> None:
        """Remember the ids of the tracks labelled a team mate (every tick, in every phase)."""
        if report is not None:
            self.team_track_ids.update(tr.track_id for tr in report.tracks if tr.team_member is not None)

    # ------------------------------------------------------------------ the target's estimate
    def own_estimate(self, t_s: float, report, vessel_name: str) -> TargetEstimate | None:
        """The leader's estimate from its own tracks (None when it has none)."""
        o = self.options
        keep = self.estimate.track_id if self.estimate is not None else None
        around = self.estimate.position_at(t_s) if self.estimate is not None else o.target_hint_m
        gate = o.reacquire_gate_m if self.estimate is not None else o.designation_gate_m
        tr = designate_target(report, around, gate, keep, self.team_track_ids)
        if tr is None:
            return None
        if keep is None:
            self.events.append((t_s, f"mission: target designated (track {tr.track_id})"))
        elif tr.track_id != keep:
            self.reacquired += 1
            self.events.append((t_s, f"mission: target re-acquired (track {keep} → {tr.track_id})"))
        v = (tr.speed_m_s * math.cos(tr.heading_rad), tr.speed_m_s * math.sin(tr.heading_rad))
        return TargetEstimate(float(tr.time_s), np.array(tr.position_m[:2], dtype=float), np.array(v), tr.track_id,
                              vessel_name, float(tr.turn_rate_rad_s))

    def _update_estimate(self, t_s: float, report, mates: dict) -> None:
        if self.is_leader:
            est = self.own_estimate(t_s, report, self.vessel_name)
        else:
            b = mates.get(self.options.leader)
            est = b.target if b is not None else None
        if est is not None and (self.estimate is None or est.time_s >= self.estimate.time_s):
            self.estimate = est
            if self.first_estimate_s is None:
                self.first_estimate_s = float(t_s)
            if est.speed_m_s >= _SLOW_M_S or self.course_rad is None:
                self.course_rad = float(math.atan2(est.velocity_m_s[1], est.velocity_m_s[0]))

    # ------------------------------------------------------------------ the phase
    def begin(self, t_s: float, nav) -> MissionLeg:
        """Start: towards the station around the target's expected position (its course taken as
        the bearing from the vessel) at cruise speed, until an estimate exists."""
        self.t0_s = self._last_t = float(t_s)
        p = np.asarray(nav.position_m[:2], dtype=float)
        hint = self.options.target_hint_m
        d = hint - p
        bearing = float(math.atan2(d[1], d[0])) if math.hypot(*d) > 1.0 else float(nav.heading_rad)
        goal = station(hint, bearing, self.offset_m)
        if math.hypot(*(goal - p)) < 1.0:
            goal = p + 20.0 * np.array([math.cos(bearing), math.sin(bearing)])
        self._path = Path.line(p, goal)
        return MissionLeg(self.name, self.index, self._path, 0.0, self.cruise_m_s, coordinated=False,
                          station_keeping=True)

    def broadcast(self) -> MissionBroadcast:
        """The leader's estimate goes out with its messages (followers send none)."""
        return MissionBroadcast(self.index, target=self.estimate if self.is_leader else None)

    def step(self, x: PhaseInputs) -> tuple[MissionLeg | None, bool]:
        """(a new leg — a re-drawn line or a new speed —, whether the phase's time is up)."""
        t_s, nav, in_mission = x.t_s, x.nav, x.in_mission
        o = self.options
        dt = t_s - self._last_t if self._last_t is not None else 0.0
        self._last_t = float(t_s)
        self._update_estimate(t_s, x.report, x.mates)
        done = t_s - self.t0_s >= o.duration_s
        est = self.estimate
        fresh = est is not None and t_s - est.time_s <= o.max_estimate_age_s
        if fresh:  # (the phase's time: before the first designation the target is out of track too)
            self.in_track_s += dt
            self._gap_s = 0.0
        else:
            self.out_of_track_s += dt
            if self.first_estimate_s is not None:  # (a gap: after the target was first in track)
                self._gap_s += dt
                self.longest_gap_s = max(self.longest_gap_s, self._gap_s)
        if est is None:
            return None, done
        p_t = est.position_at(t_s)
        chi = self.course_rad
        s = station(p_t, chi, self.offset_m)
        u = np.array([math.cos(chi), math.sin(chi)])
        pos = np.asarray(nav.position_m[:2], dtype=float)
        along = float((s - pos) @ u)
        # the station's own speed |ṡ|, ṡ = v_T + ω J R(χ) o: along the course |v_T| − ω o_port (outside a
        # turn: faster), across it ω o_ahead (a station astern swings sideways; the line it is on with it)
        w = est.turn_rate_rad_s
        station_speed = math.hypot(est.speed_m_s - w * float(self.offset_m[1]), w * float(self.offset_m[0]))
        speed = min(max(station_speed + o.speed_gain_1_s * along, 0.0), self.top_m_s)
        if t_s - self.t0_s >= o.settle_s:
            self._errors.append((float(math.hypot(*(s - pos))), along, float(math.hypot(*(p_t - pos)))))
        leg = None
        if in_mission and t_s - self._last_replan_s >= o.replan_period_s:
            self._last_replan_s = float(t_s)
            back = min(float((pos - s) @ u), 0.0) - 20.0
            self._path = Path.line(s + back * u, s + (est.speed_m_s * o.line_ahead_s + 5.0) * u)
            g0 = float(self._path.project(pos))
            self._speed = speed
            leg = MissionLeg(self.name, self.index, self._path, g0, speed, coordinated=False, station_keeping=True)
        elif abs(speed - self._speed) > 0.01:
            self._speed = speed
            leg = MissionLeg(self.name, self.index, self._path, math.nan, speed, coordinated=False, new_path=False)
        return leg, done

    def result(self) -> dict:
        o = self.options
        tracked = self.in_track_s + self.out_of_track_s
        out = {"role": "leader" if self.is_leader else "follower",
               "target_acquired_s": None if self.first_estimate_s is None else round(self.first_estimate_s, 3),
               "in_track_fraction": round(self.in_track_s / tracked, 4) if tracked > 0 else 0.0,
               "longest_gap_s": round(self.longest_gap_s, 3), "reacquired": self.reacquired}
        if self._errors:
            e = np.array(self._errors)
            out.update(station_error_rms_m=round(float(np.sqrt(np.mean(e[:, 0] ** 2))), 3),
                       station_error_max_m=round(float(e[:, 0].max()), 3),
                       standoff_mean_m=round(float(e[:, 2].mean()), 3),
                       standoff_nominal_m=round(float(math.hypot(*self.offset_m)), 3))
        out["completed"] = bool(self.first_estimate_s is not None and tracked > 0
                                and self.in_track_s / tracked >= o.min_in_track_fraction)
        return out
