"""The broadcast plan's compiled form (``mjasc.avoidance.intent_plan``) gives the numpy form's
points bit for bit: on the demo's paths (lines and arcs, every γ, with and without a velocity
correction) and on every plan the demo broadcasts."""

import math
from dataclasses import replace
from types import SimpleNamespace

import numpy as np

from mjasc.avoidance import system
from mjasc.avoidance.intent_plan import plan_offsets, planned_points
from mjasc.avoidance.prediction import gamma_of_time
from mjasc.avoidance.system import CollisionAvoidance, _correction_profile, _correction_terms
from mjasc.guidance.paths import Path


def _reference(path, t, gamma_m, speed_m_s, correction, position_m, horizon_s=60.0, step_s=1.0):
    """The numpy form of ``planned_trajectory`` (before the kernels), a path follower present."""
    t = float(t)
    times = t + np.arange(0.0, float(horizon_s) + 0.5 * float(step_s), float(step_s))
    g0 = float(np.clip(gamma_m, 0.0, path.length))
    g = np.clip(gamma_of_time(_correction_profile(correction, t, g0, speed_m_s), g0, t)(times), 0.0, path.length)
    pts = np.asarray(path.point(g), dtype=float).reshape(-1, 2)
    off = np.asarray(position_m, dtype=float)[:2] - pts[0]
    pts = pts + np.clip(1.0 - (times - t) / 10.0, 0.0, 1.0)[:, None] * off
    return times, pts


def _fast(path, t, gamma_m, speed_m_s, correction, position_m, horizon_s=60.0, step_s=1.0):
    g0 = float(np.clip(gamma_m, 0.0, path.length))
    return planned_points(path, float(t), g0, _correction_terms(correction, float(t), speed_m_s),
                          plan_offsets(horizon_s, step_s), position_m)


def _demo_paths():
    """The demo's three mission paths (two lines joined by an arc) and a polyline detour."""
    paths = [Path.from_waypoints([[0.0, 12.0], [160.0, 12.0], [160.0, 170.0]], 20.0),
             Path.from_waypoints([[-6.0, 0.0], [172.0, 0.0], [172.0, 170.0]], 32.0),
             Path.from_waypoints([[3.0, -12.0], [184.0, -12.0], [184.0, 170.0]], 44.0)]
    s = np.linspace(0.0, 1.0, 40)
    paths.append(Path.from_points(np.stack([60.0 + 40.0 * s, 12.0 + 9.0 * np.sin(np.pi * s)], axis=1)))
    return paths


def test_the_compiled_plan_equals_the_numpy_form_on_the_demos_paths():
    rng = np.random.default_rng(9)
    corrections = [None,
                   SimpleNamespace(law=SimpleNamespace(t_goal=130.0, desired_speed=0.6)),
                   SimpleNamespace(law=SimpleNamespace(t_goal=95.0, desired_speed=-0.1)),  # ended, clipped speed
                   SimpleNamespace(law=SimpleNamespace(t_goal=101.3, desired_speed=1.1))]
    n = 0
    for path in _demo_paths():
        for gamma in np.concatenate([np.linspace(-3.0, path.length + 3.0, 120), [0.0, path.length],
                                     path.segment_starts, rng.uniform(0.0, path.length, 30)]):
            for correction in corrections:
                t = 100.0 + rng.uniform(0.0, 2.0)
                pos = path.point(float(np.clip(gamma, 0.0, path.length))) + rng.normal(0.0, 1.5, 2)
                speed = float(rng.choice([0.0, 1.5, rng.uniform(0.5, 2.5)]))
                for horizon, step in ((60.0, 1.0), (30.0, 0.5), (24.0, 3.0)):
                    ref = _reference(path, t, gamma, speed, correction, pos, horizon, step)
                    got = _fast(path, t, gamma, speed, correction, pos, horizon, step)
                    assert got is not None
                    np.testing.assert_array_equal(got[0], ref[0])
                    np.testing.assert_array_equal(got[1], ref[1])
                    n += 1
    assert n > 1000


def test_the_kernels_sine_and_cosine_are_numpys_here():
    """The kernel takes the arc angles' sine and cosine by ``math`` where the numpy form took
    ``np.sin`` / ``np.cos`` of the angles' array: the same bits on this machine class
    (docs/architecture.md, compiled kernels); a machine where they differ fails here."""
    rng = np.random.default_rng(4)
    th = np.concatenate([rng.uniform(-10.0, 10.0, 200_000), rng.uniform(-1e4, 1e4, 20_000),
                         np.linspace(-np.pi, np.pi, 10_001)])
    assert np.sin(th).tobytes() == np.array([math.sin(x) for x in th.tolist()]).tobytes()
    assert np.cos(th).tobytes() == np.array([math.cos(x) for x in th.tolist()]).tobytes()


def test_short_plans_and_bad_speeds_are_left_to_the_numpy_form():
    path = _demo_paths()[0]
    assert _fast(path, 10.0, 5.0, 1.5, None, [0.0, 12.0], horizon_s=5.0, step_s=1.0) is None  # 6 samples
    assert _fast(path, 10.0, 5.0, np.nan, None, [0.0, 12.0]) is None
    assert _fast(path, 10.0, 5.0, -1.0, None, [0.0, 12.0]) is None


def test_every_plan_the_demo_broadcasts_equals_the_numpy_form(monkeypatch):
    """Each ``planned_trajectory`` of the demo's first 120 s (the ferry's correction included)
    returns the numpy form's times and points bit for bit."""
    import mjasc
    from mjasc.runs.runner import Runner

    planned, seen = CollisionAvoidance.planned_trajectory, []

    def checked(self, t, nav, guidance, horizon_s, step_s):
        got = planned(self, t, nav, guidance, horizon_s, step_s)
        ref = _reference(guidance.path, t, guidance.gamma_m, guidance.mission_speed_m_s, self.correction,
                         nav.position_m, horizon_s, step_s)
        np.testing.assert_array_equal(got[0], ref[0])
        np.testing.assert_array_equal(got[1], ref[1])
        seen.append(self.correction is not None)
        return got

    monkeypatch.setattr(CollisionAvoidance, "planned_trajectory", checked)
    sc = mjasc.load_scenario("demo").with_overrides(duration_s=120.0, video=False)
    Runner(replace(sc, outputs=replace(sc.outputs, recording=False))).run()
    assert len(seen) > 600 and any(seen)
    assert system.planned_points is planned_points
