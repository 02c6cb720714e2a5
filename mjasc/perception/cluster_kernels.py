"""Compiled loops of the clustering in :func:`mjasc.perception.detection.detect_many`: which returns
of a tick's scans form one object, and which objects have a hidden edge (world ENU, metres,
radians; the rules are in the docstring of :mod:`mjasc.perception.detection`, "Clustering" and
"Partly hidden objects").

The scans' returns are stacked, scan s owning ``ret_off[s] : ret_off[s+1]`` in beam order; per
scan (arrays (S,)): beams n, spacing Δθ, d₀, λ, the gap bridged + 1 (``gap``), σ_ρ, full circle.

* :func:`cluster_order` — per return i and its cyclic successor j in its scan: beam gap
  ``g = b_j − b_i (+ n at the scan's last return)``, step ``‖p_j − p_i‖``, a break where
  ``g > gap`` or ``step > d₀ + λ·min(ρ_i, ρ_j)·g·Δθ`` — unless (scans of ≥ 3 returns) the step
  continues a grazed wall (below); the last return of a scan always breaks unless the fan is a
  full circle with more than one return. Each scan's sequence then starts just after its first
  break (none: in beam order); clusters start at a scan's first return and after each break.
  *Wall*: with ``ℓ = max(step, 10⁻⁹)``, ``û = (p_j − p_i)/ℓ`` and the per-beam length
  ``ℓ / max(g, 1)``, the step i → j and the previous one (p → i) are both bridged (g ≤ gap), turn
  forward (``û_p·û_i > 0``) by less than ``min(1, 3σ(1/ℓ_i + 1/ℓ_p)) + 0.035`` in ``|û_p × û_i|``,
  and have per-beam lengths within ``max ≤ 5·min + 6σ``: ``back_i``; the step is a wall's when
  ``back_i ∨ back_j``, it is bridged and at most 50 m.
* :func:`occluded_edges` — a cluster's edge return at beam b has, among the ``gap`` beams beyond it
  (cyclic in a full circle, clipped to the fan otherwise), a return nearer by more than 1 m, or (a
  partial fan) the next beam is outside the fan.

Every comparison and arithmetic expression is the numpy form's (kept in
``tests/test_cluster_kernels.py`` as the reference), in the same order, so the clusters are the
same; ``min``/``max`` propagate NaN as ``np.minimum``/``np.maximum`` do.
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.compiled import kernel, maximum, minimum

__all__ = ["cluster_order", "occluded_edges"]

_OCCLUDER_MARGIN_M = 1.0  # a neighbouring return this much nearer hides the cluster's edge
_WALL_SIN_TOL = 0.035  # 2°: three returns this straight on neighbouring beams are a wall
_WALL_STEP_MAX_M = 50.0  # longest step along a grazed wall kept in one object
#: Neighbouring beams hit a straight wall at spacings h·sin Δθ / (sin φ_k sin φ_k+1) (h the wall's
#: distance, φ_k the beam's angle to the wall), so successive spacings differ by the factor
#: sin φ_k / sin φ_k+2: at most 5 while φ ≥ Δθ/2. A long step after (or before) a short one is
#: not the same wall: it is the jump from another object's edge onto a wall behind it.
_WALL_STEP_RATIO = 5.0


@kernel
def cluster_order(beams, P, rho, ret_off, n_beams, d0, lam, dth, gap, sigma, full):
    """The clusters of the stacked returns (module docstring): ``order`` (K,) the returns in
    cluster sequence (each scan's rotated), ``starts`` (m,) and ``counts`` (m,) of the clusters
    in that sequence, ``cs`` (m,) the scan of each. ``beams`` (K,) int, ``P`` (K, 2) [m], ``rho`` (K,) [m]."""
    S = ret_off.shape[0] - 1
    K = P.shape[0]
    nxt = np.empty(K, dtype=np.int64)
    gaps = np.empty(K, dtype=np.int64)
    step = np.empty(K)
    brk = np.empty(K, dtype=np.bool_)
    length = np.empty(K)
    ux = np.empty(K)
    uy = np.empty(K)
    per_beam = np.empty(K)
    back = np.empty(K, dtype=np.bool_)
    order = np.empty(K, dtype=np.int64)
    starts = np.empty(K, dtype=np.int64)
    cs = np.empty(K, dtype=np.int64)
    m = 0
    for s in range(S):
        a, b = ret_off[s], ret_off[s + 1]
        k = b - a
        if k == 0:
            continue
        for i in range(a, b):
            last = i == b - 1
            j = a if last else i + 1
            nxt[i] = j
            g = beams[j] - beams[i] + (n_beams[s] if last else 0)
            gaps[i] = g
            dx, dy = P[j, 0] - P[i, 0], P[j, 1] - P[i, 1]
            st = math.hypot(dx, dy)
            step[i] = st
            thr = d0[s] + lam[s] * minimum(rho[i], rho[j]) * g * dth[s]
            brk[i] = g > gap[s] or st > thr
            ln = maximum(st, 1e-9)
            length[i] = ln
            ux[i], uy[i] = dx / ln, dy / ln
            per_beam[i] = ln / max(g, 1)
        if k >= 3:  # steps along a grazed wall do not break
            sig = sigma[s]
            for i in range(a, b):
                p = b - 1 if i == a else i - 1
                tol = minimum(1.0, 3.0 * sig * (1.0 / length[i] + 1.0 / length[p])) + _WALL_SIN_TOL
                cross = abs(ux[p] * uy[i] - uy[p] * ux[i])
                hi_pb = maximum(per_beam[i], per_beam[p])
                lo_pb = minimum(per_beam[i], per_beam[p])
                similar = hi_pb <= _WALL_STEP_RATIO * lo_pb + 6.0 * sig
                back[i] = (gaps[i] <= gap[s] and gaps[p] <= gap[s] and ux[p] * ux[i] + uy[p] * uy[i] > 0
                           and cross < tol and similar)
            for i in range(a, b):
                wall = (back[i] or back[nxt[i]]) and gaps[i] <= gap[s] and step[i] <= _WALL_STEP_MAX_M
                if wall:
                    brk[i] = False
        if not (full[s] and k > 1):
            brk[b - 1] = True
        shift = 0
        for i in range(a, b):
            if brk[i]:
                shift = i - a + 1
                break
        for q in range(k):  # each scan's sequence starts just after its first break
            i = a + (q + shift) % k
            order[a + q] = i
            if q == 0 or brk[order[a + q - 1]]:
                starts[m] = a + q
                cs[m] = s
                m += 1
    counts = np.empty(m, dtype=np.int64)
    for c in range(m):
        counts[c] = (starts[c + 1] if c + 1 < m else K) - starts[c]
    return order, starts[:m].copy(), counts, cs[:m].copy()


@kernel
def occluded_edges(beams, rho, starts, counts, cs, beam_off, n_beams, gap, full, hit_all, ranges_all):
    """(m,) bool: cluster c (returns ``starts[c] : starts[c] + counts[c]`` of ``beams`` / ``rho``
    in cluster sequence, scan ``cs[c]``) has a hidden edge (module docstring). The scans' beams are
    stacked in ``hit_all`` / ``ranges_all`` [m] from ``beam_off`` (S,)."""
    m = starts.shape[0]
    occ = np.zeros(m, dtype=np.bool_)
    for c in range(m):
        s = cs[c]
        n, fc, base, g = n_beams[s], full[s], beam_off[s], gap[s]
        hidden = False
        for side in range(2):
            edge = starts[c] if side == 0 else starts[c] + counts[c] - 1
            sign = -1 if side == 0 else 1
            b0 = beams[edge]
            if not fc and (b0 + sign < 0 or b0 + sign >= n):
                hidden = True
            lim = rho[edge] - _OCCLUDER_MARGIN_M
            for k in range(1, g + 1):
                nb = b0 + sign * k
                if fc:
                    nb = nb % n
                else:
                    nb = min(max(nb, 0), n - 1)
                if hit_all[base + nb] and ranges_all[base + nb] < lim:
                    hidden = True
        occ[c] = hidden
    return occ
