"""Compiled loops behind :mod:`mjasc.core.geometry`: convex hull, distance to a polygon's boundary and
containment (world frame ENU, metres).

They are called at every tick by every vessel (a static track's outline, the run metrics'
clearance to mapped land, the static map), on a few dozen points at a time, where numpy's cost per
call was most of the work. Each loop evaluates the same expression, in the same order, as the
vectorized numpy formulation it replaced, so the results are bit-identical to it
(``tests/test_geometry_kernels.py`` checks that against numpy and scipy's Qhull).

* :func:`hull_indices` — Andrew's monotone chain over lexicographically sorted distinct points:
  the counter-clockwise hull from the smallest point, collinear boundary points dropped (a
  point is kept only on a strict left turn, ``cross > 0``).
* :func:`canonical_hull` — the whole canonical hull of :func:`mjasc.core.geometry.convex_hull` in
  one call: each coordinate rounded to 1 µm as ``np.round(x, 6)`` rounds (``rint(x·10⁶) / 10⁶``,
  three IEEE operations), a stable sort by x then y (``np.lexsort``'s order: −0.0 = +0.0, equal
  points keep their input order), the points equal to their predecessor dropped, then
  :func:`hull_indices`.
* :func:`boundary_distance` — per point, the minimum over edges a→b of ‖p − (a + t (b − a))‖,
  t = clip(((p − a)·(b − a)) / max(‖b − a‖², 1e-18), 0, 1).
* :func:`inside_even_odd` — per point, the parity of the edges crossing the horizontal ray to +x
  (even-odd rule).
* :func:`self_crossings` — the pairs of non-adjacent edges of one polygon that intersect or touch
  (:func:`mjasc.core.geometry.self_intersections`), :func:`edges_cross` — whether an edge of one
  polygon meets an edge of another: per pair the orientations and bounding-box
  tests of :func:`mjasc.core.geometry.segments_intersect`, the same expressions (elementwise there:
  the same booleans).
* :func:`offset_vertices` — :func:`mjasc.core.geometry.inflate_polygon`'s offset vertices: per
  vertex the miter, or the tangent bevel's two points at a convex corner sharper than 90°, with
  its expressions in its order (its 2-vector dot products ``n1 @ n2`` are numpy's unfused
  x·x' + y·y'; ``math``'s tan and acos are numpy's here, docs/architecture.md).
* :func:`clean_vertices` — the vertices :func:`mjasc.core.geometry.clean_polygon` keeps (the
  zero-length edges' and the collinear vertices' tests, then :func:`self_crossings`): indices into
  the input, so the kept vertices are the input's bits.
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.compiled import clip, kernel

__all__ = ["hull_indices", "canonical_hull", "boundary_distance", "inside_even_odd", "self_crossings",
           "edges_cross", "clean_vertices",
           "offset_vertices"]


@kernel
def _left_turn(p, o, a, i):
    """p[o] → p[a] → p[i] turns strictly left (cross product of (a − o) and (i − o) > 0)."""
    return (p[a, 0] - p[o, 0]) * (p[i, 1] - p[o, 1]) - (p[a, 1] - p[o, 1]) * (p[i, 0] - p[o, 0]) > 0.0


@kernel
def hull_indices(p):
    """Indices (k,) into ``p`` (n, 2) — sorted by x then y, no repeated point — of its convex hull,
    counter-clockwise from p[0]; n ≤ 2 or all points on a line → [0, n − 1] (or [0])."""
    n = p.shape[0]
    if n <= 2:
        return np.arange(n)
    idx = np.empty(2 * n, dtype=np.int64)
    k = 0
    for i in range(n):  # lower hull, left to right
        while k >= 2 and not _left_turn(p, idx[k - 2], idx[k - 1], i):
            k -= 1
        idx[k] = i
        k += 1
    low = k + 1
    for i in range(n - 2, -1, -1):  # upper hull, right to left
        while k >= low and not _left_turn(p, idx[k - 2], idx[k - 1], i):
            k -= 1
        idx[k] = i
        k += 1
    return idx[: k - 1].copy()  # the last index repeats the first


@kernel
def canonical_hull(points):
    """Vertices (k, 2) [m] of the canonical convex hull of ``points`` (n, 2) [m], all finite
    (module docstring): counter-clockwise from the smallest point; ≤ 2 distinct points or all on a
    line → the distinct points, or the two extreme ones."""
    n = points.shape[0]
    q = np.empty((n, 2))
    for i in range(n):  # np.round(x, 6): multiply, rint, divide
        q[i, 0] = np.rint(points[i, 0] * 1e6) / 1e6
        q[i, 1] = np.rint(points[i, 1] * 1e6) / 1e6
    order = np.empty(n, dtype=np.int64)
    for i in range(n):  # stable insertion sort by (x, y): a point moves only past strictly larger ones
        xi, yi = q[i, 0], q[i, 1]
        j = i
        while j > 0:
            o = order[j - 1]
            if q[o, 0] > xi or (q[o, 0] == xi and q[o, 1] > yi):
                order[j] = o
                j -= 1
            else:
                break
        order[j] = i
    p = np.empty((n, 2))
    m = 0
    for j in range(n):  # drop the points equal to their predecessor in that order
        i = order[j]
        if j == 0 or q[i, 0] != q[order[j - 1], 0] or q[i, 1] != q[order[j - 1], 1]:
            p[m, 0] = q[i, 0]
            p[m, 1] = q[i, 1]
            m += 1
    p = p[:m]
    if m <= 2:
        return p.copy()
    idx = hull_indices(p)
    out = np.empty((idx.size, 2))
    for j in range(idx.size):
        out[j, 0] = p[idx[j], 0]
        out[j, 1] = p[idx[j], 1]
    return out


@kernel
def boundary_distance(pts, poly):
    """Distance [m] (n,) from each point of ``pts`` (n, 2) to the boundary of the closed polygon
    ``poly`` (k, 2) (module docstring)."""
    n, m = pts.shape[0], poly.shape[0]
    out = np.empty(n)
    for i in range(n):
        px, py = pts[i, 0], pts[i, 1]
        best = np.inf
        for j in range(m):
            ax, ay = poly[j, 0], poly[j, 1]
            jb = j + 1 if j + 1 < m else 0
            abx, aby = poly[jb, 0] - ax, poly[jb, 1] - ay
            t = ((px - ax) * abx + (py - ay) * aby) / max(abx * abx + aby * aby, 1e-18)
            t = min(max(t, 0.0), 1.0)
            dx, dy = px - (ax + t * abx), py - (ay + t * aby)
            d = np.sqrt(dx * dx + dy * dy)
            if d < best:
                best = d
            elif d != d:  # NaN propagates, as np.min
                best = d
                break
        out[i] = best
    return out


@kernel
def inside_even_odd(pts, poly):
    """bool (n,): each point of ``pts`` (n, 2) strictly inside the closed polygon ``poly`` (k, 2) by
    the even-odd rule (points on the boundary may fall either way)."""
    n, m = pts.shape[0], poly.shape[0]
    out = np.zeros(n, dtype=np.bool_)
    for i in range(n):
        px, py = pts[i, 0], pts[i, 1]
        count = 0
        for j in range(m):
            ax, ay = poly[j, 0], poly[j, 1]
            jb = j + 1 if j + 1 < m else 0
            bx, by = poly[jb, 0], poly[jb, 1]
            if (ay > py) != (by > py):
                if px < ax + (py - ay) * (bx - ax) / (by - ay):
                    count += 1
        out[i] = count % 2 == 1
    return out


@kernel
def _orient(ax, ay, bx, by, cx, cy):
    """``segments_intersect``'s orient(a, b, c): (b − a) × (c − a)."""
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


