"""The record tick's per-vessel arithmetic (:meth:`mjasc.runs.runner.Runner._record`) as one compiled
pass over the vessels: each hull outline rotated by its heading and placed at its position, and the
plot series' rows (speed over ground, speed reference, thrust per side, heading in degrees, cross-track
error) in one table (a dozen small numpy calls per tick before).

Bits: the expressions of the numpy form, in its order (``tests/test_record_kernels.py`` keeps it as
the reference): an outline point ``(b_x·c + b_y·(−s)) + p_x``, ``(b_x·s + b_y·c) + p_y`` with
(c, s) = (cos ψ, sin ψ) computed by numpy (trigonometry on arrays stays numpy); the speed
``hypot(v_x, v_y)`` (the C library's, as ``np.hypot``); degrees ``ψ·(180/π)`` (numpy's ``rad2deg``).
"""

from __future__ import annotations

import math


from mjasc.core.compiled import kernel

__all__ = ["record_rows"]

_RAD2DEG = 180.0 / math.pi


@kernel
def record_rows(position, velocity, heading, cos_h, sin_h, hull_body, speed_ref, thrust, cross_track, hulls, table):
    """Write the record tick's rows of N vessels: hulls (N, k, 2) world [m], each outline
    hull_body (N, k, 2) (body frame [m]) rotated by its heading and placed at its position; and the
    plot table (6, N): speed over ground [m/s], speed_ref (N,) [m/s], port and starboard thrust from
    thrust (N, 2) [N], heading [deg], cross_track (N,) [m] (NaN: no path). From positions (N, 2) [m],
    world velocities (N, 2) [m/s], headings (N,) [rad] with their cosines and sines."""
    n, k = hull_body.shape[0], hull_body.shape[1]
    for i in range(n):
        c, s = cos_h[i], sin_h[i]
        ns = -s
        px, py = position[i, 0], position[i, 1]
        for j in range(k):
            bx, by = hull_body[i, j, 0], hull_body[i, j, 1]
            hulls[i, j, 0] = (bx * c + by * ns) + px
            hulls[i, j, 1] = (bx * s + by * c) + py
        table[0, i] = math.hypot(velocity[i, 0], velocity[i, 1])
        table[1, i] = speed_ref[i]
        table[2, i] = thrust[i, 0]
        table[3, i] = thrust[i, 1]
        table[4, i] = heading[i] * _RAD2DEG
        table[5, i] = cross_track[i]
