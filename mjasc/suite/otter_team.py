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
  with another hull (``task_kwargs={"vessel": ...}``, :mod:`mjasc.suite.vessel_choice`) the
  vessels and prefixes are ``<hull name><i>`` (``otter_payload0_body_velocity``), the shapes the same;
* reward: the team's mean of the per-vessel rewards (:meth:`Formation.vessel_rewards` gives each).

:func:`joint_policy` turns one policy per vessel (each ``observation dict → (2,) action``) into a
policy of the flat environment. World ENU, body FLU, SI units.
"""

from __future__ import annotations

import collections
import dataclasses

import numpy as np
from dm_control.rl import control
from dm_control.utils import containers, rewards

from mjasc.guidance.paths import ArcSegment, LineSegment, Path
from mjasc.suite.common import VesselPhysics, compose_world, make_control_environment, world_to_body
from mjasc.suite.otter import XML_PATH
from mjasc.suite.pixel_scene import draw_reference, draw_slots, path_polyline
from mjasc.suite.vessel_choice import hull_name, suite_vessel_type
from mjasc.suite.vessel_task import EASY, HARD, OWN_STATE_OBSERVATIONS, Difficulty, VesselTask, random_current, vec

__all__ = ["SUITE", "Formation", "SLOTS_M", "agent_observation", "joint_policy", "make_environment"]

VESSEL_TYPE = "otter"
TIME_LIMIT_S = 60.0
LEAD_IN_M = 30.0  # the leader's path starts this far behind its position at t = 0 [m]
LEADER_TURN_RADIUS_M = 20.0  # > every slot's lateral offset: the inner lane keeps a 12 m radius
#: Slots (along, lateral) [m] in the leader's frame (x along the course, y to port), one per vessel.
SLOTS_M = np.array([[0.0, 0.0], [-8.0, 8.0], [-8.0, -8.0]])

SUITE = containers.TaggedTasks()
#: A vessel's observations after its own state, in the order of the spec (and of agent_observation).
TEAM_OBSERVATIONS = ("slot_error", "leader_velocity", "course_error", "mates")


def vessel_names(n: int, vessel_type: str = VESSEL_TYPE) -> list[str]:
    """Model names of the team's vessels (also their observation prefixes): the hull's name (a
    built-in name, or a vessel folder's name for its path) and the index."""
    return [f"{hull_name(vessel_type)}{i}" for i in range(n)]


def _prefixes(observation) -> list[str]:
    """The vessels' key prefixes of a team observation, in vessel order (each vessel's first key
    is its ``body_velocity``: OWN_STATE_OBSERVATIONS)."""
    first = "_" + OWN_STATE_OBSERVATIONS[0][0]
    return [k[: -len(first) + 1] for k in observation if k.endswith(first)]


def agent_observation(observation, vessel: int, n_vessels: int = len(SLOTS_M),
                      vessel_type: str | None = None) -> collections.OrderedDict:
    """Vessel ``vessel``'s part of a team observation, keys without the prefix, in the spec's order
    (also from gymnasium's alphabetically sorted dict). The prefixes are read from the observation's
    keys (any hull), or made from ``vessel_type`` when it is given."""
    if vessel_type is None:
        prefixes = _prefixes(observation)
        if not 0 <= vessel < len(prefixes):
            raise ValueError(f"vessel: no vessel {vessel} in a team observation of {len(prefixes)}")
        prefix = prefixes[vessel]
    else:
        prefix = vessel_names(n_vessels, vessel_type)[vessel] + "_"
    own = {k[len(prefix):]: v for k, v in observation.items() if k.startswith(prefix)}
    order = [name for name, _ in OWN_STATE_OBSERVATIONS] + list(TEAM_OBSERVATIONS)  # (gymnasium sorts its keys)
    return collections.OrderedDict(sorted(own.items(), key=lambda kv: order.index(kv[0]) if kv[0] in order
                                          else len(order)))


def joint_policy(policies, n_vessels: int = len(SLOTS_M), vessel_type: str | None = None):
    """A flat-environment policy (a dm_env time step, or its observation dict as gymnasium gives
    it → (2N,) action) from one policy per vessel, each called as ``policy(agent_observation)``
    and returning that vessel's (2,) commands (the prefixes read from the observation, or made
    from ``vessel_type``)."""
    if len(policies) != n_vessels:
        raise ValueError(f"policies: need one per vessel ({n_vessels}), got {len(policies)}")

    def policy(time_step):
        observation = getattr(time_step, "observation", time_step)
        return np.concatenate([np.asarray(p(agent_observation(observation, i, n_vessels, vessel_type)),
                                          dtype=float).reshape(2) for i, p in enumerate(policies)])
    return policy


class Formation(VesselTask):
    """Hold a V formation around a virtual leader on a straight line, one policy per vessel."""

    def __init__(self, vessel_type: str, difficulty: Difficulty, slots_m=SLOTS_M, random=None,
                 time_limit_s: float | None = None):
        self.slots_m = np.asarray(slots_m, dtype=float)
        self.names = vessel_names(len(self.slots_m), vessel_type)  # (<hull name><i>)
        super().__init__(vessel_type, difficulty, random=random, time_limit_s=time_limit_s)

    def initialize_episode(self, physics: VesselPhysics) -> None:
        d, rnd = self.difficulty, self.random
        physics.configure_episode(random_current(rnd, d))
        self.course_rad = rnd.uniform(-np.pi, np.pi)
        self.speed_ref_m_s = self.vessel.cruise_speed_m_s * rnd.uniform(0.7, 1.0)
        self.origin_m = rnd.uniform(-10.0, 10.0, 2)
        self.leader_path = self._leader_path(rnd, d)
        # Lane of vessel i: the leader's path offset by the slot's lateral offset (the baseline
        # follows it); the slot moves along it with the leader.
        self.lanes = [offset_path(self.leader_path, lateral) for _, lateral in self.slots_m]
        course0 = self.course_rad
        for i in range(len(self.slots_m)):
            # At most 3 m off the slot per axis: slots are ≥ 11.3 m apart, so hulls never start touching.
            p0 = self.slot_position(i, 0.0) + rnd.uniform(-1.0, 1.0, 2) * min(d.initial_offset_m, 3.0)
            psi0 = course0 + rnd.uniform(-d.initial_heading_error_rad, d.initial_heading_error_rad)
            physics.set_pose(i, p0[0], p0[1], psi0, surge_m_s=rnd.uniform(0.5, 1.0) * self.speed_ref_m_s)
        end = self.leader_path.end_point
        self._place_target(physics, end, float(self.leader_path.tangent_angle(self.leader_path.length)))
        draw_reference(physics, [path_polyline(lane) for lane in self.lanes])
        draw_slots(physics, [self.slot_position(i, 0.0) for i in range(len(self.slots_m))])
        self._cache = {}
        physics.after_reset()
        super().initialize_episode(physics)

    def _leader_path(self, rnd, d: Difficulty) -> Path:
        """The virtual leader's path: from LEAD_IN_M behind the origin along the initial course,
        straight (``d.leader_turns`` = 0) or with that many course changes of 35–100 % of
        ``d.path_turn_rad`` (random side) rounded with LEADER_TURN_RADIUS_M, 5–15 m of straight line
        between the turns (and from the origin to the first). Long enough that the leader does not reach its end
        within the time limit (without one: after the last turn's 250 m)."""
        t0 = vec(np.cos(self.course_rad), np.sin(self.course_rad))
        points = [self.origin_m - LEAD_IN_M * t0]
        course = self.course_rad
        if d.leader_turns > 0:
            turns = [rnd.choice([-1.0, 1.0]) * rnd.uniform(0.35, 1.0) * d.path_turn_rad for _ in range(d.leader_turns)]
            cuts = [LEADER_TURN_RADIUS_M * np.tan(abs(turn) / 2) for turn in turns] + [0.0]
            points.append(self.origin_m + (cuts[0] + rnd.uniform(5.0, 15.0)) * t0)
            for k, turn in enumerate(turns):
                course += turn
                leg = cuts[k] + cuts[k + 1] + rnd.uniform(5.0, 15.0)
                points.append(points[-1] + leg * vec(np.cos(course), np.sin(course)))
        # The last leg: 250 m, or longer for a long time limit (the leader, and every slot, must
        # not stop at the path's end within the episode).
        last = max(250.0, self._travel_m(self.speed_ref_m_s) + 50.0)
        points.append(points[-1] + last * vec(np.cos(course), np.sin(course)))
        return Path.from_waypoints(np.array(points), turn_radius_m=LEADER_TURN_RADIUS_M)

    def after_step(self, physics: VesselPhysics) -> None:
        """The slots' discs in the scene to the slots at the new time (what a pixel observation shows)."""
        time_s = float(physics.data.time)
        draw_slots(physics, [self.slot_position(i, time_s) for i in range(len(self.slots_m))])
        super().after_step(physics)  # (dm_control's reward colours)

    def leader_gamma(self, time_s: float) -> float:
        """Arc length of the virtual leader on its path at ``time_s`` [m] (at the origin at t = 0)."""
        return LEAD_IN_M + self.speed_ref_m_s * float(time_s)

    def observation_shapes(self):
        """Per vessel, prefixed ``<vessel>_``: own state, slot error, leader velocity, course error, mates."""
        n = len(self.names)
        shapes = {"slot_error": (2,), "leader_velocity": (2,), "course_error": (2,), "mates": (2 * (n - 1),)}
        own = OWN_STATE_OBSERVATIONS + tuple((key, shapes[key]) for key in TEAM_OBSERVATIONS)
        return tuple((f"{name}_{key}", shape) for name in self.names for key, shape in own)

    def slot_position(self, i: int, time_s: float) -> np.ndarray:
        """World position of vessel i's slot at ``time_s`` [m]: ``along`` behind/ahead of the leader
        on its path, ``lateral`` to its port side there (the point at the same γ on lane i)."""
        along, lateral = self.slots_m[i]
        gamma = self.leader_gamma(time_s) + along
        chi = float(self.leader_path.tangent_angle(gamma))
        return self.leader_path.point(gamma) + lateral * vec(-np.sin(chi), np.cos(chi))

    def slot_speed(self, i: int, time_s: float) -> float:
        """Speed of vessel i's slot along its lane [m/s]: V·(1 − κ·lateral) (faster outside a turn)."""
        along, lateral = self.slots_m[i]
        kappa = float(self.leader_path.curvature(self.leader_gamma(time_s) + along))
        return self.speed_ref_m_s * (1.0 - kappa * lateral)

    def leader_velocity(self, time_s: float) -> np.ndarray:
        """The virtual leader's velocity over ground (2,) [m/s], world frame."""
        chi = float(self.leader_path.tangent_angle(self.leader_gamma(time_s)))
        return self.speed_ref_m_s * vec(np.cos(chi), np.sin(chi))

    def slot_course(self, i: int, time_s: float) -> float:
        """Course of vessel i's lane at its slot [rad] (the leader path's course at the slot's γ)."""
        return float(self.leader_path.tangent_angle(self.leader_gamma(time_s) + self.slots_m[i, 0]))

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
        time_s = float(physics.data.time)
        leader_v = self.leader_velocity(time_s)
        obs = collections.OrderedDict()
        for i, name in enumerate(self.names):
            prefix = name + "_"
            psi = self._noisy_heading(physics, i)
            self._own_state_observations(physics, obs, i, prefix)
            obs[prefix + "slot_error"] = world_to_body(errors[i], psi) + self._noise(d.position_noise_m, 2)
            obs[prefix + "leader_velocity"] = world_to_body(leader_v, psi) + self._noise(d.velocity_noise_m_s, 2)
            err = psi - self.slot_course(i, time_s)
            obs[prefix + "course_error"] = vec(np.sin(err), np.cos(err))
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


def offset_path(path: Path, lateral_m: float) -> Path:
    """The parallel curve of a path of lines and arcs, ``lateral_m`` to its left (port) side [m]:
    lines shifted along their normal, arcs about the same centre with radius R − sign(sweep)·lateral."""
    segments = []
    for seg in path.segments:
        if isinstance(seg, ArcSegment):
            radius = seg.radius - np.sign(seg.sweep) * lateral_m
            if radius <= 0:
                raise ValueError(f"lateral_m: {lateral_m} m is beyond the centre of a {seg.radius} m turn")
            segments.append(ArcSegment(seg.centre, radius, seg.start_angle, seg.sweep))
        else:
            t = (seg.end - seg.start) / seg.length
            n = lateral_m * vec(-t[1], t[0])
            segments.append(LineSegment(seg.start + n, seg.end + n))
    return Path.from_segments(segments)


def make_environment(vessel_type: str, difficulty: Difficulty, time_limit=None, random=None,
                     environment_kwargs=None, slots_m=SLOTS_M) -> control.Environment:
    """The formation environment of a team of ``len(slots_m)`` vessels of ``vessel_type`` (a built-in
    name or a resolved vessel folder's absolute path: :mod:`mjasc.suite.vessel_choice`)."""
    names = vessel_names(len(slots_m), vessel_type)
    world = compose_world([(n, vessel_type) for n in names], domain_xml=XML_PATH, reference_lines=len(names),
                          reference_slots=len(names))
    time_limit = TIME_LIMIT_S if time_limit is None else time_limit
    task = Formation(vessel_type, difficulty, slots_m=slots_m, random=random, time_limit_s=time_limit)
    return make_control_environment(world.physics, task, time_limit, environment_kwargs)


@SUITE.add("benchmarking", "easy", "multi_agent")
def formation(time_limit=None, random=None, vessel=None, environment_kwargs=None):
    """Three Otters (or three of ``vessel``) hold a V formation around a virtual leader (easy)."""
    return make_environment(suite_vessel_type(vessel, VESSEL_TYPE), EASY, time_limit, random, environment_kwargs)


#: formation_hard: the hard noise and initial errors, a stronger current (0.5–0.8 m/s, fluctuating)
#: and three turns of up to 90° on the leader's path.
FORMATION_HARD = dataclasses.replace(HARD, name="formation_hard", current_speed_m_s=(0.5, 0.8), leader_turns=3)


@SUITE.add("benchmarking", "hard", "multi_agent")
def formation_hard(time_limit=None, random=None, vessel=None, environment_kwargs=None):
    """Three Otters (or three of ``vessel``) hold a V formation around a virtual leader turning three
    times, in a strong current (hard)."""
    return make_environment(suite_vessel_type(vessel, VESSEL_TYPE), FORMATION_HARD, time_limit, random,
                            environment_kwargs)
