"""What every single-vessel suite task shares: the easy and hard variants' ranges (:class:`Difficulty`),
the declared observation bounds, the random current and the task base (:class:`VesselTask`: the vessel
type, observation noise, the own-state observations, the target marker).

The Otter domain (:mod:`mjasc.suite.otter`), the Delfim domain (its tasks on the Delfim hull) and the
team domain (:mod:`mjasc.suite.otter_team`) build on it. World ENU, body FLU, SI units.
"""

from __future__ import annotations

import collections
from dataclasses import dataclass

import mujoco
import numpy as np
from dm_control.suite import base
from dm_env import specs

from mjasc.physics.currents import GaussMarkovCurrent, UniformCurrent
from mjasc.physics.vessels import load_vessel_type
from mjasc.suite.common import VesselPhysics

__all__ = ["Difficulty", "EASY", "HARD", "OWN_STATE_OBSERVATIONS", "OBSERVATION_BOUNDS", "observation_array_spec",
           "random_current", "vec", "VesselTask"]

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



def random_current(random: np.random.RandomState, d: Difficulty):
    """A uniform current of random direction, steady (easy) or Gauss–Markov varying (hard)."""
    speed = random.uniform(*d.current_speed_m_s)
    direction = random.uniform(-np.pi, np.pi)
    mean = speed * np.array([np.cos(direction), np.sin(direction)])
    if d.current_sigma_m_s > 0:
        return GaussMarkovCurrent(mean, d.current_time_constant_s, d.current_sigma_m_s,
                                  seed=int(random.randint(2**31 - 1)), step_s=1.0)
    return UniformCurrent(mean)


def vec(*values) -> np.ndarray:
    """A float64 array of the values."""
    return np.array(values, dtype=float)


class VesselTask(base.Task):
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
        pos["target_heading", :2] = np.asarray(xy) + 1.5 * vec(np.cos(heading_rad), np.sin(heading_rad))
        physics.named.model.site_quat["target_heading"] = [np.cos(heading_rad / 2), 0, 0, np.sin(heading_rad / 2)]
        # The compiler marked the bar as turned with its body (the world: an identity quaternion in the
        # file), so MuJoCo's kinematics would skip its own rotation: it has one now.
        model = physics.model
        model.site_sameframe[model.name2id("target_heading", "site")] = mujoco.mjtSameFrame.mjSAMEFRAME_NONE

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
