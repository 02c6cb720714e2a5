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
from dataclasses import dataclass
from pathlib import Path as FilePath

import numpy as np
from dm_control.rl import control
from dm_control.suite import base
from dm_control.utils import containers, rewards
from dm_env import specs

from mjasc.core.frames import wrap_angle
from mjasc.guidance.paths import Path
from mjasc.perception.range_sensor import RangeSensor, SensorConfig
from mjasc.physics.currents import GaussMarkovCurrent, UniformCurrent
from mjasc.physics.obstacles import MovingObstacle
from mjasc.physics.vessels import load_vessel_type
from mjasc.suite.common import (
    CONTROL_TIMESTEP_S,
    VesselPhysics,
    basin_walls,
    compose_world,
    make_control_environment,
    range_sensor,
    world_to_body,
)
from mjasc.suite.vessel_choice import hull_name, suite_vessel_type

__all__ = ["SUITE", "Difficulty", "EASY", "HARD", "OWN_STATE_OBSERVATIONS", "PathFollowing", "StationKeeping",
           "CollisionAvoidance", "get_model_and_assets", "make_environment"]

XML_PATH = FilePath(__file__).with_suffix(".xml")
VESSEL_TYPE = "otter"
TIME_LIMITS_S = {"path_following": 60.0, "station_keeping": 40.0, "collision_avoidance": 80.0}
BASIN_HALF_SIZE_M = 40.0
TRAFFIC_RADIUS_M = 2.0
RANGE_RAYS = 32
RANGE_MAX_M = 120.0  # > the basin's diagonal (113 m): every ray always hits a wall or a hull
GOAL_RADIUS_M = 3.0
TRAFFIC_INSET_M = 4.0  # traffic lanes end this far inside the basin walls [m]

SUITE = containers.TaggedTasks()
#: Observations every task gives about the own vessel (name, shape), first in every dict.
OWN_STATE_OBSERVATIONS = (("body_velocity", (3,)), ("shaft_speed", (2,)), ("current_body", (2,)))


@dataclass(frozen=True)
class Difficulty:
    """Everything that differs between the easy and hard variant of a task (SI units)."""

    name: str
    current_speed_m_s: tuple[float, float]  # mean current speed drawn uniformly in this range
    current_sigma_m_s: float  # Gauss–Markov fluctuation σ per component (0: steady current)
    current_time_constant_s: float
    velocity_noise_m_s: float  # σ on body velocities and the current estimate
    position_noise_m: float  # σ on path / target / goal errors
    heading_noise_rad: float
    range_noise_m: float  # σ of a range return (mjasc.perception.range_sensor's noise model)
    initial_offset_m: float  # largest initial distance from the path / station / slot
    initial_heading_error_rad: float
    path_turn_rad: float  # largest course change at a waypoint
    n_traffic: int
    traffic_speed_m_s: tuple[float, float]
    range_dropout: float = 0.0  # probability that a true range return is lost
    range_clutter_per_scan: float = 0.0  # Poisson mean of false returns per scan
    leader_turns: int = 0  # course changes (≤ path_turn_rad each) of the formation leader's line


EASY = Difficulty("easy", (0.05, 0.3), 0.0, 60.0, 0.01, 0.05, 0.01, 0.05, 3.0, 0.5, np.pi / 4, 3, (0.5, 1.2),
                  range_dropout=0.01, range_clutter_per_scan=0.05)
HARD = Difficulty("hard", (0.3, 0.6), 0.08, 30.0, 0.05, 0.3, 0.03, 0.3, 8.0, 1.2, np.pi / 2, 6, (0.8, 2.0),
                  range_dropout=0.05, range_clutter_per_scan=0.3)

#: Declared bounds (minimum, maximum) of observations the physics bounds, by name (a team task's
#: ``<vessel>_<name>`` keys too); every other observation is an unbounded ``specs.Array``.
#: shaft_speed: the shaft lag keeps the activation between the commands (in [−1, 1]); sin/cos
#: pairs; unit vectors; normalized ranges (clipped to [0, 1]); distances ≥ 0.
OBSERVATION_BOUNDS = {
    "shaft_speed": (-1.0, 1.0),
    "heading_error": (-1.0, 1.0),
    "course_error": (-1.0, 1.0),
    "goal_direction": (-1.0, 1.0),
    "goal_distance": (0.0, np.inf),
    "ranges": (0.0, 1.0),
    "path_error": ([-np.inf, -1.0, -1.0], [np.inf, 1.0, 1.0]),
}


