"""Otter domain: one Otter USV following paths, keeping station, crossing traffic.

Tasks (each ``<task>`` is the easy variant, ``<task>_hard`` the hard one: stronger and
time-varying current, more and faster traffic, more observation noise, larger initial errors):

* ``path_following``: follow a randomized path of rounded legs at a randomized speed in a
  randomized current. Reward: on the path (cross-track error) × at the reference speed along it.
* ``station_keeping``: reach and hold a randomized position, bow into the current (twin fixed
  propellers cannot push sideways: the only pose held against a current faces it).
* ``collision_avoidance``: cross an 80 m walled basin to a goal through moving traffic seen only
  through a 360° range sensor (mjasc.perception.range_sensor.RangeSensor); the episode ends (discount 0) on any contact.

Actions: normalized (port, starboard) propeller commands in [−1, 1] (docs/architecture.md).
Observations: body-frame quantities only (no absolute position), Gaussian noise from ``self.random``.
The physics is mjasc's own step (common.VesselPhysics). World ENU, body FLU, SI units.
"""

from __future__ import annotations

import collections
from pathlib import Path as FilePath

import numpy as np
from dm_control.rl import control
from dm_control.utils import containers, rewards

from mjasc.core.frames import wrap_angle
from mjasc.core.geometry import circle_polygon
from mjasc.guidance.paths import Path
from mjasc.perception.range_sensor import RangeSensor, SensorConfig
from mjasc.physics.currents.gauss_markov import GaussMarkovCurrent
from mjasc.physics.obstacles import MovingObstacle
from mjasc.suite.common import (
    CONTROL_TIMESTEP_S,
    VesselPhysics,
    basin_walls,
    compose_world,
    make_control_environment,
    range_sensor,
    world_to_body,
)
from mjasc.suite.pixel_scene import OVER_TARGET_Z_M, draw_reference, path_polyline
from mjasc.suite.traffic_lanes import TRAFFIC_INSET_M, TRAFFIC_RADIUS_M, draw_lanes
from mjasc.suite.vessel_choice import hull_name, suite_vessel_type
from mjasc.suite.vessel_task import (  # (Difficulty, EASY, HARD, OWN_STATE_OBSERVATIONS: this domain's names too)
    EASY,
    HARD,
    OWN_STATE_OBSERVATIONS,
    Difficulty,
    VesselTask,
    random_current,
    vec,
)

__all__ = ["SUITE", "Difficulty", "EASY", "HARD", "OWN_STATE_OBSERVATIONS", "PathFollowing", "StationKeeping",
           "CollisionAvoidance", "get_model_and_assets", "make_environment"]

XML_PATH = FilePath(__file__).with_suffix(".xml")
VESSEL_TYPE = "otter"
TIME_LIMITS_S = {"path_following": 60.0, "station_keeping": 40.0, "collision_avoidance": 80.0}
BASIN_HALF_SIZE_M = 40.0
RANGE_RAYS = 32
RANGE_MAX_M = 120.0  # > the basin's diagonal (113 m): every ray always hits a wall or a hull
GOAL_RADIUS_M = 3.0

SUITE = containers.TaggedTasks()
def get_model_and_assets():
    """The domain MJCF (what the tasks add to mjasc's world) and its assets (none)."""
    return XML_PATH.read_text(), {}


