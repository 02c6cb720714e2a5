"""The streamline tracer's RK4 loop in one compiled call, with the bits of its numpy form.

:func:`trace_compiled` is :func:`~mjasc.avoidance.potential_field.streamlines.trace_numpy` (the
readable numpy form, kept as the reference and as the fallback) written as plain loops over the
lines: each step's checks at the current points, then the three further field evaluations of the
RK4 step, line by line — the lines never mix, so only the operations' order within a line matters.
The field is :meth:`~mjasc.avoidance.potential_field.field.PotentialField.evaluate`'s fused form
(world frame ENU, metres): uniform flow + goal sink, then ``ln r² @ A + β @ B`` over the panels'
vertices, the winding number per obstacle (``np.add.reduceat``: the first term plus numpy's
pairwise sum of the rest) and the distance to the nearest vertex.

The same bits as numpy, operation by operation: elementwise arithmetic in numpy's order;
``math``'s log, atan2, hypot and sqrt, which equal numpy's on this machine class (the
compiled-kernels convention, docs/architecture.md); the two products ``(k, m) @ (m, 2)`` in
OpenBLAS's order, which depends on how many lines the numpy form evaluates together — one line:
``dgemv``, pairs of unfused products added to a running sum four at a time; several: ``dgemm``,
fused multiply-adds over the panels in order from +0 (up to :data:`MAX_PANELS` panels: beyond,
OpenBLAS splits the sum into blocks and the caller runs the numpy form). The test
(``tests/test_streamline_kernels.py``) asserts those orders against numpy and the tracer against
its numpy form.
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.compiled import clip, fma, kernel, minimum, pairwise_sum

__all__ = ["MAX_PANELS", "trace_compiled"]

#: The most panels whose products :func:`trace_compiled` sums in OpenBLAS's order (its ``dgemm``
#: splits longer sums into blocks).
MAX_PANELS = 256

_TWO_PI = 2.0 * math.pi
# Reason codes (1 + index into streamlines.REASONS)
_GOAL, _STAGNATION, _RUNAWAY, _MAX_LENGTH, _ENTERED, _NONFINITE = 1, 2, 3, 4, 5, 6


@kernel
def row_product(x, A, col, batch):
    """Entry ``col`` of numpy's ``X @ A`` for a row ``x`` (m,) of X (k, m), A (m, 2), k = ``batch``:
    OpenBLAS's ``dgemv`` order for one row (pairs of unfused products added to a running sum, four
    at a time), its ``dgemm`` order for several (fused multiply-adds in order from +0)."""
    m = x.shape[0]
    t = 0.0
    if batch == 1:
        m4 = m - m % 4
        i = 0
        while i < m4:
            t = t + (A[i, col] * x[i] + A[i + 1, col] * x[i + 1])
            t = t + (A[i + 2, col] * x[i + 2] + A[i + 3, col] * x[i + 3])
            i += 4
        while i < m:
            t = t + A[i, col] * x[i]
            i += 1
        return t
    for i in range(m):
        t = fma(x[i], A[i, col], t)
    return t


@kernel
def _field_at(x, y, batch, goal, has_goal, u_inf, sink_c, V, nxt, A, B, r2, lr2, beta):
    """``PotentialField.evaluate`` at one point (x, y) evaluated in a batch of ``batch`` points:
    the velocity (u, v); leaves r² and β per panel in ``r2``, ``beta`` (``lr2``: scratch)."""
    u0, u1 = u_inf[0], u_inf[1]
    if has_goal:  # _free_stream: u∞ − (λ_g / 2π) d / |d|²
        d0, d1 = x - goal[0], y - goal[1]
        rg = d0 * d0 + d1 * d1
        u0, u1 = u0 - sink_c * d0 / rg, u1 - sink_c * d1 / rg
    m = V.shape[0]
    if m == 0:
        return u0, u1
    for j in range(m):
        dx, dy = x - V[j, 0], y - V[j, 1]
        r2[j] = dx * dx + dy * dy
        lr2[j] = math.log(r2[j])
    for j in range(m):  # β from this row's dx, dy at the panel's end vertex
        k = nxt[j]
        dx, dy = x - V[j, 0], y - V[j, 1]
        dxb, dyb = x - V[k, 0], y - V[k, 1]
        beta[j] = math.atan2(dy * dxb - dx * dyb, dx * dxb + dy * dyb)
    u0 = u0 + (row_product(lr2, A, 0, batch) + row_product(beta, B, 0, batch))
    u1 = u1 + (row_product(lr2, A, 1, batch) + row_product(beta, B, 1, batch))
    return u0, u1


@kernel
def _direction(x, y, batch, goal, has_goal, u_inf, sink_c, V, nxt, A, B, r2, lr2, beta):
    """The flow's unit direction u / hypot(u) at (x, y) (the tracer's ``direction``)."""
    u0, u1 = _field_at(x, y, batch, goal, has_goal, u_inf, sink_c, V, nxt, A, B, r2, lr2, beta)
    s = math.hypot(u0, u1)
    return u0 / s, u1 / s


@kernel
def _append(pts, count, i, x, y):
    """Line i's next point into ``pts`` (n, cap, 2), grown (doubled) when full; the array."""
    if count[i] == pts.shape[1]:
        grown = np.empty((pts.shape[0], 2 * pts.shape[1], 2))
        grown[:, :pts.shape[1]] = pts
        pts = grown
    pts[i, count[i], 0] = x
    pts[i, count[i], 1] = y
    count[i] += 1
    return pts


