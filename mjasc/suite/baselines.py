"""Reference policies for every suite task: uniform random, and mjasc's classical controllers.

A policy here is a callable ``time_step → action`` for one environment. The classical baselines
(:func:`baseline_policy`) read the true own state from ``env.physics`` and the task's path /
station / goal / slots from ``env.task``, not the noisy observations an agent gets; they show what
a well-tuned conventional system achieves, not an upper bound. The collision-avoidance baseline
(:class:`CASPolicy`) reads nothing about other bodies but its own sensor's scans.

* path_following: :class:`mjasc.guidance.path_following.PathFollower` (integral LOS + heading and speed
  loops) on the task's path at the task's speed.
* station_keeping: the same follower on a line through the station pointing into the current,
  with the speed reference proportional to the distance still to go plus the cross-track
  error (negative past the station: it backs down, bow into the current).
* collision_avoidance: :class:`CASPolicy`, the vessel's own pipeline (perception → collision
  avoidance → path following toward the goal). :func:`goal_line_policy` (the follower on the line
  start → goal, blind to the traffic) is the "no avoidance" reference.
* formation: one follower per vessel on its lane (the leader's path offset to its slot), the
  speed reference the slot's speed along the lane corrected by the along-lane slot error (a
  simple virtual-target speed law).

``python -m mjasc.suite.baselines`` prints the table of mean episode returns in docs/suite.md.
"""

from __future__ import annotations

import argparse
import re
import sys
import time

import numpy as np

from mjasc.avoidance.config import AvoidanceConfig
from mjasc.plugins.registry import MethodChoice, method_class
from mjasc.avoidance.prediction import CollisionPredictionConfig
from mjasc.core.config_tables import number
from mjasc.core.navigation import OwnNavigation
from mjasc.guidance.path_following import PathFollower
from mjasc.guidance.paths import Path
from mjasc.perception.tracking import TrackingConfig
from mjasc.runs.agent import VesselAgent
from mjasc.runs.agent_build import build_agent
from mjasc.runs.scenario import VesselConfig
from mjasc.runs.schedule import Schedule
from mjasc.runs.tick import run_onboard_slot
from mjasc.suite import ALL_TASKS, BENCHMARKING, load
from mjasc.suite.otter import CollisionAvoidance, PathFollowing, StationKeeping
from mjasc.suite.otter_team import Formation
from mjasc.suite.vessel_choice import suite_vessel_type

__all__ = ["random_policy", "baseline_policy", "goal_line_policy", "CASPolicy", "make_policy", "episode_return",
           "evaluate", "CAS_AVOIDANCE", "CAS_TRACKING"]

#: The CAS baseline's prediction period [s] (the runner's default is 5 s; the task's boats are
#: timed to meet the vessel, and predicting every 2 s lifted the mean return by a third).
PREDICTION_PERIOD_S = 2.0
SENSING_PERIOD_S = 0.1  # the CAS's scans and tracker updates [s]: the default control step's 10 Hz
#: The CAS baseline's avoidance settings: mjasc.avoidance.system defaults, except a 2 m safety distance
#: (default 1 m) and a 4 m margin of the virtual target's goal (default 2 m): with the defaults a
#: yielding vessel reached the crossing just as the boat left it, and touched it on a late turn.
CAS_AVOIDANCE = AvoidanceConfig(prediction=CollisionPredictionConfig(safety_distance_m=2.0), correction_margin_m=4.0)
#: The CAS baseline's tracking settings: defaults, except that a map cell needs returns in 15 scans
#: (3 s; default 3), a margin kept from before perception learnt to keep moving tracks' returns out
#: of the map and to clear cells that later rays see through (the 20-seed table used it).
CAS_TRACKING = TrackingConfig(map_min_hits=15)


def random_policy(env, seed: int = 0):
    """Uniform random actions in the action spec's bounds (seeded)."""
    spec = env.action_spec()
    rng = np.random.RandomState(seed)
    return lambda time_step: rng.uniform(spec.minimum, spec.maximum)


class _Followers:
    """PathFollowers for the vessels of an environment, rebuilt at every episode start."""

    def __init__(self, env):
        self.env = env
        self.followers: list[PathFollower] = []

    def build(self, paths) -> None:
        physics = self.env.physics
        world = physics.world
        hydro = physics.simulation.hydro
        self.followers = [PathFollower(p, world.vessel_types[i], hydro.total_mass[i], world.propeller_lateral_m[i, 0])
                          for i, p in enumerate(paths)]

    def command(self, i: int, speed_ref_m_s: float) -> np.ndarray:
        physics = self.env.physics
        cmd, _ = self.followers[i].command(physics.position(i), physics.heading(i), physics.world_velocity(i),
                                           physics.body_velocity(i), speed_ref_m_s, self.env.control_timestep())
        return np.clip(cmd, -1.0, 1.0)


