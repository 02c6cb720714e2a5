"""The bisections of spatial correlation compiled: where the obstruction interval and the
obstructed stretch end (:mod:`~mjasc.avoidance.prediction.spatial`). World frame ENU, metres,
absolute simulation times [s].

:func:`~mjasc.avoidance.prediction.spatial._bisect` locates a sign change of a gap function to
1e-6 by halving its bracket, evaluating the gap at up to 31 midpoints per numpy call. Each of its
decisions reads one midpoint's gap only, so the same halvings one midpoint at a time give the same
end (the midpoints are 0.5 (a + b) of the same brackets). Here each bisection is one compiled call
with the gap of one midpoint as the numpy form computes it, operation for operation:

- the **stretch's ends** (:func:`stretch_end`): the distance from the path's point at γ to the
  obstacle's swept polyline minus R_col — ``Path.point``
  (:func:`~mjasc.guidance.path_kernels.path_point`) then
  :func:`~mjasc.avoidance.prediction.sweep_kernels.polyline_distance`;
- the **interval's ends** (:func:`interval_end`): the distance from a constant-turn track's
  position at t (``TrackEstimate.predict_positions``: static or v = 0 its position; |ω| < 1e-9
  x₀ + (v τ) cos θ; else x₀ + (v/ω)(sin(θ + ω τ) − sin θ), y₀ − (v/ω)(cos(θ + ω τ) − cos θ),
  τ = t − t₀) to the path ahead (:func:`~mjasc.avoidance.prediction.path_distance.point_distance`)
  minus R_col.

``math``'s sin and cos give numpy's bits here (docs/architecture.md, compiled kernels);
``tests/test_spatial_kernels.py`` compares with ``_bisect`` of the numpy forms bit for bit.
"""

from __future__ import annotations

import math

from mjasc.avoidance.prediction.path_distance import _FEW_SEGMENTS, open_segments, point_distance
from mjasc.avoidance.prediction.sweep_kernels import polyline_distance
from mjasc.core.compiled import kernel
from mjasc.guidance.path_kernels import path_point

__all__ = ["stretch_end", "interval_end"]

_STEPS = 100  # _bisect's limit on halvings


@kernel
def stretch_end(table, cum, length, q, r_col, g_in, g_out, tol):
    """The end γ [m] of the obstructed stretch between ``g_in`` (gap ≤ 0) and ``g_out`` (gap > 0):
    ``_bisect`` to ``tol`` of the distance from the path's point at γ to the polyline through
    ``q`` (k, 2), k ≥ 2, minus ``r_col`` (module docstring)."""
    steps = 0
    while steps < _STEPS and abs(g_out - g_in) > tol:
        m = 0.5 * (g_in + g_out)
        x, y = path_point(table, cum, length, m)
        if polyline_distance(x, y, q) - r_col <= 0.0:
            g_in = m
        else:
            g_out = m
        steps += 1
    return 0.5 * (g_in + g_out)


@kernel
def _track_position(x0, y0, t0, v, th, w, static, t):
    """``TrackEstimate.predict_positions`` at one time t [s] (module docstring)."""
    tau = t - t0
    if static or v == 0.0:
        return x0, y0
    if abs(w) < 1e-9:
        return x0 + v * tau * math.cos(th), y0 + v * tau * math.sin(th)
    th_t = th + w * tau
    return x0 + v / w * (math.sin(th_t) - math.sin(th)), y0 - v / w * (math.cos(th_t) - math.cos(th))


@kernel
def interval_end(table, g_lo, length, track, r_col, t_in, t_out, tol):
    """(True, the end time [s] of the obstruction interval between ``t_in`` (gap ≤ 0) and ``t_out``
    (gap > 0)): ``_bisect`` to ``tol`` of the distance from the track's position at t to the
    stretch [g_lo, length] of the path (``table``; as ``path_distances``) minus ``r_col``; ``track`` = (x₀, y₀, t₀, v, θ, ω, static as 1.0 / 0.0).
    (False, NaN) when no segment of the stretch is open (the numpy form's error path)."""
    lo, hi, ok, n_ok, gap = open_segments(table, g_lo, length)
    if n_ok == 0:
        return False, math.nan
    x0, y0, t0, v, th, w, static = track[0], track[1], track[2], track[3], track[4], track[5], track[6] != 0.0
    steps = 0
    while steps < _STEPS and abs(t_out - t_in) > tol:
        m = 0.5 * (t_in + t_out)
        x, y = _track_position(x0, y0, t0, v, th, w, static, m)
        if point_distance(table, lo, hi, ok, n_ok, _FEW_SEGMENTS, gap, x, y) - r_col <= 0.0:
            t_in = m
        else:
            t_out = m
        steps += 1
    return True, 0.5 * (t_in + t_out)
