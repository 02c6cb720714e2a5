"""The run metrics' per-record-tick update (:meth:`mjasc.runs.metrics.RunMetrics.update`) as one
compiled pass over the vessels (the numpy form cost ~50 µs a tick in ~40 small numpy calls), and
the same for a batch of record ticks (:func:`update_metrics_ticks`: a run without recording folds
its ticks in chunks, :meth:`~mjasc.runs.metrics.RunMetrics.defer`).

Per vessel i, at each record tick, in this order:

* distance travelled ``+= hypot(Δx, Δy)`` (from the previous tick's position; none at the first);
* |cross-track error| (NaN = no path: 0 added, not counted): sum, count, running maximum;
* the running minimum of the clearance to every object, column by column: each static obstacle
  (polygon: ± the distance to its boundary, negative inside, by the even-odd rule; circle: the
  centre distance minus its radius) minus the vessel's radius; each moving obstacle and each other
  vessel: the centre distance ``√(dx² + dy²)`` minus both radii (to oneself: +inf).

Bits: every value is the expression of the numpy form (``tests/test_run_metrics.py`` keeps it as
the reference): ``hypot`` is the C library's in both, ``√`` is IEEE's, the polygon distance and
inclusion are :mod:`mjasc.core.polygon_kernels`' own loops, and ``np.minimum``'s NaN rule is kept
(:func:`mjasc.core.compiled.minimum`).
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.compiled import kernel, maximum, minimum
from mjasc.core.polygon_kernels import boundary_distance, inside_even_odd

__all__ = ["update_metrics", "update_metrics_ticks"]


@kernel
def update_metrics(pos, last_pos, has_last, xte, distance, xte_sum, xte_count, xte_max,
                   vertices, offsets, circles, radii, traffic_pos, traffic_radii, min_clear):
    """Fold one record tick into the running metrics, in place (module docstring).

    pos (N, 2) [m] the vessels' true positions now; last_pos (N, 2) the previous tick's (read only
    when has_last; then overwritten with pos); xte (N,) [m] cross-track errors (NaN: none);
    distance, xte_sum, xte_max (N,) floats and xte_count (N,) ints: the running sums. Static
    obstacle j: a polygon ``vertices[offsets[j]:offsets[j + 1]]`` (k, 2) or, when that is empty,
    a circle ``circles[j]`` = (centre x, centre y, radius); radii (N,) the vessels' radii [m];
    traffic_pos (M, 2), traffic_radii (M,) the moving obstacles; min_clear (N, S + M + N) the
    running minima, columns static, moving, vessels."""
    n = pos.shape[0]
    n_static = offsets.shape[0] - 1
    n_traffic = traffic_pos.shape[0]
    if has_last:
        for i in range(n):
            distance[i] += math.hypot(pos[i, 0] - last_pos[i, 0], pos[i, 1] - last_pos[i, 1])
    for i in range(n):
        last_pos[i, 0] = pos[i, 0]
        last_pos[i, 1] = pos[i, 1]
        e = xte[i]
        ok = math.isfinite(e)
        a = abs(e) if ok else 0.0
        xte_sum[i] += a
        if ok:
            xte_count[i] += 1
        xte_max[i] = maximum(xte_max[i], a)
    for j in range(n_static):
        lo, hi = offsets[j], offsets[j + 1]
        if hi > lo:
            poly = vertices[lo:hi]
            d = boundary_distance(pos, poly)
            inside = inside_even_odd(pos, poly)
            for i in range(n):
                dj = -d[i] if inside[i] else d[i]
                min_clear[i, j] = minimum(min_clear[i, j], dj - radii[i])
        else:
            cx, cy, r = circles[j, 0], circles[j, 1], circles[j, 2]
            for i in range(n):
                dj = math.hypot(pos[i, 0] - cx, pos[i, 1] - cy) - r
                min_clear[i, j] = minimum(min_clear[i, j], dj - radii[i])
    for i in range(n):
        px, py = pos[i, 0], pos[i, 1]
        for k in range(n_traffic):
            dx, dy = px - traffic_pos[k, 0], py - traffic_pos[k, 1]
            c = math.sqrt(dx * dx + dy * dy) - radii[i] - traffic_radii[k]
            min_clear[i, n_static + k] = minimum(min_clear[i, n_static + k], c)
        base = n_static + n_traffic
        for m in range(n):
            if m == i:
                c = np.inf
            else:
                dx, dy = px - pos[m, 0], py - pos[m, 1]
                c = math.sqrt(dx * dx + dy * dy) - radii[i] - radii[m]
            min_clear[i, base + m] = minimum(min_clear[i, base + m], c)


@kernel
def update_metrics_ticks(pos, last_pos, has_last, xte, distance, xte_sum, xte_count, xte_max,
                         vertices, offsets, circles, radii, traffic_pos, traffic_radii, min_clear):
    """:func:`update_metrics` of k record ticks in order, in one call: pos (k, N, 2), xte (k, N),
    traffic_pos (k, M, 2) the ticks' arguments (the other arguments as there; has_last is the
    first tick's). The same numbers as k calls (the same body, tick after tick)."""
    for k in range(pos.shape[0]):
        update_metrics(pos[k], last_pos, has_last or k > 0, xte[k], distance, xte_sum, xte_count, xte_max,
                       vertices, offsets, circles, radii, traffic_pos[k], traffic_radii, min_clear)
