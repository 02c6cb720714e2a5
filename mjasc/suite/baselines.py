"""Reference policies for every suite task: uniform random, and mjasc's classical controllers.

A policy here is a callable ``time_step → action`` for one environment. The classical baselines
(:func:`baseline_policy`) are *privileged*: they read the true vessel state from ``env.physics``
and the task's path / station / goal / slots from ``env.task``, not the noisy observations an
agent gets; they show what a well-tuned conventional autopilot achieves, not an upper bound.

* path_following: :class:`mjasc.path_following.PathFollower` (integral LOS + heading and speed
  loops) on the task's path at the task's speed.
* station_keeping: the same follower on a line through the station pointing into the current,
  with the speed reference proportional to the distance still to go plus the cross-track
  error (negative past the station: it backs down, bow into the current).
* collision_avoidance: the follower on the straight line start → goal, slowing down at the goal.
  **It does not avoid anything** (mjasc's collision avoidance is not yet usable as a policy):
  it is the "ignore the traffic" reference.
* formation: one follower per vessel on its lane (the line through its slot), the speed
  reference corrected by the along-track slot error (a simple virtual-target speed law).

``python -m mjasc.suite.baselines`` prints the table of mean episode returns in docs/suite.md.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from ..path_following import PathFollower
from ..paths import Path
from . import ALL_TASKS, BENCHMARKING, load
from .otter import CollisionAvoidance, PathFollowing, StationKeeping
from .otter_team import Formation

__all__ = ["random_policy", "baseline_policy", "make_policy", "episode_return", "evaluate"]


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
            physics = env.physics
            t = np.array([np.cos(task.course_rad), np.sin(task.course_rad)])
            out = []
            for i in range(len(task.names)):
                along = float(np.dot(task.slot_errors(physics)[i], t))
                speed = np.clip(task.speed_ref_m_s + 0.3 * along, 0.3 * task.speed_ref_m_s, 2.0 * task.speed_ref_m_s)
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
        def policy(time_step):
            if time_step.first() or not f.followers:
                route = task.goal_m - task.start_m
                f.build([Path.line(task.start_m, task.goal_m + 20.0 * route / np.linalg.norm(route))])
            to_go = float(np.linalg.norm(task.goal_m - task.start_m)) - f.followers[0].gamma_m
            return f.command(0, float(np.clip(0.3 * to_go, 0.0, task.vessel.cruise_speed_m_s)))
        return policy
    raise ValueError(f"env: no baseline for task {type(task).__name__}")


def make_policy(env, policy="random", seed: int = 0):
    """``"random"``, ``"baseline"`` or a callable ``time_step → action`` (returned as is)."""
    if callable(policy):
        return policy
    if policy == "random":
        return random_policy(env, seed)
    if policy == "baseline":
        return baseline_policy(env)
    raise ValueError(f"policy: must be 'random', 'baseline' or a callable, got {policy!r}")


def episode_return(env, policy) -> tuple[float, int]:
    """(sum of rewards, number of steps) of one episode from ``env.reset()``."""
    time_step = env.reset()
    total, steps = 0.0, 0
    while not time_step.last():
        time_step = env.step(policy(time_step))
        total += time_step.reward
        steps += 1
    return total, steps


def evaluate(domain: str, task: str, policy: str, seeds) -> np.ndarray:
    """Episode returns (len(seeds),) of ``policy`` on a task, one fresh seeded episode per seed."""
    returns = []
    for seed in seeds:
        env = load(domain, task, task_kwargs={"random": int(seed)})
        returns.append(episode_return(env, make_policy(env, policy, seed=int(seed)))[0])
        env.close()
    return np.array(returns)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description="Mean episode returns of the random and baseline policies.")
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--all", action="store_true", help="include the extra (delfim) tasks")
    args = parser.parse_args(argv)
    tasks = ALL_TASKS if args.all else BENCHMARKING
    seeds = range(args.seeds)
    print(f"Mean episode return ± standard deviation over {args.seeds} seeds (seeds 0…{args.seeds - 1}); "
          "the maximum is the number of steps.\n")
    print("| domain | task | steps | random | baseline |")
    print("|---|---|---:|---:|---:|")
    for domain, task in tasks:
        t0 = time.perf_counter()
        env = load(domain, task)
        steps = int(round(env._step_limit))
        env.close()
        cells = []
        for policy in ("random", "baseline"):
            r = evaluate(domain, task, policy, seeds)
            cells.append(f"{r.mean():.1f} ± {r.std():.1f}")
        print(f"| {domain} | {task} | {steps} | {cells[0]} | {cells[1]} |", flush=True)
        print(f"  ({time.perf_counter() - t0:.0f} s)", file=sys.stderr)


if __name__ == "__main__":
    main()
