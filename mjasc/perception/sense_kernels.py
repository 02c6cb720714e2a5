"""The compiled loop of a fleet's sensing pass after detection (:meth:`mjasc.perception.fleet.PerceptionFleet._sense`):
which detections go to the tracker, which returns to the static map (world ENU, metres).

S scans' returns are stacked (scan s owns ``ret_off[s] : ret_off[s+1]``, each return labelled with
its detection's index within its scan, −1: dropped) and so are their M detections (scan s owns
``det_off[s] : det_off[s+1]``). The discs of the tracks each scan's vessel follows (centres
(q, 2), radii (q,), grouped by scan ascending) keep returns out of the map. :func:`sort_returns`
does, in one pass, what the numpy form did in ~30 calls (kept in ``tests/test_sense_kernels.py``
as the reference), with its expressions in the same order:

1. a detection is a target unless it is ``extended``;
2. (``occ`` given: one flag per return, "on an occupied cell of its vessel's map") a target is a
   wall fragment when at least half its returns lie on occupied cells (``Σ occ / max(n, 1) ≥ ½``, the
   sum in return order), its centre lies in none of its vessel's discs, and its returns lie within
   ``FLAT_M + 2σ_ρ`` RMS of a straight line (:func:`mjasc.perception.fleet.thickness`: means and
   second moments summed in return order, as ``np.bincount`` sums); such a detection is no target;
3. the returns of the detections that are no targets go to the map (their points and their scan's
   map member), except those inside one of their vessel's discs;
4. the targets with a non-finite centre, radius or variance are dropped (counted per scan).

Per scan it counts the returns, detections, targets kept and non-finite targets dropped.

:func:`tracked_in_walls` finds, before that, the scans where a wall's cluster holds returns inside
one of the vessel's discs: only those are clustered again
(:meth:`mjasc.perception.pipeline.Perception._split_tracked`).
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.compiled import kernel, maximum
from mjasc.perception.owned_discs import _in_a_disc

__all__ = ["sort_returns", "tracked_in_walls"]


@kernel
def _disc_ranges(disc_scan, S):
    """Each scan's discs as a range ``d_lo[s] … d_hi[s] − 1`` of the discs sorted by scan
    (``disc_scan`` (D,), non-decreasing); a scan without discs has ``d_hi[s] = 0``."""
    d_lo = np.zeros(S, dtype=np.int64)
    d_hi = np.zeros(S, dtype=np.int64)
    for j in range(disc_scan.shape[0]):
        s = disc_scan[j]
        if d_hi[s] == 0:
            d_lo[s] = j
        d_hi[s] = j + 1
    return d_lo, d_hi


@kernel
def sort_returns(labels, ret_off, det_off, extended, n_points, centres, radii, variances, points, occ, sigma, flat_m,
                 disc_centres, disc_radii, disc_scan, map_member):
    """Targets (M,) bool, the map's new returns (s, 2) [m] with their map members (s,), and per
    scan (S, 4) the returns, detections, targets and non-finite targets dropped (module
    docstring). ``occ`` (K,) or (0,): not checked; ``sigma`` (S,) σ_ρ [m]; ``map_member`` (S,)."""
    S = ret_off.shape[0] - 1
    K = labels.shape[0]
    M = extended.shape[0]
    scan_of = np.empty(K, dtype=np.int64)
    glab = np.empty(K, dtype=np.int64)
    for s in range(S):
        for i in range(ret_off[s], ret_off[s + 1]):
            scan_of[i] = s
            glab[i] = labels[i] + det_off[s] if labels[i] >= 0 else -1
    det_scan = np.empty(M, dtype=np.int64)
    for s in range(S):
        for d in range(det_off[s], det_off[s + 1]):
            det_scan[d] = s
    d_lo, d_hi = _disc_ranges(disc_scan, S)  # each scan's discs d_lo[s] … d_hi[s] − 1
    targets = np.empty(M, dtype=np.bool_)
    for d in range(M):
        targets[d] = not extended[d]
    if M and occ.shape[0]:
        frac = np.zeros(M)
        for i in range(K):
            if glab[i] >= 0:
                frac[glab[i]] += 1.0 if occ[i] else 0.0
        on_map = np.zeros(M, dtype=np.bool_)
        n_on = 0
        for d in range(M):
            if targets[d] and frac[d] / max(n_points[d], 1) >= 0.5:
                s = det_scan[d]
                if not _in_a_disc(centres[d, 0], centres[d, 1], disc_centres, disc_radii, d_lo[s], d_hi[s]):
                    on_map[d] = True
                    n_on += 1
        if n_on:  # a wall fragment is flat; a hull's returns curve round it
            cnt = np.zeros(M, dtype=np.int64)
            mx = np.zeros(M)
            my = np.zeros(M)
            for i in range(K):
                d = glab[i]
                if d >= 0 and on_map[d]:
                    cnt[d] += 1
                    mx[d] += points[i, 0]
                    my[d] += points[i, 1]
            for d in range(M):
                if on_map[d]:
                    n = max(cnt[d], 1)
                    mx[d] = mx[d] / n
                    my[d] = my[d] / n
            sxx = np.zeros(M)
            syy = np.zeros(M)
            sxy = np.zeros(M)
            for i in range(K):
                d = glab[i]
                if d >= 0 and on_map[d]:
                    dx = points[i, 0] - mx[d]
                    dy = points[i, 1] - my[d]
                    sxx[d] += dx * dx
                    syy[d] += dy * dy
                    sxy[d] += dx * dy
            for d in range(M):
                if on_map[d]:
                    n = max(cnt[d], 1)
                    a, b, c = sxx[d] / n, syy[d] / n, sxy[d] / n
                    tr = 0.5 * (a + b)
                    thick = math.sqrt(maximum(tr - math.sqrt(maximum(tr * tr - (a * b - c * c), 0.0)), 0.0))
                    if thick <= flat_m + 2.0 * sigma[det_scan[d]]:
                        targets[d] = False
    mem = np.empty(K, dtype=np.int64)
    pts = np.empty((K, 2))
    k = 0
    if M:
        for i in range(K):
            d = glab[i]
            if d >= 0 and not targets[d]:
                s = scan_of[i]
                if not _in_a_disc(points[i, 0], points[i, 1], disc_centres, disc_radii, d_lo[s], d_hi[s]):
                    mem[k] = map_member[s]
                    pts[k, 0], pts[k, 1] = points[i, 0], points[i, 1]
                    k += 1
    stats = np.zeros((S, 4), dtype=np.int64)
    for s in range(S):
        stats[s, 0] = ret_off[s + 1] - ret_off[s]
    for d in range(M):
        s = det_scan[d]
        stats[s, 1] += 1
        if targets[d]:
            if (np.isfinite(centres[d, 0]) and np.isfinite(centres[d, 1]) and np.isfinite(radii[d])
                    and np.isfinite(variances[d])):
                stats[s, 2] += 1
            else:
                targets[d] = False
                stats[s, 3] += 1
    return targets, pts[:k], mem[:k], stats


@kernel
def tracked_in_walls(labels, ret_off, det_off, extended, points, disc_centres, disc_radii, disc_scan):
    """(S,) bool: scan s has a return of one of its extended detections (a wall's cluster) inside
    one of its vessel's discs — the scans whose wall clusters may have swallowed a tracked boat's
    returns (:meth:`mjasc.perception.pipeline.Perception._split_tracked` changes nothing elsewhere)."""
    S = ret_off.shape[0] - 1
    out = np.zeros(S, dtype=np.bool_)
    d_lo, d_hi = _disc_ranges(disc_scan, S)
    for s in range(S):
        if d_hi[s] == 0:
            continue
        for i in range(ret_off[s], ret_off[s + 1]):
            lab = labels[i]
            if lab >= 0 and extended[det_off[s] + lab] and _in_a_disc(points[i, 0], points[i, 1], disc_centres,
                                                                       disc_radii, d_lo[s], d_hi[s]):
                out[s] = True
                break
    return out