def baseline_policy(env):
    """The classical controller of the environment's task (see the module docstring)."""
    task = env.task
    f = _Followers(env)
    if isinstance(task, Formation):
        def policy(time_step):
            if time_step.first() or not f.followers:
                f.build(task.lanes)
                for i, follower in enumerate(f.followers):
                    follower.gamma_m = follower.path.project(env.physics.position(i))
            time_s = float(env.physics.data.time)
            out = []
            for i in range(len(task.names)):
                lane, follower = task.lanes[i], f.followers[i]
                slot_gamma = lane.project(task.slot_position(i, time_s), gamma_hint=follower.gamma_m,
                                          search_window_m=60.0)
                slot_speed = task.slot_speed(i, time_s)
                speed = np.clip(slot_speed + 0.3 * (slot_gamma - follower.gamma_m), 0.3 * slot_speed, 2.0 * slot_speed)
                out.append(f.command(i, speed))
            return np.concatenate(out)
        return policy
    if isinstance(task, PathFollowing):
        def policy(time_step):
            if time_step.first() or not f.followers:
                f.build([task.path])
            return f.command(0, task.speed_ref_m_s)
        return policy
    if isinstance(task, StationKeeping):
        def policy(time_step):
            if time_step.first() or not f.followers:
                up = np.array([np.cos(task.station_heading_rad), np.sin(task.station_heading_rad)])
                f.build([Path.line(task.station_m - 40.0 * up, task.station_m + 40.0 * up)])
            # Station at γ = 40 m; past it: back down, bow upstream. Keep way on while off the line
            # (at low speed the line-of-sight steering closes a cross-track error only slowly).
            follower = f.followers[0]
            to_go = 40.0 - follower.gamma_m
            off = abs(follower.path.cross_track_error(env.physics.position(0), follower.gamma_m))
            return f.command(0, float(np.clip(0.3 * to_go + 0.15 * off, -0.5, task.vessel.cruise_speed_m_s)))
        return policy
    if isinstance(task, CollisionAvoidance):
        return CASPolicy(env)
    raise ValueError(f"env: no baseline for task {type(task).__name__}")


def _task_name(task) -> str:
    """The suite's name of ``task``'s kind (``Formation`` → ``formation``, ``PathFollowing`` →
    ``path_following``), for messages: a user knows the tasks by those names, not the classes."""
    return re.sub(r"(?<!^)(?=[A-Z])", "_", type(task).__name__).lower()


def goal_line_policy(env):
    """collision_avoidance without avoidance: the path follower on the straight line start → goal,
    slowing down at the goal, blind to the traffic (the "no avoidance" reference)."""
    task = env.task
    if not isinstance(task, CollisionAvoidance):
        raise ValueError(f"env: the goal-line policy is for the collision_avoidance tasks, not {_task_name(task)}")
    f = _Followers(env)

    def policy(time_step):
        if time_step.first() or not f.followers:
            f.build([Path.line(task.start_m, task.goal_m)])
        to_go = float(np.linalg.norm(task.goal_m - env.physics.position(0)))
        return f.command(0, goal_speed(to_go, task.vessel.cruise_speed_m_s))
    return policy


def goal_speed(distance_to_goal_m: float, cruise_speed_m_s: float) -> float:
    """Mission speed toward a goal [m/s]: cruise, slowing linearly (0.3 /s) over the last metres."""
    return float(np.clip(0.3 * distance_to_goal_m, 0.0, cruise_speed_m_s))


