"""The map step of a fleet's sensing pass after detection in two compiled calls (world ENU, metres,
radians): which detections are targets, the static returns into the map, the free space carved
(:meth:`mjasc.perception.fleet.PerceptionFleet._sense`).

It was ten compiled calls and some forty numpy calls between them, each paid per tick; the steps
and their order are the same (the step-by-step form stays as the reference and as the path that
raises the one-line error for a return out of the map's range, ``tests/test_map_pass.py``):

1. every return's cell key in its scan's map (:func:`~mjasc.perception.cell_keys.point_keys`); a
   cell index out of range (or a point not finite) stops here with nothing changed;
2. the occupancy of the returns, when a detection is no wall's (not ``extended``) and one of the
   scans' maps has an occupied cell (:meth:`StaticMapStore.occupied`);
3. targets, wall fragments and the map's new returns (:func:`~mjasc.perception.sense_kernels.sort_returns`);
4. the new returns' hits: their distinct cells' rows, missing ones created (the sorted keys merged),
   +1 capped (:meth:`StaticMapStore.add_points`);
5. the carving's candidate cells of every scan's fan (:func:`~mjasc.perception.carve_kernels.cells_in_reach`),
   less those whose carving would change nothing: a cell holding one of the tick's returns (never
   seen through) and a cell scored 0 (carving leaves it at 0 and flips nothing);

then numpy's arctan2 of the candidates' bearings (its SIMD loop need not round like libm's), and
the second call: the cells seen through scored down (:func:`~mjasc.perception.score_kernels.carve_cells`,
its own check of the tick's returns already made). The map is the same as the steps': only the
cells-seen-through counts of :func:`carve_fans`, which nothing reads, leave those cells out.
"""

from __future__ import annotations

import numpy as np

from mjasc.core.compiled import kernel
from mjasc.perception.carve_kernels import cells_in_reach
from mjasc.perception.cell_keys import create_rows, find_rows, point_keys
from mjasc.perception.score_kernels import add_hits, carve_cells, cell_rows
from mjasc.perception.sense_kernels import sort_returns

__all__ = ["sense_map", "map_steps", "returns_to_map", "carve_fans", "carve_stacked"]

_NO_FLAGS = np.zeros(0, dtype=bool)  # sort_returns: the map's occupancy not checked


