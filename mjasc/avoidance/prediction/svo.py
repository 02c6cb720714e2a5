"""Static virtual obstacles (SVO): the polygons collision prediction hands to the re-planner
(docs/thesis.md §3, step 4; thesis §3.2.2, eq. 3.17). World frame ENU, metres, absolute times [s].

When σ(Δt_o) decides REPLAN, the obstruction becomes a static obstacle for the potential field:
the area swept by the obstacle's inflated disc (radius R_ob + R_vh + safety) over the obstruction
interval [t_i, t_f], as a counter-clockwise polygon of about ``svo_vertices`` vertices (each of its
edges becomes a planner panel). A static obstacle's SVO is its inflated outline, or its inflated
disc. Every polygon contains what it stands for (circumscribed arcs, sagitta margins).
"""

from __future__ import annotations

import numpy as np

from mjasc.core.estimates import TrackEstimate
from mjasc.core.geometry import circle_polygon, convex_hull, counter_clockwise, disc_hull

__all__ = ["swept_disc_polygon", "svo_polygon"]


def swept_disc_polygon(track: TrackEstimate, t_a: float, t_b: float, radius_m: float, n_vertices: int = 32) -> np.ndarray:
    """CCW polygon (k, 2) containing the area swept by a disc of ``radius_m`` centred on the track's
    predicted position over [t_a, t_b]: the buffered trajectory (right offset, front cap, left
    offset back, rear cap) when the trajectory turns by ≤ π with turning radius > the disc's,
    else the convex hull of the discs."""
    cap_k = 6  # arcs per semicircular cap
    n_off = max(2, (n_vertices - 2 * (cap_k - 1)) // 2)
    v, w = track.speed_m_s, track.turn_rate_rad_s
    length = v * (t_b - t_a)
    if length <= 1e-9:
        return circle_polygon(track.predict_positions(np.array([t_a]))[0], radius_m, n_vertices)
    turn = abs(w) * (t_b - t_a)
    rho = v / abs(w) if abs(w) > 1e-12 else np.inf
    ts = np.linspace(t_a, t_b, n_off)
    c = track.predict_positions(ts)
    if turn <= np.pi and rho > 1.5 * radius_m:
        # Circumscribe: caps of cap_k arcs, plus the sagitta of the outer offset's chords.
        r = radius_m / np.cos(np.pi / (2 * cap_k))
        if np.isfinite(rho):
            r += (rho + radius_m) * (1.0 - np.cos(0.5 * turn / (n_off - 1)))
        th = track.heading_rad + w * (ts - track.time_s)
        left = np.stack([-np.sin(th), np.cos(th)], axis=1)
        right_side = c - r * left
        left_side = c + r * left
        ang_end = np.linspace(th[-1] - np.pi / 2, th[-1] + np.pi / 2, cap_k + 1)[1:-1]
        ang_start = np.linspace(th[0] + np.pi / 2, th[0] + 3 * np.pi / 2, cap_k + 1)[1:-1]
        cap_end = c[-1] + r * np.stack([np.cos(ang_end), np.sin(ang_end)], axis=1)
        cap_start = c[0] + r * np.stack([np.cos(ang_start), np.sin(ang_start)], axis=1)
        return counter_clockwise(np.concatenate([right_side, cap_end, left_side[::-1], cap_start]))
    # Convex hull of discs at 40 sampled centres, each grown by the sagitta of the trajectory
    # between samples so that the discs in between are covered too.
    n_s = 40
    r = radius_m
    if np.isfinite(rho):
        r += rho * (1.0 - np.cos(0.5 * turn / (n_s - 1)))
    centres = track.predict_positions(np.linspace(t_a, t_b, n_s))
    return counter_clockwise(disc_hull(centres, r, 16))


def svo_polygon(track: TrackEstimate, t_i: float, t_f: float, r_col: float, inflate_m: float, static: bool,
                n_vertices: int) -> np.ndarray:
    """The static virtual obstacle handed to the re-planner (docs/thesis.md §3), a CCW polygon (k, 2):

    - a static track with an outline: the hull of its outline grown by ``inflate_m`` [m]
      (R_vh + safety; the hull of 16-gons around the outline's vertices);
    - a static track without one: the circumscribed ``n_vertices``-gon of radius ``r_col`` [m]
      (R_vh + R_ob + safety) around its position;
    - a moving track: the area its inflated disc (radius ``r_col``) sweeps over [t_i, t_f] [s]
      (:func:`swept_disc_polygon`).
    """
    if static:
        if track.outline_m is not None:
            outline = np.asarray(track.outline_m, dtype=float)
            if inflate_m > 0:
                return counter_clockwise(disc_hull(outline, inflate_m, 16))
            return counter_clockwise(convex_hull(outline, canonical=False))
        return circle_polygon(track.predict_positions(np.array([track.time_s]))[0], r_col, n_vertices)
    return swept_disc_polygon(track, t_i, t_f, r_col, n_vertices)
