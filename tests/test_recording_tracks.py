"""What the recording reads of a vessel's tracks at standard detail (MultiTargetTracker.confirmed_points)
is confirmed_fields' numbers, bit for bit, on a real run — read from the step's reports (made by the
control tick before the record tick) or gathered for every vessel at once."""

from pathlib import Path

import numpy as np

from mjasc.runs.runner import Runner
from mjasc.runs.scenario import load_scenario

ROOT = Path(__file__).resolve().parent.parent


def test_confirmed_points_are_confirmed_fields_columns():
    sc = load_scenario(ROOT / "tasks" / "thesis_6_4_crossing.toml").with_overrides(duration_s=4.0)
    runner = Runner(sc, out_dir=None)
    seen = 0

    def check(event) -> None:
        nonlocal seen
        for agent in runner.agents:
            tracker = agent.perception.tracker
            _, ids, x, static, team = tracker.confirmed_fields()
            fleet = tracker.fleet
            assert fleet._reports is not None  # (the control tick read them: the report's columns are read)
            for ids2, xy, static2, team2 in (tracker.confirmed_points(event.time_s), tracker.confirmed_points(),
                                             fleet._confirmed_points_read()[tracker.owner]):
                np.testing.assert_array_equal(ids2, ids)
                assert xy.shape == (len(ids), 2) and xy.tobytes() == np.ascontiguousarray(x[:, :2]).tobytes()
                np.testing.assert_array_equal(static2, static)
                assert team2 == team
            seen += len(ids)

    runner.observe("record", check)
    runner.run()
    assert seen > 0
