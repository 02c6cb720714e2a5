"""The IMM cycle as compiled loops over a bank's tracks: mixing, the per-model EKF of the
constant-turn model, the position update, the mode probabilities and the combination
(thesis §3.2.1, eq. 3.3; docs/thesis.md §2, steps 1–6).

State of a tracked object ``s = [x, y, θ, V]``: world-frame ENU position [m], course over ground
θ (CCW from east) [rad], speed over ground V ≥ 0 [m/s].

Model j of r has a fixed turn rate ω_j; its discrete process with sample time Ts (here the time
since the previous cycle, which may vary) is thesis eq. 3.3 / docs/thesis.md §2::

    x⁺ = x + Ts·V·cos θ
    y⁺ = y + Ts·V·sin θ
    θ⁺ = θ + Ts·ω_j + w_θ·√Ts        w_θ ~ N(0, Q_θ)   →  process covariance Q = diag(0, 0, Q_θ·Ts, Q_V·Ts)
    V⁺ = V + w_V·√Ts                 w_V ~ N(0, Q_V)

Each model is an EKF with the transition Jacobian ``F = [[I₂, G], [0, I₂]]``,
``G = Ts [[−V sin θ, cos θ], [V cos θ, sin θ]]`` evaluated at the mixed estimate, and the linear
measurement ``z = [x, y] + v``, ``v ~ N(0, R)``, ``R = σ²·I₂``.

One IMM cycle (Bar-Shalom, Li & Kirubarajan 2001; docs/thesis.md §2, steps 1–6):

1. ``c̄_j = Σ_i p_ij μ_i``, ``μ_{i|j} = p_ij μ_i / c̄_j``;
2. ``s0_j = Σ_i μ_{i|j} s_i``, ``P0_j = Σ_i μ_{i|j} P_i + Σ_i μ_{i|j} (s_i − s0_j)(s_i − s0_j)ᵀ``;
3. per-model EKF predict ``s_j = f_j(s0_j)``, ``P_j = F P0_j Fᵀ + Q`` and update: innovation
   ``r_j = z − H s_j``, ``S_j = H P_j Hᵀ + R``, ``K_j = P_j Hᵀ S_j⁻¹``, ``s_j += K_j r_j``,
   ``P_j −= K_j H P_j`` (S⁻¹ = adj S / det S, explicit 2×2);
4. ``L_j = exp(−½ r_jᵀ S_j⁻¹ r_j) / √det(2π S_j)`` — the Gaussian density with the measurement
   dimension 2 (thesis eq. 3.10 is wrong, see docs/thesis.md §2); evaluated in the log domain with
   the factor common to all models taken out, ``L_j ∝ √(exp(d²_min − d²_j) / det S_j)``
   (``d²_j = r_jᵀ S_j⁻¹ r_j``: the best-fitting model never underflows; 1/(2π) cancels in step 5);
5. ``μ_j ∝ L_j c̄_j``, then floored at the minimum probability and renormalized (flooring the
   unnormalized μ̃ at floor·Σμ̃ then normalizing equals normalizing, flooring, renormalizing);
6. ``s = Σ_j μ_j s_j``, ``P = Σ_j μ_j P_j + Σ_j μ_j (s_j − s)(s_j − s)ᵀ`` and ``ω̂ = Σ_j μ_j ω_j``.

A track without a measurement (or whose measurement is outside the chi-square gate of every
model: ``d²_min > gate``) coasts: steps 1–2, the prediction of step 3 and ``μ_j = c̄_j``.

**Angles are mixed as angles.** The models' courses are kept *unwrapped in one common chart* per
track (they are mixed every cycle, so they stay within a fraction of a radian of each other);
then the plain weighted sums of steps 2 and 6 equal the sums of wrapped differences
``θ_j + Σ_i μ_{i|j} wrap(θ_i − θ_j)`` whenever the courses span less than π, and cost nothing.
Only what leaves the filter is wrapped to (−π, π]. **Negative speed**: after the update, a model
whose V came out negative is re-parametrized exactly, ``(θ, V) → (θ + π, −V)`` (same velocity),
its course re-charted within π of its predicted course, the V row and column of its covariance
negated (Jacobian diag(1, 1, 1, −1)).

**Compiled, rows independent.** One call of :func:`imm_cycle` runs the whole cycle of every track
(numba, :mod:`mjasc.core.compiled`): a loop over rows, every sum over models in model order,
covariances computed on and above the diagonal and mirrored (exactly symmetric). A track's numbers
do not depend on how many other tracks share its bank, so one bank holding the tracks of a whole
fleet gives each vessel's tracks the same bits as a bank of its own
(:mod:`mjasc.perception.tracking.fleet`). The per-Ts constants come from
:class:`mjasc.perception.imm.markov.CycleConstants` with one row (shared by every track) or n.
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.compiled import inlined_kernel, kernel

__all__ = ["wrap", "imm_cycle", "position_update", "combine_covariance", "combine_row", "turn_rate"]

_TWO_PI = 2.0 * math.pi


def wrap(angle):
    """Wrap to (−π, π] (same convention as ``frames.wrap_angle``, fewer numpy calls)."""
    return math.pi - np.mod(math.pi - angle, _TWO_PI)


def turn_rate(mu, omega):
    """ω̂ = Σ_j μ_j ω_j [rad/s] per row of mu (..., r) (docs/thesis.md §2 step 6), summed per row in
    model order (not a matrix-vector product across tracks: rows are independent)."""
    return np.add.reduce(mu * omega, -1)


@kernel
def _innovate(x, P, z0, z1, var):
    """Step 3's innovation of the prior (x, P) (views (4,), (4, 4)) for z = (z0, z1), R = var·I₂:
    returns (r0, r1, S00, S01, S11, det S, d² = rᵀ S⁻¹ r)."""
    r0, r1 = z0 - x[0], z1 - x[1]
    S00, S01, S11 = P[0, 0] + var, P[0, 1], P[1, 1] + var
    det = S00 * S11 - S01 * S01
    d2 = (r0 * (S11 * r0 - S01 * r1) + r1 * (S00 * r1 - S01 * r0)) / det
    return r0, r1, S00, S01, S11, det, d2


@kernel
def _correct(x, P, r0, r1, S00, S01, S11, det):
    """Step 3's update in place: x += P Hᵀ S⁻¹ r, P −= P Hᵀ S⁻¹ H P (upper triangle, mirrored)."""
    a0, a1 = (S11 * r0 - S01 * r1) / det, (S00 * r1 - S01 * r0) / det  # S⁻¹ r
    u0 = (P[0, 0], P[1, 0], P[2, 0], P[3, 0])  # columns 0, 1 of P (= P Hᵀ) before the update
    u1 = (P[0, 1], P[1, 1], P[2, 1], P[3, 1])
    for a in range(4):
        x[a] += u0[a] * a0 + u1[a] * a1
        k0 = (S11 * u0[a] - S01 * u1[a]) / det  # K = P Hᵀ S⁻¹, row a
        k1 = (S00 * u1[a] - S01 * u0[a]) / det
        for b in range(a, 4):
            P[a, b] -= k0 * u0[b] + k1 * u1[b]
            P[b, a] = P[a, b]


