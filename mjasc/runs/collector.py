"""Python's cyclic garbage collector during a run's loop (no result depends on it).

What a run builds before its loop — the compiled world, the agents and their components, the
recording's blueprint, the imported modules: ~370,000 objects at 50 vessels — lives for the whole
run, yet every full collection walks all of it (0.3 s a pass at 50 vessels), and the young
generation is collected every 700 new containers (a control tick of 50 vessels makes thousands of
small dataclasses). :func:`pause` moves the objects alive now out of the collector's generations
(``gc.freeze``) and collects young objects ten times less often; :func:`resume` restores both.
Measured on the 50-vessel formation (10 s, recording on): 0.53 s of collection → 0.12 s.
:func:`for_the_program` sets the same young threshold for the whole ``mjasc`` program, from its
start: a command imports ~1,400 modules and builds its world before a run's loop begins.
"""

from __future__ import annotations

import gc

__all__ = ["for_the_program", "pause", "resume"]

#: The young generation's threshold while paused (Python's default is 700).
YOUNG_THRESHOLD = 7000


def pause() -> tuple[int, ...]:
    """Freeze what is alive now and raise the young generation's threshold; returns the thresholds
    to hand to :func:`resume`."""
    old = gc.get_threshold()
    gc.freeze()
    gc.set_threshold(max(YOUNG_THRESHOLD, old[0]), *old[1:])
    return old


def resume(thresholds: tuple[int, ...]) -> None:
    """Undo :func:`pause`: the thresholds as they were, the frozen objects collectable again."""
    gc.set_threshold(*thresholds)
    gc.unfreeze()


def for_the_program() -> None:
    """The ``mjasc`` program's collector from its start (:func:`mjasc.cli.command_line`; a library
    user keeps Python's): the young generation collected every :data:`YOUNG_THRESHOLD` new
    containers, as during a run's loop. At Python's default (700) the imports and the set-up of a
    §6.4.1 crossing command made ~500 young, ~45 middle and ~4 full collections, ~0.3 s of its
    ~2.7 s; with this ~50, ~4 and none, ~0.09 s."""
    old = gc.get_threshold()
    gc.set_threshold(max(YOUNG_THRESHOLD, old[0]), *old[1:])
