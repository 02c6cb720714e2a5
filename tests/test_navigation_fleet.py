"""FleetNavigation's fast forms against the readable ones: from_states and vessels() give the
same values (and the same types) as the dataclass constructor and vessel(i)."""

import numpy as np

from mjasc.core.navigation import FleetNavigation, OwnNavigation


class _States:
    def __init__(self, n, rng):
        self.time_s = float(rng.uniform(0, 100))
        self.position_m = rng.normal(size=(n, 2))
        self.heading_rad = rng.uniform(-np.pi, np.pi, n)
        self.velocity_m_s = rng.normal(size=(n, 2))
        self.body_velocity = rng.normal(size=(n, 3))


def test_vessels_equal_vessel_by_vessel():
    rng = np.random.default_rng(5)
    for n in (1, 3, 7):
        st = _States(n, rng)
        fleet = FleetNavigation.from_states(st)
        ref = FleetNavigation(st.time_s, st.position_m, st.heading_rad, st.velocity_m_s, st.body_velocity)
        assert fleet == ref
        navs = fleet.vessels()
        assert len(navs) == n
        for i, nav in enumerate(navs):
            want = ref.vessel(i)
            assert type(nav) is OwnNavigation and type(nav.heading_rad) is float
            assert nav.time_s == want.time_s and nav.heading_rad == want.heading_rad
            for f in ("position_m", "velocity_m_s", "body_velocity"):
                a, b = getattr(nav, f), getattr(want, f)
                assert a.tobytes() == b.tobytes() and a.shape == b.shape
                assert np.shares_memory(a, getattr(st, f))  # views, as vessel(i) gives
