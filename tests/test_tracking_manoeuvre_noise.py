"""ManoeuvreDetector.detect's compiled call (manoeuvre_noise: the faded NIS and the process noise of the
manoeuvring tracks past start-up) against the calls it replaced — fade_nis, then the bank's
add_process_noise_rows in numpy — bit for bit, on random inputs; and the fleet tracker's association with
those manoeuvres in one call (gated_manoeuvres_into) against gated_assignment_into and that numpy form, at
every step of a real run."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import mjasc
from mjasc.perception.tracking import fleet as fleet_mod
from mjasc.perception.tracking.manoeuvre import fade_nis, manoeuvre_noise
from mjasc.perception.tracking.step_buffers import gated_assignment_into, gated_manoeuvres_into
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


def test_gated_manoeuvres_on_a_real_run(monkeypatch):
    """gated_manoeuvres_into (what the fleet tracker calls) against gated_assignment_into, then the numpy form of
    the manoeuvres of its hit rows when it made them."""
    seen = {"calls": 0, "detected": 0, "full": 0}

    def checked(*args):
        ref = [a.copy() if isinstance(a, np.ndarray) else a for a in args]
        got = gated_manoeuvres_into(*args)
        npairs, k, ok, h, m = gated_assignment_into(*ref[:38])
        assert got[:5] == (npairs, k, ok, h, m)
        (t, active), gate, out_rows, vals = ref[9:13:3], ref[17], ref[36], ref[37]
        detect, a, start, end, nis, man, P, qh, qv, warm = ref[38:]
        if detect and ok and npairs and not h:
            want_warm = numpy_noise(out_rows[:m], vals[:m], gate, a, start, end, nis, man, vals[m:2 * m], t, P,
                                    active, qh, qv)
            assert got[5:] == (got[5], want_warm.size)
            _same(args[-1][:got[6]], want_warm)
            seen["detected"] += 1
            seen["full"] += got[5]
        else:
            assert got[5:] == (-1, 0)
        for x, y in zip(args[:-1], ref[:-1]):
            if isinstance(x, np.ndarray):
                _same(x, y)
        seen["calls"] += 1
        return got

    monkeypatch.setattr(fleet_mod, "gated_manoeuvres_into", checked)
    sc = mjasc.load_scenario(_ROOT / "tasks" / "thesis_6_4_crossing.toml").with_overrides(duration_s=40.0)
    sc = replace(sc, outputs=replace(sc.outputs, recording=False, video=False))
    Runner(sc, out_dir=None).run()
    assert seen["calls"] > 100 and seen["detected"] > 100 and seen["full"] > 10
