"""The schedule's due slots and next event (plain loops, asked at every tick) are those of their
readable forms, the comprehension over SLOT_ORDER and min over the periods."""

import pytest

from mjasc.runs.schedule import SLOT_ORDER, Schedule


@pytest.mark.parametrize("periods", [
    {"sensing": 0.2, "tracking": 0.2, "comms": 0.5, "prediction": 1.0, "control": 0.1, "record": 0.1},
    {"control": 0.1},
    {"video": 1 / 30, "control": 0.06, "record": 0.5, "sensing": 0.14},
])
def test_due_and_next_event_are_their_readable_forms(periods):
    s = Schedule.from_periods(0.02, periods)
    for step in range(0, 1500):
        assert s.due(step) == [n for n in SLOT_ORDER if n in s.period_steps and step % s.period_steps[n] == 0]
        assert s.next_event(step) == min((step // p + 1) * p for p in s.period_steps.values())


@pytest.mark.parametrize("periods", [
    {"sensing": 0.2, "tracking": 0.2, "comms": 0.5, "prediction": 1.0, "control": 0.1, "record": 0.1},
    {"control": 0.1},
    {"video": 1 / 30, "control": 0.06, "record": 0.5, "sensing": 0.14},
    {"video": 0.07, "control": 0.11, "record": 0.13, "sensing": 0.17, "comms": 0.19},  # a cycle beyond the table's
])
def test_tick_is_due_and_next_event(periods):
    s = Schedule.from_periods(0.01, periods)
    for step in list(range(0, 3000)) + [10**6 + 7, 3 * 10**7]:
        assert s.tick(step) == (tuple(s.due(step)), s.next_event(step))
