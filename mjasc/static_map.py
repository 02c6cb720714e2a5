"""A vessel's map of static structures (docks, quay walls, islands) built from its own range returns.

Returns that belong to extended objects (clusters wider than a target, see :mod:`mjasc.detection`)
are accumulated in a world-frame grid of ``cell_m`` cells; a cell counts as occupied once it was hit
in ``min_hits`` different scans (a single false return never makes a wall). The map never forgets
(static structures do not move).

``polygons()`` turns the occupied cells into convex polygons for the planner: 8-connected
components of occupied cells, each split recursively (at the median along its principal axis)
until the cells fill at least ``min_fill`` of their convex hull, so that an L- or U-shaped dock
becomes a few convex pieces hugging its walls instead of one hull covering its basin. Each polygon
is the convex hull of its cells' corners (counter-clockwise, conservative by up to one cell).
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage
from scipy.spatial import ConvexHull, QhullError

__all__ = ["StaticMap"]

_CORNERS = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])


class StaticMap:
    def __init__(self, cell_m: float = 1.0, min_hits: int = 3, min_fill: float = 0.4, max_depth: int = 6):
        if not cell_m > 0:
            raise ValueError(f"cell_m: must be > 0, got {cell_m!r}")
        if int(min_hits) != min_hits or min_hits < 1:
            raise ValueError(f"min_hits: must be an integer ≥ 1, got {min_hits!r}")
        self.cell_m = float(cell_m)
        self.min_hits = int(min_hits)
        self.min_fill = float(min_fill)
        self.max_depth = int(max_depth)
        self._counts: dict[tuple[int, int], int] = {}
        self._n_occupied = 0
        self._cache: list[np.ndarray] = []
        self._cached_n = 0

    def add_scan(self, points_world: np.ndarray) -> None:
        """Add one scan's returns (k, 2) [m] of static structures (each cell counted once per scan)."""
        p = np.asarray(points_world, dtype=float).reshape(-1, 2)
        if p.shape[0] == 0:
            return
        cells = np.unique(np.floor(p / self.cell_m).astype(np.int64), axis=0)
        counts = self._counts
        m = self.min_hits
        for i, j in cells.tolist():
            c = counts.get((i, j), 0) + 1
            counts[(i, j)] = c
            if c == m:
                self._n_occupied += 1

    def occupied(self, points_world: np.ndarray) -> np.ndarray:
        """(k,) bool: the point lies in an occupied cell."""
        p = np.asarray(points_world, dtype=float).reshape(-1, 2)
        cells = np.floor(p / self.cell_m).astype(np.int64).tolist()
        m, counts = self.min_hits, self._counts
        return np.array([counts.get((i, j), 0) >= m for i, j in cells], dtype=bool)

    @property
    def n_occupied(self) -> int:
        return self._n_occupied

    def occupied_cells(self) -> np.ndarray:
        """(c, 2) integer cell indices of the occupied cells."""
        m = self.min_hits
        cells = [k for k, c in self._counts.items() if c >= m]
        return np.array(cells, dtype=np.int64).reshape(-1, 2)

    def polygons(self) -> list[np.ndarray]:
        """Convex polygons (k, 2) [m] covering the occupied cells (cached until the map grows)."""
        if self._n_occupied == self._cached_n:
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
        self._cache, self._cached_n = out, self._n_occupied
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

