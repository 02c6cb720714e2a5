"""Otter team domain: several Otters, one policy each, sailing in formation.

Task ``formation`` (easy) / ``formation_hard``: a virtual leader moves along a straight line of
random course at a random speed; vessel i must hold its slot, a fixed offset (along, lateral)
from the leader in the leader's frame (a V of three: the apex on the line, the wings 8 m behind
and 8 m to either side). The episode ends (discount 0) on any contact.

**Multi-agent layout (flat, per-vessel prefixes).** dm_control's single-agent tooling (the suite
checks, ``flat_observation``, shimmy/gymnasium) needs one observation dict and one action array,
so the team is laid out flat and documented:

* action: shape (2·N,), vessel i's (port, starboard) commands at ``[2i, 2i + 2)``;
* observation: keys ``"<vessel>_<name>"`` (``otter0_body_velocity``, ``otter1_slot_error``, …),
  vessels in order; :func:`agent_observation` cuts out one vessel's dict with plain names;
* reward: the team's mean of the per-vessel rewards (:meth:`Formation.vessel_rewards` gives each).

:func:`joint_policy` turns one policy per vessel (each ``observation dict → (2,) action``) into a
policy of the flat environment. World ENU, body FLU, SI units.
"""

from __future__ import annotations

import collections

import numpy as np
from dm_control.rl import control
from dm_control.utils import containers, rewards

from ..paths import Path
from .common import CONTROL_TIMESTEP_S, Environment, VesselPhysics, compose_world, world_to_body
from .otter import EASY, HARD, OWN_STATE_OBSERVATIONS, XML_PATH, Difficulty, _random_current, _vec, _VesselTask

__all__ = ["SUITE", "Formation", "SLOTS_M", "agent_observation", "joint_policy", "make_environment"]

VESSEL_TYPE = "otter"
TIME_LIMIT_S = 60.0
#: Slots (along, lateral) [m] in the leader's frame (x along the course, y to port), one per vessel.
SLOTS_M = np.array([[0.0, 0.0], [-8.0, 8.0], [-8.0, -8.0]])

SUITE = containers.TaggedTasks()


def vessel_names(n: int, vessel_type: str = VESSEL_TYPE) -> list[str]:
    """Model names of the team's vessels (also their observation prefixes)."""
    return [f"{vessel_type}{i}" for i in range(n)]


def agent_observation(observation, vessel: int, n_vessels: int = len(SLOTS_M),
                      vessel_type: str = VESSEL_TYPE) -> collections.OrderedDict:
    """Vessel ``vessel``'s part of a team observation, keys without the prefix."""
    prefix = vessel_names(n_vessels, vessel_type)[vessel] + "_"
    return collections.OrderedDict((k[len(prefix):], v) for k, v in observation.items() if k.startswith(prefix))


def joint_policy(policies, n_vessels: int = len(SLOTS_M), vessel_type: str = VESSEL_TYPE):
    """A flat-environment policy (time_step → (2N,) action) from one policy per vessel, each
    called as ``policy(agent_observation)`` and returning that vessel's (2,) commands."""
    if len(policies) != n_vessels:
        raise ValueError(f"policies: need one per vessel ({n_vessels}), got {len(policies)}")

    def policy(time_step):
        return np.concatenate([np.asarray(p(agent_observation(time_step.observation, i, n_vessels, vessel_type)),
                                          dtype=float).reshape(2) for i, p in enumerate(policies)])
    return policy


