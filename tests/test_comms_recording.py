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


def test_counts_asked_only_after_a_change_write_the_same_rows():
    """With the link's ``count_changes`` the log asks the counts only when they changed or a
    waiting received count is due: the same scalar rows as asking at every record tick."""
    rng = np.random.default_rng(5)
    names = ("a", "b", "c")

    class _Scalars(_Recorder):
        def __init__(self):
            super().__init__()
            self.rows = []

        def scalar(self, entity, t_s, value):
            self.rows.append((entity, t_s, value))

    state = {n: [0, 0] for n in names}
    logs = [(CommsLog(names), _Scalars()), (CommsLog(names), _Scalars())]
    asked = []
    changes = 0
    p = np.zeros((3, 2))
    for tick in range(600):
        t = tick * 0.2
        if tick % 5 == 0 or rng.random() < 0.05:  # (the link's counts change now and then)
            for n in names:
                state[n][0] += int(rng.integers(0, 3))
                state[n][1] += int(rng.random() < 0.1)
            changes += 1
        for (log, rec), ch in zip(logs, (None, changes)):
            log.log(rec, t, [], p, lambda n, ch=ch: (asked.append(ch is not None), tuple(state[n]))[1], ch)
    assert logs[0][1].rows == logs[1][1].rows and len(logs[0][1].rows) > 50
    assert sum(asked) < 0.5 * asked.count(False)  # (most record ticks ask nothing)
