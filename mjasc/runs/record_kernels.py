"""The record tick's per-vessel arithmetic (:meth:`mjasc.runs.runner.Runner._record`) as one compiled
pass over the vessels: each hull outline rotated by its heading and placed at its position, the speed
over ground and the heading in degrees (a dozen small numpy calls per tick before).

Bits: the expressions of the numpy form, in its order (``tests/test_record_kernels.py`` keeps it as
the reference): an outline point ``(b_x·c + b_y·(−s)) + p_x``, ``(b_x·s + b_y·c) + p_y`` with
(c, s) = (cos ψ, sin ψ) computed by numpy (trigonometry on arrays stays numpy); the speed
``hypot(v_x, v_y)`` (the C library's, as ``np.hypot``); degrees ``ψ·(180/π)`` (numpy's ``rad2deg``).
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.compiled import kernel

__all__ = ["record_rows"]

_RAD2DEG = 180.0 / math.pi


@kernel
def record_rows(position, velocity, heading, cos_h, sin_h, hull_body):
    """(hulls (N, k, 2) world [m], speed (N,) [m/s], heading (N,) [deg]) of N vessels at positions
    (N, 2) [m], world velocities (N, 2) [m/s] and headings (N,) [rad] with their cosines and
    sines, and hull outlines hull_body (N, k, 2) in the body frame [m]."""
    n, k = hull_body.shape[0], hull_body.shape[1]
    hulls = np.empty((n, k, 2))
    speed = np.empty(n)
    degrees = np.empty(n)
    for i in range(n):
        c, s = cos_h[i], sin_h[i]
        ns = -s
        px, py = position[i, 0], position[i, 1]
        for j in range(k):
            bx, by = hull_body[i, j, 0], hull_body[i, j, 1]
            hulls[i, j, 0] = (bx * c + by * ns) + px
            hulls[i, j, 1] = (bx * s + by * c) + py
        speed[i] = math.hypot(velocity[i, 0], velocity[i, 1])
        degrees[i] = heading[i] * _RAD2DEG
    return hulls, speed, degrees