@kernel
def position_update(x, P, z, var, use, gate, d2):
    """Kalman update with the position measurement z (n, 2) [m] of the priors x (n, d ≥ 2) and
    P (n, d, d) in place, where ``use`` and d² ≤ gate; d² (n,) written for every row. var (n,) or
    (1,): σ² of z [m²]; use (n,) or (1,) bool. (The start-up CV filter's update; d = 4.)"""
    for k in range(x.shape[0]):
        kv = k if var.shape[0] > 1 else 0
        r0, r1, S00, S01, S11, det, m = _innovate(x[k], P[k], z[k, 0], z[k, 1], var[kv])
        d2[k] = m
        if use[k if use.shape[0] > 1 else 0] and m <= gate:
            _correct(x[k], P[k], r0, r1, S00, S01, S11, det)


@inlined_kernel
def moments_into(w, s, P, x, out):
    """The weighted mean x (4,) = Σ_i w_i s_i of the models' states s (r, 4) and the upper triangle
    (a ≤ b) of out (4, 4) = Σ_i w_i P_i + Σ_i (s_i − x) (w_i (s_i − x))ᵀ of their covariances P (r, 4, 4):
    the IMM's mixing (step 2, w = μ_{·|j}) and combination (step 6, w = μ). The sums run over i in the
    outer loop with one local accumulator per entry (s_i − x and w_i (s_i − x) made once per i): each
    sum adds the same terms in the same order as entry by entry (each entry's own loop over i, the
    spread's (s_ia − x_a) (w_i (s_ib − x_b))), ~30 % faster (registers, no reloads). Inlined into
    its two callers (:func:`~mjasc.core.compiled.inlined_kernel`)."""
    x0 = x1 = x2 = x3 = 0.0
    for i in range(w.size):
        wi = w[i]
        x0 += wi * s[i, 0]
        x1 += wi * s[i, 1]
        x2 += wi * s[i, 2]
        x3 += wi * s[i, 3]
    p00 = p01 = p02 = p03 = p11 = p12 = p13 = p22 = p23 = p33 = 0.0  # Σ_i w_i P_i
    d00 = d01 = d02 = d03 = d11 = d12 = d13 = d22 = d23 = d33 = 0.0  # the spread
    for i in range(w.size):
        wi = w[i]
        Pi = P[i]
        e0, e1, e2, e3 = s[i, 0] - x0, s[i, 1] - x1, s[i, 2] - x2, s[i, 3] - x3
        f0, f1, f2, f3 = wi * e0, wi * e1, wi * e2, wi * e3
        p00 += wi * Pi[0, 0]
        p01 += wi * Pi[0, 1]
        p02 += wi * Pi[0, 2]
        p03 += wi * Pi[0, 3]
        p11 += wi * Pi[1, 1]
        p12 += wi * Pi[1, 2]
        p13 += wi * Pi[1, 3]
        p22 += wi * Pi[2, 2]
        p23 += wi * Pi[2, 3]
        p33 += wi * Pi[3, 3]
        d00 += e0 * f0
        d01 += e0 * f1
        d02 += e0 * f2
        d03 += e0 * f3
        d11 += e1 * f1
        d12 += e1 * f2
        d13 += e1 * f3
        d22 += e2 * f2
        d23 += e2 * f3
        d33 += e3 * f3
    x[0], x[1], x[2], x[3] = x0, x1, x2, x3
    out[0, 0], out[0, 1], out[0, 2], out[0, 3] = p00 + d00, p01 + d01, p02 + d02, p03 + d03
    out[1, 1], out[1, 2], out[1, 3] = p11 + d11, p12 + d12, p13 + d13
    out[2, 2], out[2, 3], out[3, 3] = p22 + d22, p23 + d23, p33 + d33


