"""The broadcast plan's points in two compiled passes: the fast form of
:meth:`CollisionAvoidance.planned_trajectory <mjasc.avoidance.system.CollisionAvoidance.planned_trajectory>`.

A vessel with the thesis avoidance broadcasts, every comms slot, where it intends to be: the
times t + (0, step, …, horizon) [s], γ(t) along its current path (the mission speed, or the
velocity correction's virtual target until its goal time), the path's points there and the
vessel's offset from the path fading out over 10 s. As numpy that is ~25 calls on arrays of ~61
numbers per message; here it is one kernel for the times, γ, the segment of each point, the arc
angle θ = θ₀ + κ s with its sine and cosine by ``math`` (numpy's bits on this machine class,
docs/architecture.md "Rates and numerics": the test asserts it), the points and the fade. Each
operation is the numpy form's, in its order (``tests/test_intent_plan.py`` compares bit for bit
on the demo's paths).

Only for a :class:`~mjasc.guidance.paths.Path` with more than ``_SCALAR_SEGMENTS`` samples (fewer
go through the path's plain-float branch; the caller keeps the numpy form for those).
"""

from __future__ import annotations

import numpy as np

from mjasc.core.compiled import clip as _clip
from mjasc.core.compiled import kernel, maximum
from mjasc.guidance.path_kernels import path_point
from mjasc.guidance.paths import _SCALAR_SEGMENTS, Path

__all__ = ["plan_offsets", "planned_points"]

_OFFSETS: dict = {}


def plan_offsets(horizon_s: float, step_s: float) -> np.ndarray:
    """``np.arange(0, horizon + step/2, step)`` [s] (read-only; one array per (horizon, step))."""
    key = (horizon_s, step_s)
    base = _OFFSETS.get(key)
    if base is None:
        base = np.arange(0.0, horizon_s + 0.5 * step_s, step_s)
        base.flags.writeable = False
        _OFFSETS[key] = base
    return base


@kernel
def _plan_into(t, base, g0, mode, a, b, c, d, length, cum, table, px, py, times, out):
    """Per sample i: t_i = t + base_i; γ_i = g0 + a (t_i − t) (``mode`` 0: constant speed a) or
    g0 + a·clip(t_i − t, 0, b) + c·max(t_i − d, 0) (``mode`` 1: the correction's profile), clipped to
    [0, length] (twice, as the caller and the path do); the path's point there
    (:func:`mjasc.guidance.path_kernels.path_point`); then
    each point plus clip(1 − (t_i − t)/10, 0, 1) × (the vessel's position − the first point)."""
    n = base.size
    for i in range(n):
        ti = t + base[i]
        times[i] = ti
        if mode == 0:
            g = g0 + a * (ti - t)
        else:
            g = g0 + a * _clip(ti - t, 0.0, b) + c * maximum(ti - d, 0.0)
        out[i, 0], out[i, 1] = path_point(table, cum, length, _clip(g, 0.0, length))
    ox = px - out[0, 0]
    oy = py - out[0, 1]
    for i in range(n):
        w = _clip(1.0 - (times[i] - t) / 10.0, 0.0, 1.0)
        out[i, 0] = out[i, 0] + w * ox
        out[i, 1] = out[i, 1] + w * oy


def planned_points(path, t: float, g0: float, profile: tuple, base: np.ndarray, position_m):
    """(times (k,) [s], points (k, 2) [m]) of the plan (module docstring), or None where the numpy
    form must answer (not a :class:`Path`, too few samples, a speed it would reject). ``profile``:
    ``(0, v)`` a constant speed [m/s], or ``(1, v_d, span, v_m, t_start)`` the correction's γ(t) =
    g0 + v_d·clip(t − t_now, 0, span) + v_m·max(t − t_start, 0)."""
    if type(path) is not Path or base.size <= _SCALAR_SEGMENTS:
        return None
    if profile[0] == 0:
        v = profile[1]
        if not (v >= 0.0 and v < np.inf):
            return None
        mode, a, b, c, d = 0, v, 0.0, 0.0, 0.0
    else:
        mode, a, b, c, d = 1, *profile[1:]
    n = base.size
    times, out = np.empty(n), np.empty((n, 2))
    _plan_into(t, base, g0, mode, a, b, c, d, path._length, path._cum, path._table, float(position_m[0]),
               float(position_m[1]), times, out)
    return times, out
