"""Arc-length parameterized planar paths: lines and circular arcs joined end to end.

A :class:`Path` is the geometric object every vessel follows (docs/thesis.md §1: "each vessel follows its
own path, parameterized so that equal path parameters mean in formation"). World frame ENU,
metres; the path parameter γ is the arc length from the start of the path [m]; the tangent angle
(course of the path) is CCW from east [rad], wrapped to (−π, π]; curvature is signed, CCW (left
turn) positive [1/m].

Every segment is a piece of constant curvature, so internally each one is stored as
(start point p₀, start course θ₀, curvature κ, length L) and evaluated in one vectorized formula:

    p(s) = p₀ + s (cos θ₀, sin θ₀)                                   κ = 0 (line)
    p(s) = p₀ + (sin(θ₀ + κs) − sin θ₀, cos θ₀ − cos(θ₀ + κs)) / κ    κ ≠ 0 (arc)
    θ(s) = θ₀ + κ s

Paths are immutable; re-planning builds new ones with :meth:`Path.split`,
:meth:`Path.sub_path` and :meth:`Path.concatenate` (splice a detour in).
"""

from __future__ import annotations

import math
from bisect import bisect_right

import numpy as np

from mjasc.core.frames import wrap_angle
from mjasc.guidance.path_kernels import points_into
from mjasc.guidance.path_segments import (CONTINUITY_TOLERANCE_M, DUPLICATE_TOLERANCE_M, ArcSegment,
                                         LineSegment, as_point, xy_of)
from mjasc.guidance.waypoint_paths import waypoint_segments
from mjasc.guidance.segment_geometry import (
    C,
    K,
    LEN,
    TH0,
    X0,
    Y0,
    clip_scalar,
    closest_scalar,
    closest_candidates,
    pick_closest,
    point_scalar,
    segment_table,
    wrap_scalar,
)

#: Scalar γ types: queries with one of these take the plain-float path.
_SCALARS = (float, int, np.floating, np.integer)
#: A projection over fewer segments than this, or a query of at most this many γ, is done in plain
#: floats (numpy's per-call overhead dominates small arrays), else vectorized.
_SCALAR_SEGMENTS = 8


