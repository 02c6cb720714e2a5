"""The closest approaches' glue in compiled passes (mjasc.avoidance.prediction.cpa_kernels) against
the numpy form of ``closest_approaches`` it replaced (kept below), bit for bit: on every prediction
of real runs (a crossing, a head-on encounter and a demo, with their own zoom) and on random grids with padding, NaN
samples, many minima per pair, with and without a zoom."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from mjasc.avoidance.prediction import conflicts, cpa
from mjasc.runs.runner import Runner
from mjasc.runs.scenario import load_scenario

TASKS = Path(__file__).resolve().parents[1] / "tasks"


def _grid_minima(d, padded=True):
    """The grid minima as numpy wrote them."""
    if padded:
        d = np.where(np.isnan(d), np.inf, d)
    mask = np.ones(d.shape, dtype=bool)
    mask[:, 1:] = d[:, 1:] <= d[:, :-1]
    mask[:, :-1] &= d[:, :-1] < d[:, 1:]
    if padded:
        mask &= np.isfinite(d)
    return mask


def _two_segments(t_a, t_b, t_c, r_a, r_b, r_c):
    s1, d1 = cpa.segment_cpa(r_a, r_b)
    s2, d2 = cpa.segment_cpa(r_b, r_c)
    second = d2 < d1
    t = np.where(second, t_b + s2 * (t_c - t_b), t_a + s1 * (t_b - t_a))
    return t, np.where(second, d2, d1)


def _closest_approaches_numpy(times, rel, r_col, rel_at=None, stop_at_first=False):
    """closest_approaches as numpy wrote it (the reference)."""
    times = np.asarray(times, dtype=float)
    P = times.shape[0]
    d = np.hypot(rel[..., 0], rel[..., 1])
    pad = np.isnan(times)
    padded = bool(pad.any())
    if padded:
        d[pad] = np.nan
    pi, ii = _grid_minima(d, padded).nonzero()
    last = times.shape[1] - 1 - np.sum(pad, axis=1)
    lo = np.maximum(ii - 1, 0)
    hi = np.minimum(ii + 1, last[pi])
    t_lo, t_mid, t_hi = times[pi, lo], times[pi, ii], times[pi, hi]
    r_lo, r_mid, r_hi = rel[pi, lo], rel[pi, ii], rel[pi, hi]
    tt, dd = _two_segments(t_lo, t_mid, t_hi, r_lo, r_mid, r_hi)
    r_col = np.asarray(r_col, dtype=float)
    skip = None
    if rel_at is not None and pi.size:
        chord = np.maximum(np.hypot(*(r_mid - r_lo).T), np.hypot(*(r_hi - r_mid).T))
        first = np.ones(pi.size, dtype=bool)
        first[1:] = pi[1:] != pi[:-1]
        cand = (first | (dd <= r_col[pi] + 0.5 + chord)).ravel().nonzero()[0]
        tt[cand], dd[cand] = cpa._zoom(rel_at, pi[cand], t_lo[cand], t_hi[cand])
        if cand.size < pi.size:
            skip = np.ones(pi.size, dtype=bool)
            skip[cand] = False
    d_grid = d[pi, ii]
    worse = ~(dd <= d_grid)
    tt, dd = np.where(worse, times[pi, ii], tt), np.where(worse, d_grid, dd)
    pairs = np.arange(P)
    if pi.size == P and np.array_equal(pi, pairs):
        return tt, dd
    first = np.searchsorted(pi, pairs)
    has = first < pi.size
    has[has] = pi[first[has]] == pairs[has]
    col = ((dd <= r_col[pi]) if skip is None else (dd <= r_col[pi]) & ~skip).ravel().nonzero()[0]
    first_col = np.searchsorted(pi[col], pairs)
    has_col = first_col < col.size
    has_col[has_col] = pi[col[first_col[has_col]]] == pairs[has_col]
    pick = np.where(has, first, 0)
    use_col = has_col & ~np.broadcast_to(np.asarray(stop_at_first, dtype=bool), (P,))
    pick[use_col] = col[first_col[use_col]]
    if pi.size == 0:
        return np.full(P, np.nan), np.full(P, np.nan)
    return np.where(has, tt[pick], np.nan), np.where(has, dd[pick], np.nan)


def _same(got, want):
    assert len(got) == len(want) == 2
    for g, w in zip(got, want):
        assert g.shape == w.shape and g.tobytes() == w.tobytes()


def test_the_compiled_closest_approaches_have_the_numpy_forms_bits_on_real_runs(monkeypatch):
    compiled = cpa.closest_approaches
    seen = []

    def both(times, rel, r_col, rel_at=None, stop_at_first=False):
        want = _closest_approaches_numpy(times, rel.copy(), r_col, rel_at, stop_at_first)
        got = compiled(times, rel, r_col, rel_at, stop_at_first)
        _same(got, want)
        seen.append(times.shape[0])
        return got

    monkeypatch.setattr(conflicts, "closest_approaches", both)
    for name, duration in (("thesis_6_4_crossing", 40.0), ("thesis_6_4_head_on", 40.0), ("demo", 30.0)):
        sc = load_scenario(TASKS / f"{name}.toml").with_overrides(duration_s=duration)
        sc = replace(sc, outputs=replace(sc.outputs, recording=False, video=False))
        Runner(sc, None, progress=False).run()
    assert len(seen) > 15 and sum(seen) > 30


def _random_case(rng):
    P, n = int(rng.integers(0, 9)), int(rng.integers(1, 30))
    times = np.cumsum(rng.uniform(0.1, 0.6, (P, n)), axis=1) + rng.uniform(0, 100, (P, 1))
    kind = rng.integers(0, 4)
    if kind == 0:  # noisy wiggles: many minima
        rel = rng.normal(0, 3, (P, n, 2)) + rng.uniform(-5, 5, (P, 1, 2))
    elif kind == 1:  # straight passes
        rel = rng.uniform(-20, 20, (P, 1, 2)) + rng.uniform(-4, 4, (P, 1, 2)) * times[..., None] / 10.0
    elif kind == 2:  # ties and plateaus
        rel = rng.integers(-2, 3, (P, n, 2)).astype(float)
    else:  # a nearly constant distance (side by side)
        rel = np.full((P, n, 2), 3.0) + rng.normal(0, 1e-12, (P, n, 2))
    if P and n > 2 and rng.random() < 0.6:  # padding at the end of shorter grids
        for p in range(P):
            k = int(rng.integers(0, n - 1))
            if k:
                times[p, -k:] = np.nan
                rel[p, -k:] = rng.choice([np.nan, 9.0])
    if P and rng.random() < 0.2:
        rel[rng.integers(0, P), rng.integers(0, n), rng.integers(0, 2)] = rng.choice([np.nan, np.inf])
    r_col = rng.uniform(0.5, 6.0, P)
    stop = (False, True, rng.random(P) < 0.5)[rng.choice(3, p=[0.4, 0.2, 0.4])]
    return times, rel, r_col, stop


def _linear_rel_at(times, rel):
    """A true motion for the zoom: each pair's grid samples joined by straight lines with a bend."""
    def rel_at(pairs, t):
        out = np.empty(t.shape + (2,))
        for k, p in enumerate(pairs):
            ok = ~np.isnan(times[p])
            for c in range(2):
                out[k, :, c] = np.interp(t[k], times[p][ok], rel[p][ok, c]) + 0.01 * np.sin(3.0 * t[k])
        return out
    return rel_at


@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # (the NaN and inf samples)
@pytest.mark.parametrize("seed", range(6))
def test_the_compiled_closest_approaches_have_the_numpy_forms_bits_on_random_grids(seed):
    rng = np.random.default_rng(seed)
    for _ in range(150):
        times, rel, r_col, stop = _random_case(rng)
        want = _closest_approaches_numpy(times, rel.copy(), r_col, None, stop)
        _same(cpa.closest_approaches(times, rel, r_col, None, stop), want)
        if np.isfinite(rel).all() or np.isnan(times).any():
            rel_at = _linear_rel_at(times, np.nan_to_num(rel, nan=9.0, posinf=9.0))
            want = _closest_approaches_numpy(times, rel.copy(), r_col, rel_at, stop)
            _same(cpa.closest_approaches(times, rel, r_col, rel_at, stop), want)