# ---------------------------------------------------------------------------------------------
class PathFollowing(VesselTask):
    """Follow a randomized path at a randomized speed in a randomized current."""

    LOOKAHEAD_M = (5.0, 10.0, 20.0)
    OBSERVATIONS = OWN_STATE_OBSERVATIONS + (("path_error", (3,)), ("path_ahead", (6,)),
                    ("speed_error", (1,)))

    def initialize_episode(self, physics: VesselPhysics) -> None:
        d, rnd = self.difficulty, self.random
        physics.configure_episode(random_current(rnd, d))
        # Five legs of 25–40 m, course changes up to ±path_turn, rounded with a 10 m radius; the
        # last leg (150 m, longer for a long time limit) is long enough that the path does not
        # end within the time limit even at twice the cruise speed (50 m spare for the corners).
        course = rnd.uniform(-np.pi, np.pi)
        points = [np.zeros(2)]
        for k in range(5):
            if k:
                course += rnd.uniform(-d.path_turn_rad, d.path_turn_rad)
            if k < 4:
                length = rnd.uniform(25.0, 40.0)
            else:
                sailed = float(np.sum(np.linalg.norm(np.diff(points, axis=0), axis=1)))
                length = max(150.0, self._travel_m(2.0 * self.vessel.cruise_speed_m_s) - sailed + 50.0)
            points.append(points[-1] + length * vec(np.cos(course), np.sin(course)))
        self.path = Path.from_waypoints(np.array(points), turn_radius_m=10.0)
        self.speed_ref_m_s = self.vessel.cruise_speed_m_s * rnd.uniform(0.7, 1.1)
        start_course = float(self.path.tangent_angle(0.0))
        offset = rnd.uniform(-d.initial_offset_m, d.initial_offset_m)
        p0 = vec(-offset * np.sin(start_course), offset * np.cos(start_course))
        psi0 = start_course + rnd.uniform(-d.initial_heading_error_rad, d.initial_heading_error_rad)
        physics.set_pose(0, p0[0], p0[1], psi0, surge_m_s=rnd.uniform(0.0, self.speed_ref_m_s))
        self._place_target(physics, self.path.end_point)
        draw_reference(physics, [path_polyline(self.path)])
        self._gamma = 0.0
        self._cache = {}
        physics.after_reset()
        super().initialize_episode(physics)

    def path_state(self, physics: VesselPhysics) -> tuple[float, float, float]:
        """(γ [m], cross-track error e [m] (+ left of the path), path course χ_p [rad]) now."""
        def compute():
            p = physics.position(0)
            self._gamma = self.path.project(p, gamma_hint=self._gamma, search_window_m=30.0)
            return self._gamma, self.path.cross_track_error(p, self._gamma), float(self.path.tangent_angle(self._gamma))
        return self._cached(physics, "path_state", compute)

    def get_observation(self, physics: VesselPhysics) -> collections.OrderedDict:
        """Body velocities, shaft speeds, current estimate, path errors and path ahead (body frame)."""
        d = self.difficulty
        gamma, e, chi = self.path_state(physics)
        psi = self._noisy_heading(physics)
        obs = collections.OrderedDict()
        self._own_state_observations(physics, obs)
        err = psi - chi
        obs["path_error"] = vec(e + self._noise(d.position_noise_m, 1)[0], np.sin(err), np.cos(err))
        ahead = self.path.point(gamma + np.array(self.LOOKAHEAD_M)) - physics.position(0)
        ahead = world_to_body(ahead, psi) + self._noise(d.position_noise_m, 2 * len(self.LOOKAHEAD_M)).reshape(-1, 2)
        obs["path_ahead"] = ahead.reshape(-1)
        along = float(np.dot(physics.world_velocity(0), vec(np.cos(chi), np.sin(chi))))
        obs["speed_error"] = vec(self.speed_ref_m_s - along + self._noise(d.velocity_noise_m_s, 1)[0])
        return obs

    def get_reward(self, physics: VesselPhysics) -> float:
        """On the path (|e| ≤ 0.5 m) × at the reference speed along it (±0.15 m/s)."""
        _, e, chi = self.path_state(physics)
        along = float(np.dot(physics.world_velocity(0), vec(np.cos(chi), np.sin(chi))))
        on_path = rewards.tolerance(e, bounds=(-0.5, 0.5), margin=5.0, value_at_margin=0.1, sigmoid="gaussian")
        at_speed = rewards.tolerance(along - self.speed_ref_m_s, bounds=(-0.15, 0.15), margin=1.0,
                                     value_at_margin=0.1, sigmoid="gaussian")
        return float(on_path * (0.3 + 0.7 * at_speed))


# ---------------------------------------------------------------------------------------------
class StationKeeping(VesselTask):
    """Reach a randomized station and hold it, bow into the current."""

    OBSERVATIONS = OWN_STATE_OBSERVATIONS + (("station_body", (2,)), ("heading_error", (2,)))

    def initialize_episode(self, physics: VesselPhysics) -> None:
        d, rnd = self.difficulty, self.random
        current = random_current(rnd, d)
        physics.configure_episode(current)
        self.station_m = rnd.uniform(-10.0, 10.0, 2)
        # Bow into the mean current: heading = direction the water comes from. (A varying current's
        # value at t = 0 already holds a fluctuation of σ: up to 23° off the mean in hard episodes.)
        mean = current.mean_velocity_m_s if isinstance(current, GaussMarkovCurrent) else current.velocity_m_s
        self.station_heading_rad = float(wrap_angle(np.arctan2(mean[1], mean[0]) + np.pi))
        r = rnd.uniform(0.3, 1.0) * 3.0 * d.initial_offset_m
        bearing = rnd.uniform(-np.pi, np.pi)
        p0 = self.station_m + r * vec(np.cos(bearing), np.sin(bearing))
        physics.set_pose(0, p0[0], p0[1], rnd.uniform(-np.pi, np.pi))
        self._place_target(physics, self.station_m, self.station_heading_rad)
        # over the target site, which covers the station 1.5 m around (it hid the whole circle)
        draw_reference(physics, [circle_polygon(self.station_m, 1.0, 24, circumscribed=False, closed=True)],
                       OVER_TARGET_Z_M)
        physics.after_reset()
        super().initialize_episode(physics)

    def get_observation(self, physics: VesselPhysics) -> collections.OrderedDict:
        """Body velocities, shaft speeds, current estimate, station offset and heading error."""
        d = self.difficulty
        psi = self._noisy_heading(physics)
        obs = collections.OrderedDict()
        self._own_state_observations(physics, obs)
        offset = world_to_body(self.station_m - physics.position(0), psi) + self._noise(d.position_noise_m, 2)
        obs["station_body"] = offset
        err = psi - self.station_heading_rad
        obs["heading_error"] = vec(np.sin(err), np.cos(err))
        return obs

    def get_reward(self, physics: VesselPhysics) -> float:
        """Within 1 m of the station × bow within 0.2 rad of the held heading (soft)."""
        dist = float(np.linalg.norm(physics.position(0) - self.station_m))
        close = rewards.tolerance(dist, bounds=(0.0, 1.0), margin=10.0, value_at_margin=0.1, sigmoid="gaussian")
        err = abs(float(wrap_angle(physics.heading(0) - self.station_heading_rad)))
        aligned = rewards.tolerance(err, bounds=(0.0, 0.2), margin=np.pi / 2, value_at_margin=0.1, sigmoid="gaussian")
        return float(close * (0.5 + 0.5 * aligned))


