"""The compiled helpers kernels share (mjasc.core.compiled) against the numpy calls they stand for."""

import numpy as np

from mjasc.core.compiled import clip, maximum, minimum, search_right


def test_search_right_is_numpys_searchsorted_right_on_a_slice():
    rng = np.random.default_rng(3)
    for _ in range(300):
        n = int(rng.integers(0, 12))
        a = np.sort(rng.choice([-1.0, 0.0, 0.5, 1.0, 2.0, 3.5], size=n) + rng.integers(0, 2, n) * 0.25)
        lo = int(rng.integers(0, n + 1))
        hi = int(rng.integers(lo, n + 1))
        for x in (*rng.uniform(-2.0, 5.0, 4), *a[lo:hi], -np.inf, np.inf):
            want = lo + int(np.searchsorted(a[lo:hi], x, side="right"))
            assert search_right(a, float(x), lo, hi) == want, (a, lo, hi, x)
        assert search_right(a, np.nan, lo, hi) == lo  # NaN is the caller's case (documented)


def test_maximum_and_minimum_follow_numpy_on_nan_and_ties():
    for a, b in [(1.0, 2.0), (2.0, 1.0), (np.nan, 1.0), (1.0, np.nan), (0.0, -0.0), (-0.0, 0.0)]:
        for mine, ref in ((maximum(a, b), np.maximum(a, b)), (minimum(a, b), np.minimum(a, b))):
            assert np.array_equal(mine, ref, equal_nan=True)
            assert np.signbit(mine) == np.signbit(ref)


def test_compiled_clip_is_numpys_clip_on_nan_ties_and_signed_zeros():
    vals = (-1.5, -0.0, 0.0, 0.25, 1.0, 2.0, np.nan, -np.inf, np.inf)
    for v in vals:
        for lo, hi in ((0.0, 1.0), (-0.0, 0.0), (0.0, -0.0), (-1.0, np.inf), (-np.inf, -1.0)):  # bounds are numbers
            mine, ref = clip(v, lo, hi), float(np.clip(v, lo, hi))
            assert np.array_equal(mine, ref, equal_nan=True) and np.signbit(mine) == np.signbit(ref), (v, lo, hi)
