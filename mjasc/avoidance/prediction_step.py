"""One prediction of a vessel's collision avoidance: its query, and acting on its result.

The first half (:meth:`PredictionStep._prediction_query`) makes the tracks as predicted — team
mates from their fresh broadcasts (:mod:`~mjasc.avoidance.team_mates`), slow tracks static, a
mapped structure's own returns static and no larger than it
(:func:`~mjasc.avoidance.structure.structure_tracks`) — and the query of the disc tracks; the
prediction itself runs for many vessels at once (:func:`~mjasc.avoidance.fleet_slots.predict_slot`,
:func:`~mjasc.avoidance.fleet_slots.control_slot`). The second half
(:meth:`PredictionStep._act_on_prediction`) records the predicted conflicts, checks the static
ones (mapped polygons and static tracks' outlines: :mod:`~mjasc.avoidance.static_conflicts`) and
hands them to the decision (:mod:`~mjasc.avoidance.manoeuvres`). :class:`PredictionRecord` is
what the latest prediction saw (recording, figures, the threat panel).

:class:`PredictionStep` is a part of :class:`~mjasc.avoidance.system.CollisionAvoidance` (its
state is the system's). World frame ENU, SI units, absolute simulation times [s].
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from mjasc.avoidance.prediction import PredictedConflict, PredictionQuery
from mjasc.avoidance.prediction.conflicts import ConflictList
from mjasc.avoidance.speed_plan import correction_profile
from mjasc.avoidance.static_conflicts import StaticConflict, static_conflicts_of, track_outlines
from mjasc.avoidance.structure import structure_tracks
from mjasc.core.compiled import clip_float
from mjasc.guidance.paths import Path

__all__ = ["PredictionRecord", "PendingPrediction", "PredictionStep"]


@dataclass(frozen=True, eq=False)
class PredictionRecord:
    """What the latest prediction saw (for the recording and figures): its time, the path and γ it
    predicted along, every track's result (``all``, collision or not, sorted by t_c: a read-only
    sequence whose clear entries are made on first read,
    :class:`~mjasc.avoidance.prediction.conflicts.ConflictList`), the conflicts with a collision,
    the static conflicts, the tracks by id, and the triage's answer per track id
    (:attr:`~mjasc.avoidance.triage.Triage.roles`; empty when nothing was decided)."""

    time_s: float
    path: Path
    gamma_m: float
    all: Sequence
    conflicts: tuple
    statics: tuple
    tracks: dict
    roles: tuple = ()  # ((track id, answer), ...)


@dataclass(frozen=True, eq=False)
class PendingPrediction:
    """A prediction between its query and its result (:meth:`PredictionStep._prediction_query`)."""

    query: PredictionQuery | None
    tracks: list
    outlined: dict
    path: Path
    gamma: float
    profile: object


class PredictionStep:
    """The prediction's two halves and the conflict log of
    :class:`~mjasc.avoidance.system.CollisionAvoidance` (see the module docstring)."""

    def _prediction_query(self, t, tracks, grown=()) -> "PendingPrediction":
        """The first half of :meth:`_predict`: the tracks as predicted (team mates from their
        broadcasts, slow tracks static, a mapped structure's own returns static and no larger than it:
        :func:`~mjasc.avoidance.structure.structure_tracks`) and the query of the disc tracks. The
        tracks whose ids are in ``grown`` are predicted with their radius grown by ``replan_margin_m``."""
        g_state = self._guidance
        tracks = self.team_mates.tracks([tr for tr in tracks if tr.team_member != self.name], t, self._team,
                                        self._event)
        fresh = self.team_mates.fresh(self._team, t)
        v_static = self.config.static_speed_m_s
        inside, on_structure = structure_tracks(
            tracks, list(self._perceived.static_polygons) if self._perceived is not None else [],
            self.config.structure_speed_m_s)
        if set(inside) - self._in_structure:
            self._in_structure |= set(inside)
            self.stats["in_structure"] = len(self._in_structure)
            self._event(t, f"track(s) {sorted(inside)} centred inside mapped structure: the structure's own returns, "
                           f"static and no larger than the structure around their centre")
        lagging = self._static_flag_lagging(tracks, on_structure, inside)
        if lagging:
            tracks = [replace(tr, is_static=False) if tr.track_id in lagging else tr for tr in tracks]
            if lagging - self._lagging_said:
                self._lagging_said |= lagging
                self._event(t, f"track(s) {sorted(lagging)} of the running correction flagged static by the tracker, "
                               f"still at {v_static} m/s or more and more than {self.config.track_deviation_m} m from "
                               f"where first seen: predicted moving (a boat slowing down, not a moored one)")
        tracks = [replace(tr, is_static=True, speed_m_s=0.0, turn_rate_rad_s=0.0,
                          radius_m=min(tr.radius_m, inside.get(tr.track_id, np.inf)))
                  if (not tr.is_static and (tr.speed_m_s < v_static or tr.track_id in on_structure
                                            or tr.track_id in inside)
                      and not self.team_mates.broadcast_based(tr, fresh))
                  else tr for tr in tracks]
        if grown:
            tracks = [replace(tr, radius_m=tr.radius_m + self.config.replan_margin_m) if tr.track_id in grown else tr
                      for tr in tracks]
        ids = {tr.track_id for tr in tracks}
        if self.config.withdraw_false_alarms:  # (what _decide needs to tell a new track's yield)
            for k in ids - self._known_track_ids:
                self._first_predicted_s[k] = t
        self._known_track_ids |= ids
        self._predicted_tracks = {tr.track_id: tr for tr in tracks}
        self._predicted_motion, self._checked_tracks = None, None
        outlined = track_outlines(tracks)
        self.team_mates.remember_prediction(fresh)
        self._last_predict_t = t
        self._predicted_speed = g_state.mission_speed_m_s
        path = g_state.path
        gamma = clip_float(float(g_state.gamma_m), 0.0, float(path.length))  # (float(np.clip(…)) without its call)
        profile = self.predicted_gamma(t, gamma, g_state.mission_speed_m_s)
        self.stats["predictions"] += 1
        discs = [tr for tr in tracks if tr.track_id not in outlined]
        query = PredictionQuery(path, gamma, t, profile, self.radius_m, discs, self.prediction_config,
                                include_clear=True) if discs else None
        return PendingPrediction(query, tracks, outlined, path, gamma, profile)

    def _static_flag_lagging(self, tracks, on_structure, inside) -> set:
        """The track the running velocity correction is for (a moving boat the vessel yields to or
        passes) as a one-id set when its tracker flags it static while it is a boat slowing down,
        not a moored one — its speed estimate still at least ``static_speed_m_s`` (the tracker lifts
        its flag only at twice its own static speed, so the flag lags a speed estimate that dips and
        rises again) and more than ``track_deviation_m`` from where the first prediction that saw it
        put it —, else an empty set. Such a track is predicted with its estimated motion: taken as a
        static outline it asks for a detour around where it is, into where it is going. Team mates
        and tracks a mapped structure accounts for are never among them. Notes each new track's
        first position. (Any flagged track that had moved was tried: in the stressed campaigns it
        changed as many runs for the worse as for the better.)"""
        first, v_static = self._first_position_m, self.config.static_speed_m_s
        corrected_for = self.correction.track_id if self.correction is not None else None
        lagging = set()
        for tr in tracks:
            k = tr.track_id
            p0 = first.get(k)
            if p0 is None:
                first[k] = (float(tr.position_m[0]), float(tr.position_m[1]))
            elif k == corrected_for and tr.is_static and tr.speed_m_s >= v_static and tr.team_member is None \
                    and k not in on_structure and k not in inside:
                p = tr.position_m
                if math.hypot(p[0] - p0[0], p[1] - p0[1]) > self.config.track_deviation_m:
                    lagging.add(k)
        return lagging

    def predicted_gamma(self, t_now: float, gamma_now: float, mission_speed_m_s: float):
        """γ(t) [m] the own vessel is predicted to sail for t ≥ t_now: the plan (``planned_gamma``,
        what the team is told), except that a running correction's speed above the mission speed (a
        pass first's) is shed at ``slow_down_decel_m_s2`` after its goal time, as a hull sheds it
        (:mod:`~mjasc.avoidance.speed_plan`) — also once the correction has ended at its goal
        (``ended_correction``, kept by the control tick), until the excess is shed."""
        c, a = self.correction, self.config.slow_down_decel_m_s2
        if c is None and (ended := self.ended_correction) is not None:  # a pass that has just ended
            law = ended.law
            if a > 0.0 and t_now < law.t_goal + (law.desired_speed - mission_speed_m_s) / a:
                c = ended  # (its goal passed: the hull still sheds what is left of its extra speed)
            else:
                self.ended_correction = None
        return correction_profile(c, t_now, gamma_now, mission_speed_m_s, a)

    def _act_on_prediction(self, t, nav, pending: "PendingPrediction", all_c, static_polygons, after_replan=False) -> list:
        """The second half of :meth:`_predict`: record the predicted conflicts (``all_c``, one per
        disc track), check the static ones and decide."""
        tracks, outlined, path, gamma, profile = (pending.tracks, pending.outlined, pending.path, pending.gamma,
                                                  pending.profile)
        if isinstance(all_c, ConflictList):  # the clear conflicts are made only when read
            distances, conflicts = all_c.min_distances, list(all_c.collisions)
            ids, r_cols = all_c.track_ids, all_c.collision_distances
        else:
            all_c = tuple(all_c)
            distances, conflicts = [c.min_distance_m for c in all_c], [c for c in all_c if c.collision]
            ids, r_cols = [c.track_id for c in all_c], [c.collision_distance_m for c in all_c]
        m = self.min_predicted_distance_m
        for d in distances:
            m = min(m, d)
        self.min_predicted_distance_m = m
        self.team_mates.remember_clearances(self._team_clearances(tracks, ids, distances, r_cols))
        # the mapped polygons, then the static tracks' outlines (checked like a mapped polygon), in one pass
        # (each polygon's conflict is the one it has alone)
        polys = list(static_polygons)
        n_mapped = len(polys)
        tids = list(outlined)
        statics = [c if k < n_mapped else replace(c, track_id=tids[k - n_mapped]) for k, c in
                   static_conflicts_of(t, path, gamma, profile, polys + list(outlined.values()), self.radius_m,
                                       self.prediction_config)]
        by_id = {tr.track_id: tr for tr in tracks}
        if not after_replan and self._perceived is not None and (
                self._withdraw_detour(t, nav, by_id, static_polygons, conflicts) or
                self._withdraw_correction(t, path, gamma, self._predicted_speed, by_id, conflicts)):
            return self._predict(t, nav, list(self._perceived.tracks), static_polygons)
        self._last_query = pending.query
        self._team_track_ids = {tr.track_id for tr in tracks if tr.team_member in self.team}
        self._last = PredictionRecord(t, path, gamma, all_c, tuple(conflicts), tuple(statics), by_id)
        self._stands_on = frozenset()  # (the decision below names them again)
        self._log.prediction_pending()
        self.logged_now = []  # (this prediction's conflict records: the triage's answers go to these)
        for c in conflicts:
            self._record_conflict(t, c, by_id.get(c.track_id))
        for s in statics:
            self._record_static(t, s)
        if not conflicts and not statics:
            return []
        if not self.config.enabled:
            self.stats["monitor_only"] += 1
            return conflicts + statics
        self._decide(t, nav, conflicts, statics, by_id, static_polygons, allow_replan=not after_replan,
                     static_outlines=list(outlined.values()))
        return conflicts + statics

    def _team_clearances(self, tracks, ids, distances, r_cols) -> dict:
        """Each team mate's clearance in this prediction [m]: its closest predicted distance less
        the collision distance (R_vh + its radius + the safety distance, as the prediction took
        them), for the team mates predicted as discs and clear of collision
        (:meth:`TeamMates.remember_clearances`). ``ids``, ``distances``, ``r_cols``: each checked
        pair's track id, d(t_c) and collision distance, in the prediction's order (by t_c)."""
        out = {}
        if not self.team:
            return out
        mate = {tr.track_id: tr.team_member for tr in tracks if tr.team_member in self.team}
        for k, d, r in zip(ids, distances, r_cols):
            name = mate.get(k)
            if name is not None and d - r > 0.0:
                out[name] = min(d - r, out.get(name, math.inf))
        return out

    def _record_conflict(self, t, c: PredictedConflict, track) -> None:
        key = (c.track_id, round(c.t_i), c.decision.value)
        new = not any(k[0] == c.track_id and abs(k[1] - round(c.t_i)) <= 10 for k in self._conflict_keys)
        self._conflict_keys.add(key)
        if new:
            self.stats["predicted_conflicts"] += 1
        who = f"team mate {track.team_member}" if track is not None and track.team_member in self.team else \
            f"track {c.track_id}"
        tf = "∞" if not np.isfinite(c.t_f) else f"{c.t_f:.1f}"
        text = (f"collision predicted with {who} at t_c = {c.t_closest_s:.1f} s (d = {c.min_distance_m:.1f} m < "
                f"{c.collision_distance_m:.1f} m), obstruction [t_i, t_f] = [{c.t_i:.1f}, {tf}] s on "
                f"γ in [{c.gamma_a:.1f}, {c.gamma_b:.1f}] m → {c.decision.value}")
        self._event(t, text)
        self.last_conflict = {"time_s": round(t, 2), "track_id": int(c.track_id),
                              "team_member": getattr(track, "team_member", None),
                              "t_c": round(c.t_closest_s, 2), "d_min_m": round(c.min_distance_m, 2),
                              "t_i": round(c.t_i, 2), "t_f": round(c.t_f, 2) if np.isfinite(c.t_f) else None,
                              "gamma_a": round(c.gamma_a, 2), "gamma_b": round(c.gamma_b, 2),
                              "decision": c.decision.value}
        self.logged_now.append(self.last_conflict)
        if len(self.conflict_log) < 50:  # (the summary's first 50; last_conflict: the latest, for the video)
            self.conflict_log.append(self.last_conflict)

    def _record_static(self, t, s: StaticConflict) -> None:
        key = ("static", round(float(np.mean(s.polygon[:, 0]))), round(float(np.mean(s.polygon[:, 1])))) \
            if s.track_id is None else ("static track", s.track_id)
        if key not in self._conflict_keys:
            self._conflict_keys.add(key)
            self.stats["static_conflicts"] += 1
            self.stats["predicted_conflicts"] += 1
            what = "static obstacle" if s.track_id is None else f"static track {s.track_id} (its outline)"
            self._event(t, f"{what} obstructs the path on γ in [{s.gamma_a:.1f}, {s.gamma_b:.1f}] m "
                           f"(reached at t ≈ {s.t_i:.1f} s) → replan")
            self.last_conflict = {"time_s": round(t, 2), "static": True, "gamma_a": round(s.gamma_a, 2),
                                  "gamma_b": round(s.gamma_b, 2), "decision": "replan"}
            if len(self.conflict_log) < 50:
                self.conflict_log.append(self.last_conflict)