@kernel
def trace_compiled(p0, goal, has_goal, ref, runaway, max_len, tol, step, h_min, cos_max_turn, speed_floor,
                   vertex_fraction, u_inf, sink_c, V, nxt, A, B, offsets):
    """The streamlines from the starts ``p0`` (n, 2) (the module docstring): returns (points (n,
    cap, 2), each line's point count (n,), its reason code (n,), 1 + index into ``REASONS``, and
    the obstacle entered (n,), −1 for none). ``goal`` (2,) (``has_goal`` False: none), ``ref`` (2,)
    the runaway reference, ``runaway`` and ``max_len`` (n,) [m], the step's limits [m] and its
    fraction of the distance to the nearest vertex, the field's
    arrays: u∞ (2,), λ_g / 2π, the panels' vertices V (m, 2), the next vertex's index (m,), A and
    B (m, 2), each obstacle's first panel (K,)."""
    n, m, n_obs = p0.shape[0], V.shape[0], offsets.shape[0]
    pts = np.empty((n, 64, 2))
    count = np.zeros(n, dtype=np.int64)
    code = np.zeros(n, dtype=np.int64)
    entered = np.full(n, -1, dtype=np.int64)
    p = p0.copy()
    travelled = np.zeros(n)
    prev = np.full((n, 2), np.nan)
    h_cap = np.full(n, step)
    for i in range(n):
        pts = _append(pts, count, i, p[i, 0], p[i, 1])
    r2, lr2, beta = np.empty(m), np.empty(m), np.empty(m)
    u = np.empty((n, 2))
    h = np.empty(n)
    go = np.zeros(n, dtype=np.bool_)
    floor = h_min * (1.0 + 1e-9)
    active = n
    while active:
        n_go = 0
        for i in range(n):  # the checks at the current points, in order of precedence
            go[i] = False
            if code[i] != 0:
                continue
            x, y = p[i, 0], p[i, 1]
            u0, u1 = _field_at(x, y, active, goal, has_goal, u_inf, sink_c, V, nxt, A, B, r2, lr2, beta)
            speed = math.hypot(u0, u1)
            d_goal = math.hypot(x - goal[0], y - goal[1]) if has_goal else math.inf
            inside = -1
            for k in range(n_obs):
                lo = offsets[k]
                hi = offsets[k + 1] if k + 1 < n_obs else m
                w = (beta[lo] + pairwise_sum(beta, lo + 1, hi - lo - 1)) / _TWO_PI
                if abs(w) > 0.5:
                    inside = k
                    break
            c = 0
            if travelled[i] >= max_len[i]:
                c = _MAX_LENGTH
            if math.hypot(x - ref[0], y - ref[1]) > runaway[i]:
                c = _RUNAWAY
            if speed < speed_floor:
                c = _STAGNATION
            if not math.isfinite(speed):
                c = _NONFINITE
            if d_goal <= tol:
                c = _GOAL
            if inside >= 0:
                c = _ENTERED
            if c != 0:
                code[i] = c
                if c == _ENTERED:
                    entered[i] = inside
                elif c == _GOAL:
                    pts = _append(pts, count, i, goal[0], goal[1])
                continue
            d_vertex = math.inf
            if m:
                r2_min = r2[0]
                for j in range(1, m):
                    r2_min = minimum(r2_min, r2[j])
                d_vertex = math.sqrt(r2_min)
            go[i] = True
            n_go += 1
            u[i, 0], u[i, 1] = u0 / speed, u1 / speed  # k1
            h_local = minimum(vertex_fraction * d_vertex, 0.5 * d_goal)
            h[i] = clip(minimum(h_local, h_cap[i]), h_min, step)
        for i in range(n):  # the RK4 step of the lines that go on
            if not go[i]:
                continue
            x, y, hi = p[i, 0], p[i, 1], h[i]
            k1x, k1y = u[i, 0], u[i, 1]
            half = 0.5 * hi
            k2x, k2y = _direction(x + half * k1x, y + half * k1y, n_go, goal, has_goal, u_inf, sink_c, V, nxt, A, B,
                                  r2, lr2, beta)
            k3x, k3y = _direction(x + half * k2x, y + half * k2y, n_go, goal, has_goal, u_inf, sink_c, V, nxt, A, B,
                                  r2, lr2, beta)
            k4x, k4y = _direction(x + hi * k3x, y + hi * k3y, n_go, goal, has_goal, u_inf, sink_c, V, nxt, A, B,
                                  r2, lr2, beta)
            dx = (k1x + 2.0 * k2x + 2.0 * k3x + k4x) / 6.0
            dy = (k1y + 2.0 * k2y + 2.0 * k3y + k4y) / 6.0
            nx, ny = x + hi * dx, y + hi * dy
            turn_ok = k1x * k4x + k1y * k4y >= cos_max_turn
            cusp = prev[i, 0] * dx + prev[i, 1] * dy < -0.5
            bad = not (math.isfinite(nx) and math.isfinite(ny))
            at_floor = hi <= floor
            stalled = cusp or (not turn_ok and at_floor)
            if bad:
                code[i] = _NONFINITE
            elif stalled:
                code[i] = _STAGNATION
            elif not turn_ok:  # (not at the floor: retry with half the step)
                h_cap[i] = 0.5 * hi
            else:
                p[i, 0], p[i, 1] = nx, ny
                prev[i, 0], prev[i, 1] = dx, dy
                travelled[i] += hi
                h_cap[i] = minimum(2.0 * h_cap[i], step)
                pts = _append(pts, count, i, nx, ny)
        active = 0
        for i in range(n):
            if code[i] == 0:
                active += 1
    return pts, count, code, entered
