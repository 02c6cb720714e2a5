"""Source panels on polygon edges and the velocity they induce (thesis §4.1, eqs. 4.3–4.4, App. A;
docs/thesis.md §4). World frame ENU, metres; velocities in m/s-like units (only their direction is used).

A straight source panel j (length L_j, uniform density λ_j per unit length) induces

    u = λ_j/(2π) ∫_j (p − q)/‖p − q‖² dl_q.

Closed form of one panel (thesis eqs. 4.3–4.4, derived again here because the printed forms are
mangled): with the panel from a to b, unit tangent t = (b − a)/L, outward unit normal n,
r_a = ‖p − a‖, r_b = ‖p − b‖ and β ∈ (−π, π) the signed angle the panel subtends at p (seen from
p, measured from a to b; positive on the normal's side),

    ∫_j (p − q)/‖p − q‖² dl_q = ln(r_a/r_b) · t + β · n.

β → +π just outside the panel and −π just inside, so the panel's own normal velocity is
±λ_j/2 (thesis eq. 4.3ff): the jump across a panel is λ_j. Summed over a polygon's panels,
Σβ/(2π) is the winding number (1 inside, 0 outside), which the streamline integrator uses to
notice a path entering an obstacle without extra work.

Panels are laid on clean counter-clockwise polygons (:func:`mjasc.core.geometry.clean_polygon`;
numbered counter-clockwise, unlike the thesis's clockwise numbering): each edge of the inflated
polygon becomes ``panels_per_edge`` equal panels (more if ``max_panel_length`` asks for it).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

__all__ = ["TWO_PI", "Panels", "make_panels", "panel_influence"]

TWO_PI = 2.0 * np.pi


@dataclass(frozen=True)
class Panels:
    """The m straight source panels of all obstacles, numbered counter-clockwise per obstacle.

    start, end: (m, 2) endpoints [m]; centre: (m, 2) control points [m]; tangent, normal: (m, 2)
    unit tangent (start→end) and outward unit normal; length: (m,) [m]; obstacle: (m,) index of
    the obstacle each panel belongs to; next_index: (m,) index of the panel that starts where
    panel i ends (same obstacle).
    """

    start: np.ndarray
    end: np.ndarray
    centre: np.ndarray
    tangent: np.ndarray
    normal: np.ndarray
    length: np.ndarray
    obstacle: np.ndarray
    next_index: np.ndarray

    def __len__(self) -> int:
        return len(self.length)


def make_panels(
    polygons: Sequence[np.ndarray],
    panels_per_edge: Sequence[int],
    max_panel_length: float | None = None,
) -> Panels:
    """Panels for clean counter-clockwise polygons: each edge split into
    max(panels_per_edge[k], ceil(edge length / max_panel_length)) equal panels."""
    starts, obstacle, nxt = [], [], []
    offset = 0
    for k, (poly, n_sub) in enumerate(zip(polygons, panels_per_edge)):
        a = poly
        e = np.roll(poly, -1, axis=0) - a
        counts = np.full(len(a), int(n_sub))
        if max_panel_length is not None:
            need = np.ceil(np.linalg.norm(e, axis=1) / max_panel_length - 1e-9).astype(int)
            counts = np.maximum(counts, need)
        pts = np.concatenate(
            [a[i] + (np.arange(c) / c)[:, None] * e[i] for i, c in enumerate(counts)]
        )
        m_k = len(pts)
        starts.append(pts)
        obstacle.append(np.full(m_k, k))
        nxt.append(offset + (np.arange(m_k) + 1) % m_k)
        offset += m_k
    start = np.concatenate(starts)
    next_index = np.concatenate(nxt)
    end = start[next_index]
    edge = end - start
    length = np.linalg.norm(edge, axis=1)
    tangent = edge / length[:, None]
    normal = np.stack([tangent[:, 1], -tangent[:, 0]], axis=1)
    return Panels(
        start=start,
        end=end,
        centre=0.5 * (start + end),
        tangent=tangent,
        normal=normal,
        length=length,
        obstacle=np.concatenate(obstacle),
        next_index=next_index,
    )


def panel_influence(points: np.ndarray, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """Velocity (n, m, 2) induced at points (n, 2) by unit-density source panels (m endpoints):

        w_j(p) = 1/(2π) ∫_j (p − q)/‖p − q‖² dl_q = [ln(r_a/r_b) t_j + β_j n_j]/(2π)

    (closed form of thesis eqs. 4.3–4.4; see the module docstring). On a panel itself β is
    taken from the side the float sign of the zero cross product gives; use the explicit ±1/2
    limit there. The reference (unfused) form; ``PotentialField.velocity`` uses a fused one.
    """
    p = np.atleast_2d(np.asarray(points, dtype=float))
    a, b = np.asarray(start, float), np.asarray(end, float)
    e = b - a
    L = np.linalg.norm(e, axis=1)
    t = e / L[:, None]
    n = np.stack([t[:, 1], -t[:, 0]], axis=1)
    da = p[:, None, :] - a[None]
    db = p[:, None, :] - b[None]
    ra2 = np.einsum("nmj,nmj->nm", da, da)
    rb2 = np.einsum("nmj,nmj->nm", db, db)
    cross = da[..., 1] * db[..., 0] - da[..., 0] * db[..., 1]  # = η L, η = (p − a)·n (outward)
    dot = np.einsum("nmj,nmj->nm", da, db)
    beta = np.arctan2(cross, dot)
    tang = 0.5 * np.log(ra2 / rb2)
    return (tang[..., None] * t[None] + beta[..., None] * n[None]) / TWO_PI

