"""Outlines of slow and static tracks from their returns (:mod:`mjasc.perception.tracking`, item 6).

While a track is slower than ``static_speed_m_s`` the world-frame returns [m] of its detections
are accumulated as the convex hull of everything seen of it (returns farther than ``1.5·R + 0.5 m``
from its centre — another object's, merged into one cluster — are left out); the accumulation
restarts when the track moves (faster than twice that speed, or its centre more than
``outline_reset_m`` from where the accumulation started). The outline handed on
(``TrackEstimate.outline_m``, for every confirmed track slower than ``static_speed_m_s``) is that
hull united with its reflection through the track's centre (a hull is roughly point-symmetric
about midships; only the side facing the sensor is ever seen at once); without returns, the
12-gon circumscribing the track's disc. Hulls: :func:`mjasc.core.geometry.convex_hull`
(counter-clockwise).
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.compiled import kernel
from mjasc.core.estimates import Pending
from mjasc.core.geometry import circle_polygon, convex_hull
from mjasc.core.polygon_kernels import canonical_hull
from mjasc.perception.tracking.config import TrackingConfig
from mjasc.perception.tracking.track_columns import TrackColumns, column

__all__ = ["TrackOutlines", "outline_at", "grow_plan", "grown_hull"]


class TrackOutlines:
    """Per track (rows aligned with the bank's): the hull (k, 2) [m] of its returns seen while it
    was slow (None: none yet), and its centre when that accumulation started — columns of a
    :class:`~mjasc.perception.tracking.track_columns.TrackColumns` (``columns``: a tracker's store;
    None: a store of its own)."""

    def __init__(self, config: TrackingConfig, columns: TrackColumns | None = None):
        self.config = config
        self.cols = TrackColumns(config.confirm_hits <= 1) if columns is None else columns
        # row → (hull, centre x, y, radius, outline): the last outline made (a function of the hull,
        # centre and radius alone: still right for whatever row holds them after a drop)
        self._made: dict[int, tuple] = {}
        # grow_plan's reset distance [m], fast and slow speeds [m/s]
        self._plan_constants = (float(config.outline_reset_m), 2.0 * config.static_speed_m_s,
                                float(config.static_speed_m_s))

    # the store's columns (views: stale after a birth or drop)
    _hull = column("hull")  # per track: hull vertices (k, 2) of its returns [m], or None
    _hull_anchor = column("hull_anchor")  # per track: its centre when the hull was started

    def append(self, centres) -> None:
        """New tracks, now at ``centres`` (k, 2) [m] (new rows of the store: :meth:`TrackColumns.append`)."""
        centres = np.asarray(centres, dtype=float).reshape(-1, 2)
        self.cols.append(0.0, np.zeros(centres.shape[0]), centres)

    def keep(self, keep: np.ndarray) -> None:
        """Keep the rows where ``keep`` (n,) is True (:meth:`TrackColumns.keep`)."""
        self.cols.keep(keep)

    def grow(self, rows, used, speeds, positions, radii, returns_of) -> None:
        """After an update of the tracks ``rows`` (indices): restart the hull of those that move
        (faster than twice ``static_speed_m_s``, or ``outline_reset_m`` from its anchor), then add
        to the hull of each slow track updated (``used`` (k,)) the returns of its detection,
        ``returns_of(position in rows)`` → (points (p, 2) [m], labels (p,), label): the returns
        whose label is the detection's. speeds (k,) [m/s], positions (k, 2) [m] and radii (k,) [m]
        are the tracks'. (The rows to restart and to grow are one compiled call, :func:`grow_plan`;
        the returns near each growing track gathered and hulled with the hull they join by one
        compiled call per track, :func:`grown_hull`; tests/test_tracking_outlines.py keeps the numpy
        form.)"""
        ints, geo, n_reset, g = grow_plan(rows, speeds, positions, self.cols.hull_anchor, *self._plan_constants, used,
                                          radii)
        self.grow_planned(ints, geo, n_reset, g, returns_of)

    @property
    def plan_constants(self) -> tuple:
        """:func:`grow_plan`'s constants (reset distance [m], fast and slow speeds [m/s]), for a caller
        that runs it inside a compiled call of its own."""
        return self._plan_constants

    def grow_planned(self, ints, geo, n_reset: int, g: int, returns_of) -> None:
        """The rest of :meth:`grow` after :func:`grow_plan` (anchors written) — its (ints, geo, r, g)
        from wherever it ran (a fleet tracker's step runs it in its compiled call after the cycle):
        the hulls of the reset rows dropped, the returns of each growing track added to its hull."""
        cols = self.cols
        anchor, hulls = cols.hull_anchor, cols.hull
        if n_reset:
            hulls[ints[:n_reset]] = None
        if g == 0:
            return
        no_hull = _NO_HULL
        il = ints.tolist()
        for j, k, (px, py, lim) in zip(il[n_reset:n_reset + g], il[n_reset + g:], geo.tolist()):
            pts, labels, label = returns_of(j)
            h = hulls[k]
            p, n_new, hulled = grown_hull(pts, labels, label, px, py, lim, no_hull if h is None else h)
            if n_new == 0:
                continue
            if h is None:
                anchor[k] = (px, py)  # (= positions[j]: grow_plan's copy of it)
            hulls[k] = p if hulled else convex_hull(p)

    def outline(self, row: int, centre, radius: float) -> np.ndarray:
        """(k, 2) CCW outline [m] of the track in ``row``, centred at ``centre`` (2,) [m] with this
        radius [m]: the hull of its returns united with its reflection through the centre, or the
        12-gon around its disc."""
        c = centre
        h = self.cols.hull[row]
        x, y, r = float(c[0]), float(c[1]), float(radius)
        made = self._made.get(row)
        if made is not None and made[0] is h and made[1:4] == (x, y, r):  # asked again between updates
            return made[4].copy()
        out = outline_at(h, x, y, r)
        self._made[row] = (h, x, y, r, out)
        return out.copy()

    def pending(self, row: int, centre, radius: float) -> Pending:
        """:meth:`outline` of the track in ``row`` as a :class:`~mjasc.core.estimates.Pending`
        value: made on first read (only a prediction reads a track's outline; the tracker hands one
        on for every slow track at every step). It holds the row's hull now — a hull is replaced,
        never changed in place — and the centre's coordinates and the radius as numbers."""
        return Pending(outline_at, self.cols.hull[row], float(centre[0]), float(centre[1]), float(radius))


    def pendings(self, rows: list, slow: list, centres: np.ndarray, radii: np.ndarray) -> list:
        """A report's outlines column: :meth:`pending` of ``rows[j]`` with centre ``centres[j]`` (2,) [m]
        and radius ``radii[j]`` [m] where ``slow[j]``, None elsewhere (one call for the column)."""
        out = [None] * len(slow)
        if True in slow:  # (only the slow rows, their numbers from lists: no numpy scalar per row; the
            # same Python floats as float() of the array's elements)
            hull, cl, rl = self.cols.hull, centres.tolist(), radii.tolist()
            for j, lk in enumerate(slow):
                if lk:
                    c = cl[j]
                    out[j] = Pending(outline_at, hull[rows[j]], c[0], c[1], rl[j])
        return out


def outline_at(hull, x: float, y: float, radius: float) -> np.ndarray:
    """(k, 2) CCW outline [m]: the hull (h, 2) [m] (or None) united with its reflection through
    the centre (x, y) [m], or — without a hull of two points — the 12-gon circumscribing the disc
    of this radius [m] about the centre."""
    if hull is None or hull.shape[0] < 2:
        return circle_polygon((x, y), radius, 12)  # the 12-gon circumscribing the disc
    out, hulled = reflected_hull(hull, x, y)  # (convex_hull(np.vstack([h, 2.0 * c - h])), compiled)
    return out if hulled else convex_hull(out)


_NO_HULL = np.zeros((0, 2))


@kernel
def reset_rows(rows, speeds, pos, anchor, reset_m, fast, used, slow):
    """The first part of :meth:`TrackOutlines.grow` in one pass: (reset (r,), grow (g,)) — the rows
    of ``rows`` (k,) whose accumulation restarts, faster than ``fast`` or ``hypot(pos − anchor[row])
    > reset_m`` from their anchor (anchor[row] set to pos (k, 2) [m] in place), and the positions
    in rows of the ``used`` ones slower than ``slow`` [m/s] (speeds (k,))."""
    k = rows.size
    reset = np.empty(k, dtype=np.int64)
    grow = np.empty(k, dtype=np.int64)
    nr = 0
    ng = 0
    for a in range(k):
        t = rows[a]
        moved = math.hypot(pos[a, 0] - anchor[t, 0], pos[a, 1] - anchor[t, 1]) > reset_m
        if speeds[a] > fast or moved:
            reset[nr] = t
            nr += 1
            anchor[t, 0] = pos[a, 0]
            anchor[t, 1] = pos[a, 1]
        if used[a] and speeds[a] < slow:
            grow[ng] = a
            ng += 1
    return reset[:nr], grow[:ng]


@kernel
def gather_returns(points, labels, label, px, py, limit, hull):
    """(p (h + m, 2), m, canonical): the hull's vertices (h, 2) [m] followed by the returns of
    ``points`` (k, 2) [m] whose ``labels`` equal ``label`` and within ``limit`` [m] of (px, py) —
    ``hypot(x − px, y − py) ≤ limit`` —, in their order; canonical: p has at most 256 points, all
    finite (:func:`mjasc.core.geometry.convex_hull` hulls it with :func:`canonical_hull`)."""
    k = points.shape[0]
    h = hull.shape[0]
    take = np.empty(k, dtype=np.int64)
    m = 0
    for i in range(k):
        if labels[i] == label and math.hypot(points[i, 0] - px, points[i, 1] - py) <= limit:
            take[m] = i
            m += 1
    p = np.empty((h + m, 2))
    finite = True
    for i in range(h):
        p[i, 0] = hull[i, 0]
        p[i, 1] = hull[i, 1]
    for i in range(m):
        p[h + i, 0] = points[take[i], 0]
        p[h + i, 1] = points[take[i], 1]
    for i in range(h + m):
        if not (math.isfinite(p[i, 0]) and math.isfinite(p[i, 1])):
            finite = False
    return p, m, finite and h + m <= 256


@kernel
def grow_plan(rows, speeds, pos, anchor, reset_m, fast, slow, used, radii):
    """:func:`reset_rows` (arguments as there; anchor written in place) and what
    :meth:`TrackOutlines.grow` reads of each growing track: (ints (r + 2g,): the rows to reset (r,),
    the growing tracks' positions in rows (g,) and their bank rows ``rows[grow]`` (g,); (g, 3) [m]
    their positions ``pos[grow]`` and return limits ``1.5·radii[grow] + 0.5``; r; g), radii (k,) [m]
    the tracks' (one array per type: each array a kernel returns is a Python object made)."""
    reset, grow = reset_rows(rows, speeds, pos, anchor, reset_m, fast, used, slow)
    g = grow.size
    r = reset.size
    ints = np.empty(r + 2 * g, dtype=np.int64)
    geo = np.empty((g, 3))
    for a in range(r):
        ints[a] = reset[a]
    for a in range(g):
        j = grow[a]
        ints[r + a] = j
        ints[r + g + a] = rows[j]
        geo[a, 0] = pos[j, 0]
        geo[a, 1] = pos[j, 1]
        geo[a, 2] = 1.5 * radii[j] + 0.5
    return ints, geo, r, g


@kernel
def grown_hull(points, labels, label, px, py, limit, hull):
    """(p, m, hulled): :func:`gather_returns` (arguments as there) and, when it found m > 0 returns and
    its points are canonical, their :func:`canonical_hull` (hulled True); else its points (hulled
    False: for :func:`mjasc.core.geometry.convex_hull` when m > 0)."""
    p, m, canonical = gather_returns(points, labels, label, px, py, limit, hull)
    if m > 0 and canonical:
        return canonical_hull(p), m, True
    return p, m, False


@kernel
def reflected_hull(hull, cx, cy):
    """(out, hulled): the canonical hull (:func:`canonical_hull`) of the hull's vertices (h, 2) [m]
    and their reflections through (cx, cy) [m], ``2·c − hull``, stacked in that order — or, when
    they are more than 256 points or not all finite (hulled False), the stacked points for
    :func:`mjasc.core.geometry.convex_hull`."""
    h = hull.shape[0]
    p = np.empty((2 * h, 2))
    finite = True
    for i in range(h):
        p[i, 0] = hull[i, 0]
        p[i, 1] = hull[i, 1]
        p[h + i, 0] = 2.0 * cx - hull[i, 0]
        p[h + i, 1] = 2.0 * cy - hull[i, 1]
    for i in range(2 * h):
        if not (math.isfinite(p[i, 0]) and math.isfinite(p[i, 1])):
            finite = False
    if finite and 2 * h <= 256:
        return canonical_hull(p), True
    return p, False
