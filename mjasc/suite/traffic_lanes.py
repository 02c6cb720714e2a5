"""The collision_avoidance task's traffic: straight crossings of the basin, drawn apart.

Each boat crosses the vessel's route at a random point near when the vessel, at cruise speed, gets
there, on a straight lane from wall to wall (inside the walls: it never passes through one) at a
constant speed, and stops at the lane's end. The boats are kinematic (mocap bodies, no contact
among them) and do not see each other, so a boat's crossing is drawn again while its motion would
come within ``TRAFFIC_SEPARATION_M`` of a boat already placed. World ENU, SI units, times from the
episode's start [s].
"""

from __future__ import annotations

import dataclasses

import numpy as np

__all__ = ["TRAFFIC_RADIUS_M", "TRAFFIC_INSET_M", "TRAFFIC_SEPARATION_M", "TRAFFIC_DRAWS", "TrafficLane",
           "draw_lane", "draw_lanes"]

TRAFFIC_RADIUS_M = 2.0  # a traffic boat's radius [m]
TRAFFIC_INSET_M = 4.0  # traffic lanes end this far inside the basin walls [m]
TRAFFIC_SEPARATION_M = 2 * TRAFFIC_RADIUS_M + 2.0  # least centre distance between two boats' motions [m]
TRAFFIC_DRAWS = 200  # failed draws of one boat's crossing before the boats placed so far are drawn again


@dataclasses.dataclass(frozen=True)
class TrafficLane:
    """A boat's straight crossing from ``start_m`` to ``end_m`` (world ENU, m) along the unit
    ``direction``, ``length_m`` long, at ``speed_m_s`` from arc length ``start_gamma_m`` at t = 0;
    it stops at the end."""
    start_m: np.ndarray
    end_m: np.ndarray
    direction: np.ndarray
    length_m: float
    speed_m_s: float
    start_gamma_m: float

    def stop_time_s(self) -> float:
        """When the boat reaches the lane's end and stops [s]."""
        return (self.length_m - self.start_gamma_m) / self.speed_m_s

    def positions_m(self, t_s: np.ndarray) -> np.ndarray:
        """(len(t_s), 2) positions at the times ``t_s`` [s]."""
        gamma = np.minimum(self.start_gamma_m + self.speed_m_s * t_s, self.length_m)
        return self.start_m + gamma[:, None] * self.direction

    def closest_approach_m(self, other: "TrafficLane", step_s: float = 0.1) -> float:
        """The least centre distance [m] between this boat and ``other`` over their whole motions
        (sampled every ``step_s``, both boats' stops included; after both stop it stays constant)."""
        t_end = max(self.stop_time_s(), other.stop_time_s())
        t = np.append(np.arange(0.0, t_end, step_s), [self.stop_time_s(), other.stop_time_s(), t_end])
        return float(np.min(np.linalg.norm(self.positions_m(t) - other.positions_m(t), axis=1)))


def _distance_to_square_edge(point, direction, half_size_m: float) -> float:
    """Distance [m] from ``point`` (inside the square |x|, |y| ≤ half_size_m) along the unit
    ``direction`` to the square's edge."""
    t = np.inf
    for p, u in zip(point, direction):
        if abs(u) > 1e-12:
            t = min(t, ((half_size_m if u > 0 else -half_size_m) - p) / u)
    return float(max(t, 0.0))


def draw_lane(rnd: np.random.RandomState, start_m, route_m, course_rad: float, cruise_speed_m_s: float,
              speed_range_m_s, inner_half_size_m: float) -> TrafficLane:
    """One boat's crossing drawn from ``rnd``: it crosses the route (``start_m`` + s·``route_m``,
    s in [0, 1], course ``course_rad``) at a random point s = f in [0.2, 0.8], near when the vessel at
    ``cruise_speed_m_s`` would be there (± 6 s), from port or starboard at 90° ± 35°, at a speed
    drawn from ``speed_range_m_s``, on a straight line from wall to wall of the square
    |x|, |y| ≤ ``inner_half_size_m`` (where it stops). A boat that would have to start beyond the
    wall to meet the vessel starts at the wall instead (and crosses earlier)."""
    length = float(np.linalg.norm(route_m))
    f = rnd.uniform(0.2, 0.8)
    t_cross = f * length / cruise_speed_m_s + rnd.uniform(-6.0, 6.0)
    speed = rnd.uniform(*speed_range_m_s)
    heading = course_rad + rnd.choice([-1.0, 1.0]) * (np.pi / 2 + rnd.uniform(-0.6, 0.6))
    cross = start_m + f * route_m
    u = np.array([np.cos(heading), np.sin(heading)])
    back = _distance_to_square_edge(cross, -u, inner_half_size_m)
    ahead = _distance_to_square_edge(cross, u, inner_half_size_m)
    return TrafficLane(cross - back * u, cross + ahead * u, u, back + ahead, float(speed),
                       float(back - min(speed * max(t_cross, 0.0), back)))


def draw_lanes(rnd: np.random.RandomState, n: int, start_m, route_m, course_rad: float, cruise_speed_m_s: float,
               speed_range_m_s, inner_half_size_m: float) -> list[TrafficLane]:
    """``n`` crossings (:func:`draw_lane`) whose boats stay ``TRAFFIC_SEPARATION_M`` apart over their
    whole motions: a boat's crossing is drawn again while it would come closer to a boat already
    placed; after ``TRAFFIC_DRAWS`` failed draws in a row the boats placed so far are drawn again."""
    lanes: list[TrafficLane] = []
    failed = restarts = 0
    while len(lanes) < n:
        lane = draw_lane(rnd, start_m, route_m, course_rad, cruise_speed_m_s, speed_range_m_s, inner_half_size_m)
        if all(lane.closest_approach_m(other) >= TRAFFIC_SEPARATION_M for other in lanes):
            lanes.append(lane)
            failed = 0
            continue
        failed += 1
        if failed == TRAFFIC_DRAWS:
            lanes, failed, restarts = [], 0, restarts + 1
            if restarts == TRAFFIC_DRAWS:
                raise RuntimeError(f"collision_avoidance: no {n} crossings kept {TRAFFIC_SEPARATION_M} m apart in "
                                   "the basin")
    return lanes
