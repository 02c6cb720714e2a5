"""The potential-field planner's obstacles when the vessel stands inside or between safety regions
(mjasc/avoidance/replanning.py): an island's region is grown by less rather than scaled about its
centre, and when regions would merge over the vessel no detour is planned — so that no island
drops out of the field. In the §6.4.3 bottleneck both islands' regions, joined across the gap by
a crossing vessel's swept area, became one convex hull around the vessel, shrunk to a blob in the
gap's middle: the detour ran through the north island's face (held-out seeds 108, 141, 166, 180
and the open seed 40)."""

import numpy as np

from mjasc.avoidance.replanning import _inflation_leaving, merge_overlapping
from mjasc.core.geometry import distance_to_polygon, inflate_polygon, point_in_polygon

NORTH = np.array([[0.0, 7.0], [30.0, 7.0], [30.0, 30.0], [0.0, 30.0]])   # two islands, a 14 m gap
SOUTH = np.array([[0.0, -30.0], [30.0, -30.0], [30.0, -7.0], [0.0, -7.0]])
SWEPT = np.array([[12.0, -9.0], [18.0, -9.0], [18.0, 9.0], [12.0, 9.0]])  # a crossing vessel's swept area
VESSEL = np.array([5.0, 2.0])


def _inside(point, polygons):
    return [bool(point_in_polygon(point[None], p)[0]) for p in polygons]


def test_regions_that_would_merge_over_the_vessel_give_no_obstacles_to_plan_with():
    regions = [inflate_polygon(NORTH, 3.5), inflate_polygon(SOUTH, 3.5), SWEPT]
    merged = merge_overlapping(regions, clearance_m=0.5)
    assert len(merged) == 1 and _inside(VESSEL, merged) == [True]  # (what the planner used to shrink)
    assert merge_overlapping(regions, clearance_m=0.5, keep_out=VESSEL) is None
    # away from the gap they merge as before; and moving tracks' regions alone merge over it (the
    # planner then shrinks their hull to leave the vessel outside, as it always did)
    assert len(merge_overlapping(regions, clearance_m=0.5, keep_out=np.array([-30.0, 0.0]))) == 1
    assert len(merge_overlapping(regions, clearance_m=0.5, keep_out=VESSEL, solid=[False] * 3)) == 1
    assert merge_overlapping(regions, clearance_m=0.5, keep_out=VESSEL, solid=[True, False, False]) is None


def test_a_detour_from_between_joined_regions_is_refused_not_planned_through_an_island():
    """The planner says why instead (the vessel then stops and looks again every second, as for
    any failed re-plan with the conflict on its path)."""
    from mjasc.avoidance.config import AvoidanceConfig
    from mjasc.avoidance.replanning import plan_detour
    from mjasc.guidance.paths import Path

    mission = Path.from_points(np.array([[-40.0, 2.0], [80.0, 2.0]]))
    said = []
    out = plan_detour(0.0, VESSEL, mission, 45.0, [], [NORTH, SOUTH], {}, [SWEPT], AvoidanceConfig(),
                      2.1, 3.5, lambda t, text: said.append(text))
    assert out == "the vessel is between structure and obstacles whose safety regions join around it", out


def test_regions_that_do_not_enclose_the_vessel_still_merge():
    a = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]])
    merged = merge_overlapping([a, a + [1.0, 1.0]], clearance_m=0.5, keep_out=np.array([20.0, 20.0]))
    assert len(merged) == 1


def test_an_islands_region_is_grown_by_less_to_leave_a_vessel_inside_it_outside():
    assert _inflation_leaving(VESSEL, NORTH, 3.5) == 3.5                       # 5 m off: the full margin
    near = np.array([5.0, 5.0])                                               # 2 m off the face
    margin = _inflation_leaving(near, NORTH, 3.5)
    assert np.isclose(margin, 1.5)
    region = inflate_polygon(NORTH, margin)
    assert not point_in_polygon(near[None], region)[0]
    assert np.isclose(distance_to_polygon(near[None], region)[0], 0.5)
    # the island's shape all round: every face keeps the same margin (a scaling about the centre
    # would have pulled the far faces in by metres)
    far_faces = np.array([[15.0, 30.0 + margin], [30.0 + margin, 18.0], [0.0 - margin, 18.0]])
    assert np.allclose(distance_to_polygon(far_faces, region), 0.0, atol=1e-9)
    assert _inflation_leaving(np.array([10.0, 10.0]), NORTH, 3.5) == 3.5       # inside the island: unchanged
