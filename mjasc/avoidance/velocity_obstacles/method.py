"""Collision avoidance by velocity obstacles with COLREG constraints: the avoidance method
``"velocity_obstacle"`` (Fiorini & Shiller 1998; Kuwata, Wolf, Zarzhitsky & Huntsberger 2014).

Each control tick (10 Hz by default) the vessel, from what it knows — its own navigation, its
guidance state, its perception's tracks and mapped structures, never the truth:

1. takes the **preferred velocity** of its path (LOS course at the mission speed,
   :mod:`.candidates`) and candidates about it, at speeds up to the hull's top speed (a team
   slowed by its coordination can still sail faster to get clear: :mod:`.candidates`);
2. builds the **obstacles**: moving tracks as discs moving at their estimated velocity (position
   extrapolated to now), combined radius R = r_A + r_B + d_safety + k σ_max (σ_max the largest
   standard deviation of the track's position); team mates as reciprocal obstacles (RVO, half the
   effort each) when ``team_reciprocal``; static structures — mapped polygons, the outlines of
   static tracks (slower than ``static_speed_m_s``), a static track without outline as a disc —
   as discs at rest along their edges (:func:`~.cones.edge_points`), checked along each candidate's
   course at the preferred speed (:func:`~.cones.at_speed`: the horizon cuts them by distance U·T, so
   slowing down does not leave a structure's cone, only turning does — or stopping, the last
   resort; with the time horizon alone a vessel heading for an island slowed to keep the collision
   beyond T and stopped short of it, a local minimum of the truncated VO);
3. computes the time to collision of a grid of candidate velocities against every obstacle at
   once (:mod:`.cones`: VO = collision cone ⊕ v_B, truncated at the horizon T);
4. with ``colreg`` on, gives each moving track its COLREG role (fixed at its first conflict and
   kept, :class:`~.colreg_constraints.RoleMemory`), ignores a stand-on track's VO until keeping
   course would collide within ``stand_on_ttc_s``, and marks the velocities passing a head-on or
   give-way track on the forbidden side (:mod:`.colreg_constraints`);
5. when the preferred velocity lies in a VO (a conflict), or did less than ``hysteresis_s`` ago
   while steering, takes the cheapest candidate (:func:`~.candidates.choose`) and asks the path
   follower to steer its course at its speed (``AvoidanceRequest.course_override_rad`` and
   ``speed_override_m_s``, mode ``avoidance:steer``); otherwise asks nothing (mode ``mission``):
   γ has kept following the path, so the LOS law brings the vessel back onto it;
6. **holds a COLREG manoeuvre until the target is past** (rule 8 (d): the action is kept until the
   other vessel is finally past and clear): a head-on or give-way track whose role is engaged is
   also a conflict — and stays engaged — while the preferred velocity still closes on it on the
   forbidden side (passing starboard to starboard, crossing ahead) and it or the path's own motion
   (step 7) would still come within R of it at some time: one that passes clear of both is past
   and clear (a team mate 10 m abeam in a parallel lane, closing on the "wrong" side forever, held
   a vessel behind it at half speed for the rest of a run). Why: the preferred velocity is
   the LOS course, which converges onto the path, so its straight-line miss distance overstates
   how clear the path is. Released as soon as the preferred velocity merely left the VO, a vessel
   whose path runs within R of the target's track steered back towards it on the wrong side, met
   the VO again closer, was sent across the target's bow the other way, and after three such
   cycles turned too late for its hull (campaign compare_methods, team_vs_traffic run 19: contact,
   −0.72 m; tests/cas_regressions/vo_team_vs_traffic_19.toml);
7. **tests the path's own motion too**: the path's point at γ moving along its tangent at the
   mission speed, against every moving stranger track (not team mates: they broadcast their plans
   and avoid reciprocally) whose role is not stand-on or overtaken (a stand-on vessel keeps its
   course: step 4). A hit within the horizon is a conflict and engages the track's role, as a hit
   of the preferred velocity does. Why: off the path — after a manoeuvre for another track, or set by a
   current — the LOS course points back at the path and its straight line can miss a track that
   the path runs into; the conflict then appeared only once the course had converged, 15 m and 5 s
   from a head-on target, too late for a hull (stress campaign, team_vs_traffic in a current:
   contact, −0.24 m; tests/cas_regressions/vo_team_lossy_current_10.toml).
8. **departs from the rule when the rule's side is out of reach, and commits** (rule 2 (b),
   17 (b)): when no candidate is admissible — every velocity COLREG allows collides within the
   horizon — and the cheapest is collision-free but passes an engaged head-on or give-way track on
   the forbidden side, the vessel departs from the rule for that track (``colreg_departure``;
   counted in ``actions.colreg_departure``) and keeps the side it now takes: for that track the
   forbidden half-plane becomes the other one, and the port-turn penalty no longer applies for it,
   while its role is remembered (:class:`~.colreg_constraints.Departures`). A departure the hull
   cannot reach in time — begun only once it has come round onto its course (at
   ``turn_rate_deg_s``, holding its position meanwhile), it no longer clears the track — counts as
   a collision (:func:`~.colreg_constraints.departure_reachable`). Why: in a 24 m gap
   between islands passing a head-on target port to port left ~0.7 m between its cone and the
   starboard island; with nothing admissible the cheapest was forbidden, back across the target's
   line, and a moment later a crawl back to the rule's side was admissible again, then not: the
   choice flipped across the target's line until the hull, turning through 180° ahead of it, met
   it (stress campaign, bottleneck: contact, −0.23 m;
   tests/cas_regressions/vo_bottleneck_wrong_side_19.toml).

The method has no slow loop: the prediction slot asks nothing of it. Static polygons are read
from the perception report at most once a second (they change slowly; building them is the
expensive part of a report).
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.avoidance.recording import AvoidanceLog
from mjasc.avoidance.request import AvoidanceRequest
from mjasc.avoidance.velocity_obstacles import colreg_constraints as cr
from mjasc.avoidance.velocity_obstacles.candidates import candidate_grid, choose, path_velocity, preferred_velocity
from mjasc.avoidance.velocity_obstacles.cones import (Obstacles, at_speed, edge_points, relative_velocities,
                                                      static_disc_radius_m, time_to_collision)
from mjasc.avoidance.velocity_obstacles.options import VelocityObstacleOptions, check_options
from mjasc.evaluation.colreg import ColregConfig
from mjasc.plugins.stages import AvoidanceMethod

__all__ = ["VelocityObstacleAvoidance", "STEER"]

STEER = "avoidance:steer"
_MODES = ("mission", STEER)
_STATIC_REFRESH_S = 1.0
_CONFLICT_LOG_MAX = 50


class VelocityObstacleAvoidance(AvoidanceMethod):
    """One vessel's velocity-obstacle collision avoidance (module docstring); registered as the
    avoidance method ``"velocity_obstacle"``, options :class:`VelocityObstacleOptions`."""

    method = "velocity_obstacle"
    Options = VelocityObstacleOptions
    check_options = staticmethod(check_options)
    #: Its mode changes are events of its own (:meth:`_set_mode`): the runner does not log them again.
    logs_mode_changes = True

    def __init__(self, context, options: VelocityObstacleOptions | None = None):
        super().__init__(context, options)
        o = self.options
        vessel = context.vessel
        self.name = str(context.vessel_name)
        self.team = frozenset(context.team_names) - {self.name}
        self.radius_m = float(vessel.radius_m)
        self.top_speed_m_s = float(o.top_speed_m_s if o.top_speed_m_s is not None else vessel.top_speed_m_s)
        self.lookahead_m = float(o.lookahead_m if o.lookahead_m is not None else max(3.0 * vessel.length_m, 5.0))
        self.colreg_config = ColregConfig()
        self.roles = cr.RoleMemory(o.hysteresis_s)
        self.departures = cr.Departures()  # tracks the vessel departed from the rule for (step 8)
        self.mode = "mission"
        self.choice = None  # the latest Choice while steering
        self._previous_velocity = None
        self._last_conflict_t = -math.inf
        self._statics = np.zeros((0, 2))
        self._statics_t = -math.inf
        self._last_control_t: float | None = None
        self._events: list[tuple[float, str]] = []
        self._static_conflict = False
        self._stand_on_course = None  # the heading when a stand-on vessel began to act (rule 17 (c))
        self._acting: set = set()  # the stand-on tracks the vessel acts for now (rule 17 (b))
        self._log = AvoidanceLog()
        self.conflict_log: list[dict] = []
        self.last_conflict: dict | None = None  # the latest conflict's record (the video's HUD shows it)
        self.mode_time_s = {m: 0.0 for m in _MODES}
        self.stats = {"steer_episodes": 0, "decisions": 0, "inadmissible": 0, "colreg_forbidden_taken": 0,
                      "colreg_hold": 0, "path_conflict": 0, "colreg_departure": 0,
                      "roles": {name: 0 for name in cr.ROLE_NAMES if name != "none"}}
        self.min_choice_ttc_s = math.inf

    # ------------------------------------------------------------------ obstacles
    def _static_points(self, t: float, report) -> np.ndarray:
        if t - self._statics_t >= _STATIC_REFRESH_S:
            self._statics_t = t
            polygons = [np.asarray(p, dtype=float) for p in report.static_polygons]
            self._statics = np.concatenate([edge_points(polygons, self.options.static_spacing_m)]) \
                if polygons else np.zeros((0, 2))
        return self._statics

    def obstacles(self, t: float, nav, report) -> Obstacles:
        """The obstacles of this tick (module docstring, step 2)."""
        o = self.options
        p_a = np.asarray(nav.position_m, dtype=float)[:2]
        tracks = list(report.tracks)
        is_moving = [not tr.is_static and tr.speed_m_s >= o.static_speed_m_s for tr in tracks]
        moving = [tr for tr, m in zip(tracks, is_moving) if m]
        still = [tr for tr, m in zip(tracks, is_moving) if not m]
        parts = []
        if moving:
            dt = np.array([t - tr.time_s for tr in moving])
            heading = np.array([tr.heading_rad for tr in moving])
            speed = np.array([tr.speed_m_s for tr in moving])
            vel = speed[:, None] * np.stack([np.cos(heading), np.sin(heading)], axis=-1)
            pos = np.array([np.asarray(tr.position_m, dtype=float)[:2] for tr in moving]) + vel * dt[:, None]
            sigma = np.sqrt(np.array([np.max(np.linalg.eigvalsh(np.asarray(tr.position_covariance, float)))
                                      for tr in moving]).clip(min=0.0))
            radius = self.radius_m + np.array([tr.radius_m for tr in moving]) + o.safety_distance_m \
                + o.covariance_sigmas * sigma
            team = np.array([tr.team_member is not None and tr.team_member in self.team for tr in moving])
            parts.append(Obstacles(pos, vel, radius, team & o.team_reciprocal,
                                   np.array([tr.track_id for tr in moving], dtype=int), np.zeros(len(moving), bool)))
        rho = self.radius_m + o.safety_distance_m
        outlines = [np.asarray(tr.outline_m, dtype=float) for tr in still
                    if tr.outline_m is not None and len(tr.outline_m) >= 2]
        pts = [self._static_points(t, report), edge_points(outlines, o.static_spacing_m)]
        pts = np.concatenate(pts)
        pts = pts[np.hypot(pts[:, 0] - p_a[0], pts[:, 1] - p_a[1]) <= o.static_range_m] if len(pts) else pts
        if len(pts):
            n = len(pts)
            parts.append(Obstacles(pts, np.zeros((n, 2)), np.full(n, static_disc_radius_m(rho, o.static_spacing_m)),
                                   np.zeros(n, bool), np.full(n, -1), np.ones(n, bool)))
        discs = [tr for tr in still if tr.outline_m is None or len(tr.outline_m) < 2]
        if discs:
            n = len(discs)
            parts.append(Obstacles(np.array([np.asarray(tr.position_m, float)[:2] for tr in discs]), np.zeros((n, 2)),
                                   rho + np.array([tr.radius_m for tr in discs]), np.zeros(n, bool),
                                   np.array([tr.track_id for tr in discs], dtype=int), np.ones(n, bool)))
        return Obstacles.concatenate(parts)

    # ------------------------------------------------------------------ the decision
    def control(self, t, nav, guidance, report, team=None) -> AvoidanceRequest:
        """Control tick → the course and speed to steer while in conflict, else nothing (module docstring)."""
        t = float(t)
        if self._last_control_t is not None:
            self.mode_time_s[self.mode] += max(t - self._last_control_t, 0.0)
        self._last_control_t = t
        if guidance is None or report is None:
            return self._set_mode(t, "mission")
        o = self.options
        chi_pref, u_pref = preferred_velocity(nav.position_m, guidance.path, guidance.gamma_m,
                                              guidance.mission_speed_m_s, self.lookahead_m)
        obs = self.obstacles(t, nav, report)
        heading = float(nav.heading_rad)
        courses, speeds, velocities = candidate_grid(chi_pref, u_pref, o.course_candidates,
                                                     math.radians(o.course_span_deg), o.speed_candidates, heading,
                                                     self.top_speed_m_s)
        if not len(obs):  # nothing around (or a track lost for a moment): hold a choice through the hysteresis
            if self.choice is not None and t - self._last_conflict_t <= o.hysteresis_s:
                return AvoidanceRequest.of(STEER, self.choice.speed_m_s, None, (), self.choice.course_rad)
            return self._release(t)
        p_a = np.asarray(nav.position_m, dtype=float)[:2]
        v_now = np.asarray(nav.velocity_m_s, dtype=float)[:2]
        rel = obs.position_m - p_a
        w = relative_velocities(velocities, v_now, obs)
        if obs.static.any():  # structures: each course at the preferred speed (the horizon cuts by distance U·T)
            w[:, obs.static] = at_speed(velocities, u_pref)[:, None, :]
        ttc = time_to_collision(rel, w, obs.radius_m)
        in_vo_pref = ttc[0] <= o.horizon_s
        roles = np.full(len(obs), cr.NONE)
        tracked = (~obs.static) & (obs.track_id >= 0)
        path_ttc = self._path_ttc(obs, tracked, guidance, u_pref)
        on_path = path_ttc <= o.horizon_s  # step 7 of the module docstring
        if tracked.any():  # roles (all "none" without COLREG): remembered from a track's first conflict
            fresh = cr.roles(p_a, heading, obs.position_m[tracked],
                             np.arctan2(obs.velocity_m_s[tracked, 1], obs.velocity_m_s[tracked, 0]),
                             self.colreg_config) if o.colreg else np.full(int(tracked.sum()), cr.NONE)
            ids = obs.track_id[tracked].tolist()
            before = [self.roles.role(i) for i in ids]  # the roles remembered before this tick
            known = {i for i, r in zip(ids, before) if r is not None}
            prior = np.array([f if r is None else r for f, r in zip(fresh.tolist(), before)], dtype=int)
            on_path[tracked] &= ~np.isin(prior, (cr.STAND_ON, cr.OVERTAKEN))  # a stand-on vessel keeps its course
            roles[tracked] = self.roles.update(t, obs.track_id[tracked], fresh, in_vo_pref[tracked] | on_path[tracked])
            for i, r in zip(ids, roles[tracked].tolist()):
                if i not in known and self.roles.role(i) is not None:
                    self._new_conflict(t, i, cr.ROLE_NAMES[r])
        # rule 8 (d): an engaged head-on / give-way track holds the manoeuvre while the path's velocity
        # would still close on it on the forbidden side (step 6 of the module docstring)
        wrong_side = np.zeros(len(obs), bool)
        departed = np.zeros(len(obs), bool)  # the side committed to (step 8): the forbidden one is the other
        if o.colreg and tracked.any():
            remembered = np.zeros(len(obs), bool)
            remembered[tracked] = [self.roles.role(i) is not None for i in obs.track_id[tracked].tolist()]
            departed[tracked] = self.departures.of(obs.track_id[tracked], remembered[tracked])
            wrong_side = remembered & cr.forbidden_side(rel, w[:1], roles, departed)[0] \
                & (np.isfinite(ttc[0]) | np.isfinite(path_ttc))
            self.roles.keep(t, obs.track_id[wrong_side])
        # stand on (rule 17): a stand-on track's VO counts only once keeping course collides soon
        stand_on = np.isin(roles, (cr.STAND_ON, cr.OVERTAKEN))
        waived = stand_on & (ttc[0] > o.stand_on_ttc_s)
        acting_ids = obs.track_id[stand_on & ~waived].tolist()  # (rule 17 (b): keeping on would collide soon)
        for i, r in zip(acting_ids, roles[stand_on & ~waived].tolist()):
            if i not in self._acting:
                self._event(t, f"velocity obstacle: T{i} ({cr.ROLE_NAMES[r]}): keeping course and speed would "
                               f"collide within {o.stand_on_ttc_s:g} s: acting (rule 17 (b))")
                self._log_conflict(t, i, False, f"steer ({cr.ROLE_NAMES[r]}, acting)")
        self._acting = set(acting_ids)
        ttc = np.where(waived[None, :], np.inf, ttc)
        on_path &= ~stand_on
        conflict = bool(np.any(ttc[0] <= o.horizon_s) or wrong_side.any() or on_path.any())
        self.stats["path_conflict"] += int(np.any(on_path & (ttc[0] > o.horizon_s)))  # seen by step 7 only
        static_now = bool(np.any((ttc[0] <= o.horizon_s) & obs.static))
        if static_now and not self._static_conflict:
            self._new_conflict(t, -1, "static", static=True)
        self._static_conflict = static_now
        if conflict:
            self._last_conflict_t = t
            self.stats["colreg_hold"] += int(not np.any(ttc[0] <= o.horizon_s) and wrong_side.any())  # step 6 alone
        elif self.mode != STEER or t - self._last_conflict_t > o.hysteresis_s:
            return self._release(t)
        # COLREG: the forbidden half-plane of engaged head-on / give-way tracks (closing velocities on
        # the wrong side, however far their collision: a horizon here would let the vessel cross ahead
        # just beyond it)
        engaged = np.zeros(len(obs), bool)
        engaged[tracked] = [self.roles.role(i) is not None for i in obs.track_id[tracked].tolist()]
        forbidden = np.zeros(len(courses), bool)
        side = np.zeros((len(courses), len(obs)), bool)
        if o.colreg and engaged.any():
            side = cr.forbidden_side(rel, w, np.where(engaged, roles, cr.NONE), departed)
            forbidden = side.any(axis=1)
            if o.give_way_starboard and (engaged & ~departed & np.isin(roles, (cr.HEAD_ON, cr.GIVE_WAY))).any():
                forbidden |= cr.port_turn(courses, chi_pref, math.radians(5.0)) & (speeds > 0.0)
            acting = engaged & (roles == cr.STAND_ON) & ~waived
            if acting.any():  # rule 17 (c): no turn to port (of the course it stood on) for a vessel on its port side
                if self._stand_on_course is None:
                    self._stand_on_course = heading
                forbidden |= cr.port_turn(courses, self._stand_on_course, math.radians(5.0)) & (speeds > 0.0)
            else:
                self._stand_on_course = None
        ttc_min = ttc.min(axis=1)
        bound = engaged & ~departed & np.isin(roles, (cr.HEAD_ON, cr.GIVE_WAY))  # departures possible from these
        cornered = bool(o.colreg and o.colreg_departure and bound.any()
                        and not np.any((ttc_min > o.horizon_s) & ~forbidden))
        if cornered:  # step 8: a departure the hull cannot reach in time is as good as a collision
            k = np.flatnonzero((ttc_min > o.horizon_s) & side[:, bound].any(axis=1))
            turn = np.abs(np.remainder(courses[k] - heading + np.pi, 2 * np.pi) - np.pi)  # the shortest way round
            turn_s = turn / math.radians(o.turn_rate_deg_s)
            reach = cr.departure_reachable(rel[bound], obs.velocity_m_s[bound], obs.radius_m[bound], turn_s,
                                           velocities[k], o.horizon_s)
            ttc_min = ttc_min.copy()
            ttc_min[k[np.any(side[k][:, bound] & ~reach, axis=1)]] = 0.0
        choice, _ = choose(courses, speeds, velocities, chi_pref, u_pref, self._previous_velocity,
                           ttc_min, o.horizon_s, forbidden, o)
        if cornered and choice.forbidden and choice.ttc_s > o.horizon_s:
            self._depart(t, obs.track_id[side[choice.index] & bound])
        self.choice = choice
        self._previous_velocity = choice.velocity_m_s
        self.stats["decisions"] += 1
        self.stats["inadmissible"] += int(not choice.admissible)
        self.stats["colreg_forbidden_taken"] += int(choice.forbidden)
        self.min_choice_ttc_s = min(self.min_choice_ttc_s, choice.ttc_s)
        req = self._set_mode(t, STEER)
        return AvoidanceRequest.of(req.mode, choice.speed_m_s, None, (), choice.course_rad)

    def _path_ttc(self, obs: Obstacles, tracked: np.ndarray, guidance, speed_m_s: float) -> np.ndarray:
        """τ_c (t,) [s] of the path's own motion — from the path's point at γ along its tangent at the
        mission speed — with each moving stranger track (∞ for the others: team mates, structures)."""
        out = np.full(len(obs), np.inf)
        stranger = tracked & ~obs.reciprocal
        if stranger.any():
            q, v_path = path_velocity(guidance.path, guidance.gamma_m, speed_m_s)
            w = (v_path[None, :] - obs.velocity_m_s[stranger])[None, :, :]
            out[stranger] = time_to_collision(obs.position_m[stranger] - q, w, obs.radius_m[stranger])[0]
        return out

    def _depart(self, t: float, track_ids) -> None:
        """Step 8 of the module docstring: every velocity the rules allow collides, the cheapest
        free one passes these tracks on the forbidden side — depart from the rule for them and
        keep the side taken."""
        for i in self.departures.depart(track_ids):
            self.stats["colreg_departure"] += 1
            self._event(t, f"velocity obstacle: T{i} — every allowed velocity collides: departing from the rule "
                           "(rule 2 (b)), keeping the side taken until it is past")

    def _release(self, t: float) -> AvoidanceRequest:
        self.choice = None
        self._previous_velocity = None
        self._stand_on_course = None
        self._acting = set()
        return self._set_mode(t, "mission")

    def _set_mode(self, t: float, mode: str) -> AvoidanceRequest:
        if mode != self.mode:
            self._event(t, f"mode {self.mode} → {mode}")
            if mode == STEER:
                self.stats["steer_episodes"] += 1
            self.mode = mode
        return AvoidanceRequest.of(mode, None, None, (), None)

    def _new_conflict(self, t: float, track_id: int, role: str, static: bool = False) -> None:
        if not static:
            self.stats["roles"][role] = self.stats["roles"].get(role, 0) + 1
        what = "a static obstacle" if static else f"T{track_id}"
        self._event(t, f"velocity obstacle: {what} in conflict" + ("" if static else f" (role {role})"))
        standing = role in (cr.ROLE_NAMES[cr.STAND_ON], cr.ROLE_NAMES[cr.OVERTAKEN])  # (course and speed kept for now)
        self._log_conflict(t, track_id, static, "steer" if static or role == "none" else
                           f"stand on ({role})" if standing else f"steer ({role})")

    def _log_conflict(self, t: float, track_id: int, static: bool, decision: str) -> None:
        """A decision for the summary's conflict log and the video's decision line: a new conflict
        (steer; or stand on — keep course and speed —, rule 17 (a)), or a stand-on vessel beginning
        to act (rule 17 (b))."""
        self.last_conflict = {"time_s": round(t, 2), "track_id": int(track_id), "static": bool(static),
                              "decision": decision}
        if len(self.conflict_log) < _CONFLICT_LOG_MAX:  # (the summary's first ones; last_conflict: the latest)
            self.conflict_log.append(self.last_conflict)

    # ------------------------------------------------------------------ the rest of the interface
    def planned_trajectory(self, t, nav, guidance, horizon_s: float, step_s: float):
        """While steering: straight on at the chosen velocity from the vessel's position over the
        horizon; else None (the team samples the path being followed)."""
        if self.choice is None:
            return None
        times = float(t) + np.arange(0.0, float(horizon_s) + 0.5 * float(step_s), float(step_s))
        pts = np.asarray(nav.position_m, dtype=float)[:2] + (times - float(t))[:, None] * self.choice.velocity_m_s
        return times, pts

    def drain_events(self) -> list[tuple[float, str]]:
        ev, self._events = self._events, []
        return ev

    def _event(self, t: float, text: str) -> None:
        self._events.append((float(t), text))

    def summary(self) -> dict:
        total = sum(self.mode_time_s.values())
        return {
            "method": self.method,
            "colreg": self.options.colreg,
            "actions": {k: self.stats[k] for k in ("steer_episodes", "decisions", "inadmissible",
                                                   "colreg_forbidden_taken", "colreg_hold",
                                                   "path_conflict", "colreg_departure")},
            "roles": dict(self.stats["roles"]),
            "mode_time_s": {k: round(v, 2) for k, v in self.mode_time_s.items()},
            "mode_share": {k: round(v / total, 4) if total > 0 else 0.0 for k, v in self.mode_time_s.items()},
            "min_chosen_ttc_s": round(self.min_choice_ttc_s, 3) if math.isfinite(self.min_choice_ttc_s) else None,
            "conflicts": self.conflict_log,
        }

    #: :meth:`log` draws nothing of the guidance state (no velocity correction: the agent skips building it).
    logs_guidance = False

    def log(self, recorder, t, vessel_name, guidance=None) -> None:
        """The mode (state lane) and the threat panel: its header, as the thesis method's, and —
        the method predicts nothing ahead of time — its latest decision instead of a table."""
        self._log.log(recorder, t, vessel_name, self.mode, None, guidance, None, None, self.team, self._panel_note())

    def _panel_note(self) -> str:
        """The threat panel's text: how the method decides, and its latest decision."""
        text = ("velocity obstacles: no prediction ahead of time — every control tick weighs the candidate "
                "velocities against each track's time to collision")
        c = self.last_conflict
        if c is not None:
            what = "a mapped structure" if c["static"] else f"T{c['track_id']}"
            text += f"\n\nlatest decision: **{c['decision']}** for {what} at t = {c['time_s']:.1f} s"
        return text
