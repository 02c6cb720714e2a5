"""mjasc as a dm_control task suite: marine control and collision avoidance on mjasc's physics.

Mirrors ``dm_control.suite``'s API (which only knows its own domains)::

    import mjasc                      # first: chooses the offscreen GL backend (MUJOCO_GL)
    from mjasc import suite
    env = suite.load("otter", "path_following", task_kwargs={"random": 0})
    time_step = env.reset()

    env = suite.load("otter", "path_following",           # your own hull (assets/README.md)
                     task_kwargs={"random": 0, "vessel": "examples/my_hull/hulls/otter_payload"})

Domains: ``otter`` (path_following, station_keeping, collision_avoidance, each ``…_hard`` too),
``otter_team`` (formation, formation_hard: three vessels, flat per-vessel layout, see
:mod:`mjasc.suite.otter_team`) and ``delfim`` (the otter tasks on the thesis's catamaran; extras,
not benchmarking). docs/suite.md describes every task, observation and reward, the gymnasium
route (shimmy) and the baseline returns.
"""

import collections
import inspect
import numbers

import numpy as np

from mjasc.suite import delfim, otter, otter_team

__all__ = ["load", "build_environment", "ALL_TASKS", "BENCHMARKING", "EASY", "HARD", "EXTRA", "MULTI_AGENT",
           "TASKS_BY_DOMAIN", "NO_REWARD_VIZ", "REWARD_VIZ"]

# Every imported module with a SUITE is a domain.
_DOMAINS = {name: module for name, module in locals().items() if inspect.ismodule(module) and hasattr(module, "SUITE")}


def _get_tasks(tag):
    """(domain name, task name) pairs with ``tag`` (all pairs for None), domains sorted."""
    result = []
    for domain_name in sorted(_DOMAINS):
        tasks = _DOMAINS[domain_name].SUITE if tag is None else _DOMAINS[domain_name].SUITE.tagged(tag)
        result.extend((domain_name, task_name) for task_name in tasks)
    return tuple(result)


def _get_tasks_by_domain(tasks):
    """Domain name → tuple of its task names."""
    result = collections.defaultdict(list)
    for domain_name, task_name in tasks:
        result[domain_name].append(task_name)
    return {k: tuple(v) for k, v in result.items()}


#: All (domain, task) pairs.
ALL_TASKS = _get_tasks(tag=None)
#: Subsets of ALL_TASKS by tag.
BENCHMARKING = _get_tasks("benchmarking")
EASY = _get_tasks("easy")
HARD = _get_tasks("hard")
MULTI_AGENT = _get_tasks("multi_agent")
EXTRA = tuple(sorted(set(ALL_TASKS) - set(BENCHMARKING)))
NO_REWARD_VIZ = _get_tasks("no_reward_visualization")
REWARD_VIZ = tuple(sorted(set(ALL_TASKS) - set(NO_REWARD_VIZ)))
#: Domain name → its task names.
TASKS_BY_DOMAIN = _get_tasks_by_domain(ALL_TASKS)


def _check_task_kwargs(task_kwargs) -> None:
    """Clear errors for the values dm_control would reject obscurely or not at all."""
    time_limit = task_kwargs.get("time_limit")
    if time_limit is not None:
        if isinstance(time_limit, bool) or not isinstance(time_limit, numbers.Real) or not time_limit > 0:
            raise ValueError(f"task_kwargs: time_limit must be a number of seconds > 0 (inf: no limit), "
                             f"got {time_limit!r}")
    random = task_kwargs.get("random")
    if random is not None and not isinstance(random, (numbers.Integral, np.random.RandomState)):
        raise ValueError(f"task_kwargs: random must be an integer seed or a numpy.random.RandomState "
                         f"(dm_control's Task), got {type(random).__name__}")
    if isinstance(random, numbers.Integral) and not 0 <= random < 2 ** 32:
        raise ValueError(f"task_kwargs: random must be an integer seed in [0, 2**32 - 1], got {random}")


def load(domain_name, task_name, task_kwargs=None, environment_kwargs=None, visualize_reward=False):
    """An environment from a domain name, task name and optional settings.

    ``task_kwargs``: ``random`` (seed or RandomState), ``time_limit`` [s], ``vessel`` (the hull
    sailed instead of the domain's own: a built-in type's name or a vessel folder's path, relative
    to the current folder; :mod:`mjasc.suite.vessel_choice`); ``environment_kwargs``:
    passed to ``dm_control.rl.control.Environment`` (e.g. ``flat_observation=True``; its
    ``control_timestep`` or ``n_sub_steps`` replace the default 0.1 s control step);
    ``visualize_reward``: colour the reward lights (and target) by the reward in rendered frames.
    """
    return build_environment(domain_name, task_name, task_kwargs, environment_kwargs, visualize_reward)


def build_environment(domain_name, task_name, task_kwargs=None, environment_kwargs=None, visualize_reward=False):
    """As :func:`load`; raises ValueError naming an unknown domain, task or keyword argument."""
    if domain_name not in _DOMAINS:
        raise ValueError(f"domain_name: {domain_name!r} does not exist; one of {sorted(_DOMAINS)}")
    domain = _DOMAINS[domain_name]
    if task_name not in domain.SUITE:
        raise ValueError(f"task_name: {task_name!r} does not exist in domain {domain_name!r}; "
                         f"one of {sorted(domain.SUITE)}")
    factory = domain.SUITE[task_name]
    task_kwargs = dict(task_kwargs or {})
    accepted = [p for p in inspect.signature(factory).parameters if not p.startswith("_") and p != "environment_kwargs"]
    unknown = sorted(set(task_kwargs) - set(accepted))
    if unknown:
        raise ValueError(f"task_kwargs: unknown {', '.join(map(repr, unknown))} for {domain_name}/{task_name}; "
                         f"accepted: {', '.join(accepted)}")
    _check_task_kwargs(task_kwargs)
    if environment_kwargs is not None:
        task_kwargs["environment_kwargs"] = environment_kwargs
    env = factory(**task_kwargs)
    env.task.visualize_reward = visualize_reward
    return env
