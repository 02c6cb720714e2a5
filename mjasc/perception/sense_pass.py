"""A fleet's sensing pass after the casts in one compiled call (world ENU, body FLU, SI): the scans,
their detections and the map's update up to the carving's bearings
(:meth:`mjasc.perception.fleet.PerceptionFleet._sense`).

The pass was five compiled calls with Python between them (the scans' stack, the detection's
batch, the map's tables), each paid per tick; :func:`scan_detect_map` makes the first four in one
call, in the same order and on the same arrays, so every result is the same bits:

1. the scans (:func:`~mjasc.perception.scan_kernels.scan_batch`);
2. their detections (:func:`~mjasc.perception.detection_kernels.detect_clusters`; none without a
   return);
3. when a vessel has tracked discs and a detection is a wall's (``extended``), the scans whose wall
   clusters hold a return inside a tracked disc (:func:`~mjasc.perception.sense_kernels.tracked_in_walls`):
   a scan whose wall returns in its discs all lie on occupied cells of its vessel's map is not
   counted (:func:`~mjasc.perception.tracked_returns.split_tracked` leaves the wall behind, where it
   is mapped, the wall's: it would change nothing; :func:`walls_mapped`); if a scan is left, the
   call stops here and the caller re-clusters those returns in Python, as before;
4. otherwise steps 1–5 of the map pass (:func:`~mjasc.perception.map_pass.returns_to_map`).

The caller then takes numpy's arctan2 of the carving's candidates and scores them down
(:func:`~mjasc.perception.map_pass.carve_fans`, which takes it that no candidate holds one of the
tick's returns: ``returns_to_map`` left those out), as :func:`~mjasc.perception.map_pass.sense_map` does.
(numba's cache does not notice a change to a kernel this one calls: such a change edits this file
too, or deletes the cache, ``__pycache__/sense_pass.*.nb?``.)
"""

from __future__ import annotations

import numpy as np

from mjasc.core.compiled import kernel
from mjasc.perception.cell_keys import find_rows, point_keys
from mjasc.perception.detection_kernels import detect_clusters
from mjasc.perception.map_pass import returns_to_map
from mjasc.perception.owned_discs import _in_a_disc
from mjasc.perception.scan_kernels import scan_batch
from mjasc.perception.sense_kernels import tracked_in_walls

__all__ = ["scan_detect_map", "walls_mapped", "unpack", "DETECTED", "SWALLOWED", "MAPPED", "OUT_OF_RANGE"]

#: :func:`scan_detect_map`'s status: the scans and detections only (the map step not asked for).
DETECTED = 0
#: ... a wall's cluster holds a tracked disc's return (the map step left to the caller).
SWALLOWED = 1
#: ... the map step made (up to the carving's bearings).
MAPPED = 2
#: ... a return's cell index out of the map's range (nothing changed in the map).
OUT_OF_RANGE = 3


