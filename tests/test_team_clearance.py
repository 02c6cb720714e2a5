"""A team mate's new plan is checked against the last prediction's clearance to it
(mjasc.avoidance.team_mates.TeamMates.remember_clearances): a plan that moves by more than that
clearance, though by less than ``track_deviation_m``, makes the vessel predict again; one that moves
by less cannot bring a collision the prediction did not see (docs/avoidance.md, "Team mates are
predicted from their own intentions")."""

import numpy as np
import pytest

from mjasc.avoidance.plan_deviation import plans_deviate, plans_deviate_reference
from mjasc.avoidance.team_mates import TeamMates
from mjasc.cooperation.messages import TeamIntention, TeamPicture


def _creeping(sent_s: float, stop_at_s: float | None = None) -> TeamIntention:
    """A team mate planned east at 0.2 m/s from (0, 0) at t = 10 s; with ``stop_at_s`` its plan
    stops there (0.2 m/s × 19 s = 3.8 m short of the creeping plan at the window's end)."""
    times = np.arange(sent_s, sent_s + 61.0)
    x = 0.2 * (np.minimum(times, stop_at_s) if stop_at_s is not None else times) - 2.0
    return TeamIntention("bravo", sent_s, np.array([x[0], 0.0]), 0.0, np.array([0.2, 0.0]), 1.5,
                         plan_times_s=times, plan_points_m=np.stack([x, np.zeros_like(x)], axis=1))


def _mates(clearance_m=None) -> TeamMates:
    mates = TeamMates("alpha", {"bravo"}, 1.5, max_age_s=5.0, deviation_m=5.0, horizon_s=30.0)
    mates.remember_prediction({"bravo": _creeping(10.0)})
    if clearance_m is not None:
        mates.remember_clearances({"bravo": clearance_m})
    return mates


def _stopped_move_m() -> float:
    """How far the stopped plan departs from the creeping one at the comparison's times."""
    times = 11.0 + np.linspace(0.0, 30.0, 16)
    return float(np.max(np.hypot(*(_creeping(11.0, stop_at_s=22.0).positions(times)
                                   - _creeping(10.0).positions(times)).T)))


@pytest.mark.parametrize("clearance_m,changed", [(None, False), (10.0, False), (4.5, False), (3.0, True), (0.5, True)])
def test_a_stop_within_the_deviation_counts_when_it_moves_more_than_the_clearance(clearance_m, changed):
    """The team mate stops 3.8 m short of the plan the prediction used: below ``deviation_m`` (5 m),
    so it counts only when the last prediction cleared it by less than that."""
    move = _stopped_move_m()
    assert 3.0 < move < 4.5  # (the case is where it should be: between the limits tested)
    mates = _mates(clearance_m)
    picture = TeamPicture(11.1, {"bravo": _creeping(11.0, stop_at_s=22.0)})
    assert mates.plans_changed(11.1, picture) is changed
    assert mates.clearance_changes == int(changed)


def test_a_plan_moved_beyond_the_deviation_is_a_change_whatever_the_clearance():
    mates = _mates(20.0)  # (a clearance larger than deviation_m does not raise the limit)
    far = _creeping(11.0)
    far = TeamIntention(far.name, far.sent_time_s, far.position_m, 0.0, far.velocity_m_s, 1.5,
                        plan_times_s=far.plan_times_s, plan_points_m=far.plan_points_m + np.array([0.0, 6.0]))
    assert mates.plans_changed(11.1, TeamPicture(11.1, {"bravo": far}))
    assert mates.clearance_changes == 0  # (the deviation alone found it)


