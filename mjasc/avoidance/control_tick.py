"""The control tick of a vessel's collision avoidance: whether to predict at once, and the
running manoeuvre's references.

Every control tick (:func:`~mjasc.avoidance.fleet_slots.control_slot`) polls the team's broadcasts and
asks :meth:`ControlTick._prediction_due`: a new track, a running emergency, a new mission leg, a
changed own mission speed, a team mate's changed plan, or a track that left the motion the last
prediction assumed (:meth:`ControlTick._deviating`, one array operation on the last prediction's
stacked track motions) predict at once. After it :meth:`ControlTick._control_rest` gives the speed
and course overrides of the manoeuvre running (a velocity correction's law, a detour's end, a
sharp turn on a detour: brake, then turn) and notes the mode. :meth:`ControlTick.gives_way_to`
names the team mate a running yield is for (the coordination broadcasts it).

:class:`ControlTick` is a part of :class:`~mjasc.avoidance.system.CollisionAvoidance` (its state
is the system's). World frame ENU, SI units, absolute simulation times [s].
"""

from __future__ import annotations

import math
from operator import attrgetter

import numpy as np

from mjasc.avoidance.prediction import TrackMotions
from mjasc.avoidance.static_conflicts import track_outlines
from mjasc.avoidance.structure import REVERSAL_RAD, turn_away_from_structure
from mjasc.core.estimates import TrackRows, track_columns
from mjasc.guidance.segment_geometry import wrap_scalar

__all__ = ["ControlTick"]

_TRACK_ID = attrgetter("track_id")
#: A near-reversal sharp turn beside structure (structure.turn_away_from_structure): the bow's sweep
#: is measured this far ahead (the detour's aim point, 5 m), the long way taken when it clears the
#: structure by this much more, and steered by a course 90° round until this much turn is left.
_REVERSAL_PROBE_M = 5.0
_REVERSAL_MARGIN_M = 1.0
_LONG_WAY_RELEASE_RAD = math.radians(150.0)
#: A sharp turn's guard (ControlTick._turn_closes_on_track): tracks at most this fast [m/s] are
#: where they are during the turn; the hull is held when it would reach one's collision distance
#: within this many seconds at its speed [s], once it makes at least this much way [m/s].
_SLOW_TRACK_M_S = 0.5
_TURN_GUARD_S = 1.0
_TURN_GUARD_MIN_SPEED_M_S = 0.05
_INT64 = 2 ** 63
#: A sharp turn the guard held (the hull beside a slow track) goes on in place until the hull points
#: this close to its aim point [rad] — not only within ``sharp_turn_deg``: released 57° off, the path
#: follower sailed the rest of the turn as an arc at mission speed into the moored boat the guard had
#: stopped it for (thesis_6_2_dock stressed, seed 297).
_HELD_RELEASE_RAD = math.radians(20.0)


