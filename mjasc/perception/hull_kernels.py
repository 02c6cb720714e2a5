"""Compiled loops of the map's polygon split (:func:`mjasc.perception.map_polygons.split_component`):
the exact area of the convex hull of a set of grid cells (integer cell indices, in cells²), to
decide that a piece is too sparse for its hull without building the hull, and the median where a
piece is cut (``np.median``'s value: the middle element of the sorted values, or the mean of the
two middle ones, ``(a + b) / 2``, as numpy's mean of two; NaN if any value is NaN; a zero's sign
may differ from numpy's, which picks among equal values in its partition's order: the split only
compares with it), and the cut itself: a piece's cells centred on their mean (:func:`centred`) and its two
halves at the median (:func:`halves`), numpy's numbers without its per-call overhead; and, before
the split, the map's cells grouped into 8-connected components (:func:`components`:
``ndimage.label``'s components, numbering and order, without building the grid; its test compares
them), and a piece's cell corners as qhull takes them (:func:`corners`).

A cell (i, j) is the unit square with corners (i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1). The
hull of those corners is found by Andrew's monotone chain (corners sorted by x, then y; a turn
that is not strictly counter-clockwise is dropped) and its doubled area by the shoelace formula,
all in int64: exact for cell indices of up to ±2³⁰ (the map's keys allow ±2²⁰,
:mod:`mjasc.perception.cell_keys`). Its test compares it with scipy's ``ConvexHull`` on random
and on mapped cells.
"""

from __future__ import annotations

import numpy as np

from mjasc.core.compiled import kernel

__all__ = ["centred", "components", "corners", "halves", "hull_area2", "median"]


@kernel
def hull_area2(cells):
    """Twice the area [cells²] of the convex hull of the corners of the cells ``cells`` (c, 2)
    int64 (module docstring); 0 for no cells."""
    c = cells.shape[0]
    if c == 0:
        return 0
    m = 4 * c
    x = np.empty(m, dtype=np.int64)
    y = np.empty(m, dtype=np.int64)
    for k in range(c):
        i, j = cells[k, 0], cells[k, 1]
        x[4 * k], y[4 * k] = i, j
        x[4 * k + 1], y[4 * k + 1] = i + 1, j
        x[4 * k + 2], y[4 * k + 2] = i + 1, j + 1
        x[4 * k + 3], y[4 * k + 3] = i, j + 1
    x0 = x.min()
    y0 = y.min()
    key = np.empty(m, dtype=np.int64)
    for k in range(m):
        key[k] = ((x[k] - x0) << 32) | (y[k] - y0)
    order = np.argsort(key)
    hx = np.empty(2 * m + 1, dtype=np.int64)
    hy = np.empty(2 * m + 1, dtype=np.int64)
    h = 0
    for q in range(m):  # lower chain
        px, py = x[order[q]], y[order[q]]
        while h >= 2 and (hx[h - 1] - hx[h - 2]) * (py - hy[h - 2]) - (hy[h - 1] - hy[h - 2]) * (px - hx[h - 2]) <= 0:
            h -= 1
        hx[h], hy[h] = px, py
        h += 1
    low = h + 1
    for q in range(m - 2, -1, -1):  # upper chain
        px, py = x[order[q]], y[order[q]]
        while h >= low and (hx[h - 1] - hx[h - 2]) * (py - hy[h - 2]) - (hy[h - 1] - hy[h - 2]) * (px - hx[h - 2]) <= 0:
            h -= 1
        hx[h], hy[h] = px, py
        h += 1
    a2 = 0
    for k in range(h - 1):  # the chain ends where it started
        a2 += hx[k] * hy[k + 1] - hx[k + 1] * hy[k]
    return a2


@kernel
def median(values):
    """``np.median`` of ``values`` (n ≥ 1,) float (module docstring)."""
    n = values.shape[0]
    s = np.sort(values)  # NaN sorts last, as numpy's partition puts it
    if s[n - 1] != s[n - 1]:
        return s[n - 1]
    h = n // 2
    if n % 2 == 1:
        return s[h]
    return (s[h - 1] + s[h]) / 2.0


@kernel
def halves(comp, proj):
    """The two halves of a piece's cells ``comp`` (c, 2) int64 where it is cut: ``left`` the cells
    whose projection ``proj`` (c,) float is at most :func:`median`'s value (``proj <= cut``), the
    others ``right``, each in ``comp``'s order (``comp[left]``, ``comp[~left]``). Returns (left,
    right), or two empty arrays when one half would be empty (every cell on one side, or a NaN)."""
    n = comp.shape[0]
    cut = median(proj)
    n_left = 0
    for k in range(n):
        if proj[k] <= cut:
            n_left += 1
    if n_left == 0 or n_left == n:
        return np.empty((0, 2), dtype=np.int64), np.empty((0, 2), dtype=np.int64)
    left = np.empty((n_left, 2), dtype=np.int64)
    right = np.empty((n - n_left, 2), dtype=np.int64)
    a = 0
    b = 0
    for k in range(n):
        if proj[k] <= cut:
            left[a, 0], left[a, 1] = comp[k, 0], comp[k, 1]
            a += 1
        else:
            right[b, 0], right[b, 1] = comp[k, 0], comp[k, 1]
            b += 1
    return left, right