@kernel
def returns_to_map(labels, ret_off, det_off, extended, n_points, centres, radii, variances, points, sigma, flat_m,
                   disc_centres, disc_radii, disc_scan, slot, carve, origins, max_range_m, n_beams, cell_m,
                   sorted_keys, key_rows, cells, member, score, n, cap, min_hits, n_occupied, version):
    """Steps 1–5 of the module docstring for S scans stacked (``ret_off``, ``det_off``; the arguments
    of :func:`~mjasc.perception.sense_kernels.sort_returns`, ``slot`` (S,) each scan's map member),
    the fans' origins (S, 2), max ranges and beams (S,); ``carve``: the candidates are wanted. The
    store's table (``cells``, ``member``, ``score`` with room for n + K rows; sorted keys and their
    rows; per member cell size, cap, min hits, occupied count and version) is updated in place.

    Returns ok (False: a cell index out of range, nothing changed), the targets (M,), per scan
    (S, 4) counts, the sorted keys and their rows (new arrays when rows were created), the number
    of rows, the candidates' rows and fans (2, c), their r, h and far (3, c) [m] and their
    positions relative to the sensor (c, 2) [m]."""
    S = ret_off.shape[0] - 1
    K = points.shape[0]
    M = extended.shape[0]
    point_member = np.empty(K, dtype=np.int64)
    for s in range(S):
        for i in range(ret_off[s], ret_off[s + 1]):
            point_member[i] = slot[s]
    keys, ok = point_keys(point_member, points, cell_m)
    if not ok:
        return (False, np.zeros(M, dtype=np.bool_), np.zeros((S, 4), dtype=np.int64), sorted_keys, key_rows, n,
                np.zeros((2, 0), dtype=np.int64), np.zeros((3, 0)), np.zeros((0, 2)))
    check = False
    if M:
        for d in range(M):
            if not extended[d]:
                check = True
                break
    if check:
        check = False
        for s in range(S):
            if n_occupied[slot[s]] != 0:
                check = True
    if check and n > 0:
        occ = np.zeros(K, dtype=np.bool_)
        rows = find_rows(keys, sorted_keys, key_rows)
        for i in range(K):
            row = rows[i]
            if row >= 0:
                occ[i] = score[row] >= min_hits[member[row]]
    else:
        occ = np.zeros(0, dtype=np.bool_)
    targets, p_static, m_static, stats = sort_returns(labels, ret_off, det_off, extended, n_points, centres, radii,
                                                      variances, points, occ, sigma, flat_m, disc_centres, disc_radii,
                                                      disc_scan, slot)
    if m_static.shape[0]:
        ukeys, urows, _ = cell_rows(m_static, p_static, cell_m, sorted_keys, key_rows)
        k = 0
        for i in range(urows.shape[0]):
            if urows[i] < 0:
                k += 1
        if k:
            nk = np.empty(k, dtype=np.int64)
            j = 0
            for i in range(urows.shape[0]):
                if urows[i] < 0:
                    nk[j] = ukeys[i]
                    urows[i] = n + j
                    j += 1
            sorted_keys, key_rows = create_rows(nk, n, cells, member, score, sorted_keys, key_rows)
            n += k
        add_hits(urows, score, member, cap, min_hits, n_occupied, version)
    if not carve or n == 0 or S == 0:
        return (True, targets, stats, sorted_keys, key_rows, n, np.zeros((2, 0), dtype=np.int64), np.zeros((3, 0)),
                np.zeros((0, 2)))
    fan = np.full(version.shape[0], -1, dtype=np.int64)
    for s in range(S):
        fan[slot[s]] = s if n_beams[s] > 0 else -1
    rows, qs, rel, r, half, far = cells_in_reach(cells[:n], member[:n], fan, cell_m, origins, max_range_m)
    live = np.empty(n, dtype=np.bool_)  # carving the row can change it: scored, and no return of the tick in it
    for row in range(n):
        live[row] = score[row] > 0.0
    now = find_rows(keys, sorted_keys, key_rows)
    for i in range(K):
        if now[i] >= 0:
            live[now[i]] = False
    c = 0
    for i in range(rows.shape[0]):
        if live[rows[i]]:
            c += 1
    cand = np.empty((2, c), dtype=np.int64)
    geo = np.empty((3, c))
    rel_live = np.empty((c, 2))
    k = 0
    for i in range(rows.shape[0]):
        if live[rows[i]]:
            cand[0, k], cand[1, k] = rows[i], qs[i]
            geo[0, k], geo[1, k], geo[2, k] = r[i], half[i], far[i]
            rel_live[k, 0], rel_live[k, 1] = rel[i, 0], rel[i, 1]
            k += 1
    return True, targets, stats, sorted_keys, key_rows, n, cand, geo, rel_live


@kernel
def carve_fans(cand, geo, bearing, n, margin_m, first_angle_body, last_angle_body, headings, n_beams, full, ranges,
               hit, beam_off, sigma, score, member, miss, min_hits, n_occupied, version):
    """The candidates of :func:`returns_to_map` (``cand``, ``geo``, their ``bearing`` = numpy's
    arctan2 [rad]; none holds a return of the tick) seen through by the fans of the S stacked scans
    scored down: each fan's world angles of its first and last beam ``angle_body + heading``, then
    :func:`~mjasc.perception.score_kernels.carve_cells` (without returns to check). Returns the
    candidates seen through per fan (S,)."""
    S = n_beams.shape[0]
    a0 = np.empty(S)
    a1 = np.empty(S)
    for s in range(S):
        a0[s] = first_angle_body[s] + headings[s]
        a1[s] = last_angle_body[s] + headings[s]
    none = np.zeros(0, dtype=np.int64)
    counts, _ = carve_cells(cand[0], member[:n], margin_m, cand[1], bearing, geo[0], geo[1], geo[2], a0, a1, n_beams,
                            full, ranges, hit, beam_off, sigma, none, np.zeros((0, 2)), np.zeros(0), none, none, score,
                            member, miss, min_hits, n_occupied, version)
    return counts


