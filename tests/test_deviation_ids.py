"""The control tick's deviation check on a report's columns (TrackMotions.farther_than_ids: the
known tracks selected, their angles and the check in one compiled pass) answers as the readable
form — the known tracks picked by id in Python, then TrackMotions.farther_than — on random tracks
and on every check of real runs."""

from dataclasses import replace

import numpy as np
import pytest

import mjasc
from mjasc.avoidance.control_tick import ControlTick
from mjasc.avoidance.prediction import TrackMotions
from mjasc.cooperation.messages import TeamIntention
from mjasc.core.estimates import PlannedTrack, TrackEstimate, TrackRows
from mjasc.runs.runner import Runner


def _reference(motions, row, ids, times, pos, limit):
    sel = [(row[i], k) for k, i in enumerate(ids) if i in row]
    if not sel:
        return False
    rows, ks = zip(*sel)
    return motions.farther_than(rows, [times[k] for k in ks], [pos[k] for k in ks], limit)


def _table(row):
    known = sorted(row.items())
    return (np.array([i for i, _ in known], dtype=np.int64).reshape(-1),
            np.array([k for _, k in known], dtype=np.intp).reshape(-1))


def test_farther_than_ids_equals_the_selection_then_farther_than_on_random_tracks():
    rng = np.random.default_rng(3)
    its = [TeamIntention(f"m{k}", 49.7, rng.uniform(-50, 50, 2), 0.3, rng.normal(0, 1, 2), 2.0,
                         49.7 + np.arange(0.0, 20.0, 0.5), rng.uniform(-50, 50, (40, 2))) for k in range(2)]
    tracks = [TrackEstimate(3 * k + 1, 49.0 + 0.1 * k, rng.uniform(-40, 40, 2), rng.uniform(-3, 3), rng.uniform(0, 3),
                            float(rng.choice([0.0, 0.0, 0.03, -0.02])), 2.0, is_static=bool(k % 5 == 4))
              for k in range(12)]
    planned = [PlannedTrack(100 + k, it.sent_time_s, it.position_m, 0.0, 1.0, 0.0, 1.5, team_member=it.name,
                            intention=it) for k, it in enumerate(its)]
    for group in (tracks, [tr for tr in tracks if tr.turn_rate_rad_s == 0.0], tracks + planned):
        m = TrackMotions(group)
        row = {tr.track_id: k for k, tr in enumerate(group)}
        known_ids, known_rows = _table(row)
        for _ in range(300):
            ids = [int(i) for i in rng.choice([tr.track_id for tr in group] + [0, 2, 5, 99, 200], size=int(rng.integers(0, 8)))]
            times = (50.0 + rng.uniform(0.0, 3.0, len(ids))).tolist()
            pos = rng.uniform(-45, 45, (len(ids), 2))
            for limit in (0.5, 5.0, 30.0, 80.0):
                assert m.farther_than_ids(known_ids, known_rows, ids, times, pos, limit) == \
                    _reference(m, row, ids, times, pos, limit)
            sel = [k for k, i in enumerate(ids) if i in row]
            if sel:  # limits at the distances themselves (the comparison's edge)
                rows = np.array([row[ids[k]] for k in sel])
                d = np.hypot(*(m.at(rows, np.array([times[k] for k in sel])[:, None])[:, 0] - pos[sel]).T)
                for limit in (float(d.max()), float(np.nextafter(d.max(), -np.inf)), float(d.min())):
                    assert m.farther_than_ids(known_ids, known_rows, ids, times, pos, limit) == \
                        _reference(m, row, ids, times, pos, limit)


@pytest.mark.parametrize("name,duration_s", [("demo", 60.0), ("thesis_6_4_crossing", 40.0)])
def test_deviation_checks_of_real_runs_equal_the_readable_form(monkeypatch, name, duration_s):
    """Every deviation check on a report's columns answers as the known tracks picked by id in
    Python and TrackMotions.farther_than (the check's readable form)."""
    deviating, seen = ControlTick._deviating, []

    def checked(self, tracks):
        got = deviating(self, tracks)
        if type(tracks) is TrackRows and self._predicted_motion is not None and len(tracks):
            ref = _reference(self._predicted_motion, self._predicted_row, tracks.track_ids, tracks.times_s,
                             tracks.positions_m, self.config.track_deviation_m)
            assert got == ref
            seen.append(got)
        return got

    monkeypatch.setattr(ControlTick, "_deviating", checked)
    sc = mjasc.load_scenario(f"tasks/{name}.toml").with_overrides(duration_s=duration_s, video=False)
    Runner(replace(sc, outputs=replace(sc.outputs, recording=False))).run()
    assert len(seen) > 100