class CASPolicy:
    """mjasc's collision avoidance system as a policy of a ``collision_avoidance`` task.

    Per episode it builds the vessel's own pipeline on the environment's physics with the runner's
    own :func:`mjasc.runs.agent_build.build_agent`: a :class:`mjasc.runs.agent.VesselAgent` whose mission
    is the straight line start → goal, with :class:`mjasc.perception.pipeline.Perception` (the
    vessel's range sensor at its ``sensor_mount`` → detections → static map and IMM tracks) and
    :class:`mjasc.avoidance.system.CollisionAvoidance` (conflict prediction on the tracks, velocity
    correction or potential-field re-planning). Each call is one control tick, run slot by slot
    with the runner's own :func:`mjasc.runs.tick.run_onboard_slot` on a
    :class:`mjasc.runs.schedule.Schedule` of control ticks: sensing and tracking every tick (the
    sensor keeps its own rate), prediction every ``prediction_period_s`` (and at once on a new
    track), then control (path following at the mission speed — cruise, slowing down near the
    goal — or the avoidance's override / detour).

    What it reads: the vessel's own navigation state (position, heading, velocities) and its own
    sensor's scans (ray casts on the physics); the mission (start, goal). Never another body's
    state. Its sensor is ``sensor_config`` (default: the project's 720-beam scanner,
    :class:`mjasc.perception.range_sensor.SensorConfig`), not the 32 normalized ranges of the observation.
    ``seed`` seeds the sensor's noise (the policy is otherwise deterministic).

    ``method``: any registered collision-avoidance method (:func:`mjasc.plugins.available`
    ``("avoidance")``; default the thesis's), with ``avoidance_config`` its options (an instance of
    the method's ``Options``; default :data:`CAS_AVOIDANCE` for the thesis method, the method's
    defaults for any other).
    """

    def __init__(self, env, sensor_config=None, tracking_config=None, avoidance_config=None,
                 prediction_period_s: float = PREDICTION_PERIOD_S, seed: int = 0, method: str = "thesis"):
        if not isinstance(env.task, CollisionAvoidance):
            raise ValueError(f"env: the CAS policy is for the collision_avoidance tasks, not {_task_name(env.task)}")
        prediction_period_s = number(prediction_period_s, "prediction_period_s", positive=True)
        self.env = env
        self.sensor_config = sensor_config
        self.tracking_config = CAS_TRACKING if tracking_config is None else tracking_config
        cls = method_class("avoidance", method, "method")
        if avoidance_config is None:
            avoidance_config = CAS_AVOIDANCE if method == "thesis" else (cls.Options() if cls.Options else None)
        self.avoidance = MethodChoice("avoidance", method, avoidance_config)
        self.prediction_period_s = prediction_period_s
        self.seed = int(seed)
        self.agent: VesselAgent | None = None
        self.episodes = 0
        dt = env.control_timestep()  # perception keeps its 10 Hz with any control step (at 25 Hz the map and
        sense = max(dt, SENSING_PERIOD_S)  # tracks, tuned in scans, filled up and the vessel stopped short)
        self.schedule = Schedule.from_periods(dt, {"sensing": sense, "tracking": sense,
                                                   "prediction": prediction_period_s, "control": dt})

    def _build(self) -> None:
        env, task = self.env, self.env.task
        physics = env.physics
        world = physics.world
        name = world.vessel_names[0]
        vessel = world.vessel_types[0]
        config = VesselConfig(name=name, type=vessel.name, position_m=physics.position(0),
                              heading_rad=physics.heading(0), speed_m_s=0.0, controller="path_following",
                              path=Path.line(task.start_m, task.goal_m), cruise_speed_m_s=vessel.cruise_speed_m_s,
                              options={"sensor": self.sensor_config, "tracking": self.tracking_config,
                                       "avoidance": self.avoidance})
        self.agent = build_agent(config, 0, world, physics.simulation.hydro.total_mass[0], [name], None,
                                 [self.seed, self.episodes, 0])
        self.goal_m = np.asarray(task.goal_m, dtype=float)
        self._step = 0
        self.episodes += 1

    def navigation(self) -> OwnNavigation:
        """The vessel's own navigation state now (what its pipeline may read of the physics)."""
        p = self.env.physics
        return OwnNavigation(float(p.data.time), p.position(0), p.heading(0), p.world_velocity(0), p.body_velocity(0))

    def __call__(self, time_step) -> np.ndarray:
        if time_step.first() or self.agent is None:
            self._build()
        agent, nav = self.agent, self.navigation()
        out = None
        for slot in self.schedule.due(self._step):
            if slot == "control":  # the mission: cruise toward the goal, slowing down at it
                to_go = float(np.linalg.norm(self.goal_m - nav.position_m))
                agent.mission_speed_m_s = goal_speed(to_go, agent.vessel.cruise_speed_m_s)
            outputs = run_onboard_slot(slot, [agent], [nav], self.env.control_timestep())
            if outputs is not None:
                out = outputs[0]
        self._step += 1
        return np.clip(out.commands, -1.0, 1.0)


