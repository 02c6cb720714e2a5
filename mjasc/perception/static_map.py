"""A vessel's map of static structures (docks, quay walls, islands) built from its own range returns.

Returns that belong to extended objects (clusters wider than a target, see :mod:`mjasc.perception.detection`)
are accumulated in a world-frame grid of ``cell_m`` cells. Each cell keeps a score (an occupancy
grid's log-odds in integer steps, Thrun, Burgard & Fox 2005 §9.2, "inverse sensor model"):

* **hit**: +1 for each scan with a static return in the cell (a cell counts once per scan);
* **seen through** (:meth:`StaticMap.carve`): −``miss_weight`` (½) for each scan in which every beam
  across the cell's angular extent, seen from the sensor, returned (or nothing returned) at least
  ``cell_m`` + a margin beyond the cell's far side: the rays passed through it, so it is free now.

A cell is occupied while its score is ≥ ``min_hits`` (one false return never makes a wall); the
score is capped at ``min_hits + headroom``, so a cell that stood occupied for a long time is freed
after at most ``(headroom + 1) / miss_weight`` scans seen through (2.4 s at 5 Hz with headroom 5).
A hit counts twice a miss: a wall cell hit in more than a third of the scans and looked past in
the others (a wall at grazing incidence, whose returns fall now in this cell, now in the next) is
mapped, and once mapped, one hit in three keeps it. What this removes is what a moving object leaves behind: cells that a boat's returns
filled while it was taken for part of a wall (merged into the wall's cluster) are seen through
once the boat has moved on, and vanish from the map.

``polygons()`` turns the occupied cells into convex polygons for the planner: 8-connected
components of occupied cells, each split recursively (at the median along its principal axis)
until the cells fill at least ``min_fill`` of their convex hull, so that an L- or U-shaped dock
becomes a few convex pieces hugging its walls instead of one hull covering its basin. Each polygon
is the convex hull of its cells' corners (counter-clockwise, conservative by up to one cell).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.spatial import ConvexHull, QhullError

from mjasc.core.config_tables import check_params, param

__all__ = ["StaticMap", "StaticMapConfig"]

_CORNERS = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
#: A cell's half-extent as seen from the sensor, in cells (> the half-diagonal √2/2: conservative).
_HALF_EXTENT_CELLS = 0.75


@dataclass(frozen=True)
class StaticMapConfig:
    """Parameters of a :class:`StaticMap`, each declared once (bounds, unit, doc). A scenario sets
    ``cell_m`` and ``min_hits`` through ``[vessels.tracking]`` (``map_cell_m``, ``map_min_hits``)."""

    cell_m: float = param(1.0, positive=True, unit="m", doc="grid cell size")
    min_hits: int = param(3, minimum=1, doc="score at which a cell is occupied (one false return never makes a wall)")
    min_fill: float = param(
        0.4, nonneg=True, maximum=1.0,
        doc="a polygon's cells fill at least this fraction of its convex hull, else it is split")
    max_depth: int = param(6, minimum=0, doc="depth limit of the recursive splitting of a component")
    headroom: int = param(
        5, minimum=0, doc="score cap above min_hits: an occupied cell is freed after at most "
                          "(headroom + 1) / miss_weight scans seen through")
    miss_weight: float = param(0.5, nonneg=True, maximum=1.0, phrase="must be in [0, 1] (0: never forget)",
                               doc="score taken off a cell per scan that sees through it (0: never forget)")
    carve_margin_m: float = param(
        1.0, nonneg=True, unit="m",
        doc="a cell is seen through when every beam across it reached this (+ 3σ_ρ) beyond its far side")

    def __post_init__(self):
        check_params(self, "static_map")


class StaticMap:
    """World grid of static returns. ``add_scan(points)`` (hits), ``carve(...)`` (rays seen through),
    ``occupied(points)``, ``occupied_cells()``, ``polygons()``; ``version`` changes whenever the set of
    occupied cells does. The arguments are those of :class:`StaticMapConfig` (``config``)."""

    def __init__(self, cell_m: float = 1.0, min_hits: int = 3, min_fill: float = 0.4, max_depth: int = 6,
                 headroom: int = 5, miss_weight: float = 0.5, carve_margin_m: float = 1.0):
        self.config = c = StaticMapConfig(cell_m, min_hits, min_fill, max_depth, headroom, miss_weight, carve_margin_m)
        self.cell_m = float(c.cell_m)
        self.min_hits = int(c.min_hits)
        self.min_fill = float(c.min_fill)
        self.max_depth = int(c.max_depth)
        self.cap = float(self.min_hits + int(c.headroom))
        self.miss_weight = float(c.miss_weight)
        self.carve_margin_m = float(c.carve_margin_m)
        self._index: dict[tuple[int, int], int] = {}  # cell → row of _cells / _score
        self._cells = np.zeros((0, 2), dtype=np.int64)
        self._score = np.zeros(0)
        self._n = 0
        self._n_occupied = 0
        self._version = 0
        self._cache: list[np.ndarray] = []
        self._cached_version = 0

    # ------------------------------------------------------------------ updates
    def add_scan(self, points_world: np.ndarray) -> None:
        """Add one scan's returns (k, 2) [m] of static structures (each cell counted once per scan)."""
        p = np.asarray(points_world, dtype=float).reshape(-1, 2)
        if p.shape[0] == 0:
            return
        cells = np.unique(np.floor(p / self.cell_m).astype(np.int64), axis=0)
        rows = np.array([self._row(i, j) for i, j in cells.tolist()], dtype=np.int64)
        self._set_scores(rows, np.minimum(self._score[rows] + 1.0, self.cap))

    def carve(self, origin_m, beam_angles_world: np.ndarray, ranges_m: np.ndarray, hit: np.ndarray,
              max_range_m: float, full_circle: bool = True, range_noise_std_m: float = 0.0,
              hit_points_world: np.ndarray | None = None) -> int:
        """Free-space update from one scan; returns the number of cells seen through.

        origin_m (2,) sensor position; beam_angles_world (n,) uniformly spaced, increasing [rad];
        ranges_m (n,) and hit (n,) as in :class:`mjasc.perception.range_sensor.Scan` (a beam without a return
        saw free space out to ``max_range_m``). A cell with a score is seen through when it lies
        within ``max_range_m`` and every beam across its angular extent (± 0.75 cell / its distance,
        at least the nearest beam) reached beyond its far side by ``carve_margin_m`` + 3σ_ρ; cells
        with a return in this scan (``hit_points_world``) are never seen through.
        """
        n = self._n
        a = np.asarray(beam_angles_world, dtype=float).reshape(-1)
        nb = a.size
        if n == 0 or nb == 0:
            return 0
        rho = np.where(np.asarray(hit, dtype=bool), np.asarray(ranges_m, dtype=float), math.inf)
        o = np.asarray(origin_m, dtype=float).reshape(2)
        rel = (self._cells[:n] + 0.5) * self.cell_m - o
        r = np.hypot(rel[:, 0], rel[:, 1])
        half = _HALF_EXTENT_CELLS * self.cell_m
        far = r + half
        live = (far < max_range_m) & (r > half)  # the sensor's own cell is never carved
        if not live.any():
            return 0
        rows = np.flatnonzero(live)
        dth = (a[-1] - a[0]) / (nb - 1) if nb > 1 else 2.0 * math.pi
        centre = 0.5 * (a[0] + a[-1])
        bearing = np.arctan2(rel[rows, 1], rel[rows, 0]) - centre
        bearing = (bearing + math.pi) % (2.0 * math.pi) - math.pi + centre - a[0]  # from beam 0, fan-centred
        ext = np.maximum(half / r[rows], 0.5 * dth)
        lo = np.ceil((bearing - ext) / dth - 1e-9)  # first beam at or after bearing − ext
        hi = np.floor((bearing + ext) / dth + 1e-9)
        if full_circle:
            shift = np.floor(lo / nb) * nb
            lo, hi = lo - shift, hi - shift  # lo in [0, nb)
            hi = np.minimum(hi, lo + nb - 1)
            doubled = np.concatenate([rho, rho])
        else:
            inside = (lo >= 0) & (hi <= nb - 1)
            rows, lo, hi, bearing = rows[inside], lo[inside], hi[inside], bearing[inside]
            doubled = rho
        if rows.size == 0:
            return 0
        nearest = np.rint(bearing / dth)
        if full_circle:
            nearest = np.mod(nearest, nb)
        empty = hi < lo  # the cell falls between two beams: use the nearest one
        lo = np.where(empty, np.clip(nearest, 0, nb - 1), lo).astype(np.int64)
        hi = np.where(empty, lo, hi).astype(np.int64)
        edges = np.empty(2 * lo.size, dtype=np.int64)
        edges[0::2], edges[1::2] = lo, hi + 1
        seen = np.minimum.reduceat(np.append(doubled, math.inf), edges)[0::2]
        free = seen > far[rows] + self.carve_margin_m + 3.0 * range_noise_std_m
        if hit_points_world is not None and free.any():
            p = np.asarray(hit_points_world, dtype=float).reshape(-1, 2)
            if p.shape[0]:
                cells = np.floor(p / self.cell_m).astype(np.int64).tolist()
                now = {self._index[(i, j)] for i, j in cells if (i, j) in self._index}
                if now:
                    free &= ~np.isin(rows, np.fromiter(now, dtype=np.int64))
        rows = rows[free]
        if rows.size:
            self._set_scores(rows, np.maximum(self._score[rows] - self.miss_weight, 0.0))
        return int(rows.size)

    def _row(self, i: int, j: int) -> int:
        k = self._index.get((i, j))
        if k is None:
            k = self._n
            if k == self._cells.shape[0]:
                size = max(64, 2 * k)
                self._cells = np.resize(self._cells, (size, 2))
                self._score = np.concatenate([self._score, np.zeros(size - self._score.size)])
            self._cells[k] = (i, j)
            self._score[k] = 0.0
            self._index[(i, j)] = k
            self._n += 1
        return k

    def _set_scores(self, rows: np.ndarray, new: np.ndarray) -> None:
        m = self.min_hits
        was = self._score[rows] >= m
        self._score[rows] = new
        now = new >= m
        change = int(now.sum()) - int(was.sum())
        if change or (was != now).any():
            self._n_occupied += change
            self._version += 1

    # ------------------------------------------------------------------ queries
    def occupied(self, points_world: np.ndarray) -> np.ndarray:
        """(k,) bool: the point lies in an occupied cell."""
        p = np.asarray(points_world, dtype=float).reshape(-1, 2)
        cells = np.floor(p / self.cell_m).astype(np.int64).tolist()
        idx, score, m = self._index, self._score, self.min_hits
        return np.array([(k := idx.get((i, j))) is not None and score[k] >= m for i, j in cells], dtype=bool)

    @property
    def n_occupied(self) -> int:
        return self._n_occupied

    @property
    def version(self) -> int:
        """Changes whenever a cell becomes occupied or free (for caches and the recording)."""
        return self._version

    def occupied_cells(self) -> np.ndarray:
        """(c, 2) integer cell indices of the occupied cells."""
        n = self._n
        return self._cells[:n][self._score[:n] >= self.min_hits].reshape(-1, 2)

    def polygons(self) -> list[np.ndarray]:
        """Convex polygons (k, 2) [m] covering the occupied cells (cached until the map changes)."""
        if self._version == self._cached_version:
            return list(self._cache)
        cells = self.occupied_cells()
        out: list[np.ndarray] = []
        if cells.size:
            lo = cells.min(axis=0)
            grid = np.zeros(tuple(cells.max(axis=0) - lo + 1), dtype=bool)
            grid[tuple((cells - lo).T)] = True
            labels, n = ndimage.label(grid, structure=np.ones((3, 3)))
            for k in range(1, n + 1):
                comp = np.argwhere(labels == k) + lo
                self._split(comp, 0, out)
        self._cache, self._cached_version = out, self._version
        return list(out)

    def _split(self, comp: np.ndarray, depth: int, out: list) -> None:
        corners = (comp[:, None, :] + _CORNERS[None, :, :]).reshape(-1, 2) * self.cell_m
        try:
            hull = ConvexHull(corners)
        except QhullError:
            return
        fill = comp.shape[0] * self.cell_m**2 / hull.volume
        if fill >= self.min_fill or comp.shape[0] <= 4 or depth >= self.max_depth:
            out.append(corners[hull.vertices])
            return
        c = comp - comp.mean(axis=0)
        _, vec = np.linalg.eigh(c.T @ c)
        proj = c @ vec[:, -1]
        cut = np.median(proj)
        left = proj <= cut
        if left.all() or not left.any():
            out.append(corners[hull.vertices])
            return
        self._split(comp[left], depth + 1, out)
        self._split(comp[~left], depth + 1, out)
