"""ManoeuvreDetector.detect's compiled call (manoeuvre_noise: the faded NIS and the process noise of the
manoeuvring tracks past start-up) against the calls it replaced — fade_nis, then the bank's
add_process_noise_rows in numpy — bit for bit, on random inputs and at every detection of a real run."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import mjasc
from mjasc.perception.tracking import manoeuvre as man_mod
from mjasc.perception.tracking.manoeuvre import fade_nis, manoeuvre_noise
from mjasc.runs.runner import Runner

_ROOT = __import__("pathlib").Path(__file__).resolve().parents[1]


def _same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def numpy_noise(rows, d2, gate, a, start, end, nis, man, t_s, t_last, P, active, q_heading, q_speed):
    """The reference: fade_nis, then add_process_noise_rows' numpy form for the rows past start-up
    (changes nis, man, P in place; returns the positions of the manoeuvring rows in start-up)."""
    hot = np.empty(rows.size, dtype=bool)
    if not fade_nis(rows, d2, gate, a, start, end, nis, man, hot):
        return np.zeros(0, dtype=np.int64)
    hot_rows = rows[hot]
    dt = np.maximum(t_s[hot] - t_last[hot_rows], 0.0)
    dth, dv = q_heading * dt, q_speed * dt
    warm = active[hot_rows]
    full = hot_rows[~warm]
    if full.size:
        P[full, :, 2, 2] += dth[~warm, None]
        P[full, :, 3, 3] += dv[~warm, None]
    return hot.nonzero()[0][warm]


def _check(rows, d2, gate, a, start, end, nis, man, t_s, t_last, P, active, qh, qv):
    ref = [nis.copy(), man.copy(), P.copy()]
    want_warm = numpy_noise(rows, d2, gate, a, start, end, *ref[:2], t_s, t_last, ref[2], active, qh, qv)
    warm = np.empty(rows.size, dtype=np.int64)
    n_full, n_warm = manoeuvre_noise(rows, d2, gate, a, start, end, nis, man, t_s, t_last, P, active, qh, qv, warm)
    _same(nis, ref[0])
    _same(man, ref[1])
    _same(P, ref[2])
    _same(warm[:n_warm], want_warm)
    return n_full, n_warm


@pytest.mark.parametrize("seed", range(30))
def test_manoeuvre_noise_on_random_inputs(seed):
    rng = np.random.default_rng(seed)
    n, r = int(rng.integers(1, 25)), int(rng.integers(1, 5))
    rows = np.sort(rng.choice(n, size=int(rng.integers(0, n + 1)), replace=False)).astype(np.int64)
    d2 = rng.random(rows.size) * 20
    d2[rng.random(rows.size) < 0.1] = np.nan
    nis, man = rng.random(n) * 10, rng.random(n) < 0.5
    t_last = rng.uniform(0, 10, n)
    t_s = t_last[rows] + rng.uniform(-0.1, 0.5, rows.size)  # (some earlier: Ts clipped at 0)
    P = rng.normal(size=(n, r, 4, 4))
    active = rng.random(n) < 0.3
    _check(rows, d2, 9.21, 0.8, 6.0, 3.0, nis, man, t_s, t_last, P, active, float(rng.random()), float(rng.random()))


def test_manoeuvre_noise_on_a_real_run(monkeypatch):
    seen = {"calls": 0, "full": 0, "warm": 0}

    def checked(rows, d2, gate, a, start, end, nis, man, t_s, t_last, P, active, qh, qv, warm):
        ref = [nis.copy(), man.copy(), P.copy()]
        want_warm = numpy_noise(rows, d2, gate, a, start, end, *ref[:2], t_s, t_last, ref[2], active, qh, qv)
        got = manoeuvre_noise(rows, d2, gate, a, start, end, nis, man, t_s, t_last, P, active, qh, qv, warm)
        for x, y in zip((nis, man, P, warm[:got[1]]), (*ref, want_warm)):
            _same(x, y)
        seen["calls"] += 1
        seen["full"] += got[0]
        seen["warm"] += got[1]
        return got

    monkeypatch.setattr(man_mod, "manoeuvre_noise", checked)
    sc = mjasc.load_scenario(_ROOT / "tasks" / "demo.toml").with_overrides(duration_s=60.0)
    sc = replace(sc, outputs=replace(sc.outputs, recording=False, video=False))
    Runner(sc, out_dir=None).run()
    assert seen["calls"] > 100 and seen["full"] > 10
