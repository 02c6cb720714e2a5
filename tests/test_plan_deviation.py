"""The plan comparison's compiled form (mjasc.avoidance.plan_deviation.plans_deviate) answers as
its readable form on every comparison of real runs and on distances placed at the limit."""

from dataclasses import replace

import numpy as np
import pytest

import mjasc
from mjasc.avoidance import team_mates
from mjasc.avoidance.plan_deviation import plans_deviate, plans_deviate_reference
from mjasc.cooperation.messages import TeamIntention
from mjasc.runs.runner import Runner


@pytest.mark.parametrize("name,duration_s", [("thesis_6_4_crossing", 40.0), ("demo", 60.0)])
def test_plans_deviate_equals_the_reference_on_real_runs(name, duration_s):
    """Every plan comparison of a run: the compiled answer is the reference's, and on limits at
    the pair's own largest distance (the comparison's edge) too."""
    seen = []

    def both(pairs, times, deviation_m):
        fast = plans_deviate(pairs, times, deviation_m)
        assert fast == plans_deviate_reference(pairs, times, deviation_m)
        for new, old in pairs:
            d = np.hypot(*(new.positions(times) - old.positions(times)).T)
            for limit in (np.max(d), np.nextafter(np.max(d), -np.inf), 0.0):
                assert plans_deviate([(new, old)], times, limit) == plans_deviate_reference([(new, old)], times, limit)
        seen.append(len(pairs))
        return fast

    original = team_mates.plans_deviate
    team_mates.plans_deviate = both
    try:
        sc = mjasc.load_scenario(f"tasks/{name}.toml").with_overrides(duration_s=duration_s, video=False)
        Runner(replace(sc, outputs=replace(sc.outputs, recording=False))).run()
    finally:
        team_mates.plans_deviate = original
    assert len(seen) > 20


def _intention(rng, name, sent, k):
    ts = np.sort(rng.uniform(sent, sent + 60.0, k)) if k else np.zeros(0)
    return TeamIntention(name, sent, rng.uniform(-50, 50, 2), rng.uniform(0, 6), rng.uniform(-2, 2, 2), 1.5,
                         plan_times_s=ts, plan_points_m=rng.uniform(-80, 80, (k, 2)))


def test_plans_deviate_on_random_plans_nan_and_fall_backs():
    """Random plans (none, two knots, many), one and two pairs, a NaN knot (the largest distance is
    NaN: False), and three pairs (the reference itself)."""
    rng = np.random.default_rng(5)
    times = 30.0 + np.linspace(0.0, 30.0, 16)
    for _ in range(200):
        its = [_intention(rng, f"m{j}", rng.uniform(0, 40), int(rng.choice([0, 2, 5, 9]))) for j in range(6)]
        for n in (1, 2, 3):
            pairs = [(its[2 * j], its[2 * j + 1]) for j in range(n)]
            for limit in (0.0, 10.0, 60.0, 1e9):
                assert plans_deviate(pairs, times, limit) == plans_deviate_reference(pairs, times, limit)
    a, b = _intention(rng, "a", 10.0, 5), _intention(rng, "b", 12.0, 5)
    bad = replace(b, plan_points_m=np.where(np.arange(10).reshape(5, 2) == 3, np.nan, b.plan_points_m))
    for pairs in ([(a, bad)], [(a, b), (a, bad)], [(a, bad), (a, b)]):
        assert plans_deviate(pairs, times, 0.0) == plans_deviate_reference(pairs, times, 0.0)
