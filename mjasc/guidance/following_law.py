"""The path-following law: integral line-of-sight guidance, heading and speed loops, allocation to
the twin propellers.

Guidance: integral LOS (Børhaug, Pavlov & Pettersen 2008; Fossen 2021 §12.4). With γ the vessel's
projection on the path, χ_p the path's course there and e the signed cross-track error (positive
when the vessel is left of the path)::

    ψ_d = χ_p − atan((e + σ e_i) / Δ)         desired heading, lookahead Δ [m], integral gain σ
    ė_i = Δ e / (Δ² + (e + σ e_i)²)           integral of the cross-track error (bounded rate)

A course override (collision avoidance steering a chosen course over ground, e.g. the velocity
obstacles' choice) replaces ψ_d by that course while it is set; the LOS integral is frozen and the
curvature feed-forward dropped meanwhile, and γ keeps following the path, so the vessel comes back
to its path through the LOS law when the override ends. No override (NaN) gives the same bits as
before the override existed.

In a constant current the integral term settles at the crab angle that cancels the drift, so the
cross-track error converges to zero (the tests check it). Measuring the crab angle and feeding it
back instead couples the sway dynamics into the heading loop and oscillated on the Otter.

Heading loop: the yaw dynamics M_33 ṙ ≈ N + N_r r give, for a closed loop of natural frequency ω_ψ
and damping ζ, ``N = −M_33 ω_ψ² (e_ψ + ∫e_ψ/T_i) − (2ζω_ψ M_33 + N_r)(r − r_d) − N_r r_d`` with the
path's turn rate r_d = κ u as feed-forward. The integral removes the steady heading error that a
crab in a cross current causes (the Munk moment (X_u̇ − Y_v̇) u_r v_r and cross-flow drag). Speed loop: feed-forward of the damping at the desired speed
plus PI on the surge error. Allocation to the twin propellers at y = ±d:
``T_s + T_p = X``, ``d (T_s − T_p) = N`` (FLU: more starboard thrust turns left), then the inverse
propeller curve gives the normalized commands; when saturated, yaw moment has priority — up to
(T_max + T_min)/2 a propeller, where the pair's forward and reverse limits meet, except while the
hull is faster than its speed reference (u > u_d: a stop, a slow-down, a sharp turn at its slow
turning speed; also a hull asked to go astern): then the differential is held within the reverse
limit T_min, so that the net thrust can come down to zero — no push ahead: the hull coasts down on
its drag while the turn saturates, and the speed loop brakes once it does not. A propeller
pushes harder ahead than astern (T_max > T_min), so a full differential leaves a net forward
thrust of T_max − T_min whatever the speed loop asks: a vessel told to stop while it turned hard
kept ~0.5 m/s through the turn and sailed on into what it was stopping for (thesis §6.4.3 under
30 % dropout and packet loss, seeds 31, 33, 37, 41). The turn is slower there (a moment of
2 d T_min instead of d (T_max + T_min)); at or below the reference yaw keeps the full range.

The law is written once over a table of operations (:func:`law`; :class:`ArrayOps` for arrays of
vessels, :class:`FloatOps` for one vessel in plain floats) and once more with the float operations
written out (:func:`law_floats`, held to ``law(FloatOps, …)`` bit for bit by
``tests/test_fleet_following.py``). A vessel's parameters are a column of the fleet's parameter
array (rows :data:`LOOKAHEAD` … :data:`NMIN`, :func:`law_parameters`), its loop states a column of
the state array (rows :data:`GAMMA`, :data:`XTE_I`, :data:`SPEED_I`, :data:`HEAD_I`).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from mjasc.guidance.segment_geometry import wrap_scalar
from mjasc.physics.vessels import VesselType

if TYPE_CHECKING:
    from mjasc.guidance.path_following import PathFollowingConfig

__all__ = ["law", "law_floats", "law_parameters", "ArrayOps", "FloatOps"]

# Rows of the parameter array (one column per vessel).
(LOOKAHEAD, WINDOW, SIGMA, FINISH, KP_PSI, KD_PSI, NR, TI, KP_U, KI_U, XU, XUU, D, TMAX, TMIN,
 KF, KR, NMAX, NMIN) = range(19)
# Rows of the state array: γ [m], ∫ LOS state e_i [m], ∫ surge error [m], ∫ heading error [rad·s].
GAMMA, XTE_I, SPEED_I, HEAD_I = range(4)


def law_parameters(vessel: VesselType, total_mass, lateral_offset_m: float, config: PathFollowingConfig) -> list[float]:
    """One vessel's column of the parameter array: gains from its rigid-body + added mass (3, 3)
    and damping, its propellers at y = ±lateral_offset_m [m]."""
    lookahead = config.lookahead_m or max(3.0 * vessel.length_m, 5.0)
    m = np.asarray(total_mass, dtype=float)
    m11, m33 = float(m[0, 0]), float(m[2, 2])
    h, p = vessel.hydro, vessel.propellers
    w, z = config.heading_bandwidth_rad_s, config.heading_damping_ratio
    kp_u = m11 * config.speed_bandwidth_rad_s
    return [lookahead, max(4.0 * lookahead, 20.0), config.integral_los_gain, config.finish_tolerance_m,
            m33 * w * w, max(2 * z * w * m33 + h.N_r, 0.0),  # N_r < 0 already damps
            h.N_r, config.heading_integral_time_s, kp_u, config.speed_integral_gain_ratio * kp_u, h.X_u, h.X_uu,
            abs(float(lateral_offset_m)), p.max_thrust_n,
            p.k_reverse * p.n_min_rad_s**2,  # reverse thrust magnitude [N]
            p.k_forward, p.k_reverse, p.n_max_rad_s, p.n_min_rad_s]


def wrap_array(a: np.ndarray) -> np.ndarray:
    """:func:`~mjasc.core.frames.wrap_angle` for a float array (the same operations, fewer calls)."""
    w = np.mod(a + np.pi, 2.0 * np.pi) - np.pi
    return np.where(w == -np.pi, np.pi, w)


def squares(x: np.ndarray) -> np.ndarray:
    """x² elementwise through the C library's pow, as ``x**2`` of a float computes it (numpy's x·x
    differs in the last bit for ~0.1 % of values): both forms of the law give the same bits, and
    the same as before the law was batched."""
    return np.array([v**2 for v in x.tolist()])


class ArrayOps:
    """The operations of :func:`law` over arrays of vessels."""

    where, abs, minimum, maximum = staticmethod(np.where), staticmethod(np.abs), staticmethod(np.minimum), \
        staticmethod(np.maximum)
    sin, cos, atan2 = staticmethod(np.sin), staticmethod(np.cos), staticmethod(np.arctan2)
    wrap, sq = staticmethod(wrap_array), staticmethod(squares)
    not_, and_, or_ = staticmethod(np.logical_not), staticmethod(np.logical_and), staticmethod(np.logical_or)


class FloatOps:
    """The operations of :func:`law` for one vessel in plain floats (numpy's semantics)."""

    @staticmethod
    def where(c, a, b):
        return a if c else b

    @staticmethod
    def minimum(a, b):
        return a if a <= b else b

    @staticmethod
    def maximum(a, b):
        return a if a >= b else b

    @staticmethod
    def sq(a):
        return a**2

    @staticmethod
    def not_(a):
        return not a

    @staticmethod
    def and_(a, b):
        return a and b

    @staticmethod
    def or_(a, b):
        return a or b

    abs, sin, cos, atan2, wrap = staticmethod(abs), staticmethod(math.sin), staticmethod(math.cos), \
        staticmethod(math.atan2), staticmethod(wrap_scalar)


def law(o, P, S, x, y, heading, u, r, speed_ref, dt_s, gamma, qx, qy, chi_p, kappa, length, course=math.nan):
    """The control law of the module docstring, once for arrays of vessels (``o`` = ArrayOps,
    P, S the parameter and state arrays) and for one vessel (``o`` = FloatOps, P, S its columns
    as lists). Inputs: position (x, y), heading, surge u, yaw rate r, speed reference; the
    projection: γ, the path's point (qx, qy), course χ_p, curvature κ and length L there; a course
    override [rad] (NaN: none; else ψ_d = the override, the LOS integral frozen and no curvature
    feed-forward — γ keeps following the path).
    Returns (T_port, T_starboard, new states (γ, e_i, ∫e_u, ∫e_ψ), status (e, ψ_d, u_d, finished))."""
    e = -(x - qx) * o.sin(chi_p) + (y - qy) * o.cos(chi_p)
    finished = gamma >= length - P[FINISH]
    steered = course == course  # a course override (not NaN)
    # integral LOS
    delta, xte_i = P[LOOKAHEAD], S[XTE_I]
    e_eff = e + P[SIGMA] * xte_i
    psi_d = o.where(steered, course, o.wrap(chi_p - o.atan2(e_eff, delta)))
    xte_i = o.where(o.or_(finished, steered), xte_i, xte_i + dt_s * delta * e / (o.sq(delta) + o.sq(e_eff)))
    # heading and speed loops
    u_d = o.where(finished, 0.0, speed_ref)
    r_d = o.where(steered, 0.0, kappa * u)
    e_psi = o.wrap(heading - psi_d)
    kp_psi = P[KP_PSI]
    n_cmd = -kp_psi * e_psi - P[KD_PSI] * (r - r_d) - P[NR] * r_d + -kp_psi / P[TI] * S[HEAD_I]
    e_u = u_d - u
    x_cmd = -P[XU] * u_d - P[XUU] * o.abs(u_d) * u_d + P[KP_U] * e_u + P[KI_U] * S[SPEED_I]
    # allocation to the twin propellers, yaw first: T_s + T_p = X, d (T_s − T_p) = N
    t_max, t_min = P[TMAX], P[TMIN]
    half_diff_free = 0.5 * n_cmd / P[D]
    half_range = (t_max + t_min) / 2
    half_range = o.where(o.and_(u > u_d, t_min < half_range), t_min, half_range)  # too fast: Σ down to 0
    half_diff = o.minimum(o.maximum(half_diff_free, -half_range), half_range)
    lo = -t_min + o.abs(half_diff)
    hi = t_max - o.abs(half_diff)
    half_sum_free = 0.5 * x_cmd
    inside = o.and_(lo <= half_sum_free, half_sum_free <= hi)
    saturated = o.or_(o.not_(inside), o.abs(half_diff_free) > o.abs(half_diff))
    half_sum = o.minimum(o.maximum(half_sum_free, lo), hi)
    # conditional integration: no wind-up while the propellers saturate; the heading integral
    # only near the reference (not through large turns)
    speed_i = o.where(saturated, S[SPEED_I], S[SPEED_I] + e_u * dt_s)
    head_i = o.where(o.and_(o.not_(saturated), o.abs(e_psi) < 0.5), S[HEAD_I] + e_psi * dt_s, S[HEAD_I])
    speed_i = o.where(finished, 0.0, speed_i)
    return half_sum - half_diff, half_sum + half_diff, (gamma, xte_i, speed_i, head_i), (e, psi_d, u_d, finished)


def law_floats(P, S, x, y, heading, u, r, speed_ref, dt_s, gamma, qx, qy, chi_p, kappa, length, course):
    """:func:`law` for one vessel in plain floats with the operations of :class:`FloatOps` written
    out (the same expressions in the same order: the same bits, ``tests/test_fleet_following.py``
    checks it on real runs); the control tick's form, a few Python calls instead of ~30."""
    e = -(x - qx) * math.sin(chi_p) + (y - qy) * math.cos(chi_p)
    finished = gamma >= length - P[FINISH]
    steered = course == course  # a course override (not NaN)
    # integral LOS
    delta, xte_i = P[LOOKAHEAD], S[XTE_I]
    e_eff = e + P[SIGMA] * xte_i
    psi_d = course if steered else wrap_scalar(chi_p - math.atan2(e_eff, delta))
    if not (finished or steered):
        xte_i = xte_i + dt_s * delta * e / (delta**2 + e_eff**2)
    # heading and speed loops
    u_d = 0.0 if finished else speed_ref
    r_d = 0.0 if steered else kappa * u
    e_psi = wrap_scalar(heading - psi_d)
    kp_psi = P[KP_PSI]
    n_cmd = -kp_psi * e_psi - P[KD_PSI] * (r - r_d) - P[NR] * r_d + -kp_psi / P[TI] * S[HEAD_I]
    e_u = u_d - u
    x_cmd = -P[XU] * u_d - P[XUU] * abs(u_d) * u_d + P[KP_U] * e_u + P[KI_U] * S[SPEED_I]
    # allocation to the twin propellers, yaw first: T_s + T_p = X, d (T_s − T_p) = N
    t_max, t_min = P[TMAX], P[TMIN]
    half_diff_free = 0.5 * n_cmd / P[D]
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
    # conditional integration: no wind-up while the propellers saturate; the heading integral
    # only near the reference (not through large turns)
    speed_i = S[SPEED_I] if saturated else S[SPEED_I] + e_u * dt_s
    head_i = S[HEAD_I] + e_psi * dt_s if not saturated and abs(e_psi) < 0.5 else S[HEAD_I]
    if finished:
        speed_i = 0.0
    return half_sum - half_diff, half_sum + half_diff, (gamma, xte_i, speed_i, head_i), (e, psi_d, u_d, finished)
