"""The closest approaches' sampled zoom in compiled passes (mjasc.avoidance.prediction.cpa._zoom)
against the numpy form it replaced (kept below), bit for bit: on every zoom of real runs (a demo
and a crossing, the pairs' own rel_at) and on brackets with NaN samples."""

from dataclasses import replace
from pathlib import Path

import numpy as np

from mjasc.avoidance.prediction import cpa
from mjasc.runs.runner import Runner
from mjasc.runs.scenario import load_scenario

TASKS = Path(__file__).resolve().parents[1] / "tasks"


def _zoom_numpy(rel_at, pairs, a, b):
    """The zoom as numpy wrote it (the reference)."""
    K = cpa.ZOOM_SAMPLES
    frac = np.linspace(0.0, 1.0, K)
    t_out, d_out = np.empty(a.size), np.empty(a.size)
    act = np.arange(a.size)
    a, b = a.copy(), b.copy()
    for level in range(cpa.ZOOM_MAX_LEVELS):
        ts = a[act, None] + (b[act] - a[act])[:, None] * frac
        r = rel_at(pairs[act], ts)
        j = np.argmin(np.hypot(r[..., 0], r[..., 1]), axis=1)
        idx = np.arange(act.size)
        ja, jb = np.maximum(j - 1, 0), np.minimum(j + 1, K - 1)
        a[act], b[act] = ts[idx, ja], ts[idx, jb]
        if level + 1 < cpa.ZOOM_LEVELS:
            continue
        r_a, r_j, r_b = r[idx, ja], r[idx, j], r[idx, jb]
        s1, d1 = cpa.segment_cpa(r_a, r_j)  # the closed form of the two segments around j
        s2, d2 = cpa.segment_cpa(r_j, r_b)
        second = d2 < d1
        t_out[act] = np.where(second, ts[idx, j] + s2 * (b[act] - ts[idx, j]), a[act] + s1 * (ts[idx, j] - a[act]))
        d_out[act] = np.where(second, d2, d1)
        bend = np.hypot(*(r_j - 0.5 * (r_a + r_b)).T)
        act = act[(bend > cpa.ZOOM_TOL_M) & (j > 0) & (j < K - 1)]
        if act.size == 0:
            break
    return t_out, d_out


def test_the_compiled_zoom_has_the_numpy_forms_bits_on_real_runs(monkeypatch):
    compiled = cpa._zoom
    seen = []

    def both(rel_at, pairs, a, b):
        want = _zoom_numpy(rel_at, pairs, a, b)
        got = compiled(rel_at, pairs, a, b)
        assert got[0].tobytes() == want[0].tobytes() and got[1].tobytes() == want[1].tobytes()
        seen.append(a.size)
        return got

    monkeypatch.setattr(cpa, "_zoom", both)
    for name, duration in (("demo", 60.0), ("thesis_6_4_crossing", 40.0)):
        sc = load_scenario(TASKS / f"{name}.toml").with_overrides(duration_s=duration)
        sc = replace(sc, outputs=replace(sc.outputs, recording=False, video=False))
        Runner(sc, None, progress=False).run()
    assert len(seen) > 20 and sum(seen) > 40


def test_nan_samples_and_kinks():
    """NaN relative positions (argmin takes the first NaN) and kinked relative paths (deeper levels)."""
    rng = np.random.default_rng(2)
    for trial in range(200):
        k = int(rng.integers(1, 7))
        corner = rng.uniform(0.0, 10.0, k)
        w1, w2 = rng.normal(0.0, 2.0, (k, 2)), rng.normal(0.0, 2.0, (k, 2))
        p0 = rng.normal(0.0, 5.0, (k, 2))
        nan_at = rng.random(k) < 0.2

        def rel_at(pairs, t):
            c = corner[pairs][:, None]
            dt1 = np.minimum(t, c)[..., None]
            dt2 = np.maximum(t - c, 0.0)[..., None]
            r = p0[pairs][:, None, :] + dt1 * w1[pairs][:, None, :] + dt2 * w2[pairs][:, None, :]
            bad = nan_at[pairs]
            r[bad, int(t.shape[1] // 2)] = np.nan
            return r

        pairs = np.arange(k)
        a = rng.uniform(0.0, 5.0, k)
        b = a + rng.uniform(0.1, 8.0, k)
        want = _zoom_numpy(rel_at, pairs, a, b)
        got = cpa._zoom(rel_at, pairs, a, b)
        for x, y in zip(got, want):  # the same numbers; a NaN may carry another sign or payload
            np.testing.assert_array_equal(x, y)
            ok = ~np.isnan(y)
            assert x[ok].tobytes() == y[ok].tobytes()