@kernel
def _mix_predict(k, s, P, mu, markov, dt, dt_omega, q, c, w, s_out, P_out, cbar):
    """Steps 1–2 and the prediction of step 3 of row k into s_out[k], P_out[k], cbar[k] (c: the
    row of the per-Ts constants; w: (r, r) scratch for μ_{i|j}; step 2: :func:`moments_into`)."""
    r = mu.shape[1]
    for j in range(r):  # 1. c̄_j = Σ_i p_ij μ_i, μ_{i|j} = p_ij μ_i / c̄_j
        cb = 0.0
        for i in range(r):
            cb += markov[c, i, j] * mu[k, i]
        cbar[k, j] = cb
        for i in range(r):
            w[j, i] = mu[k, i] / cb * markov[c, i, j]
    T = dt[c]
    for j in range(r):
        s0 = s_out[k, j]
        P0 = P_out[k, j]
        moments_into(w[j], s[k], P[k], s0, P0)  # 2. s0_j = Σ_i μ_{i|j} s_i, P0_j (upper triangle)
        # 3. predict (eq. 3.3): F = [[I, G], [0, I]], P0 = [[A, B], [Bᵀ, C]] →
        # F P0 Fᵀ = [[A + G Bᵀ + M Gᵀ, M], [Mᵀ, C]] with M = B + G C; then + Q
        th, v = s0[2], s0[3]
        cos_t, sin_t = math.cos(th), math.sin(th)
        g00, g01, g10, g11 = -sin_t * v * T, cos_t * T, cos_t * v * T, sin_t * T
        s0[0] += g01 * v
        s0[1] += g11 * v
        s0[2] += dt_omega[c, j]
        m00 = P0[0, 2] + g00 * P0[2, 2] + g01 * P0[2, 3]
        m01 = P0[0, 3] + g00 * P0[2, 3] + g01 * P0[3, 3]
        m10 = P0[1, 2] + g10 * P0[2, 2] + g11 * P0[2, 3]
        m11 = P0[1, 3] + g10 * P0[2, 3] + g11 * P0[3, 3]
        a00 = P0[0, 0] + (g00 * P0[0, 2] + g01 * P0[0, 3]) + (m00 * g00 + m01 * g01)
        a01 = P0[0, 1] + (g00 * P0[1, 2] + g01 * P0[1, 3]) + (m00 * g10 + m01 * g11)
        a11 = P0[1, 1] + (g10 * P0[1, 2] + g11 * P0[1, 3]) + (m10 * g10 + m11 * g11)
        P0[0, 0], P0[0, 1], P0[1, 1] = a00, a01, a11
        P0[0, 2], P0[0, 3], P0[1, 2], P0[1, 3] = m00, m01, m10, m11
        P0[2, 2] += q[c, 0]
        P0[3, 3] += q[c, 1]
        for a in range(4):
            for b in range(a + 1, 4):
                P0[b, a] = P0[a, b]