@kernel
def centred(comp):
    """The cells ``comp`` (c ≥ 1, 2) int64 minus their mean, (c, 2) float: ``comp - comp.mean(axis=0)``
    bit for bit (the sums of int64 values below 2⁵³ are exact in float64 in any order, the mean is
    the one rounding of sum / c, as numpy's)."""
    n = comp.shape[0]
    sx = 0.0
    sy = 0.0
    for k in range(n):
        sx += float(comp[k, 0])
        sy += float(comp[k, 1])
    mx = sx / n
    my = sy / n
    out = np.empty((n, 2))
    for k in range(n):
        out[k, 0] = comp[k, 0] - mx
        out[k, 1] = comp[k, 1] - my
    return out


@kernel
def components(cells):
    """The 8-connected components of the distinct cells ``cells`` (c ≥ 1, 2) int64: the cells
    ordered by component, then row-major (i, then j), and the number of cells of each component
    (n,), components numbered in row-major order of their first cell — ``ndimage.label``'s
    numbering on the cells' grid with the 3×3 structure, and ``np.lexsort((j, i, label))``'s order.
    Neighbours are found by binary search in the cells' sorted row-major keys, joined by union–find."""
    c = cells.shape[0]
    lo_i, lo_j, hi_j = cells[0, 0], cells[0, 1], cells[0, 1]
    for k in range(c):
        lo_i = min(lo_i, cells[k, 0])
        lo_j = min(lo_j, cells[k, 1])
        hi_j = max(hi_j, cells[k, 1])
    w = hi_j - lo_j + 3  # (j + 1 of the last column never reaches the next row)
    key = np.empty(c, dtype=np.int64)
    for k in range(c):
        key[k] = (cells[k, 0] - lo_i) * w + (cells[k, 1] - lo_j + 1)
    order = np.argsort(key)
    skey = key[order]
    parent = np.arange(c)
    for p in range(c):
        for nk in (skey[p] - w - 1, skey[p] - w, skey[p] - w + 1, skey[p] - 1):
            q = np.searchsorted(skey, nk)
            if q < p and skey[q] == nk:
                a = p
                while parent[a] != a:
                    a = parent[a]
                b = q
                while parent[b] != b:
                    b = parent[b]
                if a != b:
                    if a < b:
                        parent[b] = a
                    else:
                        parent[a] = b
    label = np.full(c, -1, dtype=np.int64)
    lab = np.empty(c, dtype=np.int64)
    n = 0
    for p in range(c):  # (a component's root is its first cell in row-major order)
        r = p
        while parent[r] != r:
            r = parent[r]
        if label[r] < 0:
            label[r] = n
            n += 1
        lab[p] = label[r]
    counts = np.zeros(n, dtype=np.int64)
    for p in range(c):
        counts[lab[p]] += 1
    start = np.zeros(n, dtype=np.int64)
    for q in range(1, n):
        start[q] = start[q - 1] + counts[q - 1]
    out = np.empty((c, 2), dtype=np.int64)
    for p in range(c):
        at = start[lab[p]]
        start[lab[p]] = at + 1
        src = order[p]
        out[at, 0], out[at, 1] = cells[src, 0], cells[src, 1]
    return out, counts


@kernel
def corners(comp, cell_m):
    """The corners (4c, 2) [m] of the cells ``comp`` (c, 2) int64, four per cell in turn: (i, j),
    (i + 1, j), (i + 1, j + 1), (i, j + 1), each ``(index + offset) · cell_m`` in float64, as
    numpy's ``(comp[:, None, :] + offsets).reshape(-1, 2) * cell_m`` rounds it (qhull's input)."""
    c = comp.shape[0]
    out = np.empty((4 * c, 2))
    for k in range(c):
        i, j = float(comp[k, 0]), float(comp[k, 1])
        out[4 * k, 0], out[4 * k, 1] = (i + 0.0) * cell_m, (j + 0.0) * cell_m
        out[4 * k + 1, 0], out[4 * k + 1, 1] = (i + 1.0) * cell_m, (j + 0.0) * cell_m
        out[4 * k + 2, 0], out[4 * k + 2, 1] = (i + 1.0) * cell_m, (j + 1.0) * cell_m
        out[4 * k + 3, 0], out[4 * k + 3, 1] = (i + 0.0) * cell_m, (j + 1.0) * cell_m
    return out