@kernel
def _on_segment(ax, ay, bx, by, cx, cy, tol):
    """``segments_intersect``'s on_segment(a, b, c): c within the box of a–b grown by ``tol``."""
    return (min(ax, bx) - tol <= cx) and (cx <= max(ax, bx) + tol) and (min(ay, by) - tol <= cy) and \
        (cy <= max(ay, by) + tol)


@kernel
def _segments_hit(p1x, p1y, p2x, p2y, q1x, q1y, q2x, q2y, tol):
    """``segments_intersect`` of the segments p1–p2 and q1–q2 (a proper crossing or a touch within
    ``tol``)."""
    d1, d2 = _orient(q1x, q1y, q2x, q2y, p1x, p1y), _orient(q1x, q1y, q2x, q2y, p2x, p2y)
    d3, d4 = _orient(p1x, p1y, p2x, p2y, q1x, q1y), _orient(p1x, p1y, p2x, p2y, q2x, q2y)
    tol2 = tol * tol
    if ((d1 > tol2 and d2 < -tol2) or (d1 < -tol2 and d2 > tol2)) and \
            ((d3 > tol2 and d4 < -tol2) or (d3 < -tol2 and d4 > tol2)):
        return True
    return ((abs(d1) <= tol2 and _on_segment(q1x, q1y, q2x, q2y, p1x, p1y, tol))
            or (abs(d2) <= tol2 and _on_segment(q1x, q1y, q2x, q2y, p2x, p2y, tol))
            or (abs(d3) <= tol2 and _on_segment(p1x, p1y, p2x, p2y, q1x, q1y, tol))
            or (abs(d4) <= tol2 and _on_segment(p1x, p1y, p2x, p2y, q2x, q2y, tol)))