# ---------------------------------------------------------------------------------------------
def _traffic_names(n: int) -> list[str]:
    return [f"traffic{k}" for k in range(n)]


class CollisionAvoidance(VesselTask):
    """Cross the basin to a goal through crossing traffic, seen only through the range sensor."""

    OBSERVATIONS = OWN_STATE_OBSERVATIONS + (("goal_direction", (2,)), ("goal_distance", (1,)),
                    ("ranges", (RANGE_RAYS,)))

    def initialize_episode(self, physics: VesselPhysics) -> None:
        d, rnd = self.difficulty, self.random
        theta = rnd.uniform(-np.pi, np.pi)
        start = 30.0 * vec(np.cos(theta), np.sin(theta))
        phi = theta + np.pi + rnd.uniform(-0.5, 0.5)
        self.goal_m = 30.0 * vec(np.cos(phi), np.sin(phi))
        route = self.goal_m - start
        course = float(np.arctan2(route[1], route[0]))
        lanes = draw_lanes(self.random, d.n_traffic, start, route, course, self.vessel.cruise_speed_m_s,
                           d.traffic_speed_m_s, BASIN_HALF_SIZE_M - TRAFFIC_INSET_M)
        traffic = [MovingObstacle(name, TRAFFIC_RADIUS_M, speed_m_s=lane.speed_m_s,
                                  path=Path.line(lane.start_m, lane.end_m), start_gamma_m=lane.start_gamma_m)
                   for name, lane in zip(_traffic_names(d.n_traffic), lanes)]
        physics.configure_episode(random_current(rnd, d), traffic)
        psi0 = course + rnd.uniform(-d.initial_heading_error_rad, d.initial_heading_error_rad)
        physics.set_pose(0, start[0], start[1], psi0, surge_m_s=rnd.uniform(0.0, self.speed_ref_m_s))
        self.start_m = start
        self._cache = {}
        self._place_target(physics, self.goal_m, course)
        draw_reference(physics, [np.array([start, self.goal_m])])  # the route
        physics.after_reset()
        super().initialize_episode(physics)

    def sensor_config(self) -> SensorConfig:
        """The vessel's range sensor: RANGE_RAYS beams over 360° out to RANGE_MAX_M, no blind zone,
        range noise / dropout / clutter of the difficulty (mjasc.perception.range_sensor's model)."""
        d = self.difficulty
        return SensorConfig(beams=RANGE_RAYS, fov_deg=360.0, max_range_m=RANGE_MAX_M, min_range_m=0.0,
                            rate_hz=1.0 / CONTROL_TIMESTEP_S, range_noise_std_m=d.range_noise_m,
                            dropout_probability=d.range_dropout, clutter_per_scan=d.range_clutter_per_scan)

    def range_sensor(self, physics: VesselPhysics) -> RangeSensor:
        """The :class:`mjasc.perception.range_sensor.RangeSensor` of the vessel (rebuilt when the difficulty or
        the model changes)."""
        key = (id(self.difficulty), id(physics.model.ptr))
        if getattr(self, "_sensor_key", None) != key:
            self._sensor = range_sensor(physics, 0, self.sensor_config())
            self._sensor_key = key
        return self._sensor

    def ranges(self, physics: VesselPhysics) -> np.ndarray:
        """True (noise-free) distances (RANGE_RAYS,) [m] along the beams, RANGE_MAX_M where a beam
        has no return; beam k at body angle −π + (k + ½)·2π/RANGE_RAYS (counter-clockwise from
        astern, so the bow lies between beams RANGE_RAYS/2 − 1 and RANGE_RAYS/2)."""
        def compute():
            dist = self.range_sensor(physics).cast(physics.data.ptr)[0]
            return np.where(dist < 0, RANGE_MAX_M, dist)
        return self._cached(physics, "ranges", compute)

    def scan_ranges(self, physics: VesselPhysics) -> np.ndarray:
        """One noisy scan's ranges (RANGE_RAYS,) [m] (max range: no return). The scan's noise,
        dropout and clutter come from a Generator seeded from the task's RandomState."""
        d = self.difficulty
        noisy = d.range_noise_m > 0 or d.range_dropout > 0 or d.range_clutter_per_scan > 0
        rng = np.random.default_rng(self.random.randint(2**31 - 1)) if noisy else None
        return self.range_sensor(physics).scan(physics.data.ptr, rng).ranges

    def get_observation(self, physics: VesselPhysics) -> collections.OrderedDict:
        """Body velocities, shaft speeds, current estimate, goal bearing/distance, ranges (0–1)."""
        d = self.difficulty
        psi = self._noisy_heading(physics)
        obs = collections.OrderedDict()
        self._own_state_observations(physics, obs)
        goal = world_to_body(self.goal_m - physics.position(0), psi) + self._noise(d.position_noise_m, 2)
        dist = float(np.hypot(*goal))
        obs["goal_direction"] = np.clip(goal / max(dist, 1e-9), -1.0, 1.0)
        obs["goal_distance"] = vec(dist)
        obs["ranges"] = np.clip(self.scan_ranges(physics) / RANGE_MAX_M, 0.0, 1.0)
        return obs

    def get_reward(self, physics: VesselPhysics) -> float:
        """Progress to the goal (linear from the start distance, 1 within 3 m) × clearance (> 5 m)."""
        dist = float(np.linalg.norm(physics.position(0) - self.goal_m))
        start = float(np.linalg.norm(self.start_m - self.goal_m))
        near = rewards.tolerance(dist, bounds=(0.0, GOAL_RADIUS_M), margin=start, sigmoid="linear",
                                 value_at_margin=0.0)
        clear = rewards.tolerance(float(np.min(self.ranges(physics))), bounds=(5.0, np.inf), margin=4.0,
                                  value_at_margin=0.1, sigmoid="gaussian")
        return float(near * (0.5 + 0.5 * clear))

    def get_termination(self, physics: VesselPhysics):
        """Discount 0 on any contact of the hull (traffic, basin walls)."""
        if physics.in_contact(0):
            return 0.0
        return None


