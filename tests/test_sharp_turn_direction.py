"""The direction of a near-reversal sharp turn beside mapped structure
(mjasc.avoidance.structure.turn_away_from_structure): the long way round when the short way sweeps
the bow through the structure, the short way otherwise. The geometry is that of
tests/cas_regressions/bottleneck_current_reversal_14.toml at 45 s (the island's south-west corner
3.5 m east and 3.9 m north of the vessel, heading 150°, the detour asking for a 162° turn clockwise)."""

import math

import numpy as np
import pytest

from mjasc.avoidance.structure import turn_away_from_structure

ISLAND = np.array([[-9.96, 37.5], [-9.96, 67.5], [-39.96, 67.5], [-39.96, 37.5]])
HERE = np.array([-43.5, 33.6])


def _way(position, heading_deg, error_deg, polygons=(ISLAND,)):
    return turn_away_from_structure(position, math.radians(heading_deg), math.radians(error_deg), polygons,
                                     probe_m=5.0, margin_m=1.0)


def test_a_reversal_whose_short_way_sweeps_the_island_goes_the_long_way():
    assert _way(HERE, 150.0, -162.0) == 1  # counter-clockwise: the bow through south, away from the corner


def test_a_reversal_whose_short_way_is_clear_stays_the_short_way():
    assert _way(HERE, 150.0, 162.0) == 0  # counter-clockwise is the short way and already away from it
    far = HERE + np.array([-30.0, -30.0])
    assert _way(far, 150.0, -162.0) == 0  # no structure within the sweep: the short way


@pytest.mark.parametrize("error_deg", [-100.0, -134.0])
def test_a_turn_short_of_a_reversal_is_never_taken_the_long_way(error_deg):
    assert _way(HERE, 150.0, error_deg) == 0


def test_without_mapped_structure_the_short_way():
    assert _way(HERE, 150.0, -162.0, polygons=()) == 0


def test_mirrored_geometry_mirrors_the_choice():
    mirrored = ISLAND * np.array([1.0, -1.0])
    assert _way(HERE * np.array([1.0, -1.0]), -150.0, 162.0, polygons=(mirrored[::-1],)) == -1