def sense_map(store, labels, ret_off, det_off, extended, n_points, centres, radii, variances, points, sigma, flat_m,
              disc_centres, disc_radii, disc_scan, slot, stack, carve: bool):
    """Steps 1–5, numpy's arctan2 and the carving (module docstring) on ``store`` (a
    :class:`~mjasc.perception.static_map.StaticMapStore`) for the scans of ``stack`` (a
    :class:`~mjasc.perception.scan_batch.ScanStack`; scan s by member ``slot[s]``, σ_ρ ``sigma[s]``;
    ``carve``: every scan's map carves). Returns the targets (M,) and per scan (S, 4) the counts of
    :func:`~mjasc.perception.sense_kernels.sort_returns`, or None when a return's cell index is out
    of range (nothing changed: the caller takes the step-by-step path, which raises the error)."""
    t = store.pass_tables(points.shape[0])
    cell_m, keys, key_rows, cells, member, score, n, cap, min_hits, n_occ, version, miss, margin = t
    ok, targets, stats, keys, key_rows, n, cand, geo, rel = returns_to_map(
        labels, ret_off, det_off, extended, n_points, centres, radii, variances, points, sigma, flat_m, disc_centres,
        disc_radii, disc_scan, slot, carve, stack.origins_m, stack.max_range_m, stack.n_beams, cell_m, keys, key_rows,
        cells, member, score, n, cap, min_hits, n_occ, version)
    if not ok:
        return None
    carve_stacked(store, t, keys, key_rows, n, cand, geo, rel, stack, sigma)
    return targets, stats


def carve_stacked(store, tables, keys, key_rows, n, cand, geo, rel, stack, sigma) -> None:
    """The end of :func:`sense_map` after :func:`returns_to_map` (on the store's ``tables``, its
    :meth:`~mjasc.perception.static_map.StaticMapStore.pass_tables`): the store's rows taken over
    (``keys``, ``key_rows``, ``n``), numpy's arctan2 of the candidates' bearings and
    :func:`carve_fans`."""
    _, _, _, _, member, score, _, _, min_hits, n_occ, version, miss, margin = tables
    store.set_rows(keys, key_rows, n)
    if cand.shape[1]:
        bearing = np.arctan2(rel[:, 1], rel[:, 0])
        carve_fans(cand, geo, bearing, n, margin, stack.first_angle_body, stack.last_angle_body, stack.headings_rad,
                   stack.n_beams, stack.full_circle, stack.ranges_m, stack.hit, stack.beam_off, sigma, score, member,
                   miss, min_hits, n_occ, version)


def map_steps(store, labels, ret_off, det_off, extended, n_points, centres, radii, variances, points, sigma, flat_m,
              disc_centres, disc_radii, disc_scan, slot, stack, carve: bool):
    """:func:`sense_map` one step at a time through the store's methods (the form it replaced, the
    reference of its test; the path that raises the one-line error for a return out of the map's
    range): occupancy of the returns, targets and static returns, hits, the carving when ``carve``.
    Returns the targets and the per-scan counts."""
    occ = _NO_FLAGS
    ret_slot = None  # the map member of each return
    if extended.size and not extended.all() and store.any_occupied(slot):
        ret_slot = np.repeat(slot, np.diff(ret_off))
        occ = store.occupied(ret_slot, points)
    targets, p_static, m_static, counts = sort_returns(labels, ret_off, det_off, extended, n_points, centres, radii,
                                                       variances, points, occ, sigma, flat_m, disc_centres,
                                                       disc_radii, disc_scan, slot)
    if m_static.size:
        store.add_points(m_static, p_static)
    if carve:
        store.carve_stack(slot, stack, sigma, ret_slot)
    return targets, counts
