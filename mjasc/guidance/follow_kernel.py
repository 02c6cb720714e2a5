"""The control tick's path following for a small fleet in one compiled call: projection, law and
inverse propeller curve of every vessel (world ENU, metres, seconds, radians).

:func:`follow_fleet` is :meth:`~mjasc.guidance.path_following.FleetPathFollower._command_floats`
(the readable plain-float form, kept as the reference and as the fallback) and the inverse
propeller curve (:func:`~mjasc.physics.thrusters.command_for_thrust_scalar`) written as one loop
over the vessels, on the fleet's stacked segment table (:class:`~mjasc.guidance.stacked_paths.StackedPaths`):

* the projection of ``Path.project_near`` — the window [max(0, h − w), min(L, h + w)] around the
  clamped hint h, the segments ``bisect_right(cum, lo) − 2 … bisect_right(cum, hi)`` of the path,
  each segment's candidates as :func:`~mjasc.guidance.segment_geometry.closest_scalar` computes
  them, the smallest squared distance and the smallest γ within its tie, clamped to [0, L]
  (the candidates are evaluated twice, once for the minimum and once for the tie: the same
  numbers both times);
* ``Path.at`` at that γ (the segment found by bisection, a later segment winning at a joint);
* :func:`~mjasc.guidance.following_law.law_floats`, the same expressions in the same order;
  ``x**2`` of a Python float is the C library's ``pow(|x|, 2.0)`` (CPython's float power), so the
  kernel calls ``pow`` with the exponent ``two`` passed in at run time (a literal 2 would be
  compiled to ``x·x``, which differs in the last bit for ~0.1 % of values);
* the inverse propeller curve per propeller.

``math``'s sin, cos, atan2, pow and sqrt in a kernel are the C library's, as in Python. The kernel
returns False, having changed nothing, when a position is not finite or a window holds no
candidate: the caller then runs the Python form (and its error).
"""

from __future__ import annotations

import math

from mjasc.core.compiled import clip as _clip
from mjasc.core.compiled import kernel, search_right
from mjasc.guidance.segment_geometry import A0, C, COS0, CX, CY, K, LEN, SIN0, TH0, X0, Y0

__all__ = ["follow_fleet"]

_TWO_PI = 2.0 * math.pi
_TIE = 1.0 + 1e-12
_TIE_ABS = 1e-18

# Rows of the follower's parameter and state arrays (mjasc.guidance.path_following).
(_LOOKAHEAD, _WINDOW, _SIGMA, _FINISH, _KP_PSI, _KD_PSI, _NR, _TI, _KP_U, _KI_U, _XU, _XUU, _D, _TMAX, _TMIN,
 _KF, _KR, _NMAX, _NMIN) = range(19)
_GAMMA, _XTE_I, _SPEED_I, _HEAD_I = range(4)


@kernel
def _wrap(a):
    """``wrap_scalar``: to (−π, π]."""
    w = (a + math.pi) % _TWO_PI - math.pi
    return math.pi if w == -math.pi else w


@kernel
def _count_le(starts, a, m, length, x):
    """``bisect_right(cum, x)`` of a path's cumulative lengths (its segments' start γ
    ``starts[a:a + m]``, then its length)."""
    return search_right(starts, x, a, a + m) - a + (1 if length <= x else 0)


@kernel
def _consider(d, g, pick, d_min, best, found):
    """One candidate (d² [m²], its γ [m]) for :func:`_best`: the new (best, found)."""
    if not pick:
        return (d if not found or d < best else best), True
    if d <= d_min and (not found or g < best):
        return g, True
    return best, found


