"""Closed-form geometry of constant-curvature path segments, over arrays and for one point.

A path is a chain of lines and circular arcs (:mod:`mjasc.guidance.paths`). Each segment is one
column of a *segment table* (rows = the fields below), so that one vectorized pass serves every
segment of a path, or every vessel's window of segments in a fleet
(:mod:`mjasc.guidance.stacked_paths`). World frame ENU [m]; angles CCW from east [rad]; local arc
length s ∈ [0, LEN] from the segment's start; the path parameter there is γ = C + s.

    p(s) = p₀ + s (cos θ₀, sin θ₀)                                   κ = 0 (line)
    p(s) = p₀ + (sin(θ₀ + κs) − sin θ₀, cos θ₀ − cos(θ₀ + κs)) / κ    κ ≠ 0 (arc)
    θ(s) = θ₀ + κ s                     an arc's centre: c = p₀ + (−sin θ₀, cos θ₀) / κ

Closest point of a query q on a segment, restricted to local arc lengths [lo, hi] (a window):
a line has one candidate, the clamped foot of the perpendicular s* = clamp((q − p₀)·t₀, lo, hi);
an arc has three, the clamped polar angle s* = clamp(mod(sgn κ (φ − a₀), 2π)/|κ|, lo, hi)
(φ = atan2(q − c), a₀ the polar angle of p₀) and both clamped ends (the polar angle wraps, and an
end is the answer whenever the foot lies outside). Over all candidates the answer is the
smallest γ among those within (1 + 1e-12)·d²_min + 1e-18 of the smallest squared distance (ties
go to the smallest γ).

The ``*_scalar`` functions are the same formulas in plain float math for one query and one
segment (no numpy call per operation); they give the same bits as the array versions (``math``'s
sin, cos and atan2 equal numpy's on x86-64 without AVX-512; ``tests/test_paths.py`` checks it).
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.compiled import clip_float

__all__ = ["FIELDS", "segment_table", "eval_points", "closest_candidates", "pick_closest", "wrap_scalar",
           "clip_scalar", "point_scalar", "closest_scalar"]

#: Rows of a segment table: γ at the segment's start, its length, start point, start course θ₀,
#: curvature κ, cos θ₀, sin θ₀, and for arcs the centre and the polar angle a₀ of the start
#: point about it (0 for lines).
FIELDS = ("C", "LEN", "X0", "Y0", "TH0", "K", "COS0", "SIN0", "CX", "CY", "A0")
C, LEN, X0, Y0, TH0, K, COS0, SIN0, CX, CY, A0 = range(len(FIELDS))

_TWO_PI = 2.0 * np.pi
_TIE_REL, _TIE_ABS = 1e-12, 1e-18


def segment_table(starts_m, lengths_m, start_points_m, start_courses_rad, curvatures_1_m) -> np.ndarray:
    """The (len(FIELDS), m) table of m segments from their start γ, lengths, start points (m, 2),
    start courses and signed curvatures (CCW > 0)."""
    c = np.asarray(starts_m, dtype=float)
    p0 = np.asarray(start_points_m, dtype=float).reshape(-1, 2)
    th0 = np.asarray(start_courses_rad, dtype=float)
    k = np.asarray(curvatures_1_m, dtype=float)
    t = np.zeros((len(FIELDS), c.size))
    t[C], t[LEN], t[X0], t[Y0], t[TH0], t[K] = c, lengths_m, p0[:, 0], p0[:, 1], th0, k
    t[COS0], t[SIN0] = np.cos(th0), np.sin(th0)
    arc = k != 0.0
    if arc.any():
        ka = k[arc]
        cx = p0[arc, 0] + -t[SIN0, arc] / ka
        cy = p0[arc, 1] + t[COS0, arc] / ka
        t[CX, arc], t[CY, arc] = cx, cy
        t[A0, arc] = np.arctan2(p0[arc, 1] - cy, p0[arc, 0] - cx)
    return t


def eval_points(seg: np.ndarray, s):
    """(x, y) at local arc lengths ``s`` on the segments ``seg`` (fields first; trailing shapes
    broadcast with ``s``)."""
    k = seg[K]
    straight = k == 0.0
    if straight.all():  # lines only (the common case): no trigonometry, the same bits
        return seg[X0] + s * seg[COS0], seg[Y0] + s * seg[SIN0]
    k_safe = np.where(straight, 1.0, k)
    th = seg[TH0] + k * s
    dx = np.where(straight, s * seg[COS0], (np.sin(th) - seg[SIN0]) / k_safe)
    dy = np.where(straight, s * seg[SIN0], (seg[COS0] - np.cos(th)) / k_safe)
    return seg[X0] + dx, seg[Y0] + dy


def closest_candidates(qx, qy, seg: np.ndarray, lo, hi):
    """Candidates for the closest point of queries (qx, qy) on segments ``seg`` (fields first)
    within local arc lengths [lo, hi]; q, the segments' trailing shape, lo and hi broadcast to a
    common shape S. Returns (d² (S + (c,)), γ (S + (c,))): c = 1 for lines only, 3 for arcs only,
    4 for a mix (a line's unused candidates and an arc's unused one are +inf)."""
    k = seg[K]
    arc = k != 0.0
    n_arc = int(arc.sum())
    d2s, gams = [], []
    if n_arc < arc.size:  # lines: the clamped foot of the perpendicular
        dx, dy = qx - seg[X0], qy - seg[Y0]
        c0, s0 = seg[COS0], seg[SIN0]
        s = np.minimum(np.maximum(dx * c0 + dy * s0, lo), hi)
        d2 = (dx - s * c0) ** 2 + (dy - s * s0) ** 2
        g = seg[C] + s
        if n_arc:
            d2 = np.where(arc, np.inf, d2)
        d2s.append(d2[..., None])
        gams.append(g[..., None])
    if n_arc:  # arcs: the clamped polar angle and both clamped ends
        k_safe = np.where(arc, k, 1.0)
        phi = np.arctan2(qy - seg[CY], qx - seg[CX])
        s_star = np.minimum(np.maximum(np.mod(np.sign(k_safe) * (phi - seg[A0]), _TWO_PI) / np.abs(k_safe), lo), hi)
        shape = np.shape(s_star)
        s = np.stack([s_star, np.broadcast_to(lo, shape), np.broadcast_to(hi, shape)], axis=-1)
        sub = seg[..., None]
        th = sub[TH0] + k_safe[..., None] * s
        x = sub[X0] + (np.sin(th) - sub[SIN0]) / k_safe[..., None]
        y = sub[Y0] + (sub[COS0] - np.cos(th)) / k_safe[..., None]
        qxa, qya = np.asarray(qx)[..., None], np.asarray(qy)[..., None]
        d2 = (x - qxa) ** 2 + (y - qya) ** 2
        if n_arc < arc.size:
            d2 = np.where(arc[..., None], d2, np.inf)
        d2s.append(d2)
        gams.append(sub[C] + s)
    if len(d2s) == 1:
        return d2s[0], gams[0]
    shape = np.broadcast_shapes(d2s[0].shape[:-1], d2s[1].shape[:-1])
    return (np.concatenate([np.broadcast_to(a, shape + a.shape[-1:]) for a in d2s], axis=-1),
            np.concatenate([np.broadcast_to(a, shape + a.shape[-1:]) for a in gams], axis=-1))


def pick_closest(d2: np.ndarray, gam: np.ndarray, length_m):
    """Per row of (n, c) candidates: (γ of the closest, clamped to [0, length_m], distance) with
    the tie rule of the module docstring."""
    dmin = d2.min(axis=1, keepdims=True)
    g = np.where(d2 <= dmin * (1.0 + _TIE_REL) + _TIE_ABS, gam, np.inf).min(axis=1)
    return np.minimum(np.maximum(g, 0.0), length_m), np.sqrt(dmin[:, 0])


# ------------------------------------------------------------------ one point, plain float math
#: numpy's clip for one float (NaN propagates, the value wins ties: −0.0 clipped to [0, …] stays −0.0).
clip_scalar = clip_float


def wrap_scalar(a: float) -> float:
    """:func:`mjasc.core.frames.wrap_angle` for one float, to (−π, π]."""
    w = (a + math.pi) % _TWO_PI - math.pi
    return math.pi if w == -math.pi else w


def point_scalar(row, s: float) -> tuple[float, float]:
    """(x, y) at local arc length ``s`` on one segment (``row``: its table column as a list)."""
    k = row[K]
    if k == 0.0:
        return row[X0] + s * row[COS0], row[Y0] + s * row[SIN0]
    th = row[TH0] + k * s
    return row[X0] + (math.sin(th) - row[SIN0]) / k, row[Y0] + (row[COS0] - math.cos(th)) / k


def closest_scalar(qx: float, qy: float, row, lo: float, hi: float, out: list) -> None:
    """Append (d², γ) of the candidates of one segment (``row``) for the query (qx, qy) to ``out``."""
    k = row[K]
    if k == 0.0:
        dx, dy = qx - row[X0], qy - row[Y0]
        c0, s0 = row[COS0], row[SIN0]
        s = clip_scalar(dx * c0 + dy * s0, lo, hi)
        ex, ey = dx - s * c0, dy - s * s0
        out.append((ex * ex + ey * ey, row[C] + s))
        return
    phi = math.atan2(qy - row[CY], qx - row[CX])
    sgn = 1.0 if k > 0.0 else -1.0
    s_star = clip_scalar((sgn * (phi - row[A0])) % _TWO_PI / abs(k), lo, hi)
    x0, y0, th0, sin0, cos0, c0 = row[X0], row[Y0], row[TH0], row[SIN0], row[COS0], row[C]
    for s in (s_star, lo, hi):
        th = th0 + k * s  # point_scalar(row, s) on an arc
        ex, ey = x0 + (math.sin(th) - sin0) / k - qx, y0 + (cos0 - math.cos(th)) / k - qy
        out.append((ex * ex + ey * ey, c0 + s))
