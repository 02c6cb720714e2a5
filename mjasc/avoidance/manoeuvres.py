"""Decision σ on a prediction's conflicts and the manoeuvres it switches to.

:meth:`Manoeuvres._decide` sorts the conflicts (:func:`~mjasc.avoidance.triage.triage`): a lane
change to starboard head-on (:mod:`~mjasc.avoidance.lane_change`), a re-plan around swept areas
and static obstructions (:func:`~mjasc.avoidance.replanning.plan_detour`, a detour onto mapped
structure refused: :func:`~mjasc.avoidance.structure.detour_onto_structure`), velocity
corrections (:mod:`~mjasc.avoidance.decision`) with the emergency stop for what is left
unresolved, each candidate speed plan checked against all tracks (:mod:`~mjasc.avoidance.checked_choice`).
The path switches: onto a detour, back to the mission path at a detour's end, a detour withdrawn
when its causes are gone or it now leads into one of them; a yield withdrawn when its track,
predicted again without it, no longer conflicts (:meth:`Manoeuvres._withdraw_correction`).

:class:`Manoeuvres` is a part of :class:`~mjasc.avoidance.system.CollisionAvoidance` (its state is
the system's). World frame ENU, SI units, absolute simulation times [s].
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from mjasc.avoidance.checked_choice import CheckedChoice
from mjasc.avoidance.decision import emergency_yield, velocity_correction_for
from mjasc.avoidance.lane_change import plan_lane_change
from mjasc.avoidance.prediction import PredictionQuery, predict_fleet
from mjasc.avoidance.replanning import Detour, plan_detour
from mjasc.avoidance.separation import separation_detour, separation_turn, stuck_with
from mjasc.avoidance.speed_plan import correction_profile
from mjasc.avoidance.static_conflicts import StaticConflict, static_conflicts, track_outlines
from mjasc.avoidance.structure import detour_onto_structure
from mjasc.avoidance.triage import swept, triage

__all__ = ["Manoeuvres"]


class Manoeuvres(CheckedChoice):
    """Decision σ and the path switches of :class:`~mjasc.avoidance.system.CollisionAvoidance`
    (see the module docstring)."""

    def _note_answers(self, t, roles: dict) -> None:
        """The triage's answer to each conflict of this prediction (``roles``: track id → text): the
        ``action`` of its record in the conflict log (its ``decision`` is the prediction's σ, which
        the triage may answer otherwise: a give-way vessel yields to a team mate rather than
        re-plan around it; a stand-on vessel keeps its speed), and an event when a track's answer
        changes."""
        if not roles:
            return
        said = self._answers
        for e in self.logged_now:
            text = roles.get(e.get("track_id"))
            if text is not None and "action" not in e:
                e["action"] = text
        for track_id, text in roles.items():
            if track_id is not None and said.get(track_id) != text:
                said[track_id] = text
                self._event(t, f"track {track_id}: {text}")

    def _decide(self, t, nav, conflicts, statics, by_id, static_polygons, allow_replan=True,
                static_outlines=()) -> None:
        gamma = float(self._guidance.gamma_m)
        cfg = self.config
        conflicts = self._while_separating(t, conflicts)
        giving_way, standing_on = self._mates_declaring(t)
        tri = triage(t, nav, gamma, conflicts, statics, by_id, self.team, cfg, self.speed_max_m_s, self.correction,
                     giving_way, standing_on, self.name, float(self._guidance.path.length))
        self._stands_on = frozenset(tri.stand_on_mates)
        self._last = replace(self._last, roles=tuple(tri.roles.items()))  # for the threat panel
        self._note_answers(t, tri.roles)
        for stat, text in tri.notes:
            if stat is not None:
                self.stats[stat] += 1
            self._event(t, text)
        candidates, svos, unresolved, starboard = tri.candidates, tri.svos, tri.unresolved, tri.starboard
        if starboard and allow_replan:
            if self._lane_change_to_starboard(t, nav, starboard, static_polygons, static_outlines):
                self.correction = None
                self._predict(t, nav, list(by_id.values()), static_polygons, after_replan=True,
                              grown=tri.give_way_mates)
                return
            for c in starboard:  # no starboard lane: as the thesis would
                svos.append((c.svo_polygon if c.svo_polygon is not None else swept(by_id[c.track_id], c, t, cfg), c))
        if svos and allow_replan:
            if self._replan(t, nav, svos, static_polygons, by_id, static_outlines):
                # The path changed: predict again on the detour (velocity corrections only). The team
                # mates this vessel gives way to are not in the field (it never goes around them): the
                # detour is checked against them with the margin the planner gives the obstacles it
                # goes around (``replan_margin_m``), for the hull's lag onto the fresh path (harbour
                # case: a detour clear of a yielding team mate by 0.36 m, sailed 2.9 m off, into it).
                self.correction = None
                self._predict(t, nav, list(by_id.values()), static_polygons, after_replan=True,
                              grown=tri.give_way_mates)
                return
        # No detour (none found, or this is the check of a fresh one): the path sailed is known to
        # conflict — in the stressed dock a moored boat's track moving by noise; in the stressed
        # head-on a detour around a team mate led back into the oncoming vessel's swept area. Slow
        # down and look again every second (a re-plan then sees every conflict) rather than sail on.
        unresolved += tri.go_around
        for c in tri.overtaken:  # no lane to leave: speed up and let it pass astern, else stop (Imazu case 16)
            corr = velocity_correction_for(t, gamma, c, cfg, self.speed_max_m_s, pass_only=True,
                                           path_end_m=float(self._guidance.path.length))
            if corr is not None:
                candidates.append(corr)
            else:
                unresolved.append(c)
        # The emergency stop (for the nearest unresolved conflict) is a candidate whenever a conflict
        # is left unresolved: beside corrections for other tracks (Imazu case 12: a yield to one
        # target was taken while a conflict with another, 5 s ahead, was left; the checked choice
        # weighs them all), and in place of a running yield planned on an earlier estimate (in
        # the §6.4.3 bottleneck one kept a give-way vessel creeping into its team mate's lane).
        # A running emergency stop with nothing else to choose from is simply kept. A new one is
        # counted and said only once the checked choice has taken it (not when it keeps way instead).
        stop_note = None
        if allow_replan and self._separate(t, nav, conflicts, by_id, static_polygons, static_outlines):
            self.correction = None
            self._predict(t, nav, list(by_id.values()), static_polygons, after_replan=True, grown=tri.give_way_mates)
            return
        if unresolved:
            nearest = min(unresolved, key=lambda u: u.t_closest_s)
            emergency_running = self.correction is not None and self.correction.emergency
            if candidates or not emergency_running:
                candidates.append(emergency_yield(t, gamma, nearest, cfg, self.speed_max_m_s))
            if not emergency_running:
                stop_note = f"no manoeuvre clears track {nearest.track_id}: " + (
                    f"emergency slow-down to {cfg.emergency_speed_m_s:g} m/s" if cfg.emergency_speed_m_s > 0.0
                    else "emergency stop (all way off)")
        if candidates:
            yields = [c for c in candidates if c.kind == "yield"]
            chosen = min(yields, key=lambda c: c.law.desired_speed) if yields else \
                max(candidates, key=lambda c: c.law.desired_speed)
            chosen = self._checked_choice(t, chosen, candidates, conflicts, tri.no_pass)
            if chosen is not None and chosen is self.correction:  # the running one kept (said and counted there)
                self._clear_since_s = None
                return
            if stop_note is not None and chosen is not None and chosen.emergency:
                self.stats["emergency"] += 1
                self._event(t, stop_note)
            if chosen is None:
                self.correction = None
                return
            if cfg.withdraw_false_alarms and chosen.kind == "yield" and not chosen.emergency and \
                    t - self._first_predicted_s.get(chosen.track_id, -math.inf) <= cfg.withdraw_new_track_s and \
                    getattr(by_id.get(chosen.track_id), "team_member", None) not in self.team:
                chosen = replace(chosen, withdrawable=True)  # (decided on a stranger's first estimates)
            self.correction = chosen
            self._clear_since_s = None
            self.stats[chosen.kind] += 1
            law = chosen.law
            self._event(t, f"velocity correction ({chosen.kind}) for track {chosen.track_id}: virtual target "
                           f"γ {law.gamma0:.1f} → {law.gamma_goal:.1f} m by t = {law.t_goal:.1f} s, "
                           f"V_d = {law.desired_speed:.2f} m/s, k = {law.gain_k:g}")

    def _while_separating(self, t, conflicts) -> list:
        """The conflicts to act on: while a separation's leg is sailed (:mod:`~mjasc.avoidance.separation`),
        not those with team mates from which the leg opens the range (their closest approach is now)."""
        sep = self._separating
        if sep is None:
            return conflicts
        if self.detour is not sep or self._guidance.path is not sep.path or \
                float(self._guidance.gamma_m) >= sep.detour_length_m:
            self._separating = None
            return conflicts
        team = self._team_track_ids
        return [c for c in conflicts if c.track_id not in team or c.t_closest_s > t + 1e-6]

    def _separate(self, t, nav, conflicts, by_id, static_polygons, static_outlines) -> bool:
        """Move apart from a team mate both stopped inside the collision distance for ``deadlock_s``
        (:mod:`~mjasc.avoidance.separation`; also from a leg stopped on the way). True when switched
        to the leg away."""
        cfg = self.config
        if cfg.deadlock_s <= 0.0:
            return False
        u, v = float(nav.body_velocity[0]), float(nav.body_velocity[1])
        stuck = self._stuck_since = stuck_with(t, nav.position_m, math.hypot(u, v), conflicts, by_id,
                                               self._stuck_since)
        if not stuck or t < self._separation_asked_s + cfg.deadlock_s:
            return False
        wait_s = cfg.deadlock_s * separation_turn(self.name, [by_id[k].team_member for k in stuck])
        due = [k for k, since in stuck.items() if t - since >= wait_s]
        if not due:
            return False
        c = min((c for c in conflicts if c.track_id in due), key=lambda c: c.min_distance_m)
        mate = by_id[c.track_id]
        others = [by_id[k].position_m for k in sorted(self._team_track_ids) if k != c.track_id and k in by_id]
        out = separation_detour(t, nav.position_m, mate.position_m, c.collision_distance_m + 2.0 * cfg.replan_margin_m,
                                self.mission_gamma_m(self._guidance), list(static_polygons) + list(static_outlines),
                                self.static_inflation_m, others, c.collision_distance_m)
        self._separation_asked_s = t
        stopped_s = t - stuck[c.track_id]
        apart_m = float(np.hypot(*(np.asarray(nav.position_m, dtype=float) - mate.position_m)))
        said = f"deadlock with team mate {mate.team_member} (both stopped {stopped_s:.0f} s, {apart_m:.1f} m apart)"
        if isinstance(out, str):
            self.stats["separate_refused"] += 1
            self._event(t, f"{said}: {out}; asked again in {cfg.deadlock_s:g} s")
            return False
        self._stuck_since = {}
        self._take_detour(t, out, f"{said}: moving {out.detour_length_m:.1f} m away before going on", "separate")
        self._separating = out
        return True

    def _mates_declaring(self, t) -> tuple[frozenset, frozenset]:
        """The team mates whose broadcast, at most ``team_broadcast_max_age_s`` old, says they give
        way to / stand on toward this vessel (:attr:`~mjasc.cooperation.messages.TeamIntention.gives_way_to`,
        ``stands_on_to``)."""
        team = self._team
        if team is None or not team.intentions:
            return frozenset(), frozenset()
        fresh = team.fresh(t, self.config.team_broadcast_max_age_s).items()
        return (frozenset(name for name, it in fresh if self.name in it.gives_way_to),
                frozenset(name for name, it in fresh if self.name in it.stands_on_to))

    def _lane_change_to_starboard(self, t, nav, conflicts, static_polygons, static_outlines) -> bool:
        """COLREG rule 14 (head-on): leave the target's lane to starboard. True when switched."""
        lane = plan_lane_change(t, nav.position_m, self.mission_path, self.mission_gamma_m(self._guidance),
                                self._guidance.mission_speed_m_s, conflicts,
                                list(static_polygons) + list(static_outlines), self.config, self.static_inflation_m,
                                starboard_only=True, hold_past_end=self.station_keeping)
        if isinstance(lane, str):
            self._event(t, f"head-on: {lane}")
            return False
        self._take_detour(t, lane, f"head-on (COLREG rule 14): lane change to starboard of {lane.detour_length_m:.1f} m, "
                                   f"rejoining the mission path at γ = {lane.mission_gamma_goal_m:.1f} m")
        return True

    def _replan(self, t, nav, svos, static_polygons, by_id=None, static_outlines=()) -> bool:
        """Plan a detour (:func:`~mjasc.avoidance.replanning.plan_detour`) and switch to it. True on success."""
        mission = self.mission_path
        g_now_m = self.mission_gamma_m(self._guidance)
        out = plan_detour(t, nav.position_m, mission, g_now_m, svos, static_polygons, by_id, static_outlines,
                          self.config, self.radius_m, self.static_inflation_m, self._event)
        dynamic = [c for _, c in svos if not isinstance(c, StaticConflict) and not c.is_static]
        if not isinstance(out, str) and dynamic:
            why = detour_onto_structure(t, nav.position_m, out, list(static_polygons) + list(static_outlines),
                                        self._guidance.mission_speed_m_s, self.radius_m, self.prediction_config,
                                        self.config.detour_structure_slack_m)
            if why is not None:
                self.stats["detour_rejected"] += 1
                out = why
        if isinstance(out, str) and dynamic:  # the swept area cannot be gone around: leave the threat's lane
            team_ids = frozenset(c.track_id for c in dynamic if by_id is not None
                                 and getattr(by_id.get(c.track_id), "team_member", None) is not None)
            lane = plan_lane_change(t, nav.position_m, mission, g_now_m, self._guidance.mission_speed_m_s, dynamic,
                                    list(static_polygons) + list(static_outlines), self.config,
                                    self.static_inflation_m, hold_past_end=self.station_keeping, team_ids=team_ids)
            if isinstance(lane, str):
                out = f"{out}; {lane}"
            else:
                self._event(t, f"potential-field detour impossible ({out}): lane change instead")
                out = lane
        if isinstance(out, str):
            self.stats["replan_failed"] += 1
            self._event(t, f"re-planning failed: {out}")
            return False
        fld = out.field
        if fld is None:
            what = f"re-planned: lane change of {out.detour_length_m:.1f} m"
        else:
            what = (f"re-planned: detour of {out.detour_length_m:.1f} m around {len(out.obstacles)} obstacle(s) "
                    f"(potential field, {len(fld.panels) if fld.panels is not None else 0} panels, "
                    f"r = {fld.safety_ratio}, λ_g = {fld.sink_strength:.0f})")
        self._take_detour(t, out, f"{what}, rejoining the mission path at γ = {out.mission_gamma_goal_m:.1f} m")
        self._detour_causes = None if len(dynamic) < len(svos) else {int(c.track_id) for c in dynamic}
        return True

    def _withdraw_detour(self, t, nav, by_id, static_polygons, conflicts=()) -> bool:
        """Leave a detour around tracks for the mission path when the vessel is within
        ``withdraw_offset_m`` of it and the mission path from there is clear of every track and
        mapped structure, in two cases:

        - its causes are gone: every track it went around is no longer among the predicted tracks
          (a team mate's stale copy set aside once its broadcast was heard, or a track lost).
          (Thesis §6.4.1 under packet loss: a team mate's track, not yet matched to its broadcast,
          sent a vessel onto a 98 m detour that it sailed for 88 s after the track was set aside,
          into the crossing ship's path.)
        - it is obsolete: the vessel sails it under a velocity correction (yielding or stopped for a
          track), this prediction's ``conflicts`` (on the detour) include a track it went around,
          and the mission path passes every track at least ``replan_margin_m`` outside the
          collision distance (the margin the detour itself was planned with). (The stressed §6.4.2
          head-on: the oncoming ship's later estimates put it south of the lane that alpha's detour
          turned into, and alpha, giving way to a team mate, crept along the detour into it while
          its own lane was clear.) A vessel sailing a detour at its own speed is left to it: a
          conflict there is re-planned as any other (in a head-on encounter, withdrawn, the vessel
          passed port to port without the alteration to starboard rule 14 asks).

        True when it switched back."""
        d, causes, g = self.detour, self._detour_causes, self._guidance
        if (d is None or causes is None or g.path is not d.path or self.config.withdraw_offset_m <= 0.0
                or self.mission_path is None):
            return False
        gone = not any(k in by_id for k in causes)
        met = set() if gone or self.correction is None else {c.track_id for c in conflicts}
        into = sorted(k for k in causes if k in met)  # (the causes the detour now leads into)
        if not gone and not into:
            return False
        mission = self.mission_path
        g_m = float(mission.project(nav.position_m))
        if float(np.hypot(*(mission.point(g_m) - nav.position_m))) > self.config.withdraw_offset_m:
            return False
        profile = self.predicted_gamma(t, g_m, g.mission_speed_m_s)
        outlined = track_outlines(by_id.values())
        discs = [tr for k, tr in by_id.items() if k not in outlined]
        if discs:
            margin = 0.0 if gone else self.config.replan_margin_m
            q = PredictionQuery(mission, g_m, t, profile, self.radius_m, discs, self.prediction_config,
                                include_clear=not gone)
            if any(c.collision or c.min_distance_m < c.collision_distance_m + margin for c in predict_fleet([q])[0]):
                return False
        if static_conflicts(t, mission, g_m, profile, list(static_polygons) + list(outlined.values()), self.radius_m,
                            self.prediction_config):
            return False
        self.stats["withdrawn"] += 1
        why = (f"the track(s) {sorted(causes)} it went around are gone (a team mate's stale copy, or lost)" if gone else
               f"it now leads into track(s) {into} it went around")
        self._back_to_mission(t, g_m, f"detour withdrawn: {why} and the mission path is clear: back on it at "
                                      f"γ = {g_m:.1f} m")
        return True

    def _withdraw_correction(self, t, path, gamma_m: float, mission_speed_m_s: float, by_id, conflicts) -> bool:
        """With ``withdraw_false_alarms`` (off by default): end a running yield decided on a
        stranger's first estimates (``Correction.withdrawable``) once its track, predicted again on
        ``path`` from ``gamma_m`` [m] at the mission speed [m/s] — as if the yield had not been
        taken —, has passed at least ``correction_withdraw_margin_m`` outside the collision
        distance in every check for ``withdraw_confirm_s`` (such a yield predicts again every
        second: :meth:`~mjasc.avoidance.control_tick.ControlTick._prediction_due`). A prediction
        made under the yield is clear by design and cannot tell whether the yield is still needed;
        this asks. The checks restart while the track conflicts, is lost (the object may still be
        there) or is static. Why only these yields, why the confirmation and why off by default,
        from the campaigns: docs/avoidance.md, "Decisions". True when withdrawn (the caller
        predicts again at once)."""
        c, cfg = self.correction, self.config
        if c is None or not c.withdrawable:  # (withdrawable only with withdraw_false_alarms)
            return False
        track = by_id.get(c.track_id)
        pair = None
        if track is not None and not track.is_static and not track_outlines([track]) and \
                not any(k.track_id == c.track_id for k in conflicts):
            q = PredictionQuery(path, gamma_m, t, correction_profile(None, t, gamma_m, mission_speed_m_s),
                                self.radius_m, [track], self.prediction_config, include_clear=True)
            pair = predict_fleet([q])[0]
        if not pair or pair[0].collision or \
                not pair[0].min_distance_m >= pair[0].collision_distance_m + cfg.correction_withdraw_margin_m:
            self._clear_since_s = None
            return False
        if self._clear_since_s is None:
            self._clear_since_s = t
        if t - self._clear_since_s < cfg.withdraw_confirm_s:
            return False
        self.correction, self._clear_since_s = None, None
        self.stats["withdrawn"] += 1
        self._event(t, f"velocity correction ({c.kind}) for track {c.track_id} withdrawn: predicted again at the "
                       f"mission speed it passes at d = {pair[0].min_distance_m:.1f} m (collision distance "
                       f"{pair[0].collision_distance_m:.1f} m): mission speed resumed")
        return True

    def _back_to_mission(self, t, gamma_m: float, event: str) -> None:
        """Leave the detour for the mission path at γ = ``gamma_m`` [m] (a running velocity
        correction's virtual target kept in the follower's new γ frame)."""
        if self.correction is not None:
            self.correction.gamma_offset_m += self._guidance.gamma_m - gamma_m
        self._set_path(self.mission_path, gamma_m, "mission")
        self.detour, self._detour_causes = None, None
        self._event(t, event)
        self._log.prediction_pending()

    def _take_detour(self, t, detour: Detour, event: str, counted: str = "replan") -> None:
        """Switch to ``detour`` (a streamline's, or a lane change's when its ``field`` is None) and count it
        (as ``counted``; a re-plan without a field as a lane change too)."""
        self.detour = detour
        self._detour_causes = None  # statics or unknown: the detour is sailed to its end
        self._set_path(detour.path, 0.0, "detour")
        self.stats[counted] += 1
        if counted == "replan" and detour.field is None:
            self.stats["lane_change"] += 1
        self._event(t, event)
        self._log.prediction_pending()