class Path:
    """An immutable planar path made of line and arc segments, parameterized by arc length γ [m].

    Build with :meth:`from_waypoints`, :meth:`line`, :meth:`from_segments` or :meth:`from_points`.
    All queries accept a scalar γ (return a scalar / (2,) array) or an array of γ (return (n,) /
    (n, 2)); γ is clamped to [0, length].
    """

    __slots__ = ("_segments", "_source", "_cum", "_table", "_rows", "_cum_list", "_length")

    def __init__(self, segments):
        segments = tuple(segments)
        if len(segments) == 0:
            raise ValueError("segments: a path needs at least one segment")
        for i, seg in enumerate(segments):
            if not isinstance(seg, (LineSegment, ArcSegment)):
                raise ValueError(
                    f"segments[{i}]: expected LineSegment or ArcSegment, got {type(seg).__name__}"
                )
        for i in range(1, len(segments)):
            gap = float(np.hypot(*(segments[i].start_point - segments[i - 1].end_point)))
            if gap > CONTINUITY_TOLERANCE_M:
                raise ValueError(
                    f"segments[{i}]: starts {gap:.6g} m away from the end of segments[{i - 1}] "
                    "(a path must be continuous)"
                )
        self._set(segments, None, np.array([s.length for s in segments]), [s.start_point for s in segments],
                  [s.start_course for s in segments], [s.curvature for s in segments])

    def _set(self, segments, source, lengths, starts, courses, curvatures) -> None:
        """The path's arrays from its segments' lengths, start points, courses and curvatures;
        ``segments`` a tuple, or None with ``source``, what :attr:`segments` makes them from when
        first asked: the points (n + 1, 2) of n line segments, or the list of paths joined."""
        self._segments, self._source = segments, source
        self._cum = np.concatenate([[0.0], np.cumsum(lengths)])
        self._table = segment_table(self._cum[:-1], lengths, starts, courses, curvatures)
        for a in (self._cum, self._table):
            a.flags.writeable = False
        self._rows = self._table.T.tolist()  # per segment, plain floats: the scalar queries
        self._cum_list = self._cum.tolist()
        self._length = self._cum_list[-1]

    @classmethod
    def _joined(cls, parts: list) -> "Path":
        """The path of ``parts``' segments in order (paths that join): its table from theirs (their
        segments' lengths, starts, courses and curvatures are its rows: the same arrays as building
        it from the segments), the segments joined when asked for."""
        path = cls.__new__(cls)
        t = np.concatenate([q._table for q in parts], axis=1)
        path._set(None, list(parts), t[LEN], t[[X0, Y0]].T, t[TH0], t[K])
        return path

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_segments(cls, segments) -> "Path":
        """A path from mixed :class:`LineSegment` / :class:`ArcSegment`; each must start where the
        previous one ends (within 1e-6 m), else ValueError naming the segment index."""
        return cls(segments)

    @classmethod
    def line(cls, start, end) -> "Path":
        """A straight path from ``start`` to ``end`` [m]."""
        start = as_point(start, "start")
        end = as_point(end, "end")
        if np.hypot(*(end - start)) <= DUPLICATE_TOLERANCE_M:
            raise ValueError("end: equals start (zero-length path)")
        return cls([LineSegment(start, end)])

    @classmethod
    def from_waypoints(cls, waypoints, turn_radius_m: float = 0.0) -> "Path":
        """Straight legs between ``waypoints`` (n ≥ 2, 2) [m], each interior corner rounded by a
        circular arc of ``turn_radius_m`` tangent to both legs (0 = sharp corners).

        A corner turning by Δ needs R·tan(|Δ|/2) of each adjacent leg; an L-shaped path with legs
        a, b and a 90° corner has length a + b − 2R + πR/2.
        """
        return cls(waypoint_segments(waypoints, turn_radius_m))

    @classmethod
    def from_points(cls, points) -> "Path":
        """A polyline through dense ``points`` (n, 2) [m], e.g. a potential-field streamline.
        Consecutive duplicates (closer than 1e-9 m, as at a stagnation point) are dropped; at least
        two distinct points are required."""
        p = np.asarray(points, dtype=float)
        if p.ndim != 2 or p.shape[1] != 2 or p.shape[0] < 2:
            raise ValueError(f"points: expected shape (n ≥ 2, 2), got {p.shape}")
        bad = np.flatnonzero(~np.all(np.isfinite(p), axis=1))
        if bad.size:
            raise ValueError(f"points[{bad[0]}]: must be finite, got {p[bad[0]].tolist()}")
        step = np.hypot(*np.diff(p, axis=0).T)
        keep = np.concatenate([[True], step > DUPLICATE_TOLERANCE_M])
        p = p[keep]
        if p.shape[0] < 2:
            raise ValueError("points: need at least two distinct points")
        # The line segments' lengths, starts and courses as LineSegment gives them, for all at once
        # (numpy's hypot and arctan2 round as for one pair: the same bits); the segments made when asked.
        p.flags.writeable = False  # (p[keep] is the path's own copy: the segments' points)
        d = p[1:] - p[:-1]
        path = cls.__new__(cls)
        path._set(None, p, np.hypot(d[:, 0], d[:, 1]), p[:-1], np.arctan2(d[:, 1], d[:, 0]), np.zeros(len(d)))
        return path

    # ------------------------------------------------------------------ properties
    @property
    def length(self) -> float:
        """Total arc length [m]."""
        return self._length

    @property
    def segments(self) -> tuple:
        """The line and arc segments in order (made at the first call for a path from points or
        joined paths)."""
        if self._segments is None:
            src = self._source
            if isinstance(src, np.ndarray):
                self._segments = tuple(LineSegment(src[i], src[i + 1]) for i in range(src.shape[0] - 1))
            else:
                self._segments = tuple(seg for part in src for seg in part.segments)
            self._source = None
        return self._segments

    @property
    def segment_starts(self) -> np.ndarray:
        """γ at the start of each segment, (n_segments,) [m]."""
        return self._cum[:-1]

    @property
    def table(self) -> np.ndarray:
        """The segment table (read-only, fields × segments; :mod:`mjasc.guidance.segment_geometry`)."""
        return self._table

    @property
    def start_point(self) -> np.ndarray:
        return self._end(0)

    @property
    def end_point(self) -> np.ndarray:
        return self._end(-1)

    def _end(self, k: int) -> np.ndarray:
        """The first (``k`` 0) or last (−1) point, without making the segments of a path that has none yet."""
        if self._segments is not None:
            seg = self._segments[k]
            return seg.end_point if k else seg.start_point
        src = self._source
        if isinstance(src, np.ndarray):  # (a read-only copy, as a segment's point)
            p = src[k].copy()
            p.flags.writeable = False
            return p
        return src[k].end_point if k else src[k].start_point

    def __repr__(self) -> str:
        return f"Path(length={self.length:.3f} m, segments={len(self._rows)})"

    # ------------------------------------------------------------------ evaluation
    def _locate(self, gamma):
        """Segment index and local arc length for γ (clamped); at a joint the later segment wins."""
        g = np.clip(np.asarray(gamma, dtype=float), 0.0, self._length)
        idx = np.searchsorted(self._cum, g, side="right") - 1
        idx = np.clip(idx, 0, len(self._rows) - 1)
        return g, idx, g - self._cum[idx]

    def _locate_scalar(self, gamma: float):
        """:meth:`_locate` for one γ in plain floats: (segment row, local arc length)."""
        g = clip_scalar(float(gamma), 0.0, self._length)
        i = min(max(bisect_right(self._cum_list, g) - 1, 0), len(self._rows) - 1)
        return self._rows[i], g - self._cum_list[i]

    def point(self, gamma) -> np.ndarray:
        """Position at γ: (2,) for scalar γ, (n, 2) for an array [m]."""
        if isinstance(gamma, _SCALARS):
            return np.array(point_scalar(*self._locate_scalar(gamma)))
        if isinstance(gamma, np.ndarray) and gamma.ndim == 1 and gamma.size <= _SCALAR_SEGMENTS:
            return np.array([point_scalar(*self._locate_scalar(g)) for g in gamma.tolist()]).reshape(-1, 2)
        # γ clipped, its segment, the line / arc formula per γ in one compiled pass (path_kernels;
        # eval_points' numbers: tests/test_path_kernels.py keeps that numpy form as the reference)
        g = np.asarray(gamma, dtype=float)
        out = np.empty(g.shape + (2,))
        points_into(self._table, self._cum, self._length, g.reshape(-1), out.reshape(-1, 2))
        return out

    def tangent_angle(self, gamma):
        """Course of the path at γ [rad], CCW from east, wrapped to (−π, π]."""
        if isinstance(gamma, _SCALARS):
            row, s = self._locate_scalar(gamma)
            return wrap_scalar(row[TH0] + row[K] * s)
        if isinstance(gamma, np.ndarray) and gamma.ndim == 1 and gamma.size <= _SCALAR_SEGMENTS:
            return np.array([wrap_scalar(r[TH0] + r[K] * s) for r, s in map(self._locate_scalar, gamma.tolist())])
        _, idx, s = self._locate(gamma)
        return wrap_angle(self._table[TH0, idx] + self._table[K, idx] * s)

    def curvature(self, gamma):
        """Signed curvature at γ [1/m], CCW (left turn) positive; 0 on lines."""
        if isinstance(gamma, _SCALARS):
            return self._locate_scalar(gamma)[0][K]
        _, idx, _ = self._locate(gamma)
        k = self._table[K, idx]
        return float(k) if np.ndim(k) == 0 else k.copy()

    def at(self, gamma: float) -> tuple[float, float, float, float]:
        """(x [m], y [m], course [rad] wrapped, curvature [1/m]) at one γ, in plain floats: what
        :meth:`point`, :meth:`tangent_angle` and :meth:`curvature` give, in one look-up."""
        row, s = self._locate_scalar(gamma)
        x, y = point_scalar(row, s)
        return x, y, wrap_scalar(row[TH0] + row[K] * s), row[K]

    def sample(self, spacing_m: float) -> np.ndarray:
        """Points (n, 2) every ``spacing_m`` metres along the path, both ends included."""
        spacing_m = float(spacing_m)
        if not np.isfinite(spacing_m) or spacing_m <= 0.0:
            raise ValueError(f"spacing_m: must be finite and > 0, got {spacing_m}")
        n = max(int(np.ceil(self.length / spacing_m)), 1) + 1
        return self.point(np.linspace(0.0, self.length, n))

    def cross_track_error(self, point, gamma: float) -> float:
        """Signed distance of ``point`` from the path's tangent line at γ [m], positive when the
        point is LEFT of the path (port side of a vessel sailing along it)."""
        px, py = xy_of(point, "point")
        row, s = self._locate_scalar(gamma)
        qx, qy = point_scalar(row, s)
        th = wrap_scalar(row[TH0] + row[K] * s)
        return -(px - qx) * math.sin(th) + (py - qy) * math.cos(th)

    # ------------------------------------------------------------------ projection
    def project(self, point, gamma_hint: float | None = None, search_window_m: float | None = None) -> float:
        """γ of the point of the path closest to ``point`` [m].

        With ``gamma_hint`` and ``search_window_m`` only [hint − window, hint + window] is searched,
        which keeps γ continuous for a follower on a path that crosses or nears itself. Ties go
        to the smallest γ.
        """
        px, py = xy_of(point, "point")
        lo, hi = 0.0, self._length
        if gamma_hint is not None or search_window_m is not None:
            if gamma_hint is None or search_window_m is None:
                raise ValueError("gamma_hint: give both gamma_hint and search_window_m, or neither")
            w = float(search_window_m)
            if not math.isfinite(w) or w <= 0.0:
                raise ValueError(f"search_window_m: must be finite and > 0, got {search_window_m}")
            h = clip_scalar(float(gamma_hint), 0.0, self._length)
            lo, hi = max(0.0, h - w), min(self._length, h + w)
        return self._project_between(px, py, lo, hi)

    def project_near(self, px: float, py: float, gamma_hint: float, search_window_m: float) -> float:
        """:meth:`project` of the point (px, py) with ``gamma_hint`` and ``search_window_m``, for
        plain floats a caller has checked already (a path follower's window: finite and > 0); a
        point that is not finite goes through :meth:`project` (and its error). The same bits."""
        if not (-math.inf < px < math.inf and -math.inf < py < math.inf):
            return self.project((px, py), gamma_hint, search_window_m)
        length = self._length
        h = clip_scalar(gamma_hint, 0.0, length)
        return self._project_between(px, py, max(0.0, h - search_window_m), min(length, h + search_window_m))

    def _project_between(self, px: float, py: float, lo: float, hi: float) -> float:
        """:meth:`project`'s search on the stretch [lo, hi] of the path."""
        # the segments that can touch [lo, hi], one of margin each side (the exact test is below)
        cum = self._cum_list
        j0 = max(bisect_right(cum, lo) - 2, 0)
        j1 = min(bisect_right(cum, hi), len(self._rows) - 1)
        if j1 - j0 < _SCALAR_SEGMENTS:
            cands: list = []
            for row in self._rows[j0:j1 + 1]:
                s_lo, s_hi = lo - row[C], hi - row[C]  # max(0, ·) and min(LEN, ·) as the builtins pick
                if not s_lo > 0.0:
                    s_lo = 0.0
                if not s_hi < row[LEN]:
                    s_hi = row[LEN]
                if s_lo <= s_hi:
                    closest_scalar(px, py, row, s_lo, s_hi, cands)
            if not cands:
                raise ValueError("min() arg is an empty sequence")
            d_min = cands[0][0]  # min(d) and then min(γ within the tie) as the builtin min runs
            for d, _ in cands:
                if d < d_min:
                    d_min = d
            tie = d_min * (1.0 + 1e-12) + 1e-18
            best = None
            for d, g in cands:
                if d <= tie and (best is None or g < best):
                    best = g
            if best is None:
                raise ValueError("min() arg is an empty sequence")
            return clip_scalar(best, 0.0, self._length)
        gam, _ = self._closest(np.array([[px, py]]), lo, hi, j0, j1 + 1)
        return float(gam[0])

    def closest_points(self, points, gamma_min: float = 0.0, gamma_max: float | None = None):
        """For each of ``points`` (n, 2): the γ of the closest point of the stretch
        [gamma_min, gamma_max] of the path and the distance to it. Returns (gammas (n,), distances (n,))."""
        pts = np.asarray(points, dtype=float)
        if pts.ndim != 2 or pts.shape[1] != 2:
            raise ValueError(f"points: expected shape (n, 2), got {pts.shape}")
        lo = float(np.clip(gamma_min, 0.0, self.length))
        hi = self.length if gamma_max is None else float(np.clip(gamma_max, 0.0, self.length))
        if hi < lo:
            raise ValueError(f"gamma_max: must be ≥ gamma_min ({gamma_min}), got {gamma_max}")
        return self._closest(pts, lo, hi)

    def _closest(self, pts: np.ndarray, g_lo: float, g_hi: float, j0: int = 0, j1: int | None = None,
                 chunk: int = 200_000):
        """Closest points on the stretch [g_lo, g_hi] (among segments j0 … j1 − 1), vectorized over
        points × segments (:func:`~mjasc.guidance.segment_geometry.closest_candidates`)."""
        table = self._table[:, j0:j1]
        lo = np.maximum(0.0, g_lo - table[C])
        hi = np.minimum(table[LEN], g_hi - table[C])
        ok = np.flatnonzero(lo <= hi)
        seg, lo, hi = table[:, ok], lo[ok], hi[ok]
        n_arc = int(np.count_nonzero(seg[K]))
        out_g = np.empty(pts.shape[0])
        out_d = np.empty(pts.shape[0])
        step = max(1, chunk // max(1, ok.size + 3 * n_arc))
        for c in range(0, pts.shape[0], step):
            q = pts[c : c + step, None, :]  # (m, 1, 2)
            d2, gam = closest_candidates(q[..., 0], q[..., 1], seg, lo, hi)
            m = d2.shape[0]
            out_g[c : c + step], out_d[c : c + step] = pick_closest(d2.reshape(m, -1), gam.reshape(m, -1),
                                                                    self._length)
        return out_g, out_d

    # ------------------------------------------------------------------ editing
    def sub_path(self, gamma_a: float, gamma_b: float) -> "Path":
        """The piece of this path between γ_a < γ_b (both in [0, length]), as a new path whose γ
        starts at 0."""
        a, b = float(gamma_a), float(gamma_b)
        if not (0.0 <= a <= self.length):
            raise ValueError(f"gamma_a: must be in [0, {self.length:g}], got {gamma_a}")
        if not (0.0 <= b <= self.length):
            raise ValueError(f"gamma_b: must be in [0, {self.length:g}], got {gamma_b}")
        if b - a <= DUPLICATE_TOLERANCE_M:
            raise ValueError(f"gamma_b: must exceed gamma_a ({gamma_a}), got {gamma_b}")
        pieces = []
        for i, seg in enumerate(self.segments):
            s0, s1 = self._cum[i], self._cum[i + 1]
            lo, hi = max(a, s0), min(b, s1)
            if hi - lo <= DUPLICATE_TOLERANCE_M:
                continue
            if lo == s0 and hi == s1:
                pieces.append(seg)
            else:
                pieces.append(seg.sub(lo - s0, hi - s0))
        return Path(pieces)

    def split(self, gamma: float) -> tuple["Path", "Path"]:
        """(before, after) at 0 < γ < length; ``before.concatenate(after)`` is this path again."""
        g = float(gamma)
        if not (DUPLICATE_TOLERANCE_M < g < self.length - DUPLICATE_TOLERANCE_M):
            raise ValueError(f"gamma: must be strictly inside (0, {self.length:g}), got {gamma}")
        return self.sub_path(0.0, g), self.sub_path(g, self.length)

    def concatenate(self, other: "Path") -> "Path":
        """This path followed by ``other``, which must start where this one ends."""
        if not isinstance(other, Path):
            raise ValueError(f"other: expected a Path, got {type(other).__name__}")
        gap = float(np.hypot(*(other.start_point - self.end_point)))
        if gap > CONTINUITY_TOLERANCE_M:
            raise ValueError(
                f"other: starts {gap:.6g} m away from the end of this path (paths must join)"
            )
        return Path._joined([self, other])
