"""Compiled per-cluster loops of :func:`mjasc.perception.detection.detect_many`: the disc of each
cluster of returns — centre [m] (world ENU), radius [m] and isotropic centre variance [m²]
(equations in the docstring of :mod:`mjasc.perception.detection`, "Centre and radius" and
"Measurement noise").

Cluster c holds the returns ``starts[c] : starts[c] + counts[c]`` of ``P`` (world x, y) and
``rho`` (their ranges), taken by the sensor of scan ``cs[c]`` at ``origins[cs[c]]``. With its
extreme returns p_f, p_l::

    w = ‖p_l − p_f‖,   ρ̄ = Σρ / n,   Δ = ρ̄·Δθ,   r_w = max(½ (w + Δ (1 + 2 e_lost)), r_min)
    mid = ½ (p_f + p_l),   u = (mid − o) / ‖mid − o‖ (‖·‖ = 0: divided by 1)
    d_i = (p_i − o)·u,   y_i = (p_i − mid)·(−u_y, u_x),   b_i = √max(r_w² − y_i², 0),   g_i = b_i + 10⁻³ r_w
    D = Σ g_i (d_i + b_i) / Σ g_i,   c = o + D u
    twice: J_i = (c − p_i) / max(‖c − p_i‖, 10⁻⁹), e_i = ‖c − p_i‖ − r_w,
           A = [[ΣJ_x² + 0.1 n, ΣJ_x J_y], [·, ΣJ_y² + 0.1 n]],  c ← c − A⁻¹ [ΣJ_x e, ΣJ_y e]  (2×2 adjugate)
    radius = max(r_w, max_i ‖p_i − c‖),   σ_c² = Δ² (1/12 + e_var) + σ_ρ² / n + σ_floor²

This is the numpy form the function had (kept in ``tests/test_detection_kernels.py`` as the
reference), evaluated in the same order, so the results are bit-identical to it: each sum over a
cluster is what ``np.add.reduceat`` computes — the first term plus numpy's pairwise sum of the rest
(:func:`mjasc.core.compiled.pairwise_sum`, numpy's ``pairwise_sum``: blocks of 8 partial sums up to 128 terms, halves
above) — and ``max`` propagates NaN as ``np.maximum`` does.

:func:`kept_detections` then keeps the clusters with enough returns, in order, with their centres
in the sensor's body frame, ranges, extended flags and each return's label within its scan.
:func:`detect_clusters` is the whole detection of a tick's stacked returns in one call: the
clusters and hidden edges (:mod:`mjasc.perception.cluster_kernels`), the discs, the kept ones.
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.compiled import kernel, maximum, pairwise_sum
from mjasc.perception.cluster_kernels import cluster_order, occluded_edges

__all__ = ["cluster_discs", "kept_detections", "detect_clusters", "unpack_detections"]

_REFINE = 2  # Gauss–Newton iterations of the centre
_DAMP = 0.1  # their damping per return (keeps a one- or two-return cluster at its first estimate)


@kernel
def _segment_sum(a, start, n):
    """``np.add.reduceat``'s sum of ``a[start : start + n]`` (n ≥ 1): the first term plus the
    pairwise sum of the rest."""
    return a[start] + pairwise_sum(a, start + 1, n - 1)


@kernel
def cluster_discs(P, rho, starts, counts, cs, origins, dth, edge_lost, min_rad, edge_var, sig2, floor2):
    """Centres (m, 2) [m], radii (m,) [m] and centre variances (m,) [m²] of the m clusters
    ``starts``/``counts`` of the returns ``P`` (K, 2) with ranges ``rho`` (K,), cluster c seen from
    ``origins[cs[c]]`` (S, 2); per scan (S,): beam spacing Δθ [rad], mean and variance of the beams
    lost beyond an edge, smallest radius [m], σ_ρ² and σ_floor² [m²] (module docstring)."""
    m = starts.shape[0]
    K = P.shape[0]
    centres = np.empty((m, 2))
    radii = np.empty(m)
    var = np.empty(m)
    t1 = np.empty(K)
    t2 = np.empty(K)
    t3 = np.empty(K)
    t4 = np.empty(K)
    t5 = np.empty(K)
    for c in range(m):
        s, n, q = starts[c], counts[c], cs[c]
        e = s + n - 1
        ox, oy = origins[q, 0], origins[q, 1]
        width = math.hypot(P[e, 0] - P[s, 0], P[e, 1] - P[s, 1])
        spacing = _segment_sum(rho, s, n) / n * dth[q]
        r_w = maximum(0.5 * (width + spacing * (1.0 + 2.0 * edge_lost[q])), min_rad[q])
        mx, my = 0.5 * (P[s, 0] + P[e, 0]), 0.5 * (P[s, 1] + P[e, 1])
        lx, ly = mx - ox, my - oy
        los_n = math.hypot(lx, ly)
        if not los_n > 0:
            los_n = 1.0
        ux, uy = lx / los_n, ly / los_n
        r_w2 = r_w * r_w
        for i in range(s, s + n):
            d = (P[i, 0] - ox) * ux + (P[i, 1] - oy) * uy
            y = (P[i, 0] - mx) * -uy + (P[i, 1] - my) * ux
            behind = math.sqrt(maximum(r_w2 - y * y, 0.0))
            w = behind + 1e-3 * r_w
            t1[i] = w * (d + behind)
            t2[i] = w
        D = _segment_sum(t1, s, n) / _segment_sum(t2, s, n)
        cx, cy = ox + D * ux, oy + D * uy
        for _ in range(_REFINE):  # damped Gauss–Newton on Σ (‖p_i − c‖ − r_w)²
            for i in range(s, s + n):
                dx, dy = cx - P[i, 0], cy - P[i, 1]
                dist = math.hypot(dx, dy)
                den = maximum(dist, 1e-9)
                jx, jy = dx / den, dy / den
                err = dist - r_w
                t1[i] = jx * jx
                t2[i] = jx * jy
                t3[i] = jy * jy
                t4[i] = jx * err
                t5[i] = jy * err
            a11 = _segment_sum(t1, s, n) + _DAMP * n
            a12 = _segment_sum(t2, s, n)
            a22 = _segment_sum(t3, s, n) + _DAMP * n
            g1 = _segment_sum(t4, s, n)
            g2 = _segment_sum(t5, s, n)
            det = a11 * a22 - a12 * a12
            sx = (a22 * g1 - a12 * g2) / det
            sy = (a11 * g2 - a12 * g1) / det
            cx, cy = cx - sx, cy - sy
        far = math.hypot(P[s, 0] - cx, P[s, 1] - cy)
        for i in range(s + 1, s + n):
            far = maximum(far, math.hypot(P[i, 0] - cx, P[i, 1] - cy))
        centres[c, 0], centres[c, 1] = cx, cy
        radii[c] = maximum(r_w, far)
        var[c] = spacing * spacing * (1.0 / 12.0 + edge_var[q]) + sig2[q] / n + floor2[q]
    return centres, radii, var


@kernel
def kept_detections(order, counts, cs, centres, radii, var, occluded, origins, cos_h, sin_h, min_pts, max_radius_m):
    """The clusters with at least ``min_pts[scan]`` returns become detections (scans' order kept):
    their centres (d, 2) [m] world and body frame (x forward, y to port: ``(c·x + s·y, −s·x + c·y)``
    of the centre relative to the sensor, c, s the cosine and sine of the scan's heading), radii,
    variances, return counts, ranges ``‖centre − origin‖`` [m], extended (radius > ``max_radius_m``),
    occluded; the offsets (S + 1,) of each scan's detections; and each return's detection index
    within its scan (K,) (−1: its cluster was dropped), returns indexed before ``order``. Per
    scan (S,): ``origins`` (S, 2), ``cos_h``, ``sin_h``, ``min_pts``, ``max_radius_m``."""
    m = counts.shape[0]
    S = origins.shape[0]
    K = order.shape[0]
    det_off = np.zeros(S + 1, dtype=np.int64)
    new_index = np.full(m, -1, dtype=np.int64)
    d = 0
    for c in range(m):
        if counts[c] >= min_pts[cs[c]]:
            new_index[c] = d
            d += 1
            det_off[cs[c] + 1] += 1
    for s in range(S):
        det_off[s + 1] += det_off[s]
    labels = np.full(K, -1, dtype=np.int64)
    at = 0
    for c in range(m):
        n = counts[c]
        if new_index[c] >= 0:
            local = new_index[c] - det_off[cs[c]]  # index among the kept clusters of its scan
            for i in range(at, at + n):
                labels[order[i]] = local
        at += n
    cen = np.empty((d, 2))
    body = np.empty((d, 2))
    rad = np.empty(d)
    vr = np.empty(d)
    cnt = np.empty(d, dtype=np.int64)
    rng = np.empty(d)
    ext = np.empty(d, dtype=np.bool_)
    occ = np.empty(d, dtype=np.bool_)
    for c in range(m):
        k = new_index[c]
        if k < 0:
            continue
        s = cs[c]
        cx, cy = centres[c, 0], centres[c, 1]
        rx, ry = cx - origins[s, 0], cy - origins[s, 1]
        ch, sh = cos_h[s], sin_h[s]
        cen[k, 0], cen[k, 1] = cx, cy
        body[k, 0] = ch * rx + sh * ry
        body[k, 1] = -sh * rx + ch * ry
        rad[k], vr[k], cnt[k], occ[k] = radii[c], var[c], counts[c], occluded[c]
        rng[k] = math.hypot(rx, ry)
        ext[k] = radii[c] > max_radius_m[s]
    return cen, body, rad, vr, cnt, rng, ext, occ, labels, det_off


@kernel
def detect_clusters(beams, P, rho, ret_off, n_beams, d0, lam, dth, gap, sigma, full, beam_off, hit_all, ranges_all,
                    origins, cos_h, sin_h, edge_lost, min_rad, edge_var, sig2, floor2, min_pts, max_radius_m):
    """The detections of the stacked returns of S scans (:func:`mjasc.perception.detection.detect_many`):
    :func:`~mjasc.perception.cluster_kernels.cluster_order` of the returns (hit beams (K,), points
    (K, 2) [m], ranges (K,) [m], scan s owning ``ret_off[s] : ret_off[s+1]``), then
    :func:`cluster_discs` and :func:`~mjasc.perception.cluster_kernels.occluded_edges` of the returns
    in cluster sequence, then :func:`kept_detections`; the per-scan (S,) arguments are theirs
    (``dth`` the beam spacing). Returns what :func:`kept_detections` returns for d detections,
    packed into four arrays (every returned array costs the caller a Python call to unbox it)
    and d: ``points`` (2d, 2) = centres, then centres in the body frame; ``floats`` (3d,) =
    radii, variances, ranges; ``ints`` (d + K + S + 1,) = return counts, labels (K,), offsets
    (S + 1,); ``flags`` (2d,) = extended, occluded (:func:`unpack_detections`, the caller's slices)."""
    order, starts, counts, cs = cluster_order(beams, P, rho, ret_off, n_beams, d0, lam, dth, gap, sigma, full)
    P_o = P[order]
    rho_o = rho[order]
    centres, radii, var = cluster_discs(P_o, rho_o, starts, counts, cs, origins, dth, edge_lost, min_rad, edge_var,
                                        sig2, floor2)
    occluded = occluded_edges(beams[order], rho_o, starts, counts, cs, beam_off, n_beams, gap, full, hit_all,
                              ranges_all)
    cen, body, rad, vr, cnt, rng, ext, occ, labels, det_off = kept_detections(
        order, counts, cs, centres, radii, var, occluded, origins, cos_h, sin_h, min_pts, max_radius_m)
    d, K, S = rad.shape[0], labels.shape[0], det_off.shape[0] - 1
    points = np.empty((2 * d, 2))
    floats = np.empty(3 * d)
    ints = np.empty(d + K + S + 1, dtype=np.int64)
    flags = np.empty(2 * d, dtype=np.bool_)
    points[:d] = cen
    points[d:] = body
    floats[:d] = rad
    floats[d:2 * d] = vr
    floats[2 * d:] = rng
    ints[:d] = cnt
    ints[d:d + K] = labels
    ints[d + K:] = det_off
    flags[:d] = ext
    flags[d:] = occ
    return points, floats, ints, flags, d


def unpack_detections(points, floats, ints, flags, d, K):
    """:func:`detect_clusters`' packed outputs (d detections, K returns) as :func:`kept_detections`
    returns them (views): centres, centres in the body frame, radii, variances, return counts,
    ranges, extended, occluded, labels, offsets. (:func:`mjasc.perception.detection._detect`
    slices them in place of this call.)"""
    return (points[:d], points[d:], floats[:d], floats[d:2 * d], ints[:d], floats[2 * d:], flags[:d], flags[d:],
            ints[d:d + K], ints[d + K:])
