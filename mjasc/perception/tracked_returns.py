"""A tracked boat's returns that a wall's cluster swallowed, clustered again as target detections
(world ENU, SI), and the subsets of a scan's detections the tracker is given.

A boat close to a wall (or to another boat) can join the wall's cluster: it would be written into
the map as part of the wall and its track would starve. The fleet's sensing pass
(:meth:`mjasc.perception.fleet.PerceptionFleet._sense`) finds the scans where a wall's cluster holds
returns inside one of the vessel's tracked discs (:func:`mjasc.perception.sense_kernels.tracked_in_walls`);
:func:`split_tracked` takes those returns out of their cluster (where the vessel's map has not
mapped the cell: the wall behind stays the wall's), clusters them again on their own and keeps the
new detections that look like a tracked object. :func:`split_in_pass` is the same for a scan of
the pass, in one compiled call on the pass's stacked arrays (:mod:`mjasc.perception.split_kernels`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from mjasc.perception.detection import DetectionConfig, Detections, detect
from mjasc.perception.tracked_discs import DISC_MARGIN_M
from mjasc.perception.owned_discs import inside_discs
from mjasc.perception.range_sensor import Scan
from mjasc.perception.split_kernels import OUT_OF_RANGE, SPLIT, split_pass_scan
from mjasc.perception.static_map import StaticMap

__all__ = ["split_tracked", "split_in_pass", "targets_only", "subset", "inside"]


def split_tracked(scan: Scan, det: Detections, discs, static_map: StaticMap, config: DetectionConfig,
                  range_noise_std_m: float, dropout_probability: float) -> Detections:
    """``det`` (the detections of ``scan``) with the returns of its extended clusters that lie in a
    tracked disc (``discs``: centres (q, 2), radii (q,) [m], :meth:`mjasc.perception.fleet.PerceptionFleet._discs`)
    and on no occupied cell of ``static_map`` clustered again on their own (``config``, σ_ρ and the
    dropout probability of the sensor), as target detections appended after det's (the returns'
    labels changed to them); ``det`` itself when nothing changes."""
    lab = det.labels
    good = lab >= 0
    take = good & det.extended[np.maximum(lab, 0)] & inside(scan.hit_points_world, *discs)
    if take.any() and static_map.n_occupied:  # the wall behind, where it is mapped, stays the wall's
        take[take] = ~static_map.occupied(scan.hit_points_world[take])
    if not take.any():
        return det
    mask = np.zeros_like(scan.hit)
    beams = scan.hit_beams[take]
    mask[beams] = True
    sub = replace(scan, hit=mask, ranges=np.where(mask, scan.ranges, scan.max_range_m), hit_beams=beams,
                  hit_points_body=scan.hit_points_body[take], hit_points_world=scan.hit_points_world[take])
    extra = detect(sub, config, range_noise_std_m, dropout_probability)
    if len(extra) == 0:
        return det
    # only what looks like a tracked object: a disc no larger than the track's, centred within
    # its radius of the predicted centre (a piece of the wall beside it stays the wall's)
    c, r = discs
    d = np.hypot(*(extra.centres_m[:, None, :] - c[None, :, :]).transpose(2, 0, 1))
    core = r - DISC_MARGIN_M
    fits = ((d <= core[None, :]) & (extra.radii_m[:, None] <= core[None, :] + 0.5)).any(axis=1) & ~extra.extended
    if not fits.any():
        return det
    keep = np.flatnonzero(fits)
    new = np.full(len(extra), -1)
    new[keep] = np.arange(keep.size) + len(det)
    sub_lab = np.where(extra.labels >= 0, new[np.maximum(extra.labels, 0)], -1)
    labels = lab.copy()
    labels[take] = np.where(sub_lab >= 0, sub_lab, lab[take])
    extra = subset(extra, keep)
    cat = lambda a, b: np.concatenate([a, b])  # noqa: E731
    occ = None if det.occluded is None else cat(det.occluded, extra.occluded)
    return Detections(det.time_s, det.origin_m, det.heading_rad, cat(det.centres_m, extra.centres_m),
                      cat(det.centres_body, extra.centres_body), cat(det.radii_m, extra.radii_m),
                      cat(det.variances_m2, extra.variances_m2), cat(det.n_points, extra.n_points),
                      cat(det.ranges_m, extra.ranges_m), cat(det.extended, extra.extended), labels, occ)


def split_in_pass(k: int, det: Detections, batch, stack, discs, a: int, b: int, constants, tables, map_member: int,
                  fallback) -> Detections:
    """:func:`split_tracked` of scan ``k`` of a sensing pass: its detections ``det`` (scan k's of
    ``batch``, a :class:`~mjasc.perception.detection.DetectionBatch` of the pass's
    :class:`~mjasc.perception.scan_batch.ScanStack` ``stack``), its discs ``a : b`` of ``discs``
    (centres (q, 2), radii (q,) [m], grouped by scan), the pass's detection ``constants``
    (:func:`~mjasc.perception.detection.detection_constants`, scan k's those of its vessel's
    settings), the store's ``tables`` as the pass found them
    (:meth:`~mjasc.perception.static_map.StaticMapStore.pass_tables`; its sorted keys and rows as the
    pass left them) and the vessel's map member. The same result, bit for bit
    (:mod:`mjasc.perception.split_kernels`); ``fallback()`` (``split_tracked`` itself) where a
    taken return's cell is out of the map's range (it raises the one-line error)."""
    cell_m, keys, key_rows, _, member, score, _, _, min_hits, n_occ, *_ = tables
    n_beams, d0, lam, dth, gap, sig, full = constants.cluster_scan
    _, edge_lost, min_rad, edge_var, sig2, floor2 = constants.per_scan
    status, labels, points, floats, counts, flags = split_pass_scan(
        k, batch.ret_offsets, batch.det_offsets, batch.labels, batch.extended, batch.occluded, batch.centres_m,
        batch.centres_body, batch.radii_m, batch.variances_m2, batch.n_points, batch.ranges_m, stack.hit_points_world,
        stack.hit_beams, stack.hit_ranges_m, stack.n_beams, stack.max_range_m, stack.origins_m, stack.cos_heading,
        stack.sin_heading, discs[0], discs[1], a, b, d0, lam, dth, gap, sig, full, edge_lost, min_rad, edge_var, sig2,
        floor2, *constants.keep_scan, DISC_MARGIN_M, map_member, n_occ[map_member] != 0, cell_m, keys, key_rows, score,
        member, min_hits)
    if status == SPLIT:
        m = counts.shape[0]
        return Detections(det.time_s, det.origin_m, det.heading_rad, points[:m], points[m:], floats[:m],
                          floats[m:2 * m], counts, floats[2 * m:], flags[:m], labels, flags[m:])
    if status == OUT_OF_RANGE:
        return fallback()
    return det


def targets_only(d: Detections, mask: np.ndarray) -> Detections:
    """The detections ``mask`` of d, the returns' labels renumbered (−1: a return of another one)."""
    keep = np.flatnonzero(mask)
    new = np.full(len(d), -1)
    new[keep] = np.arange(keep.size)
    labels = np.where(d.labels >= 0, new[np.maximum(d.labels, 0)], -1)
    return replace(subset(d, keep), labels=labels)


def subset(d: Detections, keep: np.ndarray) -> Detections:
    """The detections ``keep`` of d (labels not remapped: the caller does)."""
    return Detections(d.time_s, d.origin_m, d.heading_rad, d.centres_m[keep], d.centres_body[keep], d.radii_m[keep],
                      d.variances_m2[keep], d.n_points[keep], d.ranges_m[keep], d.extended[keep], d.labels,
                      None if d.occluded is None else d.occluded[keep])


def inside(p: np.ndarray, centres: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """(k,) bool: point p (k, 2) lies in one of the discs (centres (q, 2), radii (q,))."""
    return inside_discs(p, centres, radii)
