"""Gated global-nearest-neighbour association of one scan's detections with a vessel's tracks
(thesis §3.2.1; :mod:`mjasc.perception.tracking`, items 1–2). World ENU, SI.

1. **Prediction and gating.** Each track's combined estimate predicted to the scan time (one EKF
   step with ω̂), ẑ_i with covariance J P Jᵀ, plus the detection's own isotropic variance σ_j²:
   ``S_ij = J_i P_i J_iᵀ + σ_j²·I`` and ``d²_ij = (z_j − ẑ_i)ᵀ S_ij⁻¹ (z_j − ẑ_i)``. A pair is
   admissible when ``d²_ij ≤ −2 ln(1 − gate_probability)`` (chi-square, 2 dof). (The bank then
   gates again on its own models when it updates.)
2. **Global nearest neighbour** association: ``scipy.optimize.linear_sum_assignment`` on the cost
   ``d²_ij + ln det S_ij`` (−2 log-likelihood up to a constant); inadmissible pairs cost a large
   constant and are dropped from the solution. Each track takes at most one detection per scan
   and vice versa.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

__all__ = ["association_costs", "gnn_assign", "BIG_COST"]

#: Cost of an inadmissible pair in the assignment problems (never chosen over an admissible one).
BIG_COST = 1e9


def association_costs(states, covariances, times_s, turn_rates, z, var, t_s: float) -> tuple[np.ndarray, np.ndarray]:
    """(n_tracks, m) squared Mahalanobis distances d²_ij and GNN costs d² + ln det S_ij for
    detections z (m, 2) [m] with isotropic variances var (m,) or (n_tracks, m) [m²], of tracks
    whose combined estimates are ``states`` (n, 4) [x, y, θ, V], ``covariances`` (n, 4, 4), at
    ``times_s`` (n,) [s] with turn rates ω̂ ``turn_rates`` (n,) [rad/s].

    The prediction is that of each track's *combined* estimate (one EKF step of thesis eq. 3.3
    with ω̂, not the r models: association needs ẑ and S, not the mixture; 10× cheaper):
    ``ẑ = p + Ts·V·[cos, sin](θ + ω̂ Ts/2)``, ``S = J P Jᵀ + σ_j² I`` with J the position rows of
    the transition Jacobian.
    """
    x = states
    P = covariances
    dt = np.maximum(t_s - times_s, 0.0)
    th_mid = x[:, 2] + 0.5 * dt * turn_rates
    c, s = np.cos(th_mid), np.sin(th_mid)
    dv = dt * x[:, 3]
    zhat = x[:, :2] + np.stack([dv * c, dv * s], axis=-1)
    J = np.zeros((x.shape[0], 2, 4))
    J[:, 0, 0] = J[:, 1, 1] = 1.0
    J[:, 0, 2], J[:, 0, 3] = -dv * s, dt * c
    J[:, 1, 2], J[:, 1, 3] = dv * c, dt * s
    S = J @ P @ np.swapaxes(J, 1, 2)
    var = np.broadcast_to(var, (S.shape[0], z.shape[0]))
    a = S[:, 0, 0, None] + var
    b = S[:, 0, 1, None]
    d = S[:, 1, 1, None] + var
    det = a * d - b * b
    y = z[None, :, :] - zhat[:, None, :]
    y0, y1 = y[..., 0], y[..., 1]
    d2 = (d * y0 * y0 - 2.0 * b * y0 * y1 + a * y1 * y1) / det
    return d2, d2 + np.log(det)


def gnn_assign(inside: np.ndarray, cost: np.ndarray) -> np.ndarray:
    """(n,) index of the detection assigned to each track (−1: none) by the global nearest
    neighbour: the least total ``cost`` (n, m) over the admissible pairs ``inside`` (n, m) bool,
    each track taking at most one detection and vice versa."""
    assigned = np.full(inside.shape[0], -1)
    if inside.any():
        rows, cols = linear_sum_assignment(np.where(inside, cost, BIG_COST))
        ok = inside[rows, cols]
        assigned[rows[ok]] = cols[ok]
    return assigned
