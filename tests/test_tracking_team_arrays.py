"""TeamMatcher keeps every vessel's broadcasts in one set of arrays and writes new values of the
same mates in place: the arrays equal those built from scratch after every change, bit for bit."""

import numpy as np

from mjasc.perception.tracking.config import TrackingConfig
from mjasc.perception.tracking.team import TeamMatcher


def _fresh(team: dict):
    m = TeamMatcher(TrackingConfig())
    for o, pos in team.items():
        m.set_positions(o, pos)
    return m._arrays()


def test_in_place_broadcasts_equal_rebuilt_arrays():
    rng = np.random.default_rng(3)
    mates = ["a", "b", "c", "d"]
    live = TeamMatcher(TrackingConfig())
    team = {}
    for step in range(300):
        o = int(rng.integers(0, 4))
        # sometimes the set of mates changes
        names = mates[:] if rng.random() < 0.9 else [m for m in mates if rng.random() < 0.6]
        if o in team and rng.random() < 0.9:
            names = list(team[o])  # mostly: the same mates, new values
        pos = {n: (float(step * 0.2 - rng.random()), rng.normal(size=2) * 100.0) for n in names}
        team[o] = pos
        live.set_positions(o, pos)
        if rng.random() < 0.7:  # (the arrays are read between some of the changes only)
            got, want = live._arrays(), _fresh(team)
            assert got[0].tobytes() == want[0].tobytes() and got[1] == want[1]
            assert got[2].tobytes() == want[2].tobytes() and got[3].tobytes() == want[3].tobytes()
