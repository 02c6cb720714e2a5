"""The moving obstacles' true states at a run's record times, in one compiled pass after the run.

The traffic is a function of time alone (:class:`~mjasc.physics.obstacles.MovingObstacleSet`:
closed-form constant turns, paths at constant speed), so a run's evaluation keeps only the record
times and evaluates the traffic at all of them at the end (:func:`traffic_at`) instead of reading
it at every record tick. The numbers are :meth:`~mjasc.physics.obstacles.MovingObstacleSet.rows`'
(and ``Simulation.traffic_state``'s) bit for bit: each pose is
:func:`~mjasc.physics.step_kernels.obstacle_pose`, the expressions of ``rows``, and the velocity
``speed·(cos h, sin h)`` as there (tests/test_step_kernels.py, tests/test_run_evaluation_batch.py).

World frame ENU, SI units.
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.compiled import kernel
from mjasc.physics.step_kernels import obstacle_pose, traffic_table

__all__ = ["traffic_at"]


@kernel
def traffic_rows_at(times, table, samples, out):
    """Write (x, y [m], heading [rad], vx, vy [m/s]) of every moving obstacle of
    :func:`~mjasc.physics.step_kernels.traffic_table`'s arrays at every time ``times`` (k,) [s]
    into ``out`` (k, M, 5)."""
    for k in range(times.shape[0]):
        t = times[k]
        for o in range(table.shape[0]):
            x, y, h, speed = obstacle_pose(table[o], samples, t)
            out[k, o, 0] = x
            out[k, o, 1] = y
            out[k, o, 2] = h
            out[k, o, 3] = speed * math.cos(h)
            out[k, o, 4] = speed * math.sin(h)


def traffic_at(traffic, times_s) -> np.ndarray:
    """(k, M, 5): per time of ``times_s`` (k,) [s] and moving obstacle of ``traffic`` (a
    :class:`~mjasc.physics.obstacles.MovingObstacleSet`), its (x, y, heading, vx, vy) — the rows of
    ``traffic.rows(t)`` (module docstring)."""
    times = np.asarray(times_s, dtype=float).reshape(-1)
    m = len(traffic)
    out = np.empty((times.size, m, 5))
    if m and times.size:
        table, samples = traffic_table(traffic.constants(), [0] * m, type(traffic).PATH_SAMPLE_M)
        traffic_rows_at(times, table, samples, out)
    return out
