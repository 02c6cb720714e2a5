"""Which speed plan to take when every plan of the checked choice is predicted to collide.

The checked choice (:meth:`~mjasc.avoidance.checked_choice.CheckedChoice._checked_choice`) predicts each
candidate speed plan against every track and takes the first that clears them all. When none does,
:func:`least_bad_option` picks one from the predictions alone (pure, so the rule is tested on
hand-made predictions): the first option — the thesis's choice — unless another keeps
``margin_gain_m`` more distance at its worst predicted miss (estimates are not finer than that).

One exception, for a vessel stopped for a team mate it gives way to (its running emergency stop,
an option of the choice): a plan predicted to run into that team mate before the stop's own first
predicted collision does not replace the stop, however its worst miss compares. In the stressed
§6.4.2 head-on (seeds 149 and 205) alpha, stopped for bravo on a detour that led into bravo's lane,
was offered a pass first for the oncoming stranger each second. Once the stranger's noisy estimate
brought the stop's worst miss (the stranger 25–30 s ahead) within 0.5 m of the pass's (bravo 6–10 s
ahead), the pass was taken; the next prediction, sailing it, met bravo and the vessel stopped again,
a metre further along the detour, into the stranger's lane: five such flips on seed 205, then
contact with the stranger. A collision further ahead leaves time to look again (the stop predicts every
second); one with the team mate the stop is for undoes the reason for stopping.
"""

from __future__ import annotations

from typing import Iterable, Sequence

import numpy as np

from mjasc.avoidance.keep_way import worst_miss_m

__all__ = ["least_bad_option", "first_collision_s"]


def first_collision_s(results: Iterable, track_id=None) -> float:
    """The earliest t_c [s] among the predicted collisions of ``results`` (each a
    :class:`~mjasc.avoidance.prediction.PredictedConflict`) — of every track, or of ``track_id``'s
    alone; inf when there is none."""
    return min((r.t_closest_s for r in results if r.collision and (track_id is None or r.track_id == track_id)),
               default=np.inf)


def least_bad_option(results: Sequence, margin_gain_m: float, stop_for_mate: tuple[int, int] | None = None) -> int:
    """The index of the option to take among ``results`` (one list of predicted pairs per option,
    each predicted to collide; option 0 is the first choice): the first, unless another's worst
    predicted miss (:func:`~mjasc.avoidance.keep_way.worst_miss_m`) is larger by more than
    ``margin_gain_m`` [m] — then the one with the largest. ``stop_for_mate``: (the index of the
    running emergency stop for a team mate, that team mate's track id) or None; an option whose
    first predicted collision with that team mate comes no later than the stop's first predicted
    collision (with anyone) is not taken instead of the stop (module docstring)."""
    margin = [worst_miss_m(res) for res in results]
    if stop_for_mate is not None:
        stop, mate = stop_for_mate
        t_stop = first_collision_s(results[stop])
        for j, res in enumerate(results):
            if j != stop and first_collision_s(res, mate) <= t_stop:
                margin[j] = -np.inf
    best = int(np.argmax(margin))
    return best if margin[best] > margin[0] + margin_gain_m else 0
