"""Compiled loops behind the cell table of :class:`mjasc.perception.static_map.StaticMapStore`:
from world points to the keys and rows of their cells (world ENU, metres).

A point p of member m falls in cell ``(i, j) = (⌊p_x / cell⌋, ⌊p_y / cell⌋)`` (``cell`` the member's
cell size [m]); its key packs ``(m, i, j)`` into one int64,
``(m << 48) | ((i + 2²³) << 24) | (j + 2²³)``, ordered like (member, i, j), for cell indices in
[−2²³, 2²³). The store keeps its keys sorted with the row of each; a key's row is found by binary
search (−1: no such row). These are the numpy form's expressions (``np.floor(p / cell)``, the shifts,
``np.searchsorted`` and an equality test; kept in ``tests/test_cell_keys.py`` as the reference), so
the keys and rows are the same. :func:`create_rows` appends the rows of new keys to the table and
merges their keys into the sorted ones (what ``np.insert`` at ``np.searchsorted`` did).
"""

from __future__ import annotations

import numpy as np

from mjasc.core.compiled import kernel

__all__ = ["point_keys", "find_rows", "create_rows", "IJ_BITS", "IJ_HALF", "MEMBER_SHIFT"]

IJ_BITS = 24  # cell indices i, j in [−2²³, 2²³) (±8,388 km at 1 m cells); members < 2¹⁵
IJ_HALF = 1 << (IJ_BITS - 1)
MEMBER_SHIFT = 2 * IJ_BITS


@kernel
def point_keys(member, points, cell_m):
    """Keys (k,) int64 of the cells of ``points`` (k, 2) [m] of members ``member`` (k,) (cell size
    ``cell_m[member]`` [m]) and whether every cell index is within [−2²³, 2²³) (False: a point too
    far or not finite; its key is meaningless)."""
    k = points.shape[0]
    keys = np.empty(k, dtype=np.int64)
    ok = True
    for n in range(k):
        m = member[n]
        cell = cell_m[m]
        fi = np.floor(points[n, 0] / cell)
        fj = np.floor(points[n, 1] / cell)
        if not (-IJ_HALF <= fi < IJ_HALF and -IJ_HALF <= fj < IJ_HALF):
            ok = False
            keys[n] = 0
            continue
        i, j = np.int64(fi), np.int64(fj)
        keys[n] = ((m << MEMBER_SHIFT) | ((i + IJ_HALF) << IJ_BITS)) | (j + IJ_HALF)
    return keys, ok


@kernel
def find_rows(keys, sorted_keys, key_rows):
    """(k,) the row of each key among ``sorted_keys`` (q,) ascending, distinct, with rows
    ``key_rows`` (q,); −1 where a key has no row."""
    k = keys.shape[0]
    q = sorted_keys.shape[0]
    out = np.full(k, -1, dtype=np.int64)
    for n in range(k):
        key = keys[n]
        lo, hi = 0, q
        while lo < hi:  # the first position with sorted_keys[pos] >= key
            mid = (lo + hi) >> 1
            if sorted_keys[mid] < key:
                lo = mid + 1
            else:
                hi = mid
        if lo < q and sorted_keys[lo] == key:
            out[n] = key_rows[lo]
    return out


@kernel
def create_rows(new_keys, n, cells, member, score, sorted_keys, key_rows):
    """Rows ``n … n + k − 1`` of the table (``cells`` (≥ n + k, 2), ``member``, ``score``, filled in
    place: the cell (i, j) and member a key packs, score 0) for the k distinct ascending keys
    ``new_keys``, none in ``sorted_keys``; returns the sorted keys (n' + k,) with those merged in and
    their rows (``key_rows`` with n, n + 1, … at the new keys' places)."""
    k = new_keys.shape[0]
    mask = (1 << IJ_BITS) - 1
    for q in range(k):
        key = new_keys[q]
        cells[n + q, 0] = ((key >> IJ_BITS) & mask) - IJ_HALF
        cells[n + q, 1] = (key & mask) - IJ_HALF
        member[n + q] = key >> MEMBER_SHIFT
        score[n + q] = 0.0
    m = sorted_keys.shape[0]
    keys = np.empty(m + k, dtype=np.int64)
    rows = np.empty(m + k, dtype=np.int64)
    i = 0
    j = 0
    for o in range(m + k):
        if j < k and (i >= m or new_keys[j] <= sorted_keys[i]):
            keys[o] = new_keys[j]
            rows[o] = n + j
            j += 1
        else:
            keys[o] = sorted_keys[i]
            rows[o] = key_rows[i]
            i += 1
    return keys, rows
