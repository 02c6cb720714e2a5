"""The comms log's lines (mjasc.cooperation.recording): one gather per kind gives the same numbers,
bit for bit, as the readable form (a line per sender–receiver pair)."""

import numpy as np

from mjasc.cooperation.comms import LinkOutcome
from mjasc.cooperation.recording import CommsLog


class _Recorder:
    full = False

    def __init__(self):
        self.strip_rows = []

    def style(self, *a):
        pass

    def series_style(self, *a):
        pass

    def has_views(self, name):
        return True

    def colour(self, name):
        return (10, 20, 30)

    def legend_colour(self, k):
        return (1, 2, 3)

    def scalar(self, *a):
        pass

    def strips(self, entity, t_s, strips, z=0.0, colours=None):
        self.strip_rows.append((entity, t_s, [np.asarray(s, dtype=np.float64).reshape(-1, 2) for s in strips]))


def test_lines_match_a_line_per_pair():
    rng = np.random.default_rng(3)
    names = ("a", "b", "c", "d")
    log, rec = CommsLog(names), _Recorder()
    p = rng.normal(scale=100.0, size=(4, 2)) / 3.0
    outcomes = [LinkOutcome(s, r, 0.5, np.nan if lost else 0.6, lost)
                for s, r, lost in (("a", "b", False), ("a", "c", True), ("c", "d", True), ("d", "a", False),
                                   ("b", "d", True))]
    log.log(rec, 1.0, outcomes, p, lambda n: (0, 0))
    index = {n: k for k, n in enumerate(names)}
    delivered, lost = log._pairs
    assert delivered and lost
    ref = {"world/comms/delivered": [p[[index[a], index[b]]] for a, b in delivered],
           "world/comms/lost": [np.array([p[index[a]], 0.5 * (p[index[a]] + p[index[b]])]) for a, b in lost]}
    assert [e for e, _, _ in rec.strip_rows] == list(ref)
    for entity, _, rows in rec.strip_rows:
        assert len(rows) == len(ref[entity])
        for got, want in zip(rows, ref[entity]):
            assert got.tobytes() == want.tobytes()
    log.log(rec, 3.0, [], p, lambda n: (0, 0))  # the window passed: empty rows clear the lines
    assert [len(r) for _, t, r in rec.strip_rows if t == 3.0] == [0, 0]