@kernel
def self_crossings(v, tol, out):
    """The pairs (i, j), i < j in row-major order, of non-adjacent edges (edge i: vertex i → i + 1,
    the last one back to vertex 0) of the polygon v (k, 2) that intersect or touch within ``tol``
    [m], into ``out`` (≥ k (k − 1) / 2, 2); returns their count."""
    k = v.shape[0]
    n = 0
    for i in range(k):
        i2 = i + 1 if i + 1 < k else 0
        for j in range(i + 1, k):
            if j == i + 1 or (i == 0 and j == k - 1):
                continue
            j2 = j + 1 if j + 1 < k else 0
            if _segments_hit(v[i, 0], v[i, 1], v[i2, 0], v[i2, 1], v[j, 0], v[j, 1], v[j2, 0], v[j2, 1], tol):
                out[n, 0], out[n, 1] = i, j
                n += 1
    return n


@kernel
def edges_cross(a, b, tol):
    """Whether some edge of the polygon a (k, 2) and some edge of the polygon b (m, 2) (closed: the
    last vertex joins the first) intersect or touch within ``tol`` [m] (``segments_intersect``,
    any)."""
    k, m = a.shape[0], b.shape[0]
    for i in range(k):
        i2 = i + 1 if i + 1 < k else 0
        for j in range(m):
            j2 = j + 1 if j + 1 < m else 0
            if _segments_hit(a[i, 0], a[i, 1], a[i2, 0], a[i2, 1], b[j, 0], b[j, 1], b[j2, 0], b[j2, 1], tol):
                return True
    return False


