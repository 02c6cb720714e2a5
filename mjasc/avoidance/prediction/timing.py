"""The time side of collision prediction: the window δ and the vessel's plan in time, γ(t)
(docs/thesis.md §3, step 1 and the P_v(t) of step 2; thesis §3.2.2). Absolute simulation times [s], arc
length γ [m] along the vessel's path.

- **Time window** W = [t₀, t₀ + δ], δ = v₀/a_brake + ζ (time to stop at the current speed plus a
  margin), or a fixed δ (the thesis used 30 s): :func:`prediction_window`.
- **Speed profile** → γ(t): a constant speed, piecewise-linear speed knots (integrated exactly), or
  γ(t) itself: :func:`gamma_of_time`; the vessel's predicted position is P_v(t) = path(γ(t)).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

__all__ = ["SpeedProfile", "prediction_window", "gamma_of_time", "speed_now"]

SpeedProfile = float | Callable[[np.ndarray], np.ndarray] | np.ndarray
"""A speed profile: a constant speed [m/s], a callable γ(t), or (k, 2) (time_s, speed_m_s) knots."""


def prediction_window(
    speed_m_s: float, brake_decel_m_s2: float, margin_s: float, fixed_s: float | None = None
) -> float:
    """Length δ [s] of the prediction window: ``fixed_s`` if given, else δ = v₀/a_brake + ζ
    (time to stop at the current speed plus a margin; docs/thesis.md §3)."""
    if fixed_s is not None:
        fixed_s = float(fixed_s)
        if not np.isfinite(fixed_s) or fixed_s <= 0.0:
            raise ValueError(f"fixed_s: must be finite and > 0, got {fixed_s}")
        return fixed_s
    v, a, z = float(speed_m_s), float(brake_decel_m_s2), float(margin_s)
    if not np.isfinite(v) or v < 0.0:
        raise ValueError(f"speed_m_s: must be finite and ≥ 0, got {speed_m_s}")
    if not np.isfinite(a) or a <= 0.0:
        raise ValueError(f"brake_decel_m_s2: must be finite and > 0, got {brake_decel_m_s2}")
    if not np.isfinite(z) or z < 0.0:
        raise ValueError(f"margin_s: must be finite and ≥ 0, got {margin_s}")
    delta = v / a + z
    if delta <= 0.0:
        raise ValueError("margin_s: must be > 0 when speed_m_s is 0 (the window would be empty)")
    return delta


def gamma_of_time(speed_profile: SpeedProfile, gamma_now: float, t_now: float) -> Callable:
    """γ(t) [m] at absolute times t ≥ t_now for a speed profile (not clamped to the path):

    - a number: constant speed [m/s];
    - a callable: taken to *be* γ(t) (absolute times in, absolute γ out);
    - a (k, 2) array of (time_s, speed_m_s) knots: piecewise-linear speed, held constant outside
      the knots, integrated exactly from (t_now, gamma_now).
    """
    if callable(speed_profile):
        return lambda t: np.asarray(speed_profile(np.asarray(t, dtype=float)), dtype=float)
    arr = np.asarray(speed_profile, dtype=float)
    if arr.ndim == 0:
        v = float(arr)
        if not np.isfinite(v) or v < 0.0:
            raise ValueError(f"speed_profile: constant speed must be finite and ≥ 0, got {v}")
        return lambda t: gamma_now + v * (np.asarray(t, dtype=float) - t_now)
    if arr.ndim != 2 or arr.shape[1] != 2 or arr.shape[0] < 1:
        raise ValueError(f"speed_profile: expected a number, a callable or (k, 2) knots, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)) or np.any(arr[:, 1] < 0.0):
        raise ValueError("speed_profile: knots must be finite with speeds ≥ 0")
    if np.any(np.diff(arr[:, 0]) <= 0.0):
        raise ValueError("speed_profile: knot times must be strictly increasing")
    knot_t, knot_v = arr[:, 0], arr[:, 1]
    bp = np.concatenate([[t_now], knot_t[knot_t > t_now]])
    vb = np.interp(bp, knot_t, knot_v)
    g_bp = gamma_now + np.concatenate([[0.0], np.cumsum(0.5 * (vb[1:] + vb[:-1]) * np.diff(bp))])
    slope = np.concatenate([np.diff(vb) / np.diff(bp), [0.0]])

    def f(t):
        t = np.asarray(t, dtype=float)
        j = np.clip(np.searchsorted(bp, t, side="right") - 1, 0, bp.size - 1)
        tau = t - bp[j]
        return g_bp[j] + vb[j] * tau + 0.5 * slope[j] * tau**2

    return f


def speed_now(gamma_fn: Callable, t_now: float) -> float:
    """The plan's speed dγ/dt [m/s] at t_now (forward difference over 1 ms, ≥ 0)."""
    h = 1e-3
    return max(0.0, float((gamma_fn(t_now + h) - gamma_fn(t_now)) / h))