@kernel
def _best(table, a, j0, j1, px, py, lo, hi, d_min, pick):
    """Over segments j0 … j1 of the block at ``a``, the candidates of the window [lo, hi]
    (``closest_scalar``): ``pick`` False → the smallest d² (``d_min`` the starting value, +inf);
    True → the smallest γ with d² ≤ ``d_min`` (the tie threshold). Returns (that value, whether
    some candidate gave it)."""
    best = d_min if not pick else math.inf
    found = False
    for j in range(a + j0, a + j1 + 1):
        c0 = table[C, j]
        s_lo = lo - c0
        s_hi = hi - c0
        if not s_lo > 0.0:
            s_lo = 0.0
        if not s_hi < table[LEN, j]:
            s_hi = table[LEN, j]
        if not s_lo <= s_hi:
            continue
        k = table[K, j]
        if k == 0.0:
            dx, dy = px - table[X0, j], py - table[Y0, j]
            cs, sn = table[COS0, j], table[SIN0, j]
            s = _clip(dx * cs + dy * sn, s_lo, s_hi)
            ex, ey = dx - s * cs, dy - s * sn
            best, found = _consider(ex * ex + ey * ey, c0 + s, pick, d_min, best, found)
            continue
        phi = math.atan2(py - table[CY, j], px - table[CX, j])
        sgn = 1.0 if k > 0.0 else -1.0
        s_star = _clip((sgn * (phi - table[A0, j])) % _TWO_PI / abs(k), s_lo, s_hi)
        x0, y0, th0, sin0, cos0 = table[X0, j], table[Y0, j], table[TH0, j], table[SIN0, j], table[COS0, j]
        for q in range(3):
            s = s_star if q == 0 else (s_lo if q == 1 else s_hi)
            th = th0 + k * s
            ex, ey = x0 + (math.sin(th) - sin0) / k - px, y0 + (cos0 - math.cos(th)) / k - py
            best, found = _consider(ex * ex + ey * ey, c0 + s, pick, d_min, best, found)
    return best, found


@kernel
def _sq(x, two):
    """CPython's ``x**2`` of a float: ``pow(|x|, 2.0)`` (``two`` = 2.0 at run time)."""
    return (-x if x < 0.0 else x) ** two


@kernel
def _command(t, kf, kr, n_max, n_min):
    """``command_for_thrust_scalar``: the normalized shaft speed for thrust ``t`` [N]."""
    n = math.sqrt(abs(t) / kf) if t >= 0 else -math.sqrt(abs(t) / kr)
    c = n / n_max if n >= 0 else n / -n_min
    c = c if c >= -1.0 or c != c else -1.0
    return c if c <= 1.0 or c != c else 1.0


