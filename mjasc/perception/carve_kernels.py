"""Compiled per-cell loops of :meth:`mjasc.perception.static_map.StaticMapStore.carve`: which mapped
cells a tick's fans saw through (world ENU, metres, radians).

For each row (a member's scored cell (i, j) of size ``cell`` [m]) of a member that scanned (fan q,
sensor at o_q):

1. :func:`cells_in_reach` — the cell centre relative to the sensor
   ``rel = ((i, j) + ½)·cell − o_q``, its range ``r = ‖rel‖``, half extent ``h = 0.75·cell`` and far
   side ``far = r + h``; the cell is a candidate when ``far < max range`` and ``r > h`` (never the
   sensor's own cell). Its bearing ``atan2(rel_y, rel_x)`` is then taken by numpy (the caller), whose
   SIMD arctan2 need not round like libm's.
2. :func:`cells_seen_through` — the beams across the cell: with the fan's first beam angle a₀,
   spacing Δθ, n beams and centre angle ā, the bearing from beam 0 (wrapped about the fan's centre)
   ``β = ((atan2 − ā + π) mod 2π − π) + ā − a₀``, the half width ``ε = max(h / r, ½Δθ)``, the beams
   ``lo = ⌈(β − ε)/Δθ − 10⁻⁹⌉ … hi = ⌊(β + ε)/Δθ + 10⁻⁹⌋`` (a full circle: shifted by a multiple of n
   into lo ∈ [0, n), at most n beams; a partial fan: cells beyond its edges are skipped; no beam
   within: the nearest one, ``rint(β/Δθ)``). The cell is seen through when every one of those beams
   reached beyond ``far + margin + 3σ_ρ`` (a beam without a return reaches infinitely far; this is
   "the minimum over the beams is beyond", with NaN never beyond).

Each step evaluates the expressions of the numpy form ``carve`` had (kept in
``tests/test_carve_kernels.py`` as the reference), in the same order, so the map's scores are the
same bits.
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.compiled import kernel, maximum, minimum

__all__ = ["cells_in_reach", "cells_seen_through"]

#: A cell's half-extent as seen from the sensor, in cells (> the half-diagonal √2/2: conservative).
HALF_EXTENT_CELLS = 0.75


@kernel
def cells_in_reach(cells, row_member, slot, cell_m, origins, max_range_m):
    """Candidate rows (step 1 of the module docstring) among the n rows of ``cells`` (n, 2) int
    owned by ``row_member`` (n,): those whose member has a fan (``slot[member]`` ≥ 0, its index q).
    Returns rows (k,), q (k,), rel (k, 2) [m], r (k,), h (k,) and far (k,) [m]; ``cell_m`` per member,
    ``origins`` (Q, 2) and ``max_range_m`` (Q,) per fan."""
    n = cells.shape[0]
    rows = np.empty(n, dtype=np.int64)
    qs = np.empty(n, dtype=np.int64)
    rel = np.empty((n, 2))
    r = np.empty(n)
    half = np.empty(n)
    far = np.empty(n)
    k = 0
    for row in range(n):
        mem = row_member[row]
        q = slot[mem]
        if q < 0:
            continue
        cell = cell_m[mem]
        rx = (cells[row, 0] + 0.5) * cell - origins[q, 0]
        ry = (cells[row, 1] + 0.5) * cell - origins[q, 1]
        rr = math.hypot(rx, ry)
        h = HALF_EXTENT_CELLS * cell
        f = rr + h
        if f < max_range_m[q] and rr > h:
            rows[k], qs[k] = row, q
            rel[k, 0], rel[k, 1] = rx, ry
            r[k], half[k], far[k] = rr, h, f
            k += 1
    return rows[:k].copy(), qs[:k].copy(), rel[:k].copy(), r[:k].copy(), half[:k].copy(), far[:k].copy()


@kernel
def _mod(a, b):
    """numpy's float remainder (the sign of the divisor), as ``np.mod`` / ``%``."""
    m = np.fmod(a, b)
    if m != 0.0:
        if (b < 0.0) != (m < 0.0):
            m += b
    else:
        m = math.copysign(0.0, b)
    return m


@kernel
def cells_seen_through(rows, row_member, margin_m, qs, atan2_rad, r, half, far, a0, dth, centre, n_beams, full,
                       ranges, hit, beam_off, noise_std_m):
    """(k,) bool: candidate cell k (row ``rows[k]`` of member ``row_member[rows[k]]``, whose carve
    margin is ``margin_m[member]`` [m]; fan ``qs[k]``, bearing ``atan2_rad[k]`` [rad], r, h, far [m])
    was seen through (step 2 of the module docstring). Per fan (Q,): first beam
    angle a₀, spacing Δθ and centre angle [rad], beams n, full circle, σ_ρ [m]; the fans' ranges [m]
    and hit flags stacked, fan q from ``beam_off[q]``."""
    k = qs.shape[0]
    free = np.zeros(k, dtype=np.bool_)
    two_pi = 2.0 * math.pi
    for c in range(k):
        q = qs[c]
        d, nb, fc = dth[q], n_beams[q], full[q]
        b = atan2_rad[c] - centre[q]
        b = _mod(b + math.pi, two_pi) - math.pi + centre[q] - a0[q]
        ext = maximum(half[c] / r[c], 0.5 * d)
        lo = np.ceil((b - ext) / d - 1e-9)  # beam indices as floats, as numpy has them
        hi = np.floor((b + ext) / d + 1e-9)
        if fc:
            shift = np.floor(lo / nb) * nb
            lo, hi = lo - shift, hi - shift
            hi = minimum(hi, lo + nb - 1)
        elif not (lo >= 0 and hi <= nb - 1):
            continue
        if hi < lo:  # the cell falls between two beams: the nearest one
            nearest = np.rint(b / d)
            if fc:
                nearest = _mod(nearest, float(nb))
            lo = min(max(nearest, 0.0), float(nb - 1))
            hi = lo
        ilo, ihi = int(lo), int(hi)
        reach = far[c] + margin_m[row_member[rows[c]]] + 3.0 * noise_std_m[q]
        ok = True
        base = beam_off[q]
        for j in range(ilo, ihi + 1):
            jj = j - nb if j >= nb else j
            reached = ranges[base + jj] if hit[base + jj] else math.inf
            if not reached > reach:
                ok = False
                break
        free[c] = ok
    return free
