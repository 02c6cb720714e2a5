"""The outlines' compiled gathering of a track's returns (:func:`mjasc.perception.tracking.outlines.gather_returns`)
against the numpy form it replaced, bit for bit: on a fleet tracker's run (every hull after every
tick) and on corner cases (no hull yet, non-finite returns, more than 256 points)."""

from __future__ import annotations

import numpy as np

from mjasc.core.geometry import convex_hull
from mjasc.perception.tracking import TrackingConfig
from mjasc.perception.tracking.fleet import FleetTracker
from mjasc.perception.tracking.outlines import TrackOutlines, gather_returns

from tests.test_tracking_fleet_store import N_VESSELS, _run


def _grow_numpy(self, rows, used, speeds, positions, radii, returns_of) -> None:
    """The numpy form of :meth:`TrackOutlines.grow` (before the compiled gathering)."""
    cfg = self.config
    v, pos = speeds, positions
    moved = np.hypot(*(pos - self._hull_anchor[rows]).T) > cfg.outline_reset_m
    reset = (v > 2.0 * cfg.static_speed_m_s) | moved
    if reset.any():
        r = rows[reset]
        self._hull[r] = None
        self._hull_anchor[r] = pos[reset]
    for j in np.flatnonzero(used & (v < cfg.static_speed_m_s)).tolist():
        pts, labels, label = returns_of(j)
        p = np.asarray(pts, dtype=float).reshape(-1, 2)[np.asarray(labels) == label]
        p = p[np.hypot(*(p - pos[j]).T) <= 1.5 * radii[j] + 0.5]
        if p.shape[0] == 0:
            continue
        k = rows[j]
        if self._hull[k] is None:
            self._hull_anchor[k] = pos[j]
        else:
            p = np.vstack([self._hull[k], p])
        self._hull[k] = convex_hull(p)


class _NumpyOutlines(TrackOutlines):
    grow = _grow_numpy


def test_grow_matches_numpy_form_on_a_run():
    cfg = TrackingConfig()
    fast, ref = FleetTracker(cfg), FleetTracker(cfg)
    ref.outlines = _NumpyOutlines(cfg, ref.cols)  # (the tracker's columns)
    for ft in (fast, ref):
        for _ in range(N_VESSELS):
            ft.add_owner(60.0)
    grown = 0
    for _ in zip(_run([(fast, i) for i in range(N_VESSELS)]), _run([(ref, i) for i in range(N_VESSELS)])):
        assert fast.outlines._hull.size == ref.outlines._hull.size
        np.testing.assert_array_equal(fast.outlines._hull_anchor, ref.outlines._hull_anchor)
        for a, b in zip(fast.outlines._hull, ref.outlines._hull):
            assert (a is None) == (b is None)
            if a is not None:
                grown += 1
                assert a.shape == b.shape and a.tobytes() == b.tobytes()
    assert grown > 100


def test_gather_returns_corner_cases():
    rng = np.random.default_rng(3)
    pts = rng.normal(size=(400, 2))
    labels = rng.integers(-1, 3, size=400)
    hull = convex_hull(rng.normal(size=(10, 2)))
    for label, lim, h in ((1, 1.0, np.zeros((0, 2))), (2, 0.5, hull), (0, 10.0, hull), (7, 1.0, hull)):
        p, m, canonical = gather_returns(pts, labels, label, 0.1, -0.2, lim, h)
        want = pts[(labels == label) & (np.hypot(pts[:, 0] - 0.1, pts[:, 1] + 0.2) <= lim)]
        assert m == want.shape[0]
        assert p.tobytes() == np.vstack([h, want]).tobytes()
        assert canonical == (p.shape[0] <= 256)
    bad = pts.copy()
    bad[5] = (np.inf, 0.0)
    bad[6] = (np.nan, 1.0)
    p, m, canonical = gather_returns(bad[:100], np.zeros(100, dtype=np.int64), 0, 0.0, 0.0, np.inf, hull)
    want = bad[:100][np.hypot(bad[:100, 0], bad[:100, 1]) <= np.inf]  # (the NaN return fails the test, the inf one passes)
    assert m == want.shape[0] == 99 and p.tobytes() == np.vstack([hull, want]).tobytes()
    assert not canonical


def test_reflected_hull_matches_numpy_form():
    from mjasc.perception.tracking.outlines import reflected_hull

    rng = np.random.default_rng(4)
    cases = [convex_hull(rng.normal(size=(int(rng.integers(3, 40)), 2)) * 3) for _ in range(50)]
    cases.append(rng.normal(size=(200, 2)))  # (more than 256 points with the reflections: not hulled here)
    for h in cases:
        c = rng.normal(size=2)
        out, hulled = reflected_hull(h, float(c[0]), float(c[1]))
        want = convex_hull(np.vstack([h, 2.0 * c - h]))
        if not hulled:
            assert h.shape[0] > 128
            out = convex_hull(out)
        assert out.tobytes() == want.tobytes()


def test_grown_hull_is_gather_then_hull():
    from mjasc.perception.tracking.outlines import grown_hull

    rng = np.random.default_rng(5)
    pts = rng.normal(size=(400, 2))
    labels = rng.integers(-1, 3, size=400)
    hull = convex_hull(rng.normal(size=(10, 2)))
    bad = pts[:100].copy()
    bad[5] = (np.inf, 0.0)
    for pp, lab, label, lim, h in ((pts, labels, 1, 1.0, np.zeros((0, 2))), (pts, labels, 2, 0.5, hull),
                                   (pts, labels, 0, 10.0, hull), (pts, labels, 7, 1.0, hull),
                                   (pts, np.zeros(400, dtype=np.int64), 0, np.inf, hull),
                                   (bad, np.zeros(100, dtype=np.int64), 0, np.inf, hull)):
        p, m, hulled = grown_hull(pp, lab, label, 0.1, -0.2, lim, h)
        q, m_w, canonical = gather_returns(pp, lab, label, 0.1, -0.2, lim, h)
        assert m == m_w
        if m == 0:
            assert not hulled
            continue
        got = p if hulled else convex_hull(p)
        assert hulled == canonical
        assert got.tobytes() == convex_hull(q).tobytes()
