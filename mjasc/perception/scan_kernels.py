"""Compiled per-beam loops of a range scan (:mod:`mjasc.perception.range_sensor`): what becomes of
``mj_multiRay``'s raw hits (world ENU, body FLU, metres, radians).

A scan is a few hundred beams, but its post-processing was two dozen numpy calls on them (~65 µs
per scan, 3× the ray casting itself). These loops evaluate, per beam and in the same order, the
same expressions as the numpy form they replaced (kept in ``tests/test_scan_kernels.py`` as the
reference), so the scans are the same bits. The random draws stay in numpy, in the caller, with
the same generator calls in the same order; the kernels only consume them. The trigonometric
functions stay in numpy too (numpy's SIMD sin/cos need not round like libm's).

* :func:`clean_hits` — a beam misses when its geom id < 0, its distance < 0 or > the maximum
  range: distance −1 and geom −1 (copies of the inputs).
* :func:`scan_returns` — the imperfections of a scan, in this order (docs of ``range_sensor``):
  hit = geom ≥ 0; noise ``ρ ← ρ + (σ_ρ·z)`` on hit beams (z the drawn normals, none: no noise);
  dropout ``hit ← hit ∧ (u ≥ p)`` (u the drawn uniforms, none: no dropout); clutter beams b_j at
  ranges ρ_j replace their beam where ``¬hit[b_j] ∨ ρ_j < ρ[b_j]`` (tested on the readings before
  any clutter is placed, then placed in draw order: a later draw on the same beam wins); then
  ``hit ← hit ∧ min ≤ ρ ≤ max``, geom −1 and range = max where not hit.
* :func:`scan_points` — the returns in the sensor frame ``(r cos a, r sin a)`` and in the world
  ``(o_x + c·b_x − s·b_y, o_y + s·b_x + c·b_y)`` (c, s the cosine and sine of the heading), each
  sum evaluated left to right.
* :func:`fan_directions` — the world directions ``(cos(a_k + ψ), sin(a_k + ψ), 0)`` of a fan's
  beams (body angles a_k, heading ψ) for ``mj_multiRay``: ``math.cos`` / ``math.sin`` of the sum,
  numpy's ``np.cos(np.add(a, ψ))`` bits (numpy's float64 ``cos`` / ``sin`` call the C library's
  here: docs/architecture.md, "Compiled kernels"; tests/test_scan_kernels.py asserts it).
* :func:`scan_batch` — the three above for several casts stacked (a fleet's tick, one call): each
  cast's beams ``beam_off[s] : beam_off[s+1]``, its draws and parameters per cast; the beam
  cosines and sines are the sensor's ``np.cos`` / ``np.sin`` of its beam angles, taken once
  (numpy's trigonometry rounds each element alike wherever it stands in the array).
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.compiled import kernel

__all__ = ["clean_hits", "scan_returns", "scan_points", "scan_batch", "fan_directions"]


@kernel
def clean_hits(dist, gid, max_range_m):
    """Distances [m] (n,) and geom ids (n,) of ``mj_multiRay`` with the misses (module docstring)
    set to −1; new arrays."""
    n = dist.shape[0]
    d = np.empty(n)
    g = np.empty(n, dtype=gid.dtype)
    for i in range(n):
        if gid[i] < 0 or dist[i] < 0.0 or dist[i] > max_range_m:
            d[i] = -1.0
            g[i] = -1
        else:
            d[i] = dist[i]
            g[i] = gid[i]
    return d, g


@kernel
def scan_returns(dist, gid, noise_std_m, normals, dropout_probability, uniforms, clutter_beams, clutter_ranges_m,
                 min_range_m, max_range_m, clutter_geom):
    """Ranges [m] (n,) (``max_range_m`` where no return), hit (n,) bool, geom ids (n,) (−1: no
    return, ``clutter_geom``: a false one) and the hit beams (k,) ascending, from a cast's
    distances ``dist`` (n,) (−1: nothing hit) and geom ids ``gid`` (n,) and the scan's draws:
    ``normals`` (n,) or (0,) (no noise), ``uniforms`` (n,) or (0,) (no dropout), the clutter's beams
    and ranges (k,) (module docstring). ``dist`` and ``gid`` are not modified."""
    n = dist.shape[0]
    d = dist.copy()
    g = gid.copy()
    hit = np.empty(n, dtype=np.bool_)
    for i in range(n):
        hit[i] = g[i] >= 0
    if normals.shape[0]:
        for i in range(n):
            if hit[i]:
                d[i] = d[i] + noise_std_m * normals[i]
    if uniforms.shape[0]:
        for i in range(n):
            hit[i] = hit[i] and uniforms[i] >= dropout_probability
    k = clutter_beams.shape[0]
    if k:
        nearer = np.empty(k, dtype=np.bool_)
        for j in range(k):
            b = clutter_beams[j]
            nearer[j] = (not hit[b]) or clutter_ranges_m[j] < d[b]
        for j in range(k):
            if nearer[j]:
                b = clutter_beams[j]
                d[b] = clutter_ranges_m[j]
                hit[b] = True
                g[b] = clutter_geom
    ranges = np.empty(n)
    for i in range(n):
        h = hit[i] and d[i] >= min_range_m and d[i] <= max_range_m
        hit[i] = h
        if h:
            ranges[i] = d[i]
        else:
            ranges[i] = max_range_m
            g[i] = -1
    return ranges, hit, g, np.nonzero(hit)[0]


@kernel
def scan_points(ranges, beams, cos_a, sin_a, origin_x, origin_y, cos_h, sin_h):
    """The returns of ``beams`` (k,) in the sensor frame (k, 2) and in the world (k, 2) [m]:
    range ``ranges[beams]``, beam angle with cosine ``cos_a`` and sine ``sin_a`` (k,), sensor at
    (origin_x, origin_y) with heading cosine and sine ``cos_h``, ``sin_h`` (module docstring)."""
    k = beams.shape[0]
    body = np.empty((k, 2))
    world = np.empty((k, 2))
    for i in range(k):
        r = ranges[beams[i]]
        bx = r * cos_a[i]
        by = r * sin_a[i]
        body[i, 0] = bx
        body[i, 1] = by
        world[i, 0] = origin_x + cos_h * bx - sin_h * by
        world[i, 1] = origin_y + sin_h * bx + cos_h * by
    return body, world


@kernel
def fan_directions(angles_body, yaw, vec):
    """Write the world directions of the beams at body angles ``angles_body`` (n,) [rad] of a
    sensor at heading ``yaw`` [rad] into the x and y columns of ``vec`` (n, 3) (module docstring;
    its z column is left as it is)."""
    for k in range(angles_body.shape[0]):
        a = angles_body[k] + yaw
        vec[k, 0] = math.cos(a)
        vec[k, 1] = math.sin(a)


@kernel
def scan_batch(dist, gid, beam_off, noise_std_m, normals, has_normals, dropout_probability, uniforms, has_uniforms,
               clutter_beams, clutter_ranges_m, clutter_off, min_range_m, max_range_m, clutter_geom, cos_body,
               sin_body, origins, headings, cos_h, sin_h):
    """The scans of S casts stacked: cast s owns the beams ``beam_off[s] : beam_off[s+1]`` of the raw
    ``mj_multiRay`` distances ``dist`` and geom ids ``gid``, of the draws ``normals`` / ``uniforms``
    (used where ``has_normals[s]`` / ``has_uniforms[s]``) and of the beam cosines / sines
    ``cos_body`` / ``sin_body``, and its clutter ``clutter_off[s] : clutter_off[s+1]``; per cast
    (S,): σ_ρ, dropout probability, min and max range [m], origin (S, 2) [m], heading [rad]; its
    cosine and sine are written into ``cos_h`` and ``sin_h`` (S,) (``math.cos`` / ``math.sin``,
    the C library's, as Python's ``math`` has them). Each cast is :func:`clean_hits`,
    :func:`scan_returns` and :func:`scan_points`. Returns, in five arrays and K (every returned
    array costs the caller a Python call to unbox it):

    * ``floats`` (2N,): the stacked ranges (N,) [m], then the returns' ranges (K,) [m];
    * ``points`` (2N, 2): the returns in the sensor frame (K, 2), from row N those in the world (K, 2) [m];
    * hit (N,) and geom ids (N,);
    * ``ints`` (N + S + 1,): the hit beams (K,) (indices within their cast), from N ``ret_off``
      (S + 1,) (cast s owns returns ``ret_off[s] : ret_off[s+1]``);
    * K, the number of returns.

    The three kernels' loops are written out over the stacked outputs (no per-cast arrays), each
    expression as they have it. The per-beam inputs may be longer than the N = ``beam_off[S]``
    beams (a batch's buffers, passed whole)."""
    S = beam_off.shape[0] - 1
    N = beam_off[S]
    floats = np.empty(2 * N)
    points = np.empty((2 * N, 2))
    hit = np.empty(N, dtype=np.bool_)
    geom = np.empty(N, dtype=gid.dtype)
    ints = np.empty(N + S + 1, dtype=np.int64)
    ranges, rho = floats[:N], floats[N:]
    body, world = points[:N], points[N:]
    beams, ret_off = ints[:N], ints[N:]
    ret_off[0] = 0
    for s in range(S):
        cos_h[s] = math.cos(headings[s])
        sin_h[s] = math.sin(headings[s])
    k = 0
    for s in range(S):  # the loops of clean_hits, scan_returns and scan_points, written into the outputs
        a, b = beam_off[s], beam_off[s + 1]
        mx, mn = max_range_m[s], min_range_m[s]
        sig, p = noise_std_m[s], dropout_probability[s]
        noisy, drops = has_normals[s], has_uniforms[s]
        for i in range(a, b):
            d, g = dist[i], gid[i]
            if g < 0 or d < 0.0 or d > mx:
                d, g = -1.0, -1
            h = g >= 0
            if noisy and h:
                d = d + sig * normals[i]
            if drops:
                h = h and uniforms[i] >= p
            ranges[i], geom[i], hit[i] = d, g, h
        c0, c1 = clutter_off[s], clutter_off[s + 1]
        if c1 > c0:
            nearer = np.empty(c1 - c0, dtype=np.bool_)
            for j in range(c0, c1):  # tested on the readings before any clutter is placed
                i = a + clutter_beams[j]
                nearer[j - c0] = (not hit[i]) or clutter_ranges_m[j] < ranges[i]
            for j in range(c0, c1):
                if nearer[j - c0]:
                    i = a + clutter_beams[j]
                    ranges[i] = clutter_ranges_m[j]
                    hit[i] = True
                    geom[i] = clutter_geom
        ox, oy, ch, sh = origins[s, 0], origins[s, 1], cos_h[s], sin_h[s]
        for i in range(a, b):
            d = ranges[i]
            h = hit[i] and d >= mn and d <= mx
            hit[i] = h
            if h:
                bx = d * cos_body[i]
                by = d * sin_body[i]
                beams[k] = i - a
                rho[k] = d
                body[k, 0], body[k, 1] = bx, by
                world[k, 0] = ox + ch * bx - sh * by
                world[k, 1] = oy + sh * bx + ch * by
                k += 1
            else:
                ranges[i] = mx
                geom[i] = -1
        ret_off[s + 1] = k
    return floats, points, hit, geom, ints, k