@kernel
def scan_detect_map(dist, gid, beam_off, noise_std_m, normals, has_normals, dropout_probability, uniforms, has_uniforms,
                    clutter_beams, clutter_ranges_m, clutter_off, min_range_m, max_range_m, clutter_geom, cos_body,
                    sin_body, origins, headings, cos_h, sin_h,
                    n_beams, d0, lam, dth, gap, sigma, full, det_beam_off, edge_lost, min_rad, edge_var, sig2, floor2,
                    min_pts, max_target_radius_m,
                    map_step, map_sigma, disc_centres, disc_radii, disc_scan, flat_m, slot, carve, map_n_beams, cell_m,
                    sorted_keys, key_rows, cells, member, score, n, cap, min_hits, n_occupied, version):
    """Steps 1–4 of the module docstring. The arguments: those of
    :func:`~mjasc.perception.scan_kernels.scan_batch`; the detection's per-scan constants (those of
    :func:`~mjasc.perception.detection_kernels.detect_clusters`, its ``beam_off`` as ``det_beam_off``);
    ``map_step`` (False: steps 1–2 only), σ_ρ per scan (S,) as the map takes it, then those of
    :func:`~mjasc.perception.map_pass.returns_to_map` that are not made here (the scans' fans' ``max_range_m`` and beams ``map_n_beams``).

    Returns the status (``DETECTED``, ``SWALLOWED``, ``MAPPED``, ``OUT_OF_RANGE``), the five arrays
    and K of ``scan_batch``, d detections and c carving candidates, then four arrays packing the rest
    (every returned array costs the caller a Python call to unbox it; :func:`unpack`):

    * ``bools``: the detections' flags (2d,) of ``detect_clusters``, ``swallowed`` (S,) (all False
      unless checked), the targets (d,) of ``returns_to_map`` (none unless ``MAPPED``);
    * ``ints``: the ints (d + K + S + 1,) of ``detect_clusters``, the counts (S, 4) of
      ``returns_to_map`` (none unless ``MAPPED``), its candidates' rows and fans (2, c);
    * ``floats``: the floats (3d,) of ``detect_clusters``, the candidates' r, h and far (3, c);
    * ``points``: the points (2d, 2) of ``detect_clusters``, the candidates' positions (c, 2);

    and the sorted keys, their rows and the number of rows of the map's table (those given unless
    ``MAPPED``). (Without a return, the detection's arrays are empty and its offsets zero.)"""
    floats, points, hit, geom, ints, K = scan_batch(
        dist, gid, beam_off, noise_std_m, normals, has_normals, dropout_probability, uniforms, has_uniforms,
        clutter_beams, clutter_ranges_m, clutter_off, min_range_m, max_range_m, clutter_geom, cos_body, sin_body,
        origins, headings, cos_h, sin_h)
    S = beam_off.shape[0] - 1
    N = beam_off[S]
    beams, rho, P, ranges_all, ret_off = ints[:K], floats[N:N + K], points[N:N + K], floats[:N], ints[N:]
    if K:
        dpoints, dfloats, dints, dflags, d = detect_clusters(
            beams, P, rho, ret_off, n_beams, d0, lam, dth, gap, sigma, full, det_beam_off, hit, ranges_all, origins,
            cos_h, sin_h, edge_lost, min_rad, edge_var, sig2, floor2, min_pts, max_target_radius_m)
        labels, det_off = dints[d:d + K], dints[d + K:]
    else:
        dpoints, dfloats, dflags, d = np.zeros((0, 2)), np.zeros(0), np.zeros(0, dtype=np.bool_), 0
        dints = np.zeros(S + 1, dtype=np.int64)
        labels, det_off = np.full(0, -1, dtype=np.int64), dints
    swallowed = np.zeros(S, dtype=np.bool_)
    status = DETECTED
    targets = np.zeros(0, dtype=np.bool_)
    stats = np.zeros((0, 4), dtype=np.int64)
    cand = np.zeros((2, 0), dtype=np.int64)
    geo = np.zeros((3, 0))
    rel = np.zeros((0, 2))
    extended = dflags[:d]
    if map_step:
        status = MAPPED
        if disc_scan.shape[0]:
            walls = False
            for j in range(d):
                if extended[j]:
                    walls = True
                    break
            if walls:
                swallowed = tracked_in_walls(labels, ret_off, det_off, extended, P, disc_centres, disc_radii,
                                             disc_scan)
                walls_mapped(swallowed, labels, ret_off, det_off, extended, P, disc_centres, disc_radii, disc_scan,
                             slot, cell_m, sorted_keys, key_rows, score, member, min_hits, n_occupied, n)
                for s in range(S):
                    if swallowed[s]:
                        status = SWALLOWED
                        break
    if status == MAPPED:
        ok, t_, st_, keys, rows, n2, cand_, geo_, rel_ = returns_to_map(
            labels, ret_off, det_off, extended, dints[:d], dpoints[:d], dfloats[:d], dfloats[d:2 * d], P, map_sigma,
            flat_m, disc_centres, disc_radii, disc_scan, slot, carve, origins, max_range_m, map_n_beams, cell_m,
            sorted_keys, key_rows, cells, member, score, n, cap, min_hits, n_occupied, version)
        if ok:
            targets, stats, cand, geo, rel = t_, st_, cand_, geo_, rel_
            sorted_keys, key_rows, n = keys, rows, n2
        else:
            status = OUT_OF_RANGE
    c = cand.shape[1]
    nb, ns, ni = 2 * d + S, stats.shape[0] * 4, dints.shape[0]
    bools = np.empty(nb + targets.shape[0], dtype=np.bool_)
    bools[:2 * d] = dflags
    bools[2 * d:nb] = swallowed
    bools[nb:] = targets
    ints_out = np.empty(ni + ns + 2 * c, dtype=np.int64)
    ints_out[:ni] = dints
    for i in range(stats.shape[0]):
        for j in range(4):
            ints_out[ni + 4 * i + j] = stats[i, j]
    floats_out = np.empty(3 * d + 3 * c)
    floats_out[:3 * d] = dfloats
    for i in range(c):
        ints_out[ni + ns + i] = cand[0, i]
        ints_out[ni + ns + c + i] = cand[1, i]
        for j in range(3):
            floats_out[3 * d + j * c + i] = geo[j, i]
    points_out = np.empty((2 * d + c, 2))
    points_out[:2 * d] = dpoints
    points_out[2 * d:] = rel
    return (status, floats, points, hit, geom, ints, K, d, c, bools, ints_out, floats_out, points_out, sorted_keys,
            key_rows, n)


