"""mjasc.perception.static_map.StaticMap: hits, free-space carving along rays (cells seen through are freed,
occluded and hit cells are not), polygons, argument checks. Synthetic scans: a sensor at the origin
with 720 beams over 360°."""

import math

import numpy as np
import pytest

from mjasc.perception.static_map import StaticMap

N = 720
ANGLES = -math.pi + (np.arange(N) + 0.5) * 2.0 * math.pi / N


def scan_of_wall(x_wall, y_from=-1e9, y_to=1e9, max_range=150.0, blocker=None):
    """Ranges (N,), hit (N,), points (k, 2) of a sensor at the origin facing a wall x = x_wall
    (between y_from and y_to); ``blocker`` (centre, radius): a disc in front, hit first."""
    c, s = np.cos(ANGLES), np.sin(ANGLES)
    rng = np.full(N, np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(c > 1e-9, x_wall / c, np.inf)
    y = t * s
    rng = np.where((t < max_range) & (y >= y_from) & (y <= y_to), t, rng)
    if blocker is not None:
        (bx, by), br = blocker
        b = c * bx + s * by
        disc = b * b - (bx * bx + by * by - br * br)
        tb = np.where(disc >= 0, b - np.sqrt(np.maximum(disc, 0)), np.inf)
        rng = np.where((tb > 0) & (tb < rng), tb, rng)
    hit = np.isfinite(rng)
    ranges = np.where(hit, rng, max_range)
    pts = np.stack([ranges * c, ranges * s], -1)[hit]
    return ranges, hit, pts


def test_cells_become_occupied_after_min_hits_scans():
    m = StaticMap(1.0, 3)
    for k in range(2):
        m.add_scan(np.array([[10.2, 0.5], [10.7, 0.4]]))  # same cell twice: counted once per scan
        assert m.n_occupied == 0
    m.add_scan(np.array([[10.2, 0.5]]))
    assert m.n_occupied == 1
    np.testing.assert_array_equal(m.occupied_cells(), [[10, 0]])
    assert m.occupied(np.array([[10.9, 0.9], [11.1, 0.5]])).tolist() == [True, False]


def test_a_cell_seen_through_is_freed_after_headroom_plus_one_over_miss_weight_scans():
    """A phantom cell at (10, 0) hit in 20 scans (score capped at min_hits + headroom = 8) is
    freed after (8 − 3 + 0.5) / 0.5 → 11 scans whose rays pass through it to a wall at 30 m."""
    m = StaticMap(1.0, 3, headroom=5, miss_weight=0.5)
    for _ in range(20):
        m.add_scan(np.array([[10.5, 0.5]]))
    assert m.n_occupied == 1
    ranges, hit, pts = scan_of_wall(30.0)
    v0 = m.version
    freed_after = None
    for k in range(1, 20):
        assert m.carve((0.0, 0.0), ANGLES, ranges, hit, 150.0, True, 0.05, pts) >= 1
        if m.n_occupied == 0:
            freed_after = k
            break
    assert freed_after == 11
    assert m.version != v0 and m.polygons() == []


def test_hit_and_occluded_cells_are_not_carved():
    """The wall's own cells (hit in the scan) and a cell hidden behind a disc are kept; a cell in
    front of the wall and off the disc's shadow is carved."""
    m = StaticMap(1.0, 1, headroom=0, miss_weight=1.0)
    ranges, hit, pts = scan_of_wall(30.0, blocker=((15.0, 0.0), 2.0))
    wall_cells = pts[np.abs(pts[:, 1]) > 5.0]  # wall returns, not the disc's
    m.add_scan(wall_cells)
    m.add_scan(np.array([[20.5, 0.5], [20.5, 10.5]]))  # behind the disc / in open water
    n0 = m.n_occupied
    carved = m.carve((0.0, 0.0), ANGLES, ranges, hit, 150.0, True, 0.05, pts)
    assert carved == 1
    assert m.n_occupied == n0 - 1
    occ = m.occupied(np.array([[20.5, 0.5], [20.5, 10.5]]))
    assert occ.tolist() == [True, False]
    assert m.occupied(wall_cells).all()


def test_a_wall_hit_in_a_third_of_the_scans_stays_mapped():
    """Hits count twice a miss: a mapped cell hit one scan in three and seen through in the others
    (a wall at grazing incidence) stays occupied; one hit every other scan maps a new cell."""
    m = StaticMap(1.0, 3, headroom=5, miss_weight=0.5)
    ranges, hit, pts = scan_of_wall(30.0)
    for k in range(12):
        if k % 2 == 0:
            m.add_scan(np.array([[10.5, 0.5]]))
        else:
            m.carve((0.0, 0.0), ANGLES, ranges, hit, 150.0, True, 0.05, pts)
    assert m.occupied(np.array([[10.5, 0.5]]))[0]
    for k in range(60):
        if k % 3 == 0:
            m.add_scan(np.array([[10.5, 0.5]]))
        else:
            m.carve((0.0, 0.0), ANGLES, ranges, hit, 150.0, True, 0.05, pts)
    assert m.occupied(np.array([[10.5, 0.5]]))[0]


def test_beyond_max_range_and_partial_fan_are_not_carved():
    m = StaticMap(1.0, 1, headroom=0, miss_weight=1.0)
    m.add_scan(np.array([[160.5, 0.5], [-10.5, 0.5]]))
    # a 180° fan facing +x: the cell behind (x < 0) is outside it; the far one beyond range
    fan = np.abs(ANGLES) < math.pi / 2
    a = ANGLES[fan]
    r = np.full(a.size, 100.0)
    assert m.carve((0.0, 0.0), a, r, np.zeros(a.size, bool), 100.0, False) == 0
    assert m.n_occupied == 2


@pytest.mark.parametrize("kwargs, field", [({"cell_m": 0.0}, "cell_m"), ({"min_hits": 0}, "min_hits"),
                                           ({"headroom": -1}, "headroom"), ({"miss_weight": 2.0}, "miss_weight"),
                                           ({"carve_margin_m": -1.0}, "carve_margin_m")])
def test_bad_arguments_name_the_field(kwargs, field):
    with pytest.raises(ValueError, match=field):
        StaticMap(**kwargs)
