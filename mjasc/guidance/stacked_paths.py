"""Every vessel's current path in one segment table: projection and evaluation for a whole fleet.

Row i of a :class:`StackedPaths` is vessel i's path; its segments are the columns
``first[i] … first[i] + count[i] − 1`` of one table (the fields of
:mod:`mjasc.guidance.segment_geometry`; γ is each path's own arc length [m]). Alongside, a
monotone search key ``base[i] + C`` (each path's block offset by a gap from the previous one)
lets one ``searchsorted`` find every vessel's window of segments at once.

Projection with a search window (what :meth:`mjasc.guidance.paths.Path.project` does with a hint,
for all vessels in one pass): vessel i searches [h_i − w_i, h_i + w_i] ∩ [0, L_i] around its hint
h_i (clamped to [0, L_i]); the segments that can touch it (found on the key, one segment of margin
each side) are gathered into an (n, K) block, K the largest window's segment count, and every
candidate of :func:`~mjasc.guidance.segment_geometry.closest_candidates` is evaluated at once; the
window test itself is the path's own (local γ), so the answer is bit-identical to ``Path.project``.

A path switch (an avoidance detour spliced in) appends the new path's table after the used
columns; the old block becomes dead and the table is compacted when the dead columns outnumber
the live ones (or the capacity runs out), so a switch costs O(segments of the new path).
"""

from __future__ import annotations

import numpy as np

from mjasc.core.compiled import kernel
from mjasc.guidance.paths import Path
from mjasc.guidance.segment_geometry import (
    COS0,
    C,
    FIELDS,
    LEN,
    SIN0,
    TH0,
    X0,
    Y0,
    K,
    closest_candidates,
    eval_points,
    pick_closest,
)

__all__ = ["StackedPaths", "PathQuery"]

#: Key gap between two paths' blocks [m] (any positive value: it only separates the blocks).
_GAP_M = 1.0


class PathQuery:
    """Where each queried vessel is on its path: γ (n,) [m], the point there (n,) x, y [m], the
    path's course χ_p (n,) [rad, wrapped], its curvature κ (n,) [1/m] and length L (n,) [m]."""

    __slots__ = ("gamma_m", "x_m", "y_m", "course_rad", "curvature_1_m", "length_m")

    def __init__(self, gamma_m, x_m, y_m, course_rad, curvature_1_m, length_m):
        self.gamma_m, self.x_m, self.y_m = gamma_m, x_m, y_m
        self.course_rad, self.curvature_1_m, self.length_m = course_rad, curvature_1_m, length_m