def make_policy(env, policy="random", seed: int = 0):
    """``"random"``, ``"baseline"``, ``"goal_line"``, ``"cas"`` (the thesis CAS), ``"cas:METHOD"`` (the
    vessel's pipeline with any registered avoidance method, e.g. ``"cas:velocity_obstacle"``) or a
    callable ``time_step → action`` (returned as is)."""
    if callable(policy):
        return policy
    if policy == "random":
        return random_policy(env, seed)
    if policy == "baseline":
        return baseline_policy(env)
    if policy == "goal_line":
        return goal_line_policy(env)
    if policy == "cas":
        return CASPolicy(env, seed=seed)
    if isinstance(policy, str) and policy.startswith("cas:"):
        return CASPolicy(env, seed=seed, method=policy.removeprefix("cas:"))
    raise ValueError(f"policy: must be 'random', 'baseline', 'goal_line', 'cas', 'cas:METHOD' or a callable, "
                     f"got {policy!r}")


def episode_return(env, policy) -> tuple[float, int]:
    """(sum of rewards, number of steps) of one episode from ``env.reset()``."""
    time_step = env.reset()
    total, steps = 0.0, 0
    while not time_step.last():
        time_step = env.step(policy(time_step))
        total += time_step.reward
        steps += 1
    return total, steps


def evaluate(domain: str, task: str, policy: str, seeds, vessel=None) -> np.ndarray:
    """Episode returns (len(seeds),) of ``policy`` on a task, one fresh seeded episode per seed
    (``vessel``: another hull, as ``task_kwargs``' :mod:`mjasc.suite.vessel_choice`)."""
    returns = []
    hull = {} if vessel is None else {"vessel": vessel}
    for seed in seeds:
        env = load(domain, task, task_kwargs={"random": int(seed), **hull})
        returns.append(episode_return(env, make_policy(env, policy, seed=int(seed)))[0])
        env.close()
    return np.array(returns)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description="Mean episode returns of the random and baseline policies.")
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--all", action="store_true", help="include the extra (delfim) tasks")
    parser.add_argument("--tasks", nargs="*", default=None, help="only these task names (default: all)")
    parser.add_argument("--vessel", default=None, help="sail this hull in every task: a built-in vessel type or "
                                                       "a vessel folder's path, relative to the current folder")
    parser.add_argument("--no-header", action="store_true")
    args = parser.parse_args(argv)
    if args.seeds < 1:  # (a table of NaNs over no episode would look like a result)
        parser.error(f"--seeds: must be ≥ 1, got {args.seeds}")
    if args.vessel is not None:
        try:  # (checked once, before the table starts)
            args.vessel = suite_vessel_type(args.vessel, None)
        except ValueError as exc:
            parser.error(f"--vessel: {str(exc).removeprefix('task_kwargs.vessel: ')}")
    tasks = ALL_TASKS if args.all else BENCHMARKING
    if args.tasks:
        unknown = sorted(set(args.tasks) - {t for _, t in tasks})
        if unknown:  # an empty table would look like a finished run
            parser.error(f"--tasks: unknown {', '.join(unknown)}; one of {', '.join(sorted({t for _, t in tasks}))}"
                         + ("" if args.all else " (--all adds the extra domains' tasks)"))
        tasks = [(d, t) for d, t in tasks if t in args.tasks]
    seeds = range(args.seeds)
    if not args.no_header:
        print(f"Mean episode return ± standard deviation over {args.seeds} seeds (seeds 0…{args.seeds - 1}); "
              "the maximum is the number of steps" + ("" if args.vessel is None else f"; vessel {args.vessel}")
              + ".\n")
        print("| domain | task | steps | random | goal line (no avoidance) | baseline |")
        print("|---|---|---:|---:|---:|---:|")
    for domain, task in tasks:
        t0 = time.perf_counter()
        env = load(domain, task, task_kwargs=None if args.vessel is None else {"vessel": args.vessel})
        steps = int(round(env.step_limit))
        avoidance = isinstance(env.task, CollisionAvoidance)
        env.close()
        cells = []
        for policy in ("random", "goal_line", "baseline"):
            if policy == "goal_line" and not avoidance:
                cells.append("—")
                continue
            r = evaluate(domain, task, policy, seeds, vessel=args.vessel)
            cells.append(f"{r.mean():.1f} ± {r.std():.1f}")
        name = f"{task} (CAS)" if avoidance else task
        print(f"| {domain} | {name} | {steps} | {cells[0]} | {cells[1]} | {cells[2]} |", flush=True)
        print(f"  ({time.perf_counter() - t0:.0f} s)", file=sys.stderr)


if __name__ == "__main__":
    main()
