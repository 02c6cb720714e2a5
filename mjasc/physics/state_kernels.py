"""The true vessel states read from MjData (:meth:`mjasc.physics.simulation.Simulation.states`, once
per control tick) as one compiled pass over the vessels instead of ~20 small numpy calls.

Bits: the expressions of the numpy form, in its order (``tests/test_state_kernels.py`` keeps it as
the reference): the body velocity ``(c·ẋ + s·ẏ, (−s)·ẋ + c·ẏ, r)`` with (c, s) = (cos ψ, sin ψ) by
``math.cos`` / ``math.sin`` (numpy's ``np.cos`` / ``np.sin`` of the form call the C library's here,
the same bits: docs/architecture.md, "Compiled kernels"); the heading wrapped as
``np.mod(ψ + π, 2π) − π`` (numpy's floor modulo and Python's, which numba compiles, are the same
algorithm: C ``fmod``, then the divisor added when the signs differ, a zero remainder taking the
divisor's sign); the thrust
:meth:`mjasc.physics.thrusters.Thrusters.thrust`'s ``(k·n)·|n|`` with ``n = a·n_max`` (a ≥ 0) or
``a·n_min`` (else, NaN included).
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.compiled import kernel

__all__ = ["vessel_states"]


@kernel
def vessel_states(qpos, qvel, act, propellers, current, pairs, body, heading):
    """Write the true states of N vessels owning qpos, qvel [3i, 3i + 3) and act [2i, 2i + 2)
    (MjData's arrays) into ``pairs`` (≥ 4, N, 2) — position, velocity, shaft speeds, thrust and,
    when ``current`` is (N, 2) (a uniform steady current [m/s], world frame), a copy of it as the
    fifth (``current`` (0, 2): the fifth left as it is) —, ``body`` (N, 3) (the body velocity) and
    ``heading`` (N,) in [−π, π); from the propeller constants (N, 4) = (n_max, −n_min, k_forward,
    k_reverse) of :class:`~mjasc.physics.thrusters.Thrusters` (module docstring). (Three outputs,
    each of its quantities a C-contiguous view: what the caller allocates in three calls.)"""
    n = heading.shape[0]
    if current.shape[0] == n:
        for i in range(n):
            pairs[4, i, 0] = current[i, 0]
            pairs[4, i, 1] = current[i, 1]
    position, velocity, shaft, thrust = pairs[0], pairs[1], pairs[2], pairs[3]
    two_pi = 2 * np.pi
    for i in range(n):
        x, y, psi = qpos[3 * i], qpos[3 * i + 1], qpos[3 * i + 2]
        vx, vy, r = qvel[3 * i], qvel[3 * i + 1], qvel[3 * i + 2]
        c, s = math.cos(psi), math.sin(psi)
        position[i, 0] = x
        position[i, 1] = y
        heading[i] = (psi + np.pi) % two_pi - np.pi  # (Python's float modulo: numpy's, module docstring)
        velocity[i, 0] = vx
        velocity[i, 1] = vy
        body[i, 0] = c * vx + s * vy
        body[i, 1] = (-s) * vx + c * vy
        body[i, 2] = r
        for p in range(2):
            a_p = act[2 * i + p]
            shaft[i, p] = a_p
            if a_p >= 0:
                n_p = a_p * propellers[i, 0]
                k = propellers[i, 2]
            else:
                n_p = a_p * propellers[i, 1]
                k = propellers[i, 3]
            thrust[i, p] = k * n_p * abs(n_p)