class StackedPaths:
    """The current paths of n vessels (``paths[i]`` is vessel i's :class:`~mjasc.guidance.paths.Path`)."""

    def __init__(self, paths):
        self.paths: list[Path] = list(paths)
        n = len(self.paths)
        self._first = np.zeros(n, dtype=np.intp)
        self._count = np.zeros(n, dtype=np.intp)
        self._length = np.zeros(n)
        self._base = np.zeros(n)
        self._compact()

    def __len__(self) -> int:
        return len(self.paths)

    def segment_arrays(self) -> tuple:
        """The store as a compiled kernel reads it: (segment table (fields, m) in the order of
        :data:`~mjasc.guidance.segment_geometry.FIELDS`, each path's first column (n,), its segment
        count (n,), its length L_i (n,) [m]). The store's own arrays: not to be written."""
        return self._table, self._first, self._count, self._length

    @property
    def lengths_m(self) -> np.ndarray:
        """Each path's length L_i (n,) [m] (read-only view)."""
        v = self._length.view()
        v.flags.writeable = False
        return v

    def _compact(self) -> None:
        """Rebuild the table with the live blocks only, in vessel order, with room to append."""
        tables = [p.table for p in self.paths]
        counts = np.array([t.shape[1] for t in tables], dtype=np.intp)
        used = int(counts.sum())
        cap = 2 * used + 64
        self._table = np.zeros((len(FIELDS), cap))
        self._key = np.full(cap, np.inf)
        if tables:
            self._table[:, :used] = np.concatenate(tables, axis=1)
        self._first[:] = np.cumsum(counts) - counts
        self._count[:] = counts
        self._length[:] = [p.length for p in self.paths]
        self._base[:] = np.cumsum(self._length + _GAP_M) - (self._length + _GAP_M)
        self._key[:used] = self._table[C, :used] + np.repeat(self._base, counts)
        self._used = used
        self._dead = 0
        self._key_end = float(self._base[-1] + self._length[-1]) if tables else 0.0
        self._arcs = bool(np.any(self._table[K, :used] != 0.0))  # some live segment is an arc

    def set_path(self, i: int, path: Path) -> None:
        """Vessel i follows ``path`` from now on (its old block becomes dead)."""
        if not isinstance(path, Path):
            raise ValueError(f"path: expected a Path, got {type(path).__name__}")
        self.paths[i] = path
        m = path.table.shape[1]
        self._dead += int(self._count[i])
        if self._used + m > self._table.shape[1] or self._dead > self._used - self._dead:
            self._compact()
            return
        a, b = self._used, self._used + m
        base = self._key_end + _GAP_M
        self._table[:, a:b] = path.table
        self._key[a:b] = path.table[C] + base
        self._first[i], self._count[i], self._length[i], self._base[i] = a, m, path.length, base
        self._used, self._key_end = b, base + path.length
        self._arcs = self._arcs or bool(np.any(path.table[K] != 0.0))

    def point(self, rows, gamma_m) -> np.ndarray:
        """Positions (..., 2) [m] of vessels ``rows`` (...) at γ ``gamma_m`` (...) on their own
        paths (clamped to [0, L_i]): what ``paths[row].point(γ)`` gives for an array γ (the same
        segment, the same evaluation), for many vessels in one pass."""
        rows = np.asarray(rows, dtype=np.intp)
        g = np.minimum(np.maximum(np.asarray(gamma_m, dtype=float), 0.0), self._length[rows])
        idx = np.empty(g.shape, dtype=np.intp)
        table = self._table
        _segment_of(self._first, self._count, table[C], rows.ravel(), g.ravel(), idx.reshape(-1))
        if not self._arcs:  # lines only: eval_points' line formula on the five fields it reads
            s = g - table[C][idx]
            out = np.empty(g.shape + (2,))
            np.add(table[X0][idx], s * table[COS0][idx], out=out[..., 0])
            np.add(table[Y0][idx], s * table[SIN0][idx], out=out[..., 1])
            return out
        seg = table[:, idx]
        return np.stack(eval_points(seg, g - seg[C]), axis=-1)

    def project(self, x_m, y_m, gamma_hint_m, window_m, rows=None) -> PathQuery:
        """Project each vessel's position (x_m, y_m) (n,) on its own path within ±window_m (n,)
        of its hint γ (n,); ``rows`` (k,) selects vessels (None: all, in order)."""
        if rows is None:
            first, count, length, base = self._first, self._count, self._length, self._base
        else:
            first, count, length, base = self._first[rows], self._count[rows], self._length[rows], self._base[rows]
        h = np.minimum(np.maximum(gamma_hint_m, 0.0), length)
        g_lo = np.maximum(0.0, h - window_m)
        g_hi = np.minimum(length, h + window_m)
        last = first + count - 1
        key = self._key[: self._used]
        j_lo = np.minimum(np.maximum(np.searchsorted(key, base + g_lo, side="right") - 2, first), last)
        j_hi = np.minimum(np.maximum(np.searchsorted(key, base + g_hi, side="right"), first), last)
        n_win = j_hi - j_lo + 1
        cols = np.arange(int(n_win.max()))
        valid = cols < n_win[:, None]
        J = np.minimum(j_lo[:, None] + cols, j_hi[:, None])  # (n, K) segment columns
        seg = self._table[:, J]
        lo = np.maximum(0.0, g_lo[:, None] - seg[C])
        hi = np.minimum(seg[LEN], g_hi[:, None] - seg[C])
        ok = valid & (lo <= hi)
        d2, gam = closest_candidates(np.asarray(x_m)[:, None], np.asarray(y_m)[:, None], seg, lo, hi)
        d2 = np.where(ok[..., None], d2, np.inf)
        n = d2.shape[0]
        gamma, _ = pick_closest(d2.reshape(n, -1), gam.reshape(n, -1), length)
        # the segment holding γ, as Path._locate finds it (at a joint the later segment wins):
        # every segment before the window starts before γ, none after it does
        at = j_lo + np.maximum((valid & (seg[C] <= gamma[:, None])).sum(axis=1) - 1, 0)
        row = self._table[:, at]
        s = gamma - row[C]
        x, y = eval_points(row, s)
        w = np.mod(row[TH0] + row[K] * s + np.pi, 2.0 * np.pi) - np.pi  # wrap_angle, inlined
        return PathQuery(gamma, x, y, np.where(w == -np.pi, np.pi, w), row[K], length)


@kernel
def _segment_of(first, count, starts, rows, g, out):
    """Segment column of each (row, γ) into ``out``, as :meth:`Path._locate` finds it: the last
    segment of the row's block starting at or before γ (at a joint the later one wins), by bisection
    on the block's start γ; the block's first / last segment outside its span."""
    for i in range(rows.size):
        a = first[rows[i]]
        lo, hi = a, a + count[rows[i]]
        while lo < hi:
            mid = (lo + hi) >> 1
            if starts[mid] <= g[i]:
                lo = mid + 1
            else:
                hi = mid
        out[i] = min(max(lo - 1, a), a + count[rows[i]] - 1)
