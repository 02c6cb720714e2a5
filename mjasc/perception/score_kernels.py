"""Compiled updates of the scored cells of :class:`mjasc.perception.static_map.StaticMapStore`: the
hits of a tick's static returns and the cells its fans saw through, each one call from the points
or the candidate cells to the new scores (world ENU, metres).

The store keeps per row (a member's cell) its score and member, per member its ``min_hits``, score
cap, miss weight, number of occupied cells and a version that changes whenever a cell of that
member becomes occupied or free. These loops evaluate the numpy form ``StaticMapStore`` had (kept
in ``tests/test_score_kernels.py`` as the reference), in the same order:

* :func:`set_scores` — new scores of distinct rows; a row flips when ``score ≥ min_hits`` changes;
  each flip adds ±1 to its member's occupied count, each member with a flip gets version + 1;
* :func:`cell_rows` — the distinct keys of the cells of points (``np.unique`` of
  :func:`~mjasc.perception.cell_keys.point_keys`) and their rows (−1: none yet);
* :func:`add_hits` — +1 per row, capped at the member's ``min_hits + headroom``
  (``min(score + 1, cap)``), then :func:`set_scores`;
* :func:`occupied_points` — each point lies in an occupied cell of its member's map;
* :func:`carve_cells` — :func:`~mjasc.perception.carve_kernels.cells_seen_through` of the candidate
  cells (the fans' angles from their first and last beams: spacing ``(a₁ − a₀)/(n − 1)``, 2π for one
  beam, centre ``½(a₀ + a₁)``), cells with a return of this tick's scans kept, the rest
  ``max(score − miss, 0)`` (:func:`set_scores`); per fan the number of cells seen through.

A point whose cell index is out of range (or not finite) makes the point kernels report ``ok =
False`` without changing anything; the store then takes its numpy path, which raises the one-line
error.
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.compiled import kernel
from mjasc.perception.carve_kernels import cells_seen_through
from mjasc.perception.cell_keys import find_rows, point_keys

__all__ = ["set_scores", "cell_rows", "add_hits", "occupied_points", "carve_cells"]


@kernel
def set_scores(rows, new, score, member, min_hits, n_occupied, version):
    """Scores ``new`` (k,) of the distinct ``rows`` (k,) into ``score`` (in place), with the flips
    counted into ``n_occupied`` and ``version`` (per member, in place; module docstring)."""
    flipped = np.zeros(version.shape[0], dtype=np.bool_)
    for i in range(rows.shape[0]):
        row = rows[i]
        mem = member[row]
        m = min_hits[mem]
        was = score[row] >= m
        score[row] = new[i]
        now = new[i] >= m
        if was != now:
            n_occupied[mem] += 1 if now else -1
            flipped[mem] = True
    for mem in range(version.shape[0]):
        if flipped[mem]:
            version[mem] += 1


@kernel
def cell_rows(point_member, points, cell_m, sorted_keys, key_rows):
    """The distinct keys (u,) ascending of the cells of ``points`` (k, 2) [m] of members
    ``point_member`` (k,), their rows (u,) (−1: not in the table) and whether every cell index was
    in range (False: the rest is meaningless)."""
    keys, ok = point_keys(point_member, points, cell_m)
    if not ok:
        return keys[:0], keys[:0], False
    keys = np.unique(keys)
    return keys, find_rows(keys, sorted_keys, key_rows), True


@kernel
def add_hits(rows, score, member, cap, min_hits, n_occupied, version):
    """+1 on each of the distinct ``rows``, at most the member's ``cap`` (module docstring)."""
    new = np.empty(rows.shape[0])
    for i in range(rows.shape[0]):
        row = rows[i]
        s = score[row] + 1.0
        c = cap[member[row]]
        new[i] = s if s <= c or s != s else c  # np.minimum (NaN propagates, the first wins ties)
    set_scores(rows, new, score, member, min_hits, n_occupied, version)


@kernel
def occupied_points(point_member, points, cell_m, sorted_keys, key_rows, score, member, min_hits):
    """(k,) bool: point k lies in an occupied cell of its member's map, and whether every cell
    index was in range."""
    keys, ok = point_keys(point_member, points, cell_m)
    k = points.shape[0]
    out = np.zeros(k, dtype=np.bool_)
    if not ok:
        return out, False
    rows = find_rows(keys, sorted_keys, key_rows)
    for i in range(k):
        row = rows[i]
        if row >= 0:
            out[i] = score[row] >= min_hits[member[row]]
    return out, True


@kernel
def carve_cells(rows, row_member, margin_m, qs, atan2_rad, r, half, far, a0, a1, n_beams, full, ranges, hit, beam_off,
                noise_std_m, point_member, points, cell_m, sorted_keys, key_rows, score, member, miss, min_hits,
                n_occupied, version):
    """The cells among the candidates (``rows``, fans ``qs``, bearings, r, h, far of
    :func:`~mjasc.perception.carve_kernels.cells_in_reach`) that the fans saw through, less those
    holding one of the tick's returns ``points`` (k, 2) (members ``point_member``), scored down
    (module docstring). Per fan (Q,): world angle of the first and last beam [rad], beams, full
    circle, σ_ρ; ranges and hit stacked from ``beam_off``. Returns the cells seen through per fan
    (Q,) and whether every return's cell index was in range (False: no score was changed)."""
    Q = a0.shape[0]
    counts = np.zeros(Q, dtype=np.int64)
    dth = np.empty(Q)
    centre = np.empty(Q)
    for q in range(Q):
        nb = n_beams[q]
        dth[q] = (a1[q] - a0[q]) / max(nb - 1, 1) if nb > 1 else 2.0 * math.pi
        centre[q] = 0.5 * (a0[q] + a1[q])
    free = cells_seen_through(rows, row_member, margin_m, qs, atan2_rad, r, half, far, a0, dth, centre, n_beams, full,
                              ranges, hit, beam_off, noise_std_m)
    n_free = 0
    for c in range(free.shape[0]):
        if free[c]:
            n_free += 1
    if n_free and points.shape[0]:
        keys, ok = point_keys(point_member, points, cell_m)
        if not ok:
            return counts, False
        now = find_rows(keys, sorted_keys, key_rows)
        hit_now = np.zeros(score.shape[0], dtype=np.bool_)  # cells with a return in this scan stay
        for i in range(now.shape[0]):
            if now[i] >= 0:
                hit_now[now[i]] = True
        for c in range(free.shape[0]):
            if free[c] and hit_now[rows[c]]:
                free[c] = False
                n_free -= 1
    if n_free:
        sel = np.empty(n_free, dtype=np.int64)
        new = np.empty(n_free)
        j = 0
        for c in range(free.shape[0]):
            if free[c]:
                row = rows[c]
                s = score[row] - miss[member[row]]
                sel[j] = row
                new[j] = s if s >= 0.0 or s != s else 0.0  # np.maximum(…, 0.0)
                counts[qs[c]] += 1
                j += 1
        set_scores(sel, new, score, member, min_hits, n_occupied, version)
    return counts, True
