"""An emergency stop for a vessel outside the team, weighed against keeping way, while a team mate
conflicts too.

When every manoeuvre fails for a track, the vessel stops (:func:`~mjasc.avoidance.decision.emergency_yield`),
and the checked choice (:meth:`~mjasc.avoidance.manoeuvres.Manoeuvres._checked_choice`) predicts the
stop against every track and may keep way instead when that keeps more distance. With a team mate
among the conflicts that check used to be skipped altogether (team mates settle their conflicts by
right of way and their broadcast plans): a vessel could stop in the path of an oncoming stranger
that keeps its course, where keeping way on a fresh lane would have passed it with the hulls apart
(the §6.4.2 head-on as shipped, seed 71). :func:`keep_way_instead` decides that one question from
the two options' predictions, pure: the stop against keeping the plan's speed, judged on the
strangers' predicted misses, with the team mates' collisions as a guard.
"""

from __future__ import annotations

from typing import Iterable

import numpy as np

__all__ = ["keep_way_instead", "worst_miss_m"]


def worst_miss_m(results: Iterable, track_ids, team: bool, until_s: float = np.inf) -> float:
    """The smallest d(t_c) − collision distance [m] over the predicted collisions whose track is
    (``team`` True) or is not (False) in ``track_ids``, with t_c ≤ ``until_s`` [s] for team tracks;
    inf when there is none. Negative: the predicted centres come that much inside the collision
    distance (R_vh + R_ob + safety)."""
    return min((r.min_distance_m - r.collision_distance_m for r in results
                if r.collision and (r.track_id in track_ids) == team and (not team or r.t_closest_s <= until_s)),
               default=np.inf)


def keep_way_instead(stop_results, keep_results, team_track_ids, t: float, last_resort_s: float,
                     safety_distance_m: float, margin_gain_m: float) -> bool:
    """Whether to keep way rather than stop. ``stop_results`` and ``keep_results``: the predicted
    conflicts (every pair, :class:`~mjasc.avoidance.prediction.PredictedConflict`) of the emergency
    stop and of keeping the plan's speed, at time ``t`` [s]. True when keeping way

    * brings no collision with a team mate within ``last_resort_s`` [s] worse than the stop's (a
      team collision further ahead is left to the next predictions: the caller predicts every second
      after keeping way), and
    * clears every track outside the team while the stop does not, or misses them by
      ``margin_gain_m`` [m] more than the stop and still with the hulls apart (the worst miss
      less than ``safety_distance_m`` [m] inside the collision distance): a stranger that keeps its
      course runs into a stopped vessel, and a lane sailed at speed may still pass it.

    A stop that clears the strangers is kept; so is one against a miss as deep as a hull (in the
    stressed bottleneck a fragment of an island, tracked as a large moving target, was predicted
    closer to a stopped vessel than to one that kept way into the gap: keeping way there ended in
    a contact)."""
    soon = t + last_resort_s
    team_stop = worst_miss_m(stop_results, team_track_ids, True, soon)
    if worst_miss_m(keep_results, team_track_ids, True, soon) < min(team_stop, 0.0) - 1e-9:
        return False
    stop, keep = worst_miss_m(stop_results, team_track_ids, False), worst_miss_m(keep_results, team_track_ids, False)
    if stop == np.inf:
        return False
    return keep == np.inf or (keep > stop + margin_gain_m and keep > -safety_distance_m)
