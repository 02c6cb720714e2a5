"""core.geometry against closed forms and a reference (Andrew's monotone chain, written out here)."""

import numpy as np

from mjasc.core.geometry import convex_hull


def _andrew(p):
    p = np.unique(np.round(np.asarray(p, dtype=float), 6), axis=0)
    if p.shape[0] <= 2:
        return p

    def half(q):
        out = []
        for pt in q:
            while len(out) >= 2 and ((out[-1][0] - out[-2][0]) * (pt[1] - out[-2][1])
                                     - (out[-1][1] - out[-2][1]) * (pt[0] - out[-2][0])) <= 0:
                out.pop()
            out.append(pt)
        return out

    lower, upper = half(p), half(p[::-1])
    return np.array(lower[:-1] + upper[:-1])


def test_convex_hull_matches_monotone_chain_including_degenerate_sets():
    rng = np.random.default_rng(0)
    for n in (3, 4, 7, 40):
        for _ in range(100):
            p = rng.normal(size=(n, 2)) * rng.uniform(0.1, 10)
            if rng.random() < 0.3:
                p = np.round(p)  # duplicates and collinear points
            assert np.allclose(convex_hull(p), _andrew(p))
    assert np.allclose(convex_hull([[0, 0], [1, 1], [2, 2]]), [[0, 0], [2, 2]])


def test_convex_hull_of_a_square_with_inner_points_is_its_corners_ccw():
    sq = np.array([[0, 0], [2, 0], [2, 2], [0, 2], [1, 1], [1, 0]], dtype=float)
    h = convex_hull(sq)
    assert np.allclose(h, [[0, 0], [2, 0], [2, 2], [0, 2]])
    area = 0.5 * np.sum(h[:, 0] * np.roll(h[:, 1], -1) - np.roll(h[:, 0], -1) * h[:, 1])
    assert area > 0  # counter-clockwise
