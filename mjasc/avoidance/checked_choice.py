"""The checked choice: every candidate speed plan predicted against every track before one is taken.

:meth:`CheckedChoice._checked_choice` is a part of the decision σ
(:meth:`~mjasc.avoidance.manoeuvres.Manoeuvres._decide`): the first choice's speed plan (a yield, a
pass first, an emergency stop) and the alternatives — the other candidates, passing first for each
conflict, the running correction, keeping the mission speed — predicted in one fleet prediction;
the first that clears every track is taken, else the least bad
(:func:`~mjasc.avoidance.colliding_choice.least_bad_option`). With a team mate among the conflicts
only an emergency stop for a stranger is weighed, against keeping way
(:func:`~mjasc.avoidance.keep_way.keep_way_instead`).

:class:`CheckedChoice` is a part of :class:`~mjasc.avoidance.system.CollisionAvoidance` (its state
is the system's). World frame ENU, SI units, absolute simulation times [s].
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from mjasc.avoidance.colliding_choice import least_bad_option
from mjasc.avoidance.decision import Correction, velocity_correction_for
from mjasc.avoidance.keep_way import keep_way_instead, worst_miss_m
from mjasc.avoidance.prediction import PredictedConflict, PredictionQuery, predict_fleet
from mjasc.avoidance.speed_plan import correction_profile

__all__ = ["CheckedChoice"]

#: When every candidate speed plan collides, another is taken over the first choice only if its
#: worst predicted miss distance is larger by this much [m] (estimates are not finer than that).
_MARGIN_GAIN_M = 0.5


class CheckedChoice:
    """The checked choice of :class:`~mjasc.avoidance.system.CollisionAvoidance` (see the module docstring)."""

    def _checked_choice(self, t, chosen: Correction, candidates: list[Correction], conflicts,
                        no_pass=frozenset()) -> Correction | None:
        """``chosen``, unless the speed it plans runs into another track. Every option's planned
        motion (its V_d until its goal time, the mission speed after) is predicted against all the
        disc tracks in one call; the options are ``chosen``, the other candidates (slowest first),
        passing first for each conflict where feasible (not for the tracks of ``no_pass``, toward which
        the COLREG role forbids it: a give-way vessel in a crossing never passes ahead, a stand-on
        vessel keeps its speed), the running correction (below), and keeping
        the mission speed (None). The first with no predicted collision is taken; when every one
        collides, the one whose worst predicted miss distance is largest (``chosen``, the thesis's
        choice, unless another keeps :data:`_MARGIN_GAIN_M` more: an emergency stop in a crossing
        ferry's path waits for it to arrive; a running stop for a team mate is not left for a plan into
        that team mate: :func:`~mjasc.avoidance.colliding_choice.least_bad_option`). (In Imazu case 19
        the slow-down for one target put the vessel in the path of another 5 s later.) With a team
        mate among the conflicts (between team mates the right of way and the broadcast plans decide)
        only an emergency stop for a stranger is weighed, against keeping way (:meth:`_stop_or_keep_way`).

        The running correction is an option when it is for another track, its goal is ahead and
        ``chosen`` is not an emergency stop: it settles a conflict this prediction no longer shows,
        because the prediction sails the plan it makes (in the stressed head-on, seed 168, alpha,
        yielding to bravo's unmatched track ahead, saw only the oncoming stranger and took a pass
        first at 2.12 m/s into bravo, the pass and the mission speed both predicted 2.7–2.9 m inside
        the collision distance with it). A stop for a conflict nothing else resolves is not weighed
        against it (a running yield kept instead delayed the head-on's seed 250 stop by a second,
        into contact). The running plan — that correction, or the mission speed when none runs —
        kept though it still collides is looked at again every second until its last predicted
        closest approach, as after an emergency stop."""
        query = self._last_query
        if query is None or len(query.tracks) < 2:
            return chosen
        team_ids = self._team_track_ids
        if any(getattr(c, "track_id", None) in team_ids for c in conflicts):
            # team mates coordinate by right of way and their broadcast plans: only an emergency stop
            # for a stranger is weighed, against keeping way (mjasc.avoidance.keep_way)
            if chosen.emergency and chosen.track_id not in team_ids:
                return self._stop_or_keep_way(t, chosen, query, conflicts)
            return chosen
        g_state = self._guidance
        gamma = float(np.clip(g_state.gamma_m, 0.0, g_state.path.length))
        options = [chosen] + sorted((c for c in candidates if c is not chosen), key=lambda c: c.law.desired_speed)
        for c in conflicts:
            if isinstance(c, PredictedConflict) and c.track_id not in no_pass and \
                    not any(o.kind == "pass" and o.track_id == c.track_id for o in options):
                alt = velocity_correction_for(t, gamma, c, self.config, self.speed_max_m_s, pass_only=True,
                                              path_end_m=float(g_state.path.length))
                if alt is not None:
                    options.append(alt)
        running = self.correction  # (what it does now: a new conflict must not undo the one it settles)
        weigh_running = running is not None and not chosen.emergency and running.track_id != chosen.track_id and \
            t < running.law.t_goal
        if weigh_running:  # (the candidates are all new: it is never among them)
            options.append(running)
        options.append(None)
        results = self._option_results(t, options, query)
        clear = [k for k, res in enumerate(results) if not any(r.collision for r in res)]
        if clear:
            k = clear[0]
        else:  # every plan collides: the one that keeps the most distance (the thesis's choice on ties)
            # (a running stop for a team mate is not left for a plan into it: mjasc.avoidance.colliding_choice)
            stop_for_mate = (len(options) - 2, running.track_id) if \
                weigh_running and running.emergency and running.track_id in team_ids else None
            k = least_bad_option(results, _MARGIN_GAIN_M, stop_for_mate)
            # The running plan kept though it collides — its correction, or the mission speed (None) when
            # none runs — is looked at again every second, as after an emergency stop.
            if options[k] is running:
                ahead = [float(r.t_closest_s) for r in results[k] if r.collision and math.isfinite(r.t_closest_s)]
                self._look_again_until_s = max([self._look_again_until_s] + ahead)
        if k != 0:
            self.stats["checked_choice"] += 1
            what = "keep the mission speed" if options[k] is None else \
                f"{'its running ' if options[k] is running else ''}{options[k].label} for track {options[k].track_id}"
            self._event(t, f"{chosen.label} for track {chosen.track_id} still leaves a predicted collision (with it or "
                           f"another track): {what} instead" + ("" if clear else " (no plan clears every track: "
                                                                 "this one keeps the most distance)"))
        return options[k]

    def _option_results(self, t, options: list, query: PredictionQuery) -> list:
        """Each speed option (a correction, or None: the mission speed) predicted against every track
        of ``query`` on the path sailed now, clear pairs included: one result list per option."""
        g_state = self._guidance
        gamma = float(np.clip(g_state.gamma_m, 0.0, g_state.path.length))
        return predict_fleet([replace(query, vessel_path=g_state.path, gamma_now=gamma, t_now=float(t),
                                      speed_profile=correction_profile(c, float(t), gamma, g_state.mission_speed_m_s,
                                                                       self.config.slow_down_decel_m_s2),
                                      include_clear=True) for c in options])

    def _stop_or_keep_way(self, t, stop: Correction, query: PredictionQuery, conflicts) -> Correction | None:
        """With a team mate among the conflicts: the emergency ``stop`` for a stranger's track, or None
        (keep way: the mission speed) when :func:`~mjasc.avoidance.keep_way.keep_way_instead` says so.
        After keeping way the vessel predicts every second until the latest predicted closest
        approach of its conflicts, team mates' included (each of those predictions weighs the stop
        again; a window ending at the strangers' closest approach took one run of the stressed
        bottleneck from 1.59 to −0.12 m). While that window runs, way kept against the same stranger is
        left for the stop only when the stop is predicted to miss it by more (``kept``)."""
        stop_res, keep_res = self._option_results(t, [stop, None], query)
        cfg, team = self.config, self._team_track_ids
        kept = float(t) < self._look_again_until_s and stop.track_id == self._way_kept_for
        if not keep_way_instead(stop_res, keep_res, team, float(t), cfg.last_resort_s,
                                self.prediction_config.safety_distance_m, _MARGIN_GAIN_M, kept):
            self._way_kept_for = None  # (the stop taken: the next weighing starts afresh)
            return stop
        self.stats["checked_choice"] += 1
        self._way_kept_for = stop.track_id
        ahead = [float(c.t_closest_s) for c in list(conflicts) + list(keep_res)
                 if isinstance(c, PredictedConflict) and c.collision and math.isfinite(c.t_closest_s)]
        self._look_again_until_s = max([self._look_again_until_s] + ahead)
        stop_m, keep_m = worst_miss_m(stop_res, team, False), worst_miss_m(keep_res, team, False)
        self._event(t, f"an emergency stop for track {stop.track_id} would wait in the way of a vessel outside the "
                       f"team (its worst predicted miss {-stop_m:.1f} m inside the collision distance; keeping way "
                       + ("clears them" if keep_m == np.inf else f"{-keep_m:.1f} m inside") + "): keeps way instead, "
                       f"predicting every second until t = {self._look_again_until_s:.1f} s")
        return None