class Formation(_VesselTask):
    """Hold a V formation around a virtual leader on a straight line, one policy per vessel."""

    def __init__(self, vessel_type: str, difficulty: Difficulty, slots_m=SLOTS_M, random=None):
        self.slots_m = np.asarray(slots_m, dtype=float)
        self.names = vessel_names(len(self.slots_m), vessel_type)
        super().__init__(vessel_type, difficulty, random=random)

    def initialize_episode(self, physics: VesselPhysics) -> None:
        d, rnd = self.difficulty, self.random
        physics.configure_episode(_random_current(rnd, d))
        self.course_rad = rnd.uniform(-np.pi, np.pi)
        self.speed_ref_m_s = self.vessel.cruise_speed_m_s * rnd.uniform(0.7, 1.0)
        self.origin_m = rnd.uniform(-10.0, 10.0, 2)
        t = _vec(np.cos(self.course_rad), np.sin(self.course_rad))
        n = _vec(-t[1], t[0])
        # Lane of vessel i: the line through its slot along the course, from 30 m behind the
        # start to well beyond the reach of the episode (the baseline follows it).
        self.lanes = []
        for i, (along, lateral) in enumerate(self.slots_m):
            base = self.origin_m + lateral * n
            self.lanes.append(Path.line(base - 30.0 * t, base + 250.0 * t))
            # At most 3 m off the slot per axis: slots are ≥ 11.3 m apart, so hulls never start touching.
            p0 = self.slot_position(i, 0.0) + rnd.uniform(-1.0, 1.0, 2) * min(d.initial_offset_m, 3.0)
            psi0 = self.course_rad + rnd.uniform(-d.initial_heading_error_rad, d.initial_heading_error_rad)
            physics.set_pose(i, p0[0], p0[1], psi0, surge_m_s=rnd.uniform(0.5, 1.0) * self.speed_ref_m_s)
        self._place_target(physics, self.origin_m + 250.0 * t, self.course_rad)
        self._cache = {}
        physics.after_reset()
        super().initialize_episode(physics)

    def observation_shapes(self):
        """Per vessel, prefixed ``<vessel>_``: own state, slot error, leader velocity, course error, mates."""
        n = len(self.names)
        own = OWN_STATE_OBSERVATIONS + (("slot_error", (2,)), ("leader_velocity", (2,)), ("course_error", (2,)),
                                        ("mates", (2 * (n - 1),)))
        return tuple((f"{name}_{key}", shape) for name in self.names for key, shape in own)

    def slot_position(self, i: int, time_s: float) -> np.ndarray:
        """World position of vessel i's slot at ``time_s`` [m]."""
        t = _vec(np.cos(self.course_rad), np.sin(self.course_rad))
        n = _vec(-t[1], t[0])
        along, lateral = self.slots_m[i]
        return self.origin_m + (self.speed_ref_m_s * time_s + along) * t + lateral * n

    def slot_errors(self, physics: VesselPhysics) -> np.ndarray:
        """(N, 2) slot minus vessel position, world frame [m]."""
        time_s = float(physics.data.time)
        return np.array([self.slot_position(i, time_s) - physics.position(i) for i in range(len(self.names))])

    def get_observation(self, physics: VesselPhysics) -> collections.OrderedDict:
        """Per vessel: body velocities, shaft speeds, current estimate, slot error and the
        leader's velocity in its body frame, heading error to the course, team mates' offsets."""
        d = self.difficulty
        errors = self.slot_errors(physics)
        positions = np.array([physics.position(i) for i in range(len(self.names))])
        leader_v = self.speed_ref_m_s * _vec(np.cos(self.course_rad), np.sin(self.course_rad))
        obs = collections.OrderedDict()
        for i, name in enumerate(self.names):
            prefix = name + "_"
            psi = self._noisy_heading(physics, i)
            self._own_state_observations(physics, obs, i, prefix)
            obs[prefix + "slot_error"] = world_to_body(errors[i], psi) + self._noise(d.position_noise_m, 2)
            obs[prefix + "leader_velocity"] = world_to_body(leader_v, psi) + self._noise(d.velocity_noise_m_s, 2)
            err = psi - self.course_rad
            obs[prefix + "course_error"] = _vec(np.sin(err), np.cos(err))
            mates = np.delete(positions, i, axis=0) - positions[i]
            obs[prefix + "mates"] = (world_to_body(mates, psi)
                                     + self._noise(d.position_noise_m, mates.size).reshape(mates.shape)).reshape(-1)
        return obs

    def vessel_rewards(self, physics: VesselPhysics) -> np.ndarray:
        """(N,) per-vessel rewards in [0, 1]: within 1 m of the slot (soft, 10 m margin)."""
        dist = np.linalg.norm(self.slot_errors(physics), axis=1)
        return rewards.tolerance(dist, bounds=(0.0, 1.0), margin=10.0, value_at_margin=0.1, sigmoid="gaussian")

    def get_reward(self, physics: VesselPhysics) -> float:
        """The team's mean of :meth:`vessel_rewards`."""
        return float(np.mean(self.vessel_rewards(physics)))

    def get_termination(self, physics: VesselPhysics):
        """Discount 0 on any contact between hulls."""
        if any(physics.in_contact(i) for i in range(len(self.names))):
            return 0.0
        return None


def make_environment(vessel_type: str, difficulty: Difficulty, time_limit=None, random=None,
                     environment_kwargs=None, slots_m=SLOTS_M) -> control.Environment:
    """The formation environment of a team of ``len(slots_m)`` vessels of ``vessel_type``."""
    names = vessel_names(len(slots_m), vessel_type)
    world = compose_world([(n, vessel_type) for n in names], domain_xml=XML_PATH)
    task = Formation(vessel_type, difficulty, slots_m=slots_m, random=random)
    return Environment(world.physics, task, time_limit=TIME_LIMIT_S if time_limit is None else time_limit,
                               control_timestep=CONTROL_TIMESTEP_S, **(environment_kwargs or {}))


@SUITE.add("benchmarking", "easy", "multi_agent")
def formation(time_limit=None, random=None, environment_kwargs=None):
    """Three Otters hold a V formation around a virtual leader (easy)."""
    return make_environment(VESSEL_TYPE, EASY, time_limit, random, environment_kwargs)


@SUITE.add("benchmarking", "hard", "multi_agent")
def formation_hard(time_limit=None, random=None, environment_kwargs=None):
    """Three Otters hold a V formation around a virtual leader (hard)."""
    return make_environment(VESSEL_TYPE, HARD, time_limit, random, environment_kwargs)