@kernel
def clean_vertices(v, tol, keep, pair):
    """The vertices :func:`mjasc.core.geometry.clean_polygon` keeps of the finite polygon v (k ≥ 1,
    2), ``tol`` its zero-length tolerance [m]: their indices into ``keep`` (k,) and a code:
    (n, 0) kept n; (n, 1) fewer than 3 distinct vertices (n of them); (i, 2) the boundary folds back
    at vertex i (an index into v); (n, 3) fewer than 3 non-collinear vertices; (n, 4) edges
    ``pair`` (2,) cross. The tests are numpy's: a zero-length edge ‖v_i − v_{i−1}‖ (sqrt of
    x² + y²) ≤ tol; a flat vertex |e_in × e_out| ≤ 1e-9 ‖e_in‖ ‖e_out‖, the first one merged at a
    time (a folding one, e_in · e_out < 0, refused), until none is left."""
    k = v.shape[0]
    n = 0
    for i in range(k):
        j = i - 1 if i > 0 else k - 1
        dx, dy = v[i, 0] - v[j, 0], v[i, 1] - v[j, 1]
        if math.sqrt(dx * dx + dy * dy) > tol:
            keep[n] = i
            n += 1
    if n < 3:
        return n, 1
    changed = True
    while changed and n >= 3:
        changed = False
        for i in range(n):
            a, b, c = keep[i - 1 if i > 0 else n - 1], keep[i], keep[i + 1 if i + 1 < n else 0]
            ix, iy = v[b, 0] - v[a, 0], v[b, 1] - v[a, 1]
            ox, oy = v[c, 0] - v[b, 0], v[c, 1] - v[b, 1]
            cross = ix * oy - iy * ox
            lens = math.sqrt(ix * ix + iy * iy) * math.sqrt(ox * ox + oy * oy)
            if abs(cross) <= 1e-9 * lens:
                if ix * ox + iy * oy < 0:  # (flat: |e_in · e_out| is ‖e_in‖ ‖e_out‖, its sign certain)
                    return b, 2
                for q in range(i, n - 1):
                    keep[q] = keep[q + 1]
                n -= 1
                changed = True
                break
    if n < 3:
        return n, 3
    w = np.empty((n, 2))
    for q in range(n):
        w[q, 0], w[q, 1] = v[keep[q], 0], v[keep[q], 1]
    out = np.empty((n * (n - 1) // 2, 2), dtype=np.int64)
    if self_crossings(w, tol, out):
        pair[0], pair[1] = out[0, 0], out[0, 1]
        return n, 4
    return n, 0


@kernel
def offset_vertices(v, margin, out):
    """The vertices of the clean counter-clockwise polygon v (k, 2) offset outward by ``margin`` > 0
    [m] into ``out`` (≥ 2k, 2), in order; returns their count. Per vertex, with the incoming edge's
    unit tangent t1 and outward normal n1 (n = (t_y, −t_x)) and the outgoing edge's t2, n2: at a
    convex corner (t1 × t2 > 0) sharper than 90° (cos φ = clip(n1 · n2, −1, 1) < 0) the bevel
    v + m n1 + s t1, v + m n2 − s t2 with s = m tan(acos(cos φ) / 4); else the miter
    v + m (n1 + n2) / (1 + cos φ)."""
    k = v.shape[0]
    t = np.empty((k, 2))
    for i in range(k):
        j = i + 1 if i + 1 < k else 0
        ex, ey = v[j, 0] - v[i, 0], v[j, 1] - v[i, 1]
        length = math.sqrt(ex * ex + ey * ey)
        t[i, 0], t[i, 1] = ex / length, ey / length
    n = 0
    for i in range(k):
        p = i - 1 if i > 0 else k - 1
        t1x, t1y, t2x, t2y = t[p, 0], t[p, 1], t[i, 0], t[i, 1]
        n1x, n1y, n2x, n2y = t1y, -t1x, t2y, -t2x
        turn = t1x * t2y - t1y * t2x
        cos_phi = clip(n1x * n2x + n1y * n2y, -1.0, 1.0)
        if turn > 0 and cos_phi < 0.0:
            s = margin * math.tan(math.acos(cos_phi) / 4.0)
            out[n, 0], out[n, 1] = v[i, 0] + margin * n1x + s * t1x, v[i, 1] + margin * n1y + s * t1y
            out[n + 1, 0], out[n + 1, 1] = v[i, 0] + margin * n2x - s * t2x, v[i, 1] + margin * n2y - s * t2y
            n += 2
        else:
            out[n, 0] = v[i, 0] + margin * (n1x + n2x) / (1.0 + cos_phi)
            out[n, 1] = v[i, 1] + margin * (n1y + n2y) / (1.0 + cos_phi)
            n += 1
    return n