def test_per_pair_limits_answer_as_the_reference():
    """``plans_deviate`` with a limit per pair (the clearance of each team mate) gives the reference's
    answer, on limits at each pair's own largest distance (the comparison's edge) and NaN plans."""
    rng = np.random.default_rng(8)
    times = 30.0 + np.linspace(0.0, 30.0, 16)

    def intention(sent, k):
        ts = np.sort(rng.uniform(sent, sent + 60.0, k)) if k else np.zeros(0)
        return TeamIntention("m", sent, rng.uniform(-50, 50, 2), 0.0, rng.uniform(-2, 2, 2), 1.5,
                             plan_times_s=ts, plan_points_m=rng.uniform(-80, 80, (k, 2)))

    for _ in range(150):
        n = int(rng.integers(1, 4))
        pairs = [(intention(rng.uniform(0, 40), int(rng.choice([0, 2, 5]))),
                  intention(rng.uniform(0, 40), int(rng.choice([0, 2, 5])))) for _ in range(n)]
        d = [float(np.max(np.hypot(*(a.positions(times) - b.positions(times)).T))) for a, b in pairs]
        for limits in (d, [np.nextafter(x, -np.inf) for x in d], [0.0] * n, list(rng.uniform(0, 100, n))):
            assert plans_deviate(pairs, times, limits) == plans_deviate_reference(pairs, times, limits)
            assert plans_deviate(pairs, times, limits) == any(x > lim for x, lim in zip(d, limits))
        assert plans_deviate(pairs, times, [max(d)] * n) == plans_deviate(pairs, times, max(d))
    a = intention(10.0, 5)
    bad = TeamIntention("m", 12.0, a.position_m, 0.0, a.velocity_m_s, 1.5, plan_times_s=a.plan_times_s,
                        plan_points_m=np.where(np.arange(10).reshape(5, 2) == 3, np.nan, a.plan_points_m))
    for pairs in ([(a, bad)], [(a, a), (a, bad)]):
        assert plans_deviate(pairs, times, [0.0] * len(pairs)) is False
        assert plans_deviate_reference(pairs, times, [0.0] * len(pairs)) is False


def test_the_clearances_remembered_are_each_team_mates_own_in_a_run():
    """On the §6.4.2 head-on (three vessels, an oncoming stranger): at every prediction each team
    mate's remembered clearance is its own pair's d(t_c) − R_col, found by track id among the
    prediction's pairs (which come sorted by t_c, not in the tracks' order), and only clear mates
    have one."""
    from dataclasses import replace

    import mjasc
    from mjasc.avoidance import prediction_step
    from mjasc.runs.runner import Runner

    checked = []
    original = prediction_step.PredictionStep._act_on_prediction

    def act(self, t, nav, pending, all_c, static_polygons, after_replan=False):
        pairs = list(all_c)  # (every pair made: the reference reads them as objects)
        mates = {tr.track_id: tr.team_member for tr in pending.tracks if tr.team_member in self.team}
        expected = {}
        for c in pairs:
            if c.track_id in mates and c.min_distance_m - c.collision_distance_m > 0.0:
                name = mates[c.track_id]
                expected[name] = min(c.min_distance_m - c.collision_distance_m, expected.get(name, np.inf))
        n = len(remembered)
        out = original(self, t, nav, pending, all_c, static_polygons, after_replan)
        # (this prediction's own: the first remembered in the call; a re-prediction inside it remembers its own)
        checked.append((expected, remembered[n], [c.track_id for c in pairs], [tr.track_id for tr in pending.tracks]))
        return out

    remembered = []
    remember = TeamMates.remember_clearances
    TeamMates.remember_clearances = lambda self, clearances: (remembered.append(dict(clearances)),
                                                              remember(self, clearances))[1]
    prediction_step.PredictionStep._act_on_prediction = act
    try:
        sc = mjasc.load_scenario("tasks/thesis_6_4_head_on.toml").with_overrides(duration_s=120.0, video=False)
        Runner(replace(sc, outputs=replace(sc.outputs, recording=False))).run()
    finally:
        prediction_step.PredictionStep._act_on_prediction = original
        TeamMates.remember_clearances = remember
    assert len(checked) > 20
    for expected, got, _, _ in checked:
        assert got == expected
    # (the case the pairing must survive: pairs in another order than the tracks)
    assert any(ids != [k for k in tracks if k in ids] for _, _, ids, tracks in checked)
