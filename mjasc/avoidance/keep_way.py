"""An emergency stop for a vessel outside the team, weighed against keeping way, while a team mate
conflicts too.

When every manoeuvre fails for a track, the vessel stops (:func:`~mjasc.avoidance.decision.emergency_yield`),
and the checked choice (:meth:`~mjasc.avoidance.checked_choice.CheckedChoice._checked_choice`) predicts the
stop against every track and may keep way instead when that keeps more distance. With a team mate
among the conflicts that check used to be skipped altogether (team mates settle their conflicts by
right of way and their broadcast plans): a vessel could stop in the path of an oncoming stranger
that keeps its course, where keeping way on a fresh lane would have passed it with the hulls apart
(the §6.4.2 head-on as shipped, seed 71). :func:`keep_way_instead` decides that one question from
the two options' predictions, pure: the stop against keeping way (the mission speed on the path
sailed now), judged on the strangers' predicted misses, with the team mates' collisions as a guard.

Keeping way is predicted at the mission speed from now on, as every option of the checked choice
is, and each prediction in the seconds after weighs the stop again. Once way is kept, the stop is
taken only when it is predicted to miss the same stranger by ``margin_gain_m`` more: the first
choice also asks keeping way to leave the hulls apart, and asked again, that guard turned the
choice back to the stop as the stranger came near and its predicted miss deepened — in the §6.4.2
head-on as shipped (seeds 167 and 182) bravo kept way at 114.1, 115.2 and 116.3 s and stopped at
117.4 s, 0.6 s before keeping way's predicted closest approach (1.2 m inside the collision
distance) and with the stop's own prediction 2.7 m inside: it took all way off in the oncoming
vessel's path and was run into 2.4 s later. Keeping way, it passes with the hulls apart.
"""

from __future__ import annotations

from typing import Iterable

import numpy as np

__all__ = ["keep_way_instead", "worst_miss_m"]


def worst_miss_m(results: Iterable, track_ids=(), team: bool | None = None, until_s: float = np.inf) -> float:
    """The smallest d(t_c) − collision distance [m] over the predicted collisions — of every track
    (``team`` None), or of those whose track is (True) or is not (False) in ``track_ids``, with
    t_c ≤ ``until_s`` [s] for team tracks; inf when there is none. Negative: the predicted centres
    come that much inside the collision distance (R_vh + R_ob + safety)."""
    return min((r.min_distance_m - r.collision_distance_m for r in results if r.collision and (
        team is None or (r.track_id in track_ids) == team and (not team or r.t_closest_s <= until_s))), default=np.inf)


def keep_way_instead(stop_results, keep_results, team_track_ids, t: float, last_resort_s: float,
                     safety_distance_m: float, margin_gain_m: float, kept: bool = False) -> bool:
    """Whether to keep way rather than stop. ``stop_results`` and ``keep_results``: the predicted
    conflicts (every pair, :class:`~mjasc.avoidance.prediction.PredictedConflict`) of the emergency
    stop and of keeping way (the mission speed), at time ``t`` [s]. True when keeping way

    * brings no collision with a team mate within ``last_resort_s`` [s] worse than the stop's (a
      team collision further ahead is left to the next predictions: the caller predicts every second
      after keeping way), and
    * clears every track outside the team while the stop does not, or misses them by
      ``margin_gain_m`` [m] more than the stop and still with the hulls apart (the worst miss
      less than ``safety_distance_m`` [m] inside the collision distance): a stranger that keeps its
      course runs into a stopped vessel, and a lane sailed at speed may still pass it.

    A stop that clears the strangers is kept; so is one against a keeping way that misses them by
    more than the safety distance inside the collision distance (in the stressed bottleneck a
    fragment of an island, tracked as a large moving target, was predicted 8.1 m inside against a
    stopped vessel and 6.3 m against one keeping way into the gap: keeping way there ended in a
    contact between team mates). The worst misses are over all strangers, not the stop's track
    alone.

    ``kept``: way is kept already against this stranger (the caller's look-again window runs). Then,
    the team mates' guard above still first, way is kept unless the stop misses the strangers by
    ``margin_gain_m`` more than keeping way (so also when the stop clears them and keeping way does
    not): the hull condition is not asked again, since stopping late in a stranger's path is
    no remedy for a miss that deepens as it comes near."""
    soon = t + last_resort_s
    team_stop = worst_miss_m(stop_results, team_track_ids, True, soon)
    if worst_miss_m(keep_results, team_track_ids, True, soon) < min(team_stop, 0.0) - 1e-9:
        return False
    stop, keep = worst_miss_m(stop_results, team_track_ids, False), worst_miss_m(keep_results, team_track_ids, False)
    if kept:
        return not stop > keep + margin_gain_m
    if stop == np.inf:
        return False
    return keep == np.inf or (keep > stop + margin_gain_m and keep > -safety_distance_m)
