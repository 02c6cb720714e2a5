"""TrackMotions' table made in one compiled pass (mjasc.avoidance.prediction.motion._motion_table)
against the numpy form it replaced, bit for bit: random tracks (static, at rest, turning, straight,
negative headings, NaN) and the tracks of a demo run's predictions (team mates' plans included)."""

import math
from dataclasses import replace
from pathlib import Path

import numpy as np

import mjasc.avoidance.fleet_slots as fleet_slots
import mjasc.avoidance.system as system
from mjasc.avoidance.prediction.motion import _STRAIGHT_OMEGA, TrackMotions
from mjasc.core.estimates import PlannedTrack, TrackEstimate
from mjasc.runs.runner import Runner
from mjasc.runs.scenario import load_scenario

TASKS = Path(__file__).resolve().parents[1] / "tasks"


def _numpy_table(tracks):
    m = len(tracks)
    plan = np.array([isinstance(tr, PlannedTrack) for tr in tracks], dtype=bool).reshape(m)
    a = np.array([(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, tr.radius_m) if p else
                  (tr.position_m[0], tr.position_m[1], tr.time_s, tr.speed_m_s, tr.heading_rad,
                   tr.turn_rate_rad_s, tr.is_static, 0.0, tr.radius_m) for tr, p in zip(tracks, plan.tolist())],
                 dtype=float).reshape(m, 9)
    moving = ~((a[:, 6] != 0.0) | (a[:, 3] == 0.0) | plan)
    v, th, w = a[:, 3] * moving, a[:, 4] * moving, a[:, 5] * moving
    turn = np.abs(w) >= _STRAIGHT_OMEGA
    par = np.empty((m, 9))
    par[:, :3], par[:, 3], par[:, 6], par[:, 7] = a[:, :3], v, th, w
    par[:, 4], par[:, 5] = np.cos(th), np.sin(th)
    par[:, 8] = v / np.where(turn, w, 1.0)
    kind = np.where(plan, 2, np.where(turn, 1, 0))
    return par, kind, sorted(set(kind.tolist())), a[:, 8]


def _check(tracks):
    got = TrackMotions(tracks)
    par, kind, kinds, radius = _numpy_table(tracks)
    assert got._par.tobytes() == par.tobytes()
    assert got._kind.dtype == kind.dtype and got._kind.tobytes() == kind.tobytes()
    assert got._kinds == kinds
    assert got.radius_m.tobytes() == radius.tobytes()


def test_random_tracks():
    rng = np.random.default_rng(8)
    for trial in range(300):
        tracks = []
        for i in range(int(rng.integers(0, 9))):
            speed = float(rng.choice([0.0, rng.uniform(0.0, 3.0), np.nan])) if rng.random() < 0.3 else \
                float(rng.uniform(0.0, 3.0))
            omega = float(rng.choice([0.0, 1e-10, -1e-10, 1e-9, -0.03, 0.05, np.nan]))
            tracks.append(TrackEstimate(i, float(rng.uniform(0, 100)), rng.uniform(-50, 50, 2),
                                        float(rng.uniform(-7.0, 7.0)), speed, omega, float(rng.uniform(0.5, 9.0)),
                                        is_static=bool(rng.random() < 0.2)))
        _check(tracks)


def test_the_tracks_of_a_demo_run(monkeypatch):
    seen = []
    orig = system.predict_fleet_lazy

    def both(queries):
        tracks = [tr for q in queries for tr in q.tracks]
        _check(tracks)
        seen.append(sum(isinstance(tr, PlannedTrack) for tr in tracks))
        return orig(queries)

    # the fleet's slots (fleet_slots) and a vessel's own predictions after a decision (system)
    monkeypatch.setattr(fleet_slots, "predict_fleet_lazy", both)
    monkeypatch.setattr(system, "predict_fleet_lazy", both)
    sc = load_scenario(TASKS / "demo.toml").with_overrides(duration_s=60.0)
    Runner(replace(sc, outputs=replace(sc.outputs, recording=False, video=False)), None, progress=False).run()
    assert len(seen) > 5 and sum(seen) > 0


def test_math_cos_and_sin_are_numpys():
    """What the table's and the deviation check's compiled passes rely on (docs/architecture.md,
    compiled kernels): numpy's float64 cos and sin give math's bits on this machine class."""
    from mjasc.core.compiled import kernel

    @kernel
    def cos_sin(x, out):
        for i in range(x.size):
            out[0, i], out[1, i] = math.cos(x[i]), math.sin(x[i])

    rng = np.random.default_rng(3)
    x = rng.uniform(-1.0, 1.0, 400_000) * 10.0 ** rng.uniform(-3, 4, 400_000)
    out = np.empty((2, x.size))
    cos_sin(x, out)
    assert np.array_equal(out, np.stack([np.cos(x), np.sin(x)]))