class ControlTick:
    """The control tick's checks and references of :class:`~mjasc.avoidance.system.CollisionAvoidance`
    (see the module docstring)."""

    #: Its mode changes are events of its own (:meth:`_note_mode`): the runner does not log them again.
    logs_mode_changes = True

    def gives_way_to(self) -> tuple:
        """The team mates this vessel gives way to now: the one whose track a running yield (or
        emergency stop) is for, when that track is a team mate's; empty otherwise. Broadcast by the
        coordination layer so that the stand-on team mate keeps its speed."""
        c = self.correction
        if c is None or c.kind != "yield":
            return ()
        track = self._predicted_tracks.get(c.track_id)
        mate = getattr(track, "team_member", None)
        return (mate,) if mate is not None and mate in self.team and mate != self.name else ()

    def stands_on_to(self) -> tuple:
        """The team mates toward which the last prediction made this vessel the stand-on vessel
        (before the last resort); broadcast so that of two team mates that both stand on, one gives
        way (:mod:`~mjasc.avoidance.triage`)."""
        return tuple(sorted(self._stands_on))

    def _double_stand_on(self, t) -> bool:
        """A team mate this vessel stands on toward, whose name sorts before its own, says in a fresh
        broadcast that it stands on toward this vessel too: this vessel is to give way (predict now)."""
        return any(name < self.name for name in self._mates_declaring(t)[1] & self._stands_on)

    def _predict_on_perceived(self, t, nav) -> None:
        p = self._perceived
        self._predict(t, nav, list(p.tracks), list(p.static_polygons))

    def _prediction_due(self, t) -> set | None:
        """Whether the control tick predicts at once: None (no), the new track ids (a new track),
        or an empty set (an emergency not yet cleared, way kept instead of one
        (:mod:`~mjasc.avoidance.keep_way`), the own mission speed changed, a team mate re-planned, a
        track deviates); the event and counters are noted here."""
        perceived = self._perceived
        if perceived is None:
            return None
        tracks = perceived.tracks
        if tracks is not self._no_new_in:
            if self._known_track_ids.issuperset(tracks.track_ids if type(tracks) is TrackRows
                                                else map(_TRACK_ID, tracks)):
                self._no_new_in = tracks  # known ids only grow: these tracks stay known
            else:
                new = set(track_columns(tracks)[0]) - self._known_track_ids
                self._event(t, f"new track(s) {sorted(new)}: predicting now")
                return new
        if t - self._last_predict_t < 1.0:
            return None
        if self._mission_moved:  # a new mission leg (mjasc.missions): look along it
            self._mission_moved = False
            return set()
        if t < self._look_again_until_s:  # way kept instead of a stop, or a running correction kept though it collides
            self.stats["deviation_predictions"] += 1
            return set()
        if self.correction is not None and (self.correction.emergency or self.correction.withdrawable):
            self.stats["deviation_predictions"] += 1  # nothing cleared it, or it may be a false alarm: look again
            return set()
        if self.correction is None and self._predicted_speed is not None and \
                ((dv := self._guidance.mission_speed_m_s - self._predicted_speed) > self.config.speed_change_m_s
                 or -dv > self.config.speed_change_m_s):  # (abs(dv) > the limit without its call)
            self.stats["deviation_predictions"] += 1  # own plan changed (coordination): predict again
            return set()
        team, mates = self._team, self.team_mates
        if team is not None and team.intentions is not mates.compared_intentions and mates.plans_changed(t, team):
            self.stats["deviation_predictions"] += 1  # a team mate re-planned or changed its speed
            return set()  # (the mapping compared in full last holds nothing new: plans_changed False)
        if self._stands_on and self._double_stand_on(t):
            self._event(t, "a team mate stands on toward this vessel too: predicting now")
            return set()
        # a track that left the motion the last prediction assumed (tracks checked already: no)
        if tracks is not self._checked_tracks and self._deviating(tracks):
            self.stats["deviation_predictions"] += 1
            return set()
        return None

    def _control_query(self, t) -> tuple | None:
        """The control tick up to its prediction: the team polled, and when a prediction is due
        (:meth:`_prediction_due`) its query and the new track ids, else None."""
        team = self._team
        if team is not None and team.intentions is not self.team_mates.polled_intentions:
            self.team_mates.poll(team)  # (the mapping polled last holds nothing new)
        new = self._prediction_due(t)
        if new is None:
            return None
        return self._prediction_query(t, list(self._perceived.tracks)), new

    def _control_predict(self, t, nav, pending, all_c) -> None:
        """Act on the control tick's prediction (``pending`` from :meth:`_control_query`, its
        conflicts ``all_c``)."""
        query, new = pending
        self._act_on_prediction(t, nav, query, all_c, list(self._perceived.static_polygons))
        self._known_track_ids |= new  # also those the prediction set aside (a team mate's stale copy)

    def _deviating(self, tracks) -> bool:
        """Some track is farther than ``track_deviation_m`` from where the last prediction put it
        at the track's time (team mates on a fresh broadcast excepted: their plans are compared
        instead). All tracks in one array operation on the last prediction's stacked motion; the
        same tracks are not checked twice against the same prediction."""
        if tracks is self._checked_tracks:
            return False
        ids_arr = None
        if type(tracks) is TrackRows and type(tracks.track_ids) is list:  # (track_columns and len without
            ids, times, pos = tracks.track_ids, tracks.times_s, tracks.positions_m  # their calls: the rows' columns)
            if not ids:
                return False
            ids_arr, times_arr = tracks.id_array, tracks.time_array  # (a tracker's report: the columns as arrays)
        elif not tracks:
            return False
        else:
            ids, times, pos = track_columns(tracks)
        self._checked_tracks = tracks
        motion = self._predicted_motion
        if motion is None:
            from_broadcast = self.team_mates.predicted_names()
            checked = [tr for tr in self._predicted_tracks.values() if tr.team_member not in from_broadcast]
            motion = self._predicted_motion = TrackMotions(checked)
            self._predicted_row = {tr.track_id: k for k, tr in enumerate(checked)}
            row_ids = [tr.track_id for tr in checked]  # (int64 for the compiled pass when they fit)
            self._predicted_ids = np.array(row_ids, dtype=np.int64) if all(
                type(i) is int and -_INT64 <= i < _INT64 for i in row_ids) else None
        # The rows' ids, times and positions in one compiled pass when the ids are integers (as
        # the row mapping below answers; a known row on a plan: that mapping's way): a tracker's
        # report hands them as arrays (positions (k, 2) floats), other tracks are converted
        if self._predicted_ids is None:
            ids_arr = None
        elif ids_arr is None:
            ids_arr = np.array(ids)
            times_arr, pos_arr = np.array(times, dtype=float), np.asarray(pos, dtype=float).reshape(-1, 2)
        else:
            pos_arr = pos
        if ids_arr is not None and ids_arr.dtype == np.int64 and ids_arr.ndim == 1:
            far = motion.farther_by_id(self._predicted_ids, ids_arr, times_arr, pos_arr,
                                       self.config.track_deviation_m)
            if far is not None:
                return far
        row = self._predicted_row
        sel = [(row[i], k) for k, i in enumerate(ids) if i in row]
        if not sel:
            return False
        rows, ks = zip(*sel)
        if len(ks) < len(ids):
            times, pos = [times[k] for k in ks], [pos[k] for k in ks]
        return self._predicted_motion.farther_than(rows, times, pos, self.config.track_deviation_m)

    def _control_rest(self, t, nav) -> tuple[float | None, str, float | None]:
        """The control tick after its prediction: :meth:`_control_refs`' result; switches back to
        the mission path when a detour is finished. (On the mission, without a detour, a velocity
        correction or a sharp turn to leave, there are no overrides: the mode is noted only.)"""
        override = course = None
        if self.detour is not None or self.correction is not None or self._sharp_turn is not None:
            override, course = self._manoeuvre_refs(t, nav)
        return override, self._note_mode(t), course

    def _note_mode(self, t) -> str:
        """The mode after this tick's manoeuvres (a correction, a detour, else the mission: a
        correction sailed on a detour is the correction's mode): its time counted, and the time on
        a detour in any mode (``detour_time_s``), its change logged as an event."""
        detour = self.detour is not None
        if self.correction is not None:
            mode = f"avoidance:{self.correction.kind}"
        elif detour:
            mode = "avoidance:detour"
        else:
            mode = "mission"
        if self._last_control_t is not None:
            dt = t - self._last_control_t
            dt = 0.0 if 0.0 > dt else dt  # (max(dt, 0.0) without its call)
            self.mode_time_s[self.mode] += dt
            if self._on_detour:
                self.detour_time_s += dt
        self._last_control_t, self._on_detour = t, detour
        if mode != self.mode:
            self._event(t, f"mode {self.mode} → {mode}")
            self.mode = mode
        return mode

    def _manoeuvre_refs(self, t, nav) -> tuple[float | None, float | None]:
        """(speed override [m/s] or None, course override [rad] or None) of a running manoeuvre:
        back on the mission path at a detour's end, a velocity correction's law (a finished one
        ended, the planned motion predicted again), a sharp turn on a detour."""
        d = self.detour
        g = self._guidance
        if d is not None and g.path is d.path and g.gamma_m >= d.detour_length_m - 0.5 and t >= d.hold_until_s:
            g_m = d.mission_gamma(g.gamma_m)
            self._back_to_mission(t, g_m, f"detour finished: back on the mission path at γ = {g_m:.1f} m")
        elif d is not None and g.path is not d.path:
            self.detour = None
        override = None
        c = self.correction
        if c is not None:
            if c.law.finished(t):
                self._event(t, f"velocity correction ({c.kind}) complete: mission speed resumed")
                self.correction, self.ended_correction = None, c  # (its extra speed is still being shed)
                if self._perceived is not None:  # the planned motion changed: check it before it is sailed
                    self.stats["deviation_predictions"] += 1
                    self._predict_on_perceived(t, nav)
                c = self.correction
            if c is not None and not c.law.finished(t):
                override = c.law.command(self._guidance.gamma_m + c.gamma_offset_m, t)
        course = None
        if self.detour is not None and self.correction is None:
            override, course = self._sharp_turn_speed(t, nav, override)
        elif self._sharp_turn is not None:
            self._sharp_turn = None
        return override, course

    def _sharp_turn_speed(self, t, nav, override) -> tuple[float | None, float | None]:
        """Brake, then turn, when a detour asks for a sharp turn: its point 5 m ahead more than
        ``sharp_turn_deg`` off the heading. While the hull is faster than ``sharp_turn_speed_m_s``
        it takes all way off holding its heading (course override); then it turns at that speed.
        Returns (speed override, course override [rad] or None). A saturated turn at speed leaves
        forward thrust (a full differential: reverse is the weaker propeller direction) and
        advances the hull several metres — thesis §6.2 and §6.4.3 under 30 % dropout: a re-plan 7 m
        from the pontoon / the south island asked for a 92° turn and the Otter, still at 0.55 m/s,
        ran into it; it stops from 1 m/s within a metre. Once the turn's guard has held it (the
        hull closing on a slow track: all way off, the heading held), the rest of the turn is
        turned in place — speed 0, where the allocation keeps the differential within the reverse
        thrust (:mod:`mjasc.guidance.following_law`) — instead of being sailed at the turn speed
        into the next hold, until the hull points within :data:`_HELD_RELEASE_RAD` of its aim point."""
        g, cfg = self._guidance, self.config
        x, y, _, _ = g.path.at(min(g.gamma_m + 5.0, g.path.length))
        # wrap_angle(np.arctan2(…) − ψ) and np.radians in plain floats (the same bits: math's atan2
        # equals numpy's on x86-64 without AVX-512, mjasc.guidance.segment_geometry; one call each)
        p = nav.position_m
        signed = wrap_scalar(math.atan2(float(y - p[1]), float(x - p[0])) - float(nav.heading_rad))
        err = abs(signed)
        was_held = self._sharp_turn is not None and self._sharp_turn[0] == "held"
        if err <= (_HELD_RELEASE_RAD if was_held else math.radians(cfg.sharp_turn_deg)):
            self._sharp_turn = None
            return override, None
        limit = cfg.sharp_turn_speed_m_s
        if self._sharp_turn is None:  # onset: brake first when faster than the turn speed
            self.stats["sharp_turn"] += 1
            fast = float(nav.body_velocity[0]) > limit
            self._sharp_turn = ("brake", float(nav.heading_rad)) if fast else ("turn", None)
            self._event(t, f"sharp turn on the detour ({math.degrees(err):.0f}° off the heading): "
                           + ("all way off on the heading, then " if fast else "") + f"turning at {limit:g} m/s")
        if self._sharp_turn[0] == "brake":
            if float(nav.body_velocity[0]) > limit:
                return 0.0, self._sharp_turn[1]
            self._sharp_turn = ("turn", None)
        speed = limit if override is None else min(override, limit)
        if self._sharp_turn[1] is None:  # the turn's direction, once: away from mapped structure
            way = 0
            if self._perceived is not None and err >= REVERSAL_RAD:
                # mapped structure and the outlines of static tracks (a moored boat is as solid as a quay:
                # a long way round away from the quay swept the bow into one, thesis_6_2_dock seed 11)
                solid = list(self._perceived.static_polygons) + list(track_outlines(self._perceived.tracks).values())
                way = turn_away_from_structure(p, float(nav.heading_rad), signed, solid, _REVERSAL_PROBE_M,
                                               _REVERSAL_MARGIN_M)
            self._sharp_turn = ("turn", way)
            if way:
                self.stats["turn_away"] += 1
                self._event(t, f"the {math.degrees(err):.0f}° turn the long way round "
                               f"({'to port' if way > 0 else 'to starboard'}): away from mapped structure")
        if self._turn_closes_on_track(nav):  # the turn's guard: all way off, the heading held
            if self._sharp_turn[0] != "held":
                self.stats["turn_held"] += 1
                self._event(t, "sharp turn held: the hull closes on a slow track within its safety distance")
            self._sharp_turn = ("held", self._sharp_turn[1])
            return 0.0, float(nav.heading_rad)
        way = self._sharp_turn[1]
        held = self._sharp_turn[0] == "held"  # way off: the rest of the turn in place (no thrust ahead)
        if held:
            speed = 0.0
        if way and (way * signed) % (2.0 * math.pi) > _LONG_WAY_RELEASE_RAD:  # still the long way to go
            return speed, wrap_scalar(float(nav.heading_rad) + way * 0.5 * math.pi)
        # held: towards the aim point itself (not the LOS course: with no way on γ stands still)
        return speed, wrap_scalar(float(nav.heading_rad) + signed) if held else None

    def _turn_closes_on_track(self, nav) -> bool:
        """Whether the hull, turning, closes on a slow track (static, or at most
        :data:`_SLOW_TRACK_M_S`; team mates among them) and is within its collision distance of it
        plus one second of its own speed. A sharp turn leaves the planned path — the saturated
        turn advances the hull several metres — so the predictions, made along the plan, do not see
        where the turn takes it: a 161° turn beside the §6.4.3 gap swept a Delfim 5 m onto a team
        mate stopped there (30 % dropout and packet loss, seed 4)."""
        pr = self._perceived
        if pr is None or not pr.tracks:
            return False
        vx, vy = float(nav.velocity_m_s[0]), float(nav.velocity_m_s[1])  # over ground, world [m/s]
        speed = math.hypot(vx, vy)
        if speed < _TURN_GUARD_MIN_SPEED_M_S:
            return False
        px, py = float(nav.position_m[0]), float(nav.position_m[1])
        for tr in pr.tracks:
            if not (tr.is_static or tr.speed_m_s <= _SLOW_TRACK_M_S):
                continue
            dx, dy = float(tr.position_m[0]) - px, float(tr.position_m[1]) - py
            if dx * vx + dy * vy > 0.0 and \
                    math.hypot(dx, dy) - float(tr.radius_m) - self.radius_m < speed * _TURN_GUARD_S:
                return True
        return False
