"""Multi-rate scheduling on the physics clock.

Every slot (control, sensing, tracking, prediction, comms, recording, video) runs every
``period_steps`` physics steps, with its period rounded to a whole number of steps (the realized
rate is reported). Slots due at the same step run in the fixed order of :data:`SLOT_ORDER`, so
data flows one way through a tick: sense → track → comms → predict → control → record → video.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

__all__ = ["Schedule", "SLOT_ORDER"]

SLOT_ORDER = ("sensing", "tracking", "comms", "prediction", "control", "record", "video")


#: The longest cycle (in physics steps) :meth:`Schedule.tick` keeps a table of.
_CYCLE_MAX = 20_000


@dataclass(frozen=True)
class Schedule:
    physics_dt_s: float
    period_steps: dict  # slot name -> steps between runs
    _cycle: list = field(default_factory=list, init=False, repr=False, compare=False)  # tick()'s table, once made

    @classmethod
    def from_periods(cls, physics_dt_s: float, periods_s: dict[str, float]) -> "Schedule":
        steps = {}
        for name, period in periods_s.items():
            if name not in SLOT_ORDER:
                raise ValueError(f"schedule: unknown slot {name!r} (known: {', '.join(SLOT_ORDER)})")
            if not period > 0:
                raise ValueError(f"schedule.{name}: period must be > 0, got {period}")
            steps[name] = max(1, int(round(period / physics_dt_s)))
        return cls(physics_dt_s, steps)

    def realized_rate_hz(self, slot: str) -> float:
        return 1.0 / (self.period_steps[slot] * self.physics_dt_s)

    def due(self, step: int) -> list[str]:
        """Slots that run at physics step ``step`` (step 0 runs everything), in SLOT_ORDER."""
        periods, out = self.period_steps, []
        for s in SLOT_ORDER:  # (a plain loop: the runner asks at every tick)
            if s in periods and step % periods[s] == 0:
                out += (s,)
        return out

    def next_event(self, step: int) -> int:
        """The first step after ``step`` at which any slot is due."""
        first = None
        for p in self.period_steps.values():  # (min over a generator costs a resumption per slot)
            nxt = (step // p + 1) * p
            if first is None or nxt < first:
                first = nxt
        return first

    def tick(self, step: int) -> tuple[tuple[str, ...], int]:
        """``(tuple(due(step)), next_event(step))`` in one call (the runner asks at every tick): the
        slots repeat every ``lcm`` of the periods, whose table is made on the first call (a cycle
        longer than ``_CYCLE_MAX`` steps is computed each time instead)."""
        table = self._cycle
        if not table:
            cycle = math.lcm(*self.period_steps.values()) if self.period_steps else 1
            if cycle > _CYCLE_MAX:
                return tuple(self.due(step)), self.next_event(step)
            table.append(cycle)
            table.append({s: (tuple(self.due(s)), self.next_event(s) - s) for s in range(cycle)})
        cycle, at = table
        due, ahead = at[step % cycle]  # (every slot's period divides the cycle: the same slots, the same gap)
        return due, step + ahead
