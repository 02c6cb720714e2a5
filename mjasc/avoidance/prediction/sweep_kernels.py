"""Compiled distance from points to an obstacle's swept trajectory, for the obstructed stretch of
spatial correlation (:func:`~mjasc.avoidance.prediction.spatial.obstructed_stretch`). World frame
ENU, metres.

The obstacle's trajectory over [t_i, t_f] is a polyline through q_0 … q_{k−1} (k ≥ 2); the path
samples p_0 … p_{m−1} are tested against it (a few hundred per conflict, and 31 per step of the
bisection that locates the stretch's ends). The numpy form built an (m, k−1, 2) array per
operation; the loop below evaluates the same expressions in the same order, so its result is
bit-identical to it (``tests/test_sweep_kernels.py`` keeps the numpy form as the reference).
Per point p and segment s (a = q_s, ab = q_{s+1} − q_s)::

    ab² = max(ab_x·ab_x + ab_y·ab_y, 1e-300)
    r   = p − a
    u   = min(max((r_x·ab_x + r_y·ab_y) / ab², 0), 1)
    e   = r − u·ab
    d(p) = sqrt(min over s of (e_x·e_x + e_y·e_y))

(numpy's sum over the last axis of length 2 is x + y in that order; ``x**2`` is x·x; a NaN
distance makes the minimum NaN, as numpy's ``min``.)
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.compiled import kernel

__all__ = ["polyline_distances"]


def polyline_distances(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Distance (m,) [m] from points p (m, 2) to the polyline through q (k, 2), k ≥ 2 (module
    docstring)."""
    p = np.ascontiguousarray(p, dtype=float)
    q = np.ascontiguousarray(q, dtype=float)
    out = np.empty(p.shape[0])
    _polyline_distances(p, q, out)
    return out


@kernel
def _polyline_distances(p, q, out):
    """:func:`polyline_distances` into ``out`` (the loop of the module docstring)."""
    for i in range(p.shape[0]):
        out[i] = polyline_distance(p[i, 0], p[i, 1], q)


@kernel
def polyline_distance(px, py, q):
    """The distance [m] from the point (px, py) to the polyline through q (k, 2), k ≥ 2 (the loop
    of the module docstring for one point; for kernels)."""
    k = q.shape[0]
    best = np.inf
    for s in range(k - 1):
        ax, ay = q[s, 0], q[s, 1]
        abx, aby = q[s + 1, 0] - ax, q[s + 1, 1] - ay
        ab2 = max(abx * abx + aby * aby, 1e-300)
        rx, ry = px - ax, py - ay
        u = min(max((rx * abx + ry * aby) / ab2, 0.0), 1.0)
        ex, ey = rx - u * abx, ry - u * aby
        d2 = ex * ex + ey * ey
        if d2 < best:
            best = d2
        elif d2 != d2:  # NaN: numpy's min propagates it
            best = d2
            break
    return math.sqrt(best)