def observation_array_spec(name: str, shape) -> specs.Array:
    """The float64 spec of observation ``name``: a ``BoundedArray`` when OBSERVATION_BOUNDS bounds it."""
    for key, (lo, hi) in OBSERVATION_BOUNDS.items():
        if name == key or name.endswith("_" + key):
            return specs.BoundedArray(shape, np.float64, np.asarray(lo, dtype=float), np.asarray(hi, dtype=float),
                                      name=name)
    return specs.Array(shape, np.float64, name=name)


def get_model_and_assets():
    """The domain MJCF (what the tasks add to mjasc's world) and its assets (none)."""
    return XML_PATH.read_text(), {}


def _random_current(random: np.random.RandomState, d: Difficulty):
    """A uniform current of random direction, steady (easy) or Gauss–Markov varying (hard)."""
    speed = random.uniform(*d.current_speed_m_s)
    direction = random.uniform(-np.pi, np.pi)
    mean = speed * np.array([np.cos(direction), np.sin(direction)])
    if d.current_sigma_m_s > 0:
        return GaussMarkovCurrent(mean, d.current_time_constant_s, d.current_sigma_m_s,
                                  seed=int(random.randint(2**31 - 1)), step_s=1.0)
    return UniformCurrent(mean)


def _vec(*values) -> np.ndarray:
    return np.array(values, dtype=float)


class _VesselTask(base.Task):
    """Shared parts: the vessel type, noise, the current, the target marker."""

    def __init__(self, vessel_type: str, difficulty: Difficulty, random=None, time_limit_s: float | None = None):
        self.vessel = load_vessel_type(vessel_type)
        self.difficulty = difficulty
        self.speed_ref_m_s = self.vessel.cruise_speed_m_s
        #: The episode's time limit [s] (None: the task's default), so paths outlast the episode.
        self.time_limit_s = time_limit_s
        super().__init__(random=random)

    def _travel_m(self, speed_m_s: float) -> float:
        """Distance [m] covered at ``speed_m_s`` within the episode's time limit (0 when there is
        none or it is infinite: the paths keep their default length)."""
        t = self.time_limit_s
        return speed_m_s * t if t is not None and np.isfinite(t) else 0.0

    #: (name, shape) of every observation, in order; the spec is built from it.
    OBSERVATIONS: tuple = ()

    def observation_spec(self, physics):
        """Observation arrays by name (float64), declared: building the spec draws no noise."""
        return collections.OrderedDict((name, observation_array_spec(name, shape))
                                       for name, shape in self.observation_shapes())

    def observation_shapes(self):
        """(name, shape) pairs of the observation, in order."""
        return self.OBSERVATIONS

    def _cached(self, physics: VesselPhysics, key: str, compute):
        """``compute()`` once per physics state: observation and reward read the same state."""
        stamp = (float(physics.data.time), physics.data.qpos.tobytes())
        cache = self.__dict__.setdefault("_cache", {})
        hit = cache.get(key)
        if hit is None or hit[0] != stamp:
            hit = cache[key] = (stamp, compute())
        return hit[1]

    def _noise(self, sigma: float, size: int) -> np.ndarray:
        return self.random.normal(0.0, sigma, size) if sigma > 0 else np.zeros(size)

    def _place_target(self, physics: VesselPhysics, xy, heading_rad: float = 0.0) -> None:
        pos = physics.named.model.site_pos
        pos["target", :2] = xy
        pos["target_heading", :2] = np.asarray(xy) + 1.5 * _vec(np.cos(heading_rad), np.sin(heading_rad))
        physics.named.model.site_quat["target_heading"] = [np.cos(heading_rad / 2), 0, 0, np.sin(heading_rad / 2)]

    def _own_state_observations(self, physics: VesselPhysics, obs: collections.OrderedDict, i: int = 0,
                                prefix: str = "") -> None:
        d = self.difficulty
        nu = physics.body_velocity(i)
        nu[:2] += self._noise(d.velocity_noise_m_s, 2)
        nu[2] += self._noise(d.heading_noise_rad, 1)[0]
        obs[prefix + "body_velocity"] = nu
        obs[prefix + "shaft_speed"] = physics.shaft_speed(i)
        obs[prefix + "current_body"] = physics.current_body(i) + self._noise(d.velocity_noise_m_s, 2)

    def _noisy_heading(self, physics: VesselPhysics, i: int = 0) -> float:
        return physics.heading(i) + self._noise(self.difficulty.heading_noise_rad, 1)[0]


