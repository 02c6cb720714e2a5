"""The record tick's per-vessel arithmetic (:meth:`mjasc.runs.runner.Runner._record`) as one compiled
pass over the vessels: each hull outline rotated by its heading and placed at its position, and the
plot series' rows (speed over ground, speed reference, thrust per side, heading in degrees, cross-track
error) in one table (a dozen small numpy calls per tick before).

Bits: the expressions of the numpy form, in its order (``tests/test_record_kernels.py`` keeps it as
the reference): an outline point ``(b_x·c + b_y·(−s)) + p_x``, ``(b_x·s + b_y·c) + p_y`` with
(c, s) = (cos ψ, sin ψ) from the C library (``math.cos``/``math.sin``: numpy's float64 ``cos``/``sin``
give the same bits on this machine class, docs/architecture.md "Compiled kernels"; the test asserts
it on its inputs); the speed ``hypot(v_x, v_y)`` (the C library's, as ``np.hypot``); degrees
``ψ·(180/π)`` (numpy's ``rad2deg``). The kernel writes one row (a record tick) of the truth's
preallocated columns (:class:`~mjasc.runs.fleet_columns.FleetColumns`): one call a tick.
"""

from __future__ import annotations

import math


from mjasc.core.compiled import kernel

__all__ = ["record_rows"]

_RAD2DEG = 180.0 / math.pi


@kernel
def record_rows(position, velocity, heading, hull_body, speed_ref, thrust, cross_track, row, hulls, positions, table):
    """Write the record tick's rows of N vessels at index ``row`` of the columns: hulls[row]
    (N, k, 2) world [m], each outline hull_body (N, k, 2) (body frame [m]) rotated by its heading
    and placed at its position; positions[row] (N, 2) [m], the positions; and the plot table[row]
    (6, N): speed over ground [m/s], speed_ref (N,) [m/s], port and starboard thrust from thrust
    (N, 2) [N], heading [deg], cross_track (N,) [m] (NaN: no path). From positions (N, 2) [m],
    world velocities (N, 2) [m/s] and headings (N,) [rad]."""
    n, k = hull_body.shape[0], hull_body.shape[1]
    for i in range(n):
        h = heading[i]
        c, s = math.cos(h), math.sin(h)
        ns = -s
        px, py = position[i, 0], position[i, 1]
        for j in range(k):
            bx, by = hull_body[i, j, 0], hull_body[i, j, 1]
            hulls[row, i, j, 0] = (bx * c + by * ns) + px
            hulls[row, i, j, 1] = (bx * s + by * c) + py
        positions[row, i, 0] = px
        positions[row, i, 1] = py
        table[row, 0, i] = math.hypot(velocity[i, 0], velocity[i, 1])
        table[row, 1, i] = speed_ref[i]
        table[row, 2, i] = thrust[i, 0]
        table[row, 3, i] = thrust[i, 1]
        table[row, 4, i] = h * _RAD2DEG
        table[row, 5, i] = cross_track[i]
