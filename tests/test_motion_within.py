"""TrackMotions.within — every track followed to every time, within reach of a position — gives
the numpy form's answer (TrackMotions.at, np.hypot, np.maximum) bit for bit, and the team mates'
ghost check made with it finds the same stale copies on a real run."""

from dataclasses import replace

import numpy as np

import mjasc
from mjasc.avoidance.prediction.motion import TrackMotions
from mjasc.core.estimates import PlannedTrack, TrackEstimate
from mjasc.runs.runner import Runner


def _reference(motions: TrackMotions, times, pos, radii) -> np.ndarray:
    back = motions.at(np.arange(motions.n), times)
    return np.hypot(back[..., 0] - pos[:, 0], back[..., 1] - pos[:, 1]) <= np.maximum(radii, motions.radius_m[:, None])


def _tracks(rng, n):
    out = []
    for k in range(n):
        kind = k % 4
        w = 0.0 if kind == 0 else (1e-10 if kind == 1 else rng.normal(scale=0.05))
        out.append(TrackEstimate(k, float(rng.uniform(0, 5)), rng.normal(scale=20.0, size=2), float(rng.uniform(-4, 4)),
                                 0.0 if kind == 3 and k % 8 == 3 else float(rng.uniform(0, 2)), w,
                                 float(rng.uniform(0.5, 4.0)), is_static=(kind == 3)))
    return out


def test_within_equals_the_numpy_form():
    rng = np.random.default_rng(3)
    for n, h in ((1, 1), (5, 7), (13, 40), (30, 3)):
        tracks = _tracks(rng, n)
        motions = TrackMotions(tracks)
        times = rng.uniform(-20.0, 5.0, size=h)
        centre = np.array([tr.position_m for tr in tracks]).mean(axis=0)
        pos = centre + rng.normal(scale=15.0, size=(h, 2))
        radii = rng.uniform(0.0, 30.0, size=h)
        got = motions.within(times, pos, radii)
        ref = _reference(motions, times, pos, radii)
        assert got.dtype == np.bool_ and got.shape == (n, h) and np.array_equal(got, ref)
        assert got.any() and not got.all() or n * h < 10
    # on the boundary: a radius equal to the distance the numpy form computes is within
    tracks = _tracks(rng, 6)
    motions = TrackMotions(tracks)
    times = np.array([1.0, 2.5, 4.0])
    pos = np.array([[3.0, -2.0], [0.0, 1.0], [-5.0, 7.0]])
    back = motions.at(np.arange(6), times)
    exact = np.hypot(back[..., 0] - pos[:, 0], back[..., 1] - pos[:, 1])
    radii = exact[2]  # track 2 sits exactly on every reach
    assert np.array_equal(motions.within(times, pos, radii), _reference(motions, times, pos, radii))
    assert motions.within(times, pos, radii)[2].all()
    # NaN radius propagates as numpy's maximum does: never within
    radii = np.array([np.nan, 1e9, 1e9])
    assert np.array_equal(motions.within(times, pos, radii), _reference(motions, times, pos, radii))


def test_within_with_a_plan_is_the_numpy_form():
    from mjasc.cooperation.messages import TeamIntention

    it = TeamIntention("b", 1.0, np.array([0.0, 0.0]), 0.0, np.array([1.0, 0.0]), 2.0,
                       np.array([1.0, 2.0, 3.0]), np.array([[0.0, 0.0], [1.0, 0.5], [2.0, 1.5]]))
    planned = PlannedTrack(-1, 1.0, np.array([0.0, 0.0]), 0.0, 1.0, 0.0, 2.0, team_member="b", intention=it)
    tracks = [planned] + _tracks(np.random.default_rng(4), 3)
    motions = TrackMotions(tracks)
    times, pos, radii = np.array([0.5, 1.5, 2.5, 4.0]), np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 1.0], [3.0, 2.0]]), \
        np.array([0.5, 1.0, 2.0, 0.1])
    assert np.array_equal(motions.within(times, pos, radii), _reference(motions, times, pos, radii))


def test_ghost_check_on_a_run_as_the_numpy_form():
    """On the demo (team mates heard over a lossy link): every ghost check's (track, broadcast)
    matrix equals the numpy form's."""
    from mjasc.avoidance import team_mates

    calls = []
    real = TrackMotions.within

    def checked(self, times, pos, radii):
        got = real(self, times, pos, radii)
        assert np.array_equal(got, _reference(self, np.asarray(times, dtype=float), np.asarray(pos, dtype=float),
                                              np.asarray(radii, dtype=float)))
        calls.append(got.size)
        return got

    sc = mjasc.load_scenario("tasks/demo.toml").with_overrides(duration_s=30.0)
    r = Runner(replace(sc, outputs=replace(sc.outputs, recording=False, video=False)), out_dir=None)
    TrackMotions.within = checked
    try:
        r.run()
    finally:
        TrackMotions.within = real
    assert team_mates.TrackMotions is TrackMotions and len(calls) > 5 and sum(calls) > 100


def test_within_of_straight_and_static_tracks_only_is_the_numpy_form():
    """A table without turning rows or plans (checked in one compiled pass) answers as the numpy form."""
    rng = np.random.default_rng(4)
    for n, h in ((1, 1), (6, 9), (20, 4)):
        tracks = [tr for tr in _tracks(rng, 4 * n) if tr.is_static or abs(tr.turn_rate_rad_s) < 1e-9][:n]
        motions = TrackMotions(tracks)
        times = rng.uniform(-20.0, 5.0, size=h)
        pos = np.array([tr.position_m for tr in tracks]).mean(axis=0) + rng.normal(scale=15.0, size=(h, 2))
        radii = rng.uniform(0.0, 30.0, size=h)
        got = motions.within(times, pos, radii)
        assert got.dtype == np.bool_ and got.shape == (len(tracks), h)
        assert np.array_equal(got, _reference(motions, times, pos, radii))