# ---------------------------------------------------------------------------------------------
class PathFollowing(_VesselTask):
    """Follow a randomized path at a randomized speed in a randomized current."""

    LOOKAHEAD_M = (5.0, 10.0, 20.0)
    OBSERVATIONS = OWN_STATE_OBSERVATIONS + (("path_error", (3,)), ("path_ahead", (6,)),
                    ("speed_error", (1,)))

    def initialize_episode(self, physics: VesselPhysics) -> None:
        d, rnd = self.difficulty, self.random
        physics.configure_episode(_random_current(rnd, d))
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
            points.append(points[-1] + length * _vec(np.cos(course), np.sin(course)))
        self.path = Path.from_waypoints(np.array(points), turn_radius_m=10.0)
        self.speed_ref_m_s = self.vessel.cruise_speed_m_s * rnd.uniform(0.7, 1.1)
        start_course = float(self.path.tangent_angle(0.0))
        offset = rnd.uniform(-d.initial_offset_m, d.initial_offset_m)
        p0 = _vec(-offset * np.sin(start_course), offset * np.cos(start_course))
        psi0 = start_course + rnd.uniform(-d.initial_heading_error_rad, d.initial_heading_error_rad)
        physics.set_pose(0, p0[0], p0[1], psi0, surge_m_s=rnd.uniform(0.0, self.speed_ref_m_s))
        self._place_target(physics, self.path.end_point)
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
        obs["path_error"] = _vec(e + self._noise(d.position_noise_m, 1)[0], np.sin(err), np.cos(err))
        ahead = self.path.point(gamma + np.array(self.LOOKAHEAD_M)) - physics.position(0)
        ahead = world_to_body(ahead, psi) + self._noise(d.position_noise_m, 2 * len(self.LOOKAHEAD_M)).reshape(-1, 2)
        obs["path_ahead"] = ahead.reshape(-1)
        along = float(np.dot(physics.world_velocity(0), _vec(np.cos(chi), np.sin(chi))))
        obs["speed_error"] = _vec(self.speed_ref_m_s - along + self._noise(d.velocity_noise_m_s, 1)[0])
        return obs

    def get_reward(self, physics: VesselPhysics) -> float:
        """On the path (|e| ≤ 0.5 m) × at the reference speed along it (±0.15 m/s)."""
        _, e, chi = self.path_state(physics)
        along = float(np.dot(physics.world_velocity(0), _vec(np.cos(chi), np.sin(chi))))
        on_path = rewards.tolerance(e, bounds=(-0.5, 0.5), margin=5.0, value_at_margin=0.1, sigmoid="gaussian")
        at_speed = rewards.tolerance(along - self.speed_ref_m_s, bounds=(-0.15, 0.15), margin=1.0,
                                     value_at_margin=0.1, sigmoid="gaussian")
        return float(on_path * (0.3 + 0.7 * at_speed))