@kernel
def imm_cycle(s, P, mu, markov, dt, dt_omega, q, z, var, use, floor, gate, s_out, P_out, mu_out, x_out, d2_min):
    """One IMM cycle of every row k (a track) of s (n, r, 4), P (n, r, 4, 4), μ (n, r) into
    s_out, P_out, mu_out (same shapes; not the inputs) and the combined state x_out (n, 4).

    Per-Ts constants (:class:`~mjasc.perception.imm.markov.CycleConstants`), one row shared by
    every track or one per track: markov p(Ts) (·, r, r), dt Ts (·,) [s], dt_omega Ts ω_j (·, r),
    q the (θ, V) process variances Q·Ts (·, 2). z (n, 2) [m] with σ² var (n,) or (1,) [m²]; use
    (n,) or (1,) bool: the row has a measurement. A row is updated if ``use`` and its smallest
    d²_j ≤ gate, else it coasts (μ_j = c̄_j); d2_min (n,) gets min_j d²_j (nan where not used).
    """
    n, r = mu.shape
    w = np.empty((r, r))
    d2, det = np.empty(r), np.empty(r)
    th_pred = np.empty(r)
    for k in range(n):
        c = k if dt.shape[0] > 1 else 0
        _mix_predict(k, s, P, mu, markov, dt, dt_omega, q, c, w, s_out, P_out, mu_out)
        cbar = mu_out[k]
        lo = np.nan
        if use[k if use.shape[0] > 1 else 0]:
            z0, z1, sig2 = z[k, 0], z[k, 1], var[k if var.shape[0] > 1 else 0]
            for j in range(r):
                sj, Pj = s_out[k, j], P_out[k, j]
                d2[j] = _innovate(sj, Pj, z0, z1, sig2)[6]
                lo = d2[j] if j == 0 else min(lo, d2[j])
            if lo <= gate:  # 3. update every model; flip negative speeds
                for j in range(r):
                    sj, Pj = s_out[k, j], P_out[k, j]
                    th_pred[j] = sj[2]
                    r0, r1, S00, S01, S11, dj, _ = _innovate(sj, Pj, z0, z1, sig2)
                    det[j] = dj
                    _correct(sj, Pj, r0, r1, S00, S01, S11, dj)
                    if sj[3] < 0.0:
                        sj[2] = th_pred[j] + (math.pi - (math.pi - (sj[2] + math.pi - th_pred[j])) % _TWO_PI)
                        sj[3] = -sj[3]
                        for a in range(3):
                            Pj[3, a] = -Pj[3, a]
                            Pj[a, 3] = -Pj[a, 3]
                total = 0.0  # 4.–5. μ_j ∝ c̄_j √(exp(d²_min − d²_j) / det S_j), floored, normalized
                for j in range(r):
                    cbar[j] = math.sqrt(math.exp(lo - d2[j]) / det[j]) * cbar[j]
                    total += cbar[j]
                low, total2 = total * floor, 0.0
                for j in range(r):
                    cbar[j] = max(cbar[j], low)
                    total2 += cbar[j]
                for j in range(r):
                    cbar[j] /= total2
        d2_min[k] = lo
        for a in range(4):  # 6. s = Σ_j μ_j s_j
            acc = 0.0
            for j in range(r):
                acc += cbar[j] * s_out[k, j, a]
            x_out[k, a] = acc


@kernel
def combine_row(k, s, P, mu, x, out):
    """Step 6, covariance, of row k into out[k]: Σ_j μ_j P_j + Σ_j μ_j (s_j − s)(s_j − s)ᵀ, s = Σ_j μ_j s_j
    (into the scratch x (4,)) with θ in the track's common chart (:func:`moments_into`, the upper triangle
    mirrored)."""
    o = out[k]
    moments_into(mu[k], s[k], P[k], x, o)
    for a in range(4):
        for b in range(a + 1, 4):
            o[b, a] = o[a, b]


@kernel
def combine_covariance(s, P, mu, out):
    """Step 6, covariance, per row: out[k] = Σ_j μ_j P_j + Σ_j μ_j (s_j − s)(s_j − s)ᵀ (n, 4, 4),
    s = Σ_j μ_j s_j with θ in the track's common chart (:func:`combine_row`)."""
    x = np.empty(4)
    for k in range(mu.shape[0]):
        combine_row(k, s, P, mu, x, out)
