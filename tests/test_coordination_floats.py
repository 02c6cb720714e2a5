"""The comms slot's plain-float forms give numpy's numbers bit for bit: ``clip_float`` (numpy's
clip of one float) and ``Coordination.coordination_error`` below 8 neighbours (numpy's sum, mean,
max and min of the gaps), on edge values and on every call of the demo."""

from dataclasses import replace

import numpy as np

from mjasc.cooperation.coordination import Coordination, _error_floats
from mjasc.core.compiled import clip_float


def _same(a, b) -> bool:
    return np.array(a, dtype=float).tobytes() == np.array(b, dtype=float).tobytes()


def test_clip_float_is_numpys_clip():
    values = [-0.0, 0.0, 1e-300, -1e-300, 3.5, 7.0, 7.000000000000001, np.inf, -np.inf, np.nan, 12.0, -4.0]
    for v in values:
        for lo, hi in ((0.0, 7.0), (-0.0, 7.0), (0.0, 0.0), (0.0, np.inf), (-1.0, -0.0)):
            assert _same(clip_float(v, lo, hi), float(np.clip(v, lo, hi))), (v, lo, hi)


def test_error_floats_are_numpys_or_decline():
    rng = np.random.default_rng(3)
    pool = [0.0, -0.0, 1.0, -1.0, np.nan, 2.5, 0.37, -0.125, 1e-17]
    answered = 0
    for _ in range(3000):
        xis = [float(v) for v in rng.choice(pool, int(rng.integers(1, 8)))]
        own, l_bar = float(rng.choice(pool)), float(rng.uniform(50.0, 300.0))
        got = _error_floats(xis, own, l_bar)
        if got is None:
            assert any(x != x or x == 0.0 for x in xis)
            continue
        a = np.array(xis)
        d = l_bar * (own - a)
        ref = (float(d.sum()), float(d.mean()), float(l_bar * (max(own, a.max()) - min(own, a.min()))))
        assert _same(got, ref), (xis, own)
        answered += 1
    assert answered > 500


def _reference(self, t_s, gamma_m):
    """The numpy form of ``coordination_error`` (before the plain floats)."""
    if self.path_length_m is None:
        return 0.0, 0.0, 0.0, 0
    xis, l_bar, _ = self._estimates(t_s)
    if not len(xis):
        return 0.0, 0.0, 0.0, 0
    own = self.xi(gamma_m)
    d = l_bar * (own - xis)
    spread = l_bar * (max(own, xis.max()) - min(own, xis.min()))
    return float(d.sum()), float(d.mean()), float(spread), len(xis)


def test_coordination_error_on_the_demo_equals_the_numpy_form(monkeypatch):
    import mjasc
    from mjasc.runs.runner import Runner

    fast, seen = Coordination.coordination_error, []

    def checked(self, t_s, gamma_m):
        got, ref = fast(self, t_s, gamma_m), _reference(self, t_s, gamma_m)
        assert _same(got[:3], ref[:3]) and got[3] == ref[3] and all(type(v) is float for v in got[:3])
        seen.append(got[3])
        return got

    monkeypatch.setattr(Coordination, "coordination_error", checked)
    sc = mjasc.load_scenario("demo").with_overrides(duration_s=60.0, video=False)
    Runner(replace(sc, outputs=replace(sc.outputs, recording=False))).run()
    assert len(seen) > 300 and max(seen) == 2


def test_the_plan_kernels_clip_is_numpys_clip():
    from mjasc.avoidance.intent_plan import _clip

    for v in (-0.0, 0.0, 3.5, 7.0, 9.0, -2.0, np.inf, -np.inf, np.nan):
        for lo, hi in ((0.0, 7.0), (-0.0, 7.0), (0.0, 0.0), (-1.0, -0.0)):
            assert _same(_clip(v, lo, hi), float(np.clip(v, lo, hi))), (v, lo, hi)