# ---------------------------------------------------------------------------------------------
class StationKeeping(_VesselTask):
    """Reach a randomized station and hold it, bow into the current."""

    OBSERVATIONS = OWN_STATE_OBSERVATIONS + (("station_body", (2,)), ("heading_error", (2,)))

    def initialize_episode(self, physics: VesselPhysics) -> None:
        d, rnd = self.difficulty, self.random
        current = _random_current(rnd, d)
        physics.configure_episode(current)
        self.station_m = rnd.uniform(-10.0, 10.0, 2)
        mean = current.velocity(np.zeros((1, 2)), 0.0)[0]
        # Bow into the mean current: heading = direction the water comes from.
        self.station_heading_rad = float(wrap_angle(np.arctan2(mean[1], mean[0]) + np.pi))
        r = rnd.uniform(0.3, 1.0) * 3.0 * d.initial_offset_m
        bearing = rnd.uniform(-np.pi, np.pi)
        p0 = self.station_m + r * _vec(np.cos(bearing), np.sin(bearing))
        physics.set_pose(0, p0[0], p0[1], rnd.uniform(-np.pi, np.pi))
        self._place_target(physics, self.station_m, self.station_heading_rad)
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
        obs["heading_error"] = _vec(np.sin(err), np.cos(err))
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


def _distance_to_square_edge(point, direction, half_size_m: float) -> float:
    """Distance [m] from ``point`` (inside the square |x|, |y| ≤ half_size_m) along the unit
    ``direction`` to the square's edge."""
    t = np.inf
    for p, u in zip(point, direction):
        if abs(u) > 1e-12:
            t = min(t, ((half_size_m if u > 0 else -half_size_m) - p) / u)
    return float(max(t, 0.0))


class CollisionAvoidance(_VesselTask):
    """Cross the basin to a goal through crossing traffic, seen only through the range sensor."""

    OBSERVATIONS = OWN_STATE_OBSERVATIONS + (("goal_direction", (2,)), ("goal_distance", (1,)),
                    ("ranges", (RANGE_RAYS,)))

    def initialize_episode(self, physics: VesselPhysics) -> None:
        d, rnd = self.difficulty, self.random
        theta = rnd.uniform(-np.pi, np.pi)
        start = 30.0 * _vec(np.cos(theta), np.sin(theta))
        phi = theta + np.pi + rnd.uniform(-0.5, 0.5)
        self.goal_m = 30.0 * _vec(np.cos(phi), np.sin(phi))
        route = self.goal_m - start
        length = float(np.linalg.norm(route))
        course = float(np.arctan2(route[1], route[0]))
        # Each boat crosses the route at a random point f·L, near when the own vessel at cruise
        # speed would be there (± 6 s), from port or starboard at 90° ± 35°. It sails a straight
        # line across the basin, from TRAFFIC_INSET_M inside one wall to as far inside the opposite
        # one (where it stops): it never passes through a wall. A boat that would have to start
        # beyond the wall to meet the vessel starts at the wall instead (and crosses earlier).
        traffic = []
        for k, name in enumerate(_traffic_names(d.n_traffic)):
            f = rnd.uniform(0.2, 0.8)
            t_cross = f * length / self.vessel.cruise_speed_m_s + rnd.uniform(-6.0, 6.0)
            speed = rnd.uniform(*d.traffic_speed_m_s)
            heading = course + rnd.choice([-1.0, 1.0]) * (np.pi / 2 + rnd.uniform(-0.6, 0.6))
            cross = start + f * route
            u = _vec(np.cos(heading), np.sin(heading))
            inner = BASIN_HALF_SIZE_M - TRAFFIC_INSET_M
            back, ahead = _distance_to_square_edge(cross, -u, inner), _distance_to_square_edge(cross, u, inner)
            lane = Path.line(cross - back * u, cross + ahead * u)
            gamma0 = back - min(speed * max(t_cross, 0.0), back)
            traffic.append(MovingObstacle(name, TRAFFIC_RADIUS_M, speed_m_s=float(speed), path=lane,
                                          start_gamma_m=float(gamma0)))
        physics.configure_episode(_random_current(rnd, d), traffic)
        psi0 = course + rnd.uniform(-d.initial_heading_error_rad, d.initial_heading_error_rad)
        physics.set_pose(0, start[0], start[1], psi0, surge_m_s=rnd.uniform(0.0, self.speed_ref_m_s))
        self.start_m = start
        self._cache = {}
        self._place_target(physics, self.goal_m, course)
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
        obs["goal_distance"] = _vec(dist)
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
        moving = [MovingObstacle(n, TRAFFIC_RADIUS_M, _vec(0.0, 0.0)) for n in _traffic_names(difficulty.n_traffic)]
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
