"""The compiled form of :func:`mjasc.perception.tracked_returns.split_tracked` for one scan of a
fleet's sensing pass (world ENU, metres): a tracked boat's returns that a wall's cluster
swallowed, clustered again on their own as target detections.

When a wall's cluster holds returns inside one of a vessel's tracked discs
(:func:`~mjasc.perception.sense_kernels.tracked_in_walls`), the pass
(:meth:`mjasc.perception.fleet.PerceptionFleet._sense`) splits them out of it. ``split_tracked``
does that in some forty numpy calls and a detection of its own (~0.3 ms per scan, every fifth tick
of a boat passing a quay); :func:`split_pass_scan` makes the same steps in one call, on the pass's
stacked arrays, with the same expressions in the same order (``tests/test_split_kernels.py``
compares it with ``split_tracked`` on the pass's scans):

1. ``take``: the returns of extended detections inside one of the scan's discs
   (``(p − c)·(p − c) ≤ r²``, :func:`~mjasc.perception.owned_discs.inside_discs`'s test), less
   those on an occupied cell of the vessel's map (when it has one; the map as the pass found it,
   :func:`~mjasc.perception.score_kernels.occupied_points`);
2. the taken returns alone as a scan (their beams hit, every other beam at ``max_range_m``)
   clustered with the scan's detection constants
   (:func:`~mjasc.perception.detection_kernels.detect_clusters`: what ``detect`` of that scan runs);
3. of the new detections, those that look like a tracked object: not extended, within a disc's
   ``r − DISC_MARGIN_M`` of its centre (``hypot``) with a radius at most that + 0.5 m;
4. the kept ones appended after the scan's detections, the taken returns' labels changed to them.
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.compiled import kernel
from mjasc.perception.detection_kernels import detect_clusters
from mjasc.perception.owned_discs import _in_a_disc
from mjasc.perception.score_kernels import occupied_points

__all__ = ["split_pass_scan", "UNCHANGED", "SPLIT", "OUT_OF_RANGE"]

#: :func:`split_pass_scan`'s status: nothing changes (``split_tracked`` returns the detections as they are).
UNCHANGED = 0
#: ... new detections appended (the arrays returned).
SPLIT = 1
#: ... a taken return's cell index out of the map's range (the caller's ``split_tracked`` raises the error).
OUT_OF_RANGE = 2


@kernel
def _nothing(status):
    """The result of :func:`split_pass_scan` without new detections."""
    return (status, np.empty(0, dtype=np.int64), np.empty((0, 2)), np.empty(0), np.empty(0, dtype=np.int64),
            np.empty(0, dtype=np.bool_))


@kernel
def split_pass_scan(k, ret_off, det_off, labels, extended, occluded, centres, body, radii, variances, n_points,
                    ranges, P, beams, rho, n_beams, max_range_m, origins, cos_h, sin_h, disc_centres, disc_radii, da,
                    db, d0, lam, dth, gap, sigma, full, edge_lost, min_rad, edge_var, sig2, floor2, min_pts,
                    max_target_radius_m, core_margin_m, map_member, check_map, cell_m, sorted_keys, key_rows, score,
                    member, min_hits):
    """Steps 1–4 (module docstring) for scan ``k`` of a pass: its returns ``ret_off[k] : ret_off[k+1]``
    of the stacked labels (K,), points ``P`` (K, 2), hit beams and ranges ``rho`` (K,); its
    detections ``det_off[k] : det_off[k+1]`` of the stacked fields; its discs ``da : db`` of
    ``disc_centres`` / ``disc_radii``; per scan (S,) the beams, max range, origin (S, 2), cosine
    and sine of the heading and the detection's constants (those of ``detect_clusters``);
    ``core_margin_m`` = ``DISC_MARGIN_M``; its map's member and whether it has an occupied cell
    (``check_map``), with the store's table.

    Returns the status (``UNCHANGED``, ``SPLIT``, ``OUT_OF_RANGE``), the scan's new labels (k,) and
    its m detections, the old then the kept new ones, packed: ``points`` (2m, 2) = centres, then
    centres in the body frame; ``floats`` (3m,) = radii, variances, ranges; ``counts`` (m,);
    ``flags`` (2m,) = extended, occluded (empty unless ``SPLIT``)."""
    r0, r1 = ret_off[k], ret_off[k + 1]
    a, b = det_off[k], det_off[k + 1]
    nr, nd = r1 - r0, b - a
    take = np.zeros(nr, dtype=np.bool_)
    n_take = 0
    for i in range(nr):
        lab = labels[r0 + i]
        if lab >= 0 and extended[a + lab] and _in_a_disc(P[r0 + i, 0], P[r0 + i, 1], disc_centres, disc_radii, da,
                                                         db):
            take[i] = True
            n_take += 1
    if n_take and check_map:  # the wall behind, where it is mapped, stays the wall's
        pts = np.empty((n_take, 2))
        j = 0
        for i in range(nr):
            if take[i]:
                pts[j, 0], pts[j, 1] = P[r0 + i, 0], P[r0 + i, 1]
                j += 1
        occ, ok = occupied_points(np.full(n_take, map_member, dtype=np.int64), pts, cell_m, sorted_keys, key_rows,
                                  score, member, min_hits)
        if not ok:
            return _nothing(OUT_OF_RANGE)
        j = 0
        for i in range(nr):
            if take[i]:
                if occ[j]:
                    take[i] = False
                    n_take -= 1
                j += 1
    if n_take == 0:
        return _nothing(UNCHANGED)
    # the taken returns alone as a scan of one
    n = n_beams[k]
    sub_beams = np.empty(n_take, dtype=np.int64)
    sub_P = np.empty((n_take, 2))
    sub_rho = np.empty(n_take)
    hit_all = np.zeros(n, dtype=np.bool_)
    ranges_all = np.full(n, max_range_m[k])
    j = 0
    for i in range(nr):
        if take[i]:
            bm = beams[r0 + i]
            sub_beams[j] = bm
            sub_P[j, 0], sub_P[j, 1] = P[r0 + i, 0], P[r0 + i, 1]
            sub_rho[j] = rho[r0 + i]
            hit_all[bm] = True
            ranges_all[bm] = rho[r0 + i]
            j += 1
    one_off = np.zeros(2, dtype=np.int64)
    one_off[1] = n_take
    beam_off = np.zeros(2, dtype=np.int64)
    beam_off[1] = n
    q, u = k, k + 1
    xpoints, xfloats, xints, xflags, d = detect_clusters(
        sub_beams, sub_P, sub_rho, one_off, n_beams[q:u], d0[q:u], lam[q:u], dth[q:u], gap[q:u], sigma[q:u],
        full[q:u], beam_off, hit_all, ranges_all, origins[q:u], cos_h[q:u], sin_h[q:u], edge_lost[q:u], min_rad[q:u],
        edge_var[q:u], sig2[q:u], floor2[q:u], min_pts[q:u], max_target_radius_m[q:u])
    if d == 0:
        return _nothing(UNCHANGED)
    # only what looks like a tracked object (a piece of the wall beside it stays the wall's)
    new = np.full(d, -1, dtype=np.int64)
    e = 0
    for x in range(d):
        fits = False
        for c in range(da, db):
            core = disc_radii[c] - core_margin_m
            dist = math.hypot(xpoints[x, 0] - disc_centres[c, 0], xpoints[x, 1] - disc_centres[c, 1])
            if dist <= core and xfloats[x] <= core + 0.5:
                fits = True
        if fits and not xflags[x]:
            new[x] = nd + e
            e += 1
    if e == 0:
        return _nothing(UNCHANGED)
    out_labels = np.empty(nr, dtype=np.int64)
    j = 0
    for i in range(nr):
        lab = labels[r0 + i]
        if take[i]:
            sl = xints[d + j]
            if sl >= 0 and new[sl] >= 0:
                lab = new[sl]
            j += 1
        out_labels[i] = lab
    m = nd + e
    points = np.empty((2 * m, 2))
    floats = np.empty(3 * m)
    counts = np.empty(m, dtype=np.int64)
    flags = np.empty(2 * m, dtype=np.bool_)
    for i in range(nd):
        points[i, 0], points[i, 1] = centres[a + i, 0], centres[a + i, 1]
        points[m + i, 0], points[m + i, 1] = body[a + i, 0], body[a + i, 1]
        floats[i], floats[m + i], floats[2 * m + i] = radii[a + i], variances[a + i], ranges[a + i]
        counts[i] = n_points[a + i]
        flags[i], flags[m + i] = extended[a + i], occluded[a + i]
    for x in range(d):
        i = new[x]
        if i < 0:
            continue
        points[i, 0], points[i, 1] = xpoints[x, 0], xpoints[x, 1]
        points[m + i, 0], points[m + i, 1] = xpoints[d + x, 0], xpoints[d + x, 1]
        floats[i], floats[m + i], floats[2 * m + i] = xfloats[x], xfloats[d + x], xfloats[2 * d + x]
        counts[i] = xints[x]
        flags[i], flags[m + i] = xflags[x], xflags[d + x]
    return SPLIT, out_labels, points, floats, counts, flags