# ---------------------------------------------------------------------------------------------
_TASKS = {"path_following": PathFollowing, "station_keeping": StationKeeping,
          "collision_avoidance": CollisionAvoidance}


def make_environment(task: str, vessel_type: str, difficulty: Difficulty, time_limit=None, random=None,
                     environment_kwargs=None) -> control.Environment:
    """The control.Environment of one task for one vessel type (a built-in name or a resolved vessel
    folder's absolute path: :mod:`mjasc.suite.vessel_choice`), the vessel named as its hull."""
    if task not in _TASKS:
        raise ValueError(f"task: unknown {task!r}; one of {sorted(_TASKS)}")
    static, moving = [], []
    if task == "collision_avoidance":
        static = [basin_walls(BASIN_HALF_SIZE_M)]
        moving = [MovingObstacle(n, TRAFFIC_RADIUS_M, vec(0.0, 0.0)) for n in _traffic_names(difficulty.n_traffic)]
    world = compose_world([(hull_name(vessel_type), vessel_type)], static, moving, XML_PATH)
    physics = world.physics
    time_limit = TIME_LIMITS_S[task] if time_limit is None else time_limit
    task_obj = _TASKS[task](vessel_type, difficulty, random=random, time_limit_s=time_limit)
    return make_control_environment(physics, task_obj, time_limit, environment_kwargs)


def register_tasks(suite, vessel_type: str, tags=("benchmarking",)) -> None:
    """Add every task in its easy and hard variant to ``suite`` for ``vessel_type`` (the delfim
    domain registers the same tasks for its hull); each task's ``vessel`` argument replaces the
    hull (:mod:`mjasc.suite.vessel_choice`)."""
    for task in _TASKS:
        for difficulty, name in ((EASY, task), (HARD, task + "_hard")):
            def factory(time_limit=None, random=None, vessel=None, environment_kwargs=None, _task=task, _d=difficulty):
                return make_environment(_task, suite_vessel_type(vessel, vessel_type), _d, time_limit, random,
                                        environment_kwargs)
            factory.__name__ = name
            factory.__doc__ = f"{task.replace('_', ' ').capitalize()} ({difficulty.name}) for the {vessel_type}."
            suite.add(*tags, difficulty.name)(factory)


register_tasks(SUITE, VESSEL_TYPE)