@kernel
def follow_fleet(table, first, count, length, P, S, idx, pos, heading, bv, speed, course, dt_s, two,
                 commands, status):
    """One control tick of the vessels ``idx`` (k,) of a fleet (module docstring): ``table``,
    ``first``, ``count``, ``length`` the stacked paths; ``P`` (19, n) parameters, ``S`` (4, n) states
    (updated in place); position (k, 2), heading (k,), body velocity (k, 3), speed reference (k,),
    course override (k,) (NaN: none); ``two`` = 2.0. Writes the normalized commands (k, 2) and the
    statuses (k, 6) = (γ, e, χ_p, ψ_d, u_d, finished as 1.0 / 0.0). False (nothing changed): a
    position not finite or an empty window."""
    n = idx.shape[0]
    for k in range(n):
        if not (-math.inf < pos[k, 0] < math.inf and -math.inf < pos[k, 1] < math.inf):
            return False
    gam = status[:, 0]
    for k in range(n):  # the projections first: an empty window changes nothing
        i = idx[k]
        a, m, L = first[i], count[i], length[i]
        h = _clip(S[_GAMMA, i], 0.0, L)
        w = P[_WINDOW, i]
        lo = h - w  # max(0.0, h − w) and min(L, h + w) as the builtins pick
        if not lo > 0.0:
            lo = 0.0
        hi = h + w
        if not hi < L:
            hi = L
        j0 = _count_le(table[C], a, m, L, lo) - 2
        if j0 < 0:
            j0 = 0
        j1 = _count_le(table[C], a, m, L, hi)
        if j1 > m - 1:
            j1 = m - 1
        d_min, found = _best(table, a, j0, j1, pos[k, 0], pos[k, 1], lo, hi, math.inf, False)
        if not found:
            return False
        g, found = _best(table, a, j0, j1, pos[k, 0], pos[k, 1], lo, hi, d_min * _TIE + _TIE_ABS, True)
        if not found:
            return False
        gam[k] = _clip(g, 0.0, L)
    for k in range(n):
        i = idx[k]
        a, m, L = first[i], count[i], length[i]
        g = gam[k]
        # Path.at(γ)
        gg = _clip(g, 0.0, L)
        j = _count_le(table[C], a, m, L, gg) - 1
        if j < 0:
            j = 0
        if j > m - 1:
            j = m - 1
        j += a
        s = gg - table[C, j]
        kap = table[K, j]
        if kap == 0.0:
            qx, qy = table[X0, j] + s * table[COS0, j], table[Y0, j] + s * table[SIN0, j]
        else:
            th = table[TH0, j] + kap * s
            qx = table[X0, j] + (math.sin(th) - table[SIN0, j]) / kap
            qy = table[Y0, j] + (table[COS0, j] - math.cos(th)) / kap
        chi_p = _wrap(table[TH0, j] + kap * s)
        # _law_floats
        x, y = pos[k, 0], pos[k, 1]
        u, r = bv[k, 0], bv[k, 2]
        crs = course[k]
        e = -(x - qx) * math.sin(chi_p) + (y - qy) * math.cos(chi_p)
        finished = g >= L - P[_FINISH, i]
        steered = crs == crs
        delta, xte_i = P[_LOOKAHEAD, i], S[_XTE_I, i]
        e_eff = e + P[_SIGMA, i] * xte_i
        psi_d = crs if steered else _wrap(chi_p - math.atan2(e_eff, delta))
        if not (finished or steered):
            xte_i = xte_i + dt_s * delta * e / (_sq(delta, two) + _sq(e_eff, two))
        u_d = 0.0 if finished else speed[k]
        r_d = 0.0 if steered else kap * u
        e_psi = _wrap(heading[k] - psi_d)
        kp_psi = P[_KP_PSI, i]
        head_i0, speed_i0 = S[_HEAD_I, i], S[_SPEED_I, i]
        n_cmd = -kp_psi * e_psi - P[_KD_PSI, i] * (r - r_d) - P[_NR, i] * r_d + -kp_psi / P[_TI, i] * head_i0
        e_u = u_d - u
        x_cmd = -P[_XU, i] * u_d - P[_XUU, i] * abs(u_d) * u_d + P[_KP_U, i] * e_u + P[_KI_U, i] * speed_i0
        t_max, t_min = P[_TMAX, i], P[_TMIN, i]
        half_diff_free = 0.5 * n_cmd / P[_D, i]
        half_range = (t_max + t_min) / 2
        if u > u_d and t_min < half_range:  # faster than asked: the sum can come down to zero
            half_range = t_min
        half_diff = half_diff_free if half_diff_free >= -half_range else -half_range
        if not half_diff <= half_range:
            half_diff = half_range
        lo = -t_min + abs(half_diff)
        hi = t_max - abs(half_diff)
        half_sum_free = 0.5 * x_cmd
        saturated = not (lo <= half_sum_free and half_sum_free <= hi) or abs(half_diff_free) > abs(half_diff)
        half_sum = half_sum_free if half_sum_free >= lo else lo
        if not half_sum <= hi:
            half_sum = hi
        speed_i = speed_i0 if saturated else speed_i0 + e_u * dt_s
        head_i = head_i0 + e_psi * dt_s if not saturated and abs(e_psi) < 0.5 else head_i0
        if finished:
            speed_i = 0.0
        S[_GAMMA, i], S[_XTE_I, i], S[_SPEED_I, i], S[_HEAD_I, i] = g, xte_i, speed_i, head_i
        kf, kr, n_max, n_min = P[_KF, i], P[_KR, i], P[_NMAX, i], P[_NMIN, i]
        commands[k, 0] = _command(half_sum - half_diff, kf, kr, n_max, n_min)
        commands[k, 1] = _command(half_sum + half_diff, kf, kr, n_max, n_min)
        status[k, 1], status[k, 2], status[k, 3], status[k, 4] = e, chi_p, psi_d, u_d
        status[k, 5] = 1.0 if finished else 0.0
    return True
