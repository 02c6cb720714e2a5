"""Tests for mjasc.avoidance.right_of_way: starboard rule, its edge cases, and that a pair always splits."""

import numpy as np
import pytest

from mjasc.avoidance.right_of_way import gives_way, relative_bearing


def pair(a, b):
    """(A gives way, B gives way) for team mates a = (position, heading), b = (position, heading)."""
    return gives_way(a[0], a[1], b[0], b[1], True), gives_way(b[0], b[1], a[0], a[1], True)


def test_relative_bearing_flu():
    assert relative_bearing([0, 0], 0.0, [10, 0]) == pytest.approx(0.0)
    assert relative_bearing([0, 0], 0.0, [0, 5]) == pytest.approx(np.pi / 2)  # port
    assert relative_bearing([0, 0], 0.0, [0, -5]) == pytest.approx(-np.pi / 2)  # starboard
    assert relative_bearing([0, 0], np.pi / 2, [5, 0]) == pytest.approx(-np.pi / 2)  # heading north: east is starboard
    assert abs(relative_bearing([0, 0], 0.0, [-3, 0])) == pytest.approx(np.pi)


def test_always_yield_to_a_non_team_obstacle():
    rng = np.random.default_rng(0)
    for _ in range(50):
        own, other = rng.uniform(-50, 50, (2, 2))
        assert gives_way(own, rng.uniform(-np.pi, np.pi), other, rng.uniform(-np.pi, np.pi), False)


def test_crossing_the_vessel_with_the_other_to_starboard_gives_way():
    a = ([0.0, 0.0], 0.0)  # heading east
    b = ([20.0, -20.0], np.pi / 2)  # heading north, on A's starboard bow; A is on B's port bow
    assert pair(a, b) == (True, False)


def test_dead_ahead_and_dead_astern_overtaking():
    behind = ([0.0, 0.0], 0.3)
    ahead = ([10 * np.cos(0.3), 10 * np.sin(0.3)], 0.3)  # same course, dead ahead of `behind`
    assert pair(behind, ahead) == (True, False)  # the overtaking vessel gives way, the other keeps


def test_exactly_head_on_splits_by_course():
    a = ([0.0, 0.0], 0.0)
    b = ([30.0, 0.0], np.pi)
    assert pair(a, b) == (True, False)  # heading 0 < π
    assert pair(b, a) == (False, True)


def test_symmetric_bottleneck_exactly_one_gives_way():
    # Mirror-image pairs about the line x = 0 (and about a rotated line), including the
    # converging-into-a-bottleneck geometry of thesis §6.4.3 and the head-on degenerate case.
    rng = np.random.default_rng(1)
    for theta in np.concatenate([[0.0, np.pi / 4, -np.pi / 4, np.pi / 2], rng.uniform(-np.pi, np.pi, 100)]):
        y = rng.uniform(-5, 5)
        a = ([-15.0, y], theta)
        b = ([15.0, y], np.pi - theta)  # the mirror image of a in x = 0
        ga, gb = pair(a, b)
        assert ga != gb, theta
        if abs(np.sin(relative_bearing(a[0], a[1], b[0]))) < 1e-6:
            continue  # on the bow/stern line: a tie broken by course, not rotation invariant
        phi = rng.uniform(-np.pi, np.pi)  # same pair rotated as a whole: the starboard rule holds
        c, s = np.cos(phi), np.sin(phi)
        rot = lambda p: [c * p[0] - s * p[1], s * p[0] + c * p[1]]  # noqa: E731
        assert pair((rot(a[0]), a[1] + phi), (rot(b[0]), b[1] + phi)) == (ga, gb)
    # 45° convergence into a gap: A from the south-west heading north-east has B (from the
    # south-east, heading north-west) on its starboard side → A gives way.
    assert pair(([-10.0, 0.0], np.pi / 4), ([10.0, 0.0], 3 * np.pi / 4)) == (True, False)


def test_half_turn_symmetric_pairs_split():
    # Port-to-port and starboard-to-starboard passes: the starboard rule gives neither / both.
    for offset in (3.0, -3.0):
        assert sum(pair(([0.0, offset], 0.0), ([40.0, -offset], np.pi))) == 1
    # same course, same position up to a half turn about the midpoint: falls through to course
    assert sum(pair(([0.0, 0.0], 1.0), ([5.0, 5.0], 1.0 + np.pi))) == 1


def test_every_random_pair_splits():
    rng = np.random.default_rng(2)
    for _ in range(2000):
        a = (rng.uniform(-50, 50, 2), rng.uniform(-4, 4))
        b = (rng.uniform(-50, 50, 2), rng.uniform(-4, 4))
        assert sum(pair(a, b)) == 1
    # equal headings and bearings: decided by position
    assert sum(pair(([0.0, 0.0], 0.0), ([0.0, 0.0 + 1e-12 + 10.0], 0.0))) == 1


def test_validation():
    with pytest.raises(ValueError, match="own_position"):
        gives_way([0, 0, 0], 0.0, [1, 0], 0.0, True)
    with pytest.raises(ValueError, match="other_heading"):
        gives_way([0, 0], 0.0, [1, 0], np.nan, True)
    with pytest.raises(ValueError, match="other_position"):
        gives_way([1, 1], 0.0, [1, 1], 0.0, True)


def test_overtaking_from_the_starboard_quarter_gives_way_rule_13():
    # B comes up on A from 45° abaft A's starboard beam on a converging course: by rule 15 alone A
    # (which has B on its starboard side) would give way; rule 13 makes the overtaking B keep out.
    a, a_h = np.array([0.0, 0.0]), 0.0
    b, b_h = np.array([-4.0, -3.0]), np.radians(20.0)
    assert np.degrees(abs(relative_bearing(a, a_h, b))) > 112.5
    assert not gives_way(a, a_h, b, b_h, True)
    assert gives_way(b, b_h, a, a_h, True)
    # Just forward of 22.5° abaft the beam it is a crossing again: rule 15, A gives way.
    c = np.array([-1.0, -3.0])
    assert np.degrees(abs(relative_bearing(a, a_h, c))) < 112.5
    assert gives_way(a, a_h, c, b_h, True) and not gives_way(c, b_h, a, a_h, True)
