"""Gymnasium route: mjasc suite tasks as ``gymnasium.Env`` through shimmy's dm_control wrapper.

Needs the optional dependency group ``gym`` (``pip install mjasc[gym]``: gymnasium[mujoco],
shimmy[dm-control])::

    import mjasc
    from mjasc.suite.gym_compat import make_gym_env
    env = make_gym_env("otter", "path_following", render_mode="rgb_array")
    obs, info = env.reset(seed=0)        # seeds the task's RandomState: same seed, same episode

or, after :func:`register_gym_envs`, ``gymnasium.make("mjasc/otter-path_following-v0")``.
Observations are a ``Dict`` space of float64 boxes (wrap in ``gymnasium.wrappers.FlattenObservation``
for a flat vector); actions a ``Box(-1, 1)``; ``terminated`` is True when the task ends the episode
(discount 0: a collision), ``truncated`` at the time limit.
"""

from __future__ import annotations

from mjasc.suite import ALL_TASKS, load

__all__ = ["make_gym_env", "register_gym_envs", "gym_id"]


def _shimmy():
    try:
        from shimmy import DmControlCompatibilityV0
    except ImportError as e:  # pragma: no cover - exercised only without the extra
        raise ImportError("the gymnasium route needs the optional dependencies: pip install 'mjasc[gym]' "
                          "(gymnasium[mujoco], shimmy[dm-control])") from e
    return DmControlCompatibilityV0


def make_gym_env(domain_name: str, task_name: str, task_kwargs=None, environment_kwargs=None,
                 render_mode: str | None = None, render_kwargs=None):
    """A gymnasium Env of one suite task (shimmy's ``DmControlCompatibilityV0``).

    ``render_kwargs``: dm_control ``physics.render`` arguments, e.g. ``{"camera_id": "otter/chase",
    "height": 240, "width": 320}``. ``env.close()`` frees the physics (and its GL context).
    """
    wrapper = _shimmy()
    return wrapper(load(domain_name, task_name, task_kwargs, environment_kwargs),
                   render_mode=render_mode, render_kwargs=render_kwargs)


def gym_id(domain_name: str, task_name: str) -> str:
    """Gymnasium id of a suite task: ``mjasc/<domain>-<task>-v0``."""
    return f"mjasc/{domain_name}-{task_name}-v0"


def register_gym_envs() -> list[str]:
    """Register every suite task with gymnasium (idempotent); returns the ids."""
    import gymnasium

    ids = []
    for domain_name, task_name in ALL_TASKS:
        env_id = gym_id(domain_name, task_name)
        if env_id not in gymnasium.registry:
            gymnasium.register(env_id, entry_point=make_gym_env,
                               kwargs={"domain_name": domain_name, "task_name": task_name})
        ids.append(env_id)
    return ids
