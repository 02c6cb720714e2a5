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

import numpy as np

from mjasc.core.geometry import circle_polygon, convex_hull
from mjasc.perception.tracking.config import TrackingConfig

__all__ = ["TrackOutlines"]


class TrackOutlines:
    """Per track (rows aligned with the bank's): the hull (k, 2) [m] of its returns seen while it
    was slow (None: none yet), and its centre when that accumulation started."""

    def __init__(self, config: TrackingConfig):
        self.config = config
        self._hull: list[np.ndarray | None] = []  # per track: hull vertices (k, 2) of its returns [m]
        self._hull_anchor = np.zeros((0, 2))  # per track: its centre when the hull was started

    def append(self, centre) -> None:
        """A new track, now at ``centre`` (1, 2) [m]."""
        self._hull.append(None)
        self._hull_anchor = np.vstack([self._hull_anchor, centre])

    def keep(self, keep: np.ndarray) -> None:
        """Keep the rows where ``keep`` (n,) is True."""
        self._hull = [x for x, k in zip(self._hull, keep) if k]
        self._hull_anchor = self._hull_anchor[keep]

    def grow(self, used, assigned_det, idx, labels, points_m, speeds, positions, radii) -> None:
        """Add the returns of each slow track's detection to the hull of its returns; restart it
        when the track moves. ``used`` (n,) rows updated with detection ``assigned_det`` (n,) of the
        scan's selected detections ``idx`` (cluster labels of the returns: ``labels`` (k,), the
        returns ``points_m`` (k, 2) [m]); the tracks' ``speeds`` (n,) [m/s], ``positions`` (n, 2) [m]
        and ``radii`` (n,) [m]."""
        cfg = self.config
        v = speeds
        pos = positions
        moved = np.hypot(*(pos - self._hull_anchor).T) > cfg.outline_reset_m
        for k in np.flatnonzero((v > 2.0 * cfg.static_speed_m_s) | moved):
            self._hull[k] = None
            self._hull_anchor[k] = pos[k]
        rows = np.flatnonzero(used & (assigned_det >= 0) & (v < cfg.static_speed_m_s))
        if rows.size == 0:
            return
        labels = np.asarray(labels)
        points_m = np.asarray(points_m, dtype=float).reshape(-1, 2)
        for k in rows:
            p = points_m[labels == idx[assigned_det[k]]]
            p = p[np.hypot(*(p - pos[k]).T) <= 1.5 * radii[k] + 0.5]
            if p.shape[0] == 0:
                continue
            if self._hull[k] is None:
                self._hull_anchor[k] = pos[k]
            else:
                p = np.vstack([self._hull[k], p])
            self._hull[k] = convex_hull(p)

    def outline(self, row: int, centre, radius: float) -> np.ndarray:
        """(k, 2) CCW outline [m] of the track in ``row``, centred at ``centre`` (2,) [m] with this
        radius [m]: the hull of its returns united with its reflection through the centre, or the
        12-gon around its disc."""
        c = centre
        h = self._hull[row]
        if h is None or h.shape[0] < 2:
            return circle_polygon(c, radius, 12)  # the 12-gon circumscribing the disc
        return convex_hull(np.vstack([h, 2.0 * c - h]))
