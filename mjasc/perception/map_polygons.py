"""Occupied cells of a static map → convex polygons for the planner (world ENU [m]).

The occupied cells (integer indices (i, j) of ``cell_m`` squares, :mod:`mjasc.perception.static_map`)
are grouped into 8-connected components (``scipy.ndimage.label``'s, numbered in raster order of
their first cell; :func:`~mjasc.perception.hull_kernels.components`). Each component is split
recursively (at the median of its cells along their principal axis) until its cells fill at least
``min_fill`` of their convex hull (scipy's qhull; a piece whose fill the hull's exact area,
:mod:`mjasc.perception.hull_kernels`, puts clearly below is split without building it) or
``max_depth`` is reached, so that an L- or U-shaped dock
becomes a few convex pieces hugging its walls instead of one hull covering its basin. Each polygon
is the convex hull of its cells' corners (counter-clockwise, conservative by up to one cell).

A map changes a few cells at a time, mostly in one structure: :class:`PolygonCache` keeps the
pieces of every component, and of every part of one met while splitting it, keyed by its depth and
its cells, and splits only what it has not split before (a part's pieces depend only on its own
cells, taken in row-major order, and its depth): a cell added at one end of a wall changes the
component, but often leaves a half or a quarter of it as it was. The maps of one fleet share their
memo (``PolygonCache(…, memo=)``, :meth:`mjasc.perception.static_map.StaticMapStore.polygon_memo`):
vessels that map the same structure meet the same parts (a part's pieces depend only on its cells,
its depth, the cell size, ``min_fill`` and ``max_depth``).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull, QhullError

try:  # (scipy's own qhull wrapper, which ConvexHull drives; private: ConvexHull itself if it ever moves)
    from scipy.spatial._qhull import _Qhull
except ImportError:  # pragma: no cover - the pinned scipy has it (requirements.lock)
    _Qhull = None

from mjasc.perception.hull_kernels import centred, components, halves, hull_area2
from mjasc.perception.hull_kernels import corners as cell_corners

__all__ = ["PolygonCache", "hull_2d", "split_component"]

#: A piece's fill (its cells over its hull's exact area, :func:`~mjasc.perception.hull_kernels.hull_area2`)
#: this far (relative) below ``min_fill`` is below it by qhull's area too (qhull's area is within
#: ~3e-11 of the exact one even a million cells from the origin).
SURE_SPARSE = 1e-6
#: The parts a :class:`PolygonCache` remembers at most (then it starts again from none).
MEMO_PARTS = 4096


def hull_2d(points: np.ndarray) -> tuple[np.ndarray, float]:
    """The convex hull of ``points`` (p, 2) float64 [m] as ``scipy.spatial.ConvexHull(points)``
    has it: its vertices' indices (counter-clockwise, from qhull's starting vertex) and its area
    [m²] (``.vertices``, ``.volume``); raises ``QhullError`` as it does. The same qhull run
    (options ``i Qt``, triangulated) without the facet arrays ConvexHull also builds, which cost
    about a third of its time on a piece's few dozen corners (its test compares the two). A scipy
    without that private wrapper gets ConvexHull itself (the same results, slower)."""
    if _Qhull is None:
        hull = ConvexHull(points)
        return hull.vertices, hull.volume
    qhull = _Qhull(b"i", points, b"", required_options=b"Qt")
    try:
        qhull.triangulate()
        area, _ = qhull.volume_area()
        return qhull.get_extremes_2d(), area
    finally:
        qhull.close()


def split_component(comp: np.ndarray, cell_m: float, min_fill: float, max_depth: int, depth: int, out: list,
                    memo: dict | None = None) -> None:
    """Append to ``out`` the convex pieces (k, 2) [m] of one component's cells ``comp`` (c, 2).
    ``memo``: the pieces of the parts split before, by (depth, cells' bytes), taken instead of
    splitting them again (and this part's and its parts' pieces added)."""
    if memo is None:
        _split(comp, cell_m, min_fill, max_depth, depth, out, None)
        return
    key = (depth, comp.tobytes())
    got = memo.get(key)
    if got is None:
        got = memo[key] = []
        _split(comp, cell_m, min_fill, max_depth, depth, got, memo)
    out.extend(got)


def _split(comp, cell_m, min_fill, max_depth, depth, out, memo) -> None:
    corners = None  # (made only when qhull is asked)
    vertices = None
    n = comp.shape[0]
    if n <= 4 or depth >= max_depth or not 2.0 * n < min_fill * hull_area2(comp) * (1.0 - SURE_SPARSE):
        # a piece, or a fill that the hull's exact area does not put clearly below min_fill: qhull's
        # area decides, as it always did (a piece clearly too sparse is split without its hull)
        corners = cell_corners(comp, cell_m)  # (qhull's input: four corners per cell [m])
        try:
            vertices, area = hull_2d(corners)
        except QhullError:
            return
        fill = n * cell_m**2 / area
        if fill >= min_fill or n <= 4 or depth >= max_depth:
            out.append(corners[vertices])
            return
    c = centred(comp)  # (comp - comp.mean(axis=0))
    _, vec = np.linalg.eigh(c.T @ c)
    proj = c @ vec[:, -1]
    left, right = halves(comp, proj)  # (comp[proj <= median], the others, in one compiled pass)
    if not left.shape[0]:  # every cell on one side
        if vertices is None:
            corners = cell_corners(comp, cell_m)
            vertices, _ = hull_2d(corners)
        out.append(corners[vertices])
        return
    split_component(left, cell_m, min_fill, max_depth, depth + 1, out, memo)
    split_component(right, cell_m, min_fill, max_depth, depth + 1, out, memo)


class PolygonCache:
    """Convex pieces of one map's occupied cells; a component, or a part of one, split once (module
    docstring). ``memo``: the dict of pieces to use, shared with the caches of the same cell size,
    ``min_fill`` and ``max_depth`` (default: one of its own)."""

    def __init__(self, cell_m: float, min_fill: float, max_depth: int, memo: dict | None = None):
        self.cell_m, self.min_fill, self.max_depth = float(cell_m), float(min_fill), int(max_depth)
        self._pieces: dict[tuple, list[np.ndarray]] = {} if memo is None else memo  # (depth, cells' bytes) → pieces

    def polygons(self, cells: np.ndarray) -> list[np.ndarray]:
        """Pieces of the occupied cells ``cells`` (c, 2) int64, components in raster order of
        their first cell (``ndimage.label``'s numbering)."""
        out: list[np.ndarray] = []
        if cells.size == 0:
            return out
        ordered, counts = components(cells)  # by component, then row-major (ndimage.label's numbering)
        ends = np.cumsum(counts).tolist()
        comps = [ordered[a:b] for a, b in zip([0] + ends[:-1], ends)]
        if len(self._pieces) > MEMO_PARTS:
            self._pieces.clear()  # (in place: a shared memo starts again for every cache that holds it)
        for comp in comps:
            split_component(comp, self.cell_m, self.min_fill, self.max_depth, 0, out, self._pieces)
        return out
