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

``polygons()`` turns the occupied cells into convex polygons for the planner
(:mod:`mjasc.perception.map_polygons`), only when asked and the map changed since the last call.

**One table for a fleet.** :class:`StaticMapStore` holds the maps of many vessels in one table of
cells keyed by (member, i, j) (packed into one int64, looked up by binary search in a sorted
copy of the keys): one call adds the static returns of every vessel's scan, one call carves the
free space seen by every vessel's fan, one call answers "is this return on a mapped cell" for all
returns of a tick. :class:`StaticMap` is one vessel's view of a store (a map built on its own is
a view of a store of one); its results are the same whichever store it lives in (every step is
per cell or per beam, reductions are per cell).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from mjasc.core.config_tables import check_params, param
from mjasc.perception.carve_kernels import cells_in_reach, cells_seen_through
from mjasc.perception.cell_keys import IJ_BITS, IJ_HALF, MEMBER_SHIFT, create_rows, find_rows, point_keys
from mjasc.perception.map_polygons import PolygonCache
from mjasc.perception.score_kernels import add_hits, carve_cells, cell_rows, occupied_points, set_scores

__all__ = ["StaticMap", "StaticMapConfig", "StaticMapStore"]


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


def _cell_keys(member: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """(k,) int64 keys of cells (k, 2) of members (k,), ordered like (member, i, j)."""
    if cells.size and (cells.min() < -IJ_HALF or cells.max() >= IJ_HALF):
        raise ValueError(f"points_world: a cell index beyond ±{IJ_HALF} cells (a position of "
                         f"{np.abs(cells).max()} cells from the origin)")
    return ((member << MEMBER_SHIFT) | ((cells[:, 0] + IJ_HALF) << IJ_BITS)) | (cells[:, 1] + IJ_HALF)


class StaticMapStore:
    """The static maps of many vessels (members) in one table of scored cells, one row per
    (member, cell) ever hit. Rows keep their order of creation (a member's rows in the order its
    own map would have created them)."""

    def __init__(self):
        self._configs: list[StaticMapConfig] = []
        z = np.zeros(0)
        self._cell_m, self._min_hits, self._cap, self._miss, self._margin = z, z, z, z, z
        self._version = np.zeros(0, dtype=np.int64)
        self._n_occupied = np.zeros(0, dtype=np.int64)
        self._keys = np.zeros(0, dtype=np.int64)  # sorted keys of the rows …
        self._key_rows = np.zeros(0, dtype=np.int64)  # … and their rows
        self._cells = np.zeros((0, 2), dtype=np.int64)
        self._member = np.zeros(0, dtype=np.int64)
        self._score = np.zeros(0)
        self._n = 0
        self._memos: dict[tuple, dict] = {}  # polygon_memo: (cell_m, min_fill, max_depth) → pieces

    def polygon_memo(self, cell_m: float, min_fill: float, max_depth: int) -> dict:
        """The pieces memo (:class:`~mjasc.perception.map_polygons.PolygonCache`) shared by the
        maps of this store with this cell size [m], ``min_fill`` and ``max_depth``."""
        key = (float(cell_m), float(min_fill), int(max_depth))
        got = self._memos.get(key)
        if got is None:
            got = self._memos[key] = {}
        return got

    def add_member(self, config: StaticMapConfig) -> int:
        """A new (empty) map with this config; returns its member index."""
        k = len(self._configs)
        if k >= 1 << 15:
            raise ValueError("StaticMapStore: at most 32768 maps")
        self._configs.append(config)
        c = config
        app = lambda a, v: np.append(a, v)  # noqa: E731
        self._cell_m = app(self._cell_m, float(c.cell_m))
        self._min_hits = app(self._min_hits, float(int(c.min_hits)))
        self._cap = app(self._cap, float(int(c.min_hits) + int(c.headroom)))
        self._miss = app(self._miss, float(c.miss_weight))
        self._margin = app(self._margin, float(c.carve_margin_m))
        self._version = app(self._version, 0)
        self._n_occupied = app(self._n_occupied, 0)
        return k

    # ------------------------------------------------------------------ the table
    def _cells_of(self, member: np.ndarray, points: np.ndarray) -> np.ndarray:
        return np.floor(points / self._cell_m[member][:, None]).astype(np.int64)

    def _keys_of(self, member: np.ndarray, points: np.ndarray) -> np.ndarray:
        """(k,) int64 keys of the cells of points (k, 2) [m] of members (k,) (:mod:`mjasc.perception.cell_keys`)."""
        keys, ok = point_keys(member, points, self._cell_m)
        if not ok:  # a cell index out of range (or a point not finite): the one-line error
            return _cell_keys(member, self._cells_of(member, points))
        return keys

    def _find(self, keys: np.ndarray) -> np.ndarray:
        """(k,) rows of keys (−1: no such row)."""
        return find_rows(keys, self._keys, self._key_rows)

    def _rows(self, keys: np.ndarray) -> np.ndarray:
        """Rows of the distinct (member, cell) keys given, in key order, created (score 0) where
        missing (new rows in key order)."""
        keys = np.unique(keys)
        return self._create(keys, self._find(keys))

    def _create(self, keys: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """``rows`` (u,) of the distinct ascending ``keys`` (u,) with the missing ones (−1) created."""
        new = rows < 0
        if new.any():
            nk = keys[new]
            k, n = nk.size, self._n
            if n + k > self._cells.shape[0]:
                size = max(64, 2 * (n + k))
                self._cells = np.resize(self._cells, (size, 2))
                self._member = np.resize(self._member, size)
                self._score = np.resize(self._score, size)
            self._keys, self._key_rows = create_rows(nk, n, self._cells, self._member, self._score, self._keys,
                                                     self._key_rows)
            self._n = n + k
            rows[new] = np.arange(n, n + k)
        return rows

    def pass_tables(self, extra_rows: int) -> tuple:
        """The table as a compiled pass updates it in place (:func:`mjasc.perception.map_pass.sense_map`),
        with room for ``extra_rows`` new rows: per member cell size, then the sorted keys and their
        rows, cells, member and score of the rows, the number of rows, per member the score cap,
        min hits, occupied count, version, miss weight and carve margin. The pass's new rows are
        taken over with :meth:`set_rows`."""
        need = self._n + extra_rows
        if need > self._cells.shape[0]:
            size = max(64, 2 * need)
            self._cells = np.resize(self._cells, (size, 2))
            self._member = np.resize(self._member, size)
            self._score = np.resize(self._score, size)
        return (self._cell_m, self._keys, self._key_rows, self._cells, self._member, self._score, self._n, self._cap,
                self._min_hits, self._n_occupied, self._version, self._miss, self._margin)

    def set_rows(self, sorted_keys: np.ndarray, key_rows: np.ndarray, n: int) -> None:
        """After a compiled pass on :meth:`pass_tables` that created rows: the sorted keys with
        their rows and the number of rows."""
        self._keys, self._key_rows, self._n = sorted_keys, key_rows, int(n)

    def _set_scores(self, rows: np.ndarray, new: np.ndarray) -> None:
        """New scores of (distinct) rows; a member's version changes when one of its cells
        becomes occupied or free (:func:`~mjasc.perception.score_kernels.set_scores`)."""
        set_scores(rows, new, self._score, self._member, self._min_hits, self._n_occupied, self._version)

    # ------------------------------------------------------------------ updates
    def add_points(self, member: np.ndarray, points_world: np.ndarray) -> None:
        """One scan's static returns (k, 2) [m] of the members (k,) given per return: +1 per
        (member, cell) hit, capped at min_hits + headroom."""
        p = np.asarray(points_world, dtype=float).reshape(-1, 2)
        if p.shape[0] == 0:
            return
        member = np.asarray(member, dtype=np.int64)
        keys, rows, ok = cell_rows(member, p, self._cell_m, self._keys, self._key_rows)
        if not ok:  # a cell index out of range (or a point not finite): the one-line error
            keys = np.unique(self._keys_of(member, p))
            rows = self._find(keys)
        rows = self._create(keys, rows)
        add_hits(rows, self._score, self._member, self._cap, self._min_hits, self._n_occupied, self._version)

    def carve(self, members: Sequence[int], origins_m, beam_angles_world: Sequence[np.ndarray],
              ranges_m: Sequence[np.ndarray], hit: Sequence[np.ndarray], max_range_m, full_circle,
              range_noise_std_m, hit_points_world: Sequence[np.ndarray | None]) -> np.ndarray:
        """Free-space update from one scan of each of ``members`` (q,) (per member: sensor origin
        (2,), beam angles (n,) uniformly spaced increasing [rad], ranges (n,) and hit (n,), max
        range, full circle or not, σ_ρ, the scan's returns (k, 2) or None); returns (q,) the number
        of cells each scan saw through (:meth:`StaticMap.carve`)."""
        q = len(members)
        if self._n == 0 or q == 0:
            return np.zeros(q, dtype=np.int64)
        nb = np.array([np.size(a) for a in beam_angles_world], dtype=np.int64)
        a0 = [a[0] if np.size(a) else 0.0 for a in beam_angles_world]
        a1 = [a[-1] if np.size(a) else 0.0 for a in beam_angles_world]
        beam_off = np.zeros(q, dtype=np.int64)
        np.cumsum(nb[:-1], out=beam_off[1:])
        cat = np.concatenate
        pts = [np.asarray(p, dtype=float).reshape(-1, 2) for p in hit_points_world if p is not None]
        pm = cat([np.full(np.asarray(p).reshape(-1, 2).shape[0], int(m), dtype=np.int64)
                  for m, p in zip(members, hit_points_world) if p is not None] or [np.zeros(0, dtype=np.int64)])
        ranges = cat([np.asarray(x, dtype=float).reshape(-1) for x in ranges_m])
        hits = cat([np.asarray(x, dtype=bool).reshape(-1) for x in hit])
        return self._carve(np.asarray(members, dtype=np.int64), np.asarray(origins_m, dtype=float).reshape(q, 2), nb,
                           a0, a1, max_range_m, full_circle, ranges, hits, beam_off, range_noise_std_m, pm,
                           cat(pts) if pts else np.zeros((0, 2)))

    def carve_stack(self, members: np.ndarray, stack, range_noise_std_m, point_member: np.ndarray | None = None
                    ) -> np.ndarray:
        """:meth:`carve` of the scans of a :class:`~mjasc.perception.scan_batch.ScanStack`, scan s
        by member ``members[s]`` (its σ_ρ ``range_noise_std_m[s]``): the same update, the scans'
        arrays and their sensors' constants taken stacked as they are. ``point_member``: the member
        of each of the stack's returns (``np.repeat(members, np.diff(stack.ret_off))``), if made."""
        q = stack.origins_m.shape[0]
        if self._n == 0 or q == 0:
            return np.zeros(q, dtype=np.int64)
        if point_member is None:
            point_member = np.repeat(members, np.diff(stack.ret_off))
        # the world angle of each fan's first and last beam, as ``angles_body + heading_rad`` has them
        h = stack.headings_rad
        return self._carve(members, stack.origins_m, stack.n_beams, stack.first_angle_body + h,
                           stack.last_angle_body + h, stack.max_range_m, stack.full_circle, stack.ranges_m, stack.hit,
                           stack.beam_off[:-1], range_noise_std_m, point_member, stack.hit_points_world)

    def _carve(self, members, o, nb, a0, a1, max_range_m, full_circle, ranges, hit, beam_off, range_noise_std_m,
               point_member, points) -> np.ndarray:
        """:meth:`carve` on arrays: per fan (q,) member, origin (q, 2), beams, world angle of the
        first and last beam, max range, full circle, σ_ρ; ranges and hit stacked (fan q from
        ``beam_off[q]``); the fans' returns (k, 2) with their members (k,)."""
        q = members.shape[0]
        counts = np.zeros(q, dtype=np.int64)
        n = self._n
        slot = np.full(self._version.size, -1)
        slot[members] = np.where(nb > 0, np.arange(q), -1)
        row_member = self._member[:n]
        rows, qi, rel, r, half, far = cells_in_reach(self._cells[:n], row_member, slot, self._cell_m, o,
                                                     np.asarray(max_range_m, dtype=float).reshape(q))
        if rows.size == 0:
            return counts
        a0 = np.asarray(a0, dtype=float)
        a1 = np.asarray(a1, dtype=float)
        full = np.asarray(full_circle, dtype=bool).reshape(q)
        noise = np.asarray(range_noise_std_m, dtype=float).reshape(q)
        bearing = np.arctan2(rel[:, 1], rel[:, 0])
        got, ok = carve_cells(rows, row_member, self._margin, qi, bearing, r, half, far, a0, a1, nb, full, ranges, hit,
                              beam_off, noise, point_member, points, self._cell_m, self._keys, self._key_rows,
                              self._score, self._member, self._miss, self._min_hits, self._n_occupied, self._version)
        if ok:
            return got
        # a return's cell index out of range (nothing was changed): the numpy form raises the one-line error
        dth_m = np.where(nb > 1, (a1 - a0) / np.maximum(nb - 1, 1), 2.0 * math.pi)
        free = cells_seen_through(rows, row_member, self._margin, qi, bearing, r, half, far, a0, dth_m, 0.5 * (a0 + a1),
                                  nb, full, ranges, hit, beam_off, noise)
        if free.any() and points.shape[0]:
            now = self._find(self._keys_of(point_member, points))
            hit_now = np.zeros(n, dtype=bool)  # cells with a return in this scan stay
            hit_now[now[now >= 0]] = True
            free &= ~hit_now[rows]
        rows = rows[free]
        if rows.size:
            self._set_scores(rows, np.maximum(self._score[rows] - self._miss[self._member[rows]], 0.0))
            counts += np.bincount(qi[free], minlength=q)
        return counts

    # ------------------------------------------------------------------ queries
    def occupied(self, member: np.ndarray, points_world: np.ndarray) -> np.ndarray:
        """(k,) bool: the point lies in an occupied cell of its member's map (members (k,))."""
        p = np.asarray(points_world, dtype=float).reshape(-1, 2)
        if self._n == 0:
            return np.zeros(p.shape[0], dtype=bool)
        member = np.asarray(member, dtype=np.int64)
        occ, ok = occupied_points(member, p, self._cell_m, self._keys, self._key_rows, self._score, self._member,
                                  self._min_hits)
        if ok:
            return occ
        rows = self._find(self._keys_of(member, p))  # raises the one-line error
        safe = np.maximum(rows, 0)
        return (rows >= 0) & (self._score[safe] >= self._min_hits[self._member[safe]])

    def any_occupied(self, members: np.ndarray) -> bool:
        """One of the maps ``members`` has an occupied cell."""
        return bool(self._n_occupied[members].any())

    def occupied_cells(self, member: int) -> np.ndarray:
        """(c, 2) integer cell indices of a member's occupied cells, in row order."""
        n = self._n
        sel = (self._member[:n] == member) & (self._score[:n] >= self._min_hits[member])
        return self._cells[:n][sel].reshape(-1, 2)

    def version(self, member: int) -> int:
        return int(self._version[member])

    def n_occupied(self, member: int) -> int:
        return int(self._n_occupied[member])


class StaticMap:
    """One vessel's grid of static returns. ``add_scan(points)`` (hits), ``carve(...)`` (rays seen
    through), ``occupied(points)``, ``occupied_cells()``, ``polygons()``; ``version`` changes
    whenever the set of occupied cells does. The arguments are those of :class:`StaticMapConfig`
    (``config``); ``store``: the :class:`StaticMapStore` it lives in (default: a store of its own)."""

    def __init__(self, cell_m: float = 1.0, min_hits: int = 3, min_fill: float = 0.4, max_depth: int = 6,
                 headroom: int = 5, miss_weight: float = 0.5, carve_margin_m: float = 1.0,
                 store: StaticMapStore | None = None):
        self.config = c = StaticMapConfig(cell_m, min_hits, min_fill, max_depth, headroom, miss_weight, carve_margin_m)
        self.cell_m = float(c.cell_m)
        self.min_hits = int(c.min_hits)
        self.min_fill = float(c.min_fill)
        self.max_depth = int(c.max_depth)
        self.cap = float(self.min_hits + int(c.headroom))
        self.miss_weight = float(c.miss_weight)
        self.carve_margin_m = float(c.carve_margin_m)
        self.store = StaticMapStore() if store is None else store
        self.member = self.store.add_member(c)
        self._polys = PolygonCache(self.cell_m, self.min_fill, self.max_depth,
                                   self.store.polygon_memo(self.cell_m, self.min_fill, self.max_depth))
        self._cache: list[np.ndarray] = []
        self._cached_version = 0

    def add_scan(self, points_world: np.ndarray) -> None:
        """Add one scan's returns (k, 2) [m] of static structures (each cell counted once per scan)."""
        p = np.asarray(points_world, dtype=float).reshape(-1, 2)
        self.store.add_points(np.full(p.shape[0], self.member, dtype=np.int64), p)

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
        a = np.asarray(beam_angles_world, dtype=float).reshape(-1)
        return int(self.store.carve([self.member], [origin_m], [a], [ranges_m], [hit], [max_range_m], [full_circle],
                                    [range_noise_std_m], [hit_points_world])[0])

    def occupied(self, points_world: np.ndarray) -> np.ndarray:
        """(k,) bool: the point lies in an occupied cell."""
        p = np.asarray(points_world, dtype=float).reshape(-1, 2)
        return self.store.occupied(np.full(p.shape[0], self.member, dtype=np.int64), p)

    @property
    def n_occupied(self) -> int:
        return self.store.n_occupied(self.member)

    @property
    def version(self) -> int:
        """Changes whenever a cell becomes occupied or free (for caches and the recording)."""
        return self.store.version(self.member)

    def occupied_cells(self) -> np.ndarray:
        """(c, 2) integer cell indices of the occupied cells."""
        return self.store.occupied_cells(self.member)

    @property
    def built_version(self) -> int:
        """The map version the polygons were last computed for (0 before any): what
        :meth:`built_polygons` would say first, without copying the polygons' list."""
        return self._cached_version

    def built_polygons(self) -> tuple[int, list[np.ndarray]]:
        """The map version the polygons were last computed for (:meth:`polygons`; 0 before any) and
        those polygons, building nothing: what the avoidance last planned around."""
        return self._cached_version, list(self._cache)

    def polygons(self) -> list[np.ndarray]:
        """Convex polygons (k, 2) [m] covering the occupied cells (computed when asked after the
        map changed; :mod:`mjasc.perception.map_polygons`)."""
        v = self.version
        if v != self._cached_version:
            self._cache, self._cached_version = self._polys.polygons(self.occupied_cells()), v
        return list(self._cache)
