"""The suite's ``environment_kwargs``, checked before they reach ``dm_control.rl.control.Environment``.

dm_control checks little: ``n_sub_steps=0`` divided by zero, ``n_sub_steps=-1`` ran episodes whose
time never advanced, a string was a TypeError deep inside it, ``control_timestep=None`` silently
meant one physics step (0.02 s) instead of the suite's 0.1 s, and its own errors name no key.
Here every accepted key is checked, ``None`` means "not given" (the suite's default), and a bad
value is a one-line ValueError ``environment_kwargs: KEY must be ..., got VALUE``.
"""

from __future__ import annotations

import inspect
import math
import numbers

import numpy as np
from dm_control.rl import control

__all__ = ["check_environment_kwargs"]

_BOOLEANS = ("flat_observation", "legacy_step")


def _is_bool(value) -> bool:
    return isinstance(value, (bool, np.bool_))


def check_environment_kwargs(environment_kwargs, physics_timestep_s: float, default_control_timestep_s: float) -> dict:
    """The keyword arguments for ``control.Environment`` (without physics, task, time_limit):
    ``environment_kwargs`` checked, its ``None`` values dropped, and ``control_timestep`` set to
    the default when neither it nor ``n_sub_steps`` is given."""
    kwargs = {k: v for k, v in dict(environment_kwargs or {}).items() if v is not None}
    if "time_limit" in kwargs:
        raise ValueError("environment_kwargs: time_limit is a task argument: pass it in task_kwargs")
    accepted = [p for p in inspect.signature(control.Environment.__init__).parameters
                if p not in ("self", "physics", "task", "time_limit")]
    unknown = sorted(set(kwargs) - set(accepted))
    if unknown:
        raise ValueError(f"environment_kwargs: unknown {', '.join(map(repr, unknown))}; "
                         f"accepted: {', '.join(accepted)}")
    if "control_timestep" in kwargs and "n_sub_steps" in kwargs:
        raise ValueError(f"environment_kwargs: give control_timestep or n_sub_steps, not both, got "
                         f"{kwargs['control_timestep']!r} and {kwargs['n_sub_steps']!r}")
    n_sub_steps = kwargs.get("n_sub_steps")
    if n_sub_steps is not None and (_is_bool(n_sub_steps) or not isinstance(n_sub_steps, numbers.Integral)
                                    or n_sub_steps < 1):
        raise ValueError(f"environment_kwargs: n_sub_steps must be an integer >= 1, got {n_sub_steps!r}")
    dt = kwargs.get("control_timestep")
    if dt is not None:
        ratio = dt / physics_timestep_s if isinstance(dt, numbers.Real) and not _is_bool(dt) else math.nan
        if not (math.isfinite(ratio) and round(ratio) >= 1 and abs(ratio - round(ratio)) <= 1e-6):
            raise ValueError(f"environment_kwargs: control_timestep must be a multiple of the physics step "
                             f"({physics_timestep_s:g} s) in seconds, got {dt!r}")
    for key in _BOOLEANS:
        if key in kwargs and not _is_bool(kwargs[key]):
            raise ValueError(f"environment_kwargs: {key} must be True or False, got {kwargs[key]!r}")
    if "n_sub_steps" not in kwargs:
        kwargs.setdefault("control_timestep", default_control_timestep_s)
    return kwargs