@kernel
def walls_mapped(swallowed, labels, ret_off, det_off, extended, points, disc_centres, disc_radii, disc_scan, slot,
                 cell_m, sorted_keys, key_rows, score, member, min_hits, n_occupied, n):
    """Clear ``swallowed[s]`` (in place) where the returns of scan s that
    :func:`~mjasc.perception.tracked_returns.split_tracked` would take out of a wall's cluster (a
    return of an extended detection inside one of the scan's discs) all lie on occupied cells of
    its vessel's map (``slot[s]``; the store's table as :func:`scan_detect_map` takes it, before
    this pass's hits): it keeps those returns the wall's and changes nothing. A scan whose map has
    no occupied cell, or with such a return on an unmapped cell or out of the map's range, stays
    (the caller's path decides, or raises, as before). The same tests as ``split_tracked``: the
    disc test of :func:`~mjasc.perception.owned_discs.inside_discs`, the cell of
    :func:`~mjasc.perception.cell_keys.point_keys` and the occupancy of
    :meth:`~mjasc.perception.static_map.StaticMapStore.occupied`."""
    S = ret_off.shape[0] - 1
    d_lo = np.zeros(S, dtype=np.int64)
    d_hi = np.zeros(S, dtype=np.int64)
    for j in range(disc_scan.shape[0]):  # (the discs grouped by scan, ascending)
        q = disc_scan[j]
        if d_hi[q] == 0:
            d_lo[q] = j
        d_hi[q] = j + 1
    one = np.empty(1, dtype=np.int64)
    pt = np.empty((1, 2))
    for s in range(S):
        if not swallowed[s] or n == 0 or n_occupied[slot[s]] == 0:
            continue
        one[0] = slot[s]
        mapped = True
        for i in range(ret_off[s], ret_off[s + 1]):
            lab = labels[i]
            if lab >= 0 and extended[det_off[s] + lab] and _in_a_disc(points[i, 0], points[i, 1], disc_centres,
                                                                       disc_radii, d_lo[s], d_hi[s]):
                pt[0, 0], pt[0, 1] = points[i, 0], points[i, 1]
                keys, ok = point_keys(one, pt, cell_m)
                if not ok:
                    mapped = False
                    break
                row = find_rows(keys, sorted_keys, key_rows)[0]
                if row < 0 or not score[row] >= min_hits[member[row]]:
                    mapped = False
                    break
        if mapped:
            swallowed[s] = False


def unpack(status: int, S: int, K: int, d: int, c: int, bools, ints, floats, points) -> tuple:
    """:func:`scan_detect_map`'s packed arrays (its status; S scans, K returns, d detections, c
    candidates) as views: the detection's points, floats, ints and flags (what
    ``detect_clusters`` returns), swallowed (S,), targets (d,) (none unless ``MAPPED``), counts
    (S, 4) (none unless ``MAPPED``), the candidates (2, c), their r, h, far (3, c) and positions (c, 2)."""
    ni, nb = d + K + S + 1, 2 * d + S
    ns = 4 * S if status == MAPPED else 0
    return (points[:2 * d], floats[:3 * d], ints[:ni], bools[:2 * d], bools[2 * d:nb], bools[nb:],
            ints[ni:ni + ns].reshape(ns // 4, 4), ints[ni + ns:].reshape(2, c), floats[3 * d:].reshape(3, c),
            points[2 * d:])
