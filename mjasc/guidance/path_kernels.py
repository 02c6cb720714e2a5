"""A path's points at many γ in one compiled pass (:meth:`mjasc.guidance.paths.Path.point` on
arrays). World frame ENU, metres.

``Path.point`` of an array clipped γ to [0, L], took each one's segment as the last segment start
≤ γ (``searchsorted(…, 'right') − 1``, clipped to the segments; a NaN γ sorts last: the last
segment), s = γ − C_j, and evaluated the segment formula on arrays
(:func:`~mjasc.guidance.segment_geometry.eval_points`: a line p₀ + s (cos θ₀, sin θ₀), an arc
p₀ + (sin θ − sin θ₀, cos θ₀ − cos θ) / κ with θ = θ₀ + κ s) — about ten numpy calls. The loop
below evaluates the same expressions in the same order per γ (``math``'s sin and cos give numpy's
bits here, docs/architecture.md), so the points are the numpy form's bit for bit
(``tests/test_path_kernels.py`` keeps that form as the reference).
"""

from __future__ import annotations

import math

from mjasc.core.compiled import clip, kernel, search_right
from mjasc.guidance.segment_geometry import COS0, K, SIN0, TH0, X0, Y0

__all__ = ["path_point", "points_into"]


@kernel
def path_point(table, cum, length, g):
    """(x, y) [m] of the path at one γ [m]: ``table`` its segment table (fields, n), ``cum`` (n + 1,)
    its segment starts and end, ``length`` L (module docstring; for kernels)."""
    n_seg = cum.size - 1
    g = clip(g, 0.0, length)
    if g != g:  # searchsorted sorts NaN last
        j = n_seg - 1
    else:
        j = min(max(search_right(cum, g, 0, cum.size) - 1, 0), n_seg - 1)
    s = g - cum[j]
    k = table[K, j]
    if k == 0.0:
        return table[X0, j] + s * table[COS0, j], table[Y0, j] + s * table[SIN0, j]
    th = table[TH0, j] + k * s
    return table[X0, j] + (math.sin(th) - table[SIN0, j]) / k, table[Y0, j] + (table[COS0, j] - math.cos(th)) / k


@kernel
def points_into(table, cum, length, gammas, out):
    """:func:`path_point` of each of ``gammas`` (n,) [m] into ``out`` (n, 2)."""
    for i in range(gammas.size):
        out[i, 0], out[i, 1] = path_point(table, cum, length, gammas[i])
