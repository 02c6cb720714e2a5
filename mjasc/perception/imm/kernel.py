"""The IMM cycle on stacked numpy arrays: mixing, the per-model EKF of the constant-turn model,
the mode probabilities and the combination (thesis §3.2.1, eq. 3.3; docs/thesis.md §2, steps 1–6).

State of a tracked object ``s = [x, y, θ, V]``: world-frame ENU position [m], course over ground
θ (CCW from east) [rad], speed over ground V ≥ 0 [m/s].

Model j of r has a fixed turn rate ω_j; its discrete process with sample time Ts (here the time
since the previous cycle, which may vary) is thesis eq. 3.3 / docs/thesis.md §2::

    x⁺ = x + Ts·V·cos θ
    y⁺ = y + Ts·V·sin θ
    θ⁺ = θ + Ts·ω_j + w_θ·√Ts        w_θ ~ N(0, Q_θ)   →  process covariance Q = diag(0, 0, Q_θ·Ts, Q_V·Ts)
    V⁺ = V + w_V·√Ts                 w_V ~ N(0, Q_V)

Each model is an EKF with the transition Jacobian
``[[1,0,−Ts V sinθ, Ts cosθ],[0,1,Ts V cosθ, Ts sinθ],[0,0,1,0],[0,0,0,1]]`` evaluated at the mixed
estimate, and the linear measurement ``z = [x, y] + v``, ``v ~ N(0, R)``, ``R = σ²·I₂``.

One IMM cycle (Bar-Shalom, Li & Kirubarajan 2001; docs/thesis.md §2, steps 1–6):

1. ``c̄_j = Σ_i p_ij μ_i``, ``μ_{i|j} = p_ij μ_i / c̄_j``;
2. ``s0_j = Σ_i μ_{i|j} s_i``, ``P0_j = Σ_i μ_{i|j} [P_i + (s_i − s0_j)(s_i − s0_j)ᵀ]``;
3. per-model EKF predict and update from ``(s0_j, P0_j)``: innovation ``r_j``, covariance ``S_j``;
4. ``L_j = exp(−½ r_jᵀ S_j⁻¹ r_j) / √det(2π S_j)`` — the Gaussian density with the measurement
   dimension 2 (thesis eq. 3.10 is wrong, see docs/thesis.md §2); evaluated in the log domain (the common
   factor 1/(2π) cancels in step 5);
5. ``μ_j ∝ L_j c̄_j``, then floored at the minimum probability and renormalized;
6. ``s = Σ_j μ_j s_j``, ``P = Σ_j μ_j [P_j + (s_j − s)(s_j − s)ᵀ]`` and ``ω̂ = Σ_j μ_j ω_j``.

**Angles are mixed as angles.** The models' courses are kept *unwrapped in one common chart* per
track (they are mixed every cycle, so they stay within a fraction of a radian of each other);
then the plain weighted sums of steps 2 and 6 equal the sums of wrapped differences
``θ_j + Σ_i μ_{i|j} wrap(θ_i − θ_j)`` whenever the courses span less than π, and cost nothing.
Only what leaves the filter is wrapped to (−π, π]. The one operation that moves a course by π
(the speed flip, :func:`flip_negative_speeds`) re-charts that course next to its pre-update value.

Hot path: no Python loop over models or tracks; a bank's arrays have shapes (n, r, 4) and
(n, r, 4, 4), and one cycle is ~40 numpy calls on them (:class:`IMMCycle`), the same code for one
track (:class:`mjasc.perception.imm.tracker.IMMTracker` is a one-track bank) and for many. At 7
models the arithmetic is negligible and the cost is numpy's per-call overhead (~0.3 µs for a
same-shape contiguous operation, ~1 µs with broadcasting or strided views, ~1.3 µs for a stacked
matmul), so the cycle writes into buffers allocated once per bank size through views made once,
uses F = [[I, G], [0, I]] with reused F and Fᵀ, does the whole Kalman update with one product
(:class:`PositionUpdate`), and caches what depends only on Ts (p(Ts), Ts ω_j, Q:
:class:`mjasc.perception.imm.markov.CycleConstants`). benchmarks/bench_imm.py: ≥ 20× fewer µs
per update than filterpy's IMMEstimator on the same bank and data, same estimates to ~1e-13.

**Rows are independent.** Every product is a stacked one (one small matrix per track) and every sum
over models a per-row reduction in model order (``np.add.reduce``), never a 2-D BLAS product across
tracks (OpenBLAS rounds ``(n, r) @ (r, k)`` differently for different n): a track's numbers do not
depend on how many other tracks share its bank, so one bank holding the tracks of a whole fleet
gives each vessel's tracks the same bits as a bank of its own (:mod:`mjasc.perception.tracking.fleet`).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["wrap", "PositionUpdate", "IMMCycle", "flip_negative_speeds", "combine_state", "combine_covariance",
           "turn_rate"]

_TWO_PI = 2.0 * math.pi
_G_PHASE = np.array([[-0.5 * math.pi, 0.0], [0.0, 0.5 * math.pi]])  # cos(θ − ·) = [[−sin, cos], [cos, sin]]
_DIAG = np.arange(4)
_ADJ_SIGN = np.array([[1.0, -1.0], [-1.0, 1.0]])  # adj([[a, b], [b, d]]) = [[d, −b], [−b, a]]


def wrap(angle):
    """Wrap to (−π, π] (same convention as ``frames.wrap_angle``, fewer numpy calls)."""
    return math.pi - np.mod(math.pi - angle, _TWO_PI)


# ufuncs called with a positional ``out`` (cheaper than the keyword, which counts at ~40 calls
# per cycle on arrays of a few dozen numbers)
_add, _sub, _mul, _div, _matmul = np.add, np.subtract, np.multiply, np.divide, np.matmul
_cos, _exp, _sqrt, _maximum, _min_reduce = np.cos, np.exp, np.sqrt, np.maximum, np.minimum.reduce
_add_reduce = np.add.reduce

# ---------------------------------------------------------------------------------------------
# The IMM cycle on stacked arrays: per-model states (..., r, 4), covariances (..., r, 4, 4) and
# probabilities (..., r); the leading axes are a bank's tracks (n,). At 7 models the arithmetic
# is nothing, the cost is numpy's per-call overhead: so every step writes into buffers allocated
# once per bank size, through views made once, with as few calls as the algebra allows (~45 per
# cycle; the block structure of F and H is used instead of full products where it saves calls).
# ---------------------------------------------------------------------------------------------


class PositionUpdate:
    """Kalman update with the position measurement z = H s + v, H = [I₂ 0], v ~ N(0, R), of the
    prior states held in the array ``x`` (..., 4) given at construction and the prior covariances
    written into ``self.P`` (..., 4, 4) (the start-up filter and the IMM's models share this code).

    With Z = [H P | H x − z] (2×5 per prior), one product T = Zᵀ S⁻¹ Z, S = H P Hᵀ + R and
    S⁻¹ = adj S / det S (explicit 2×2), holds the whole update: T[:4, :4] = P Hᵀ S⁻¹ H P (the
    covariance reduction), −T[:4, 4] = K r (the state correction, r = z − H x) and
    T[4, 4] = rᵀ S⁻¹ r (the squared Mahalanobis distance). P is the left 4×4 of a 4×5 buffer
    ``P_aug`` whose top two rows are Z.
    """

    def __init__(self, x):
        lead = x.shape[:-1]
        self.x = x
        self.P_aug = np.zeros(lead + (4, 5))
        self.P = P = self.P_aug[..., :4]
        self._x_xy, self._P_xy = x[..., :2], P[..., :2, :2]
        self._Z = Z = self.P_aug[..., :2, :]
        self._Z_r, self._Z_T = Z[..., 4], Z.mT
        self._S = S = np.empty(lead + (2, 2))
        self._S_flip, self._S_row0 = S[..., ::-1, ::-1], S[..., :1, :]
        self._adj = np.empty(lead + (2, 2))
        self._adj_col0 = self._adj[..., :, :1]
        self._det = np.empty(lead + (1, 1))
        self._SZ = np.empty(lead + (2, 5))
        self._T = T = np.empty(lead + (5, 5))
        self._T_x, self._T_P = T[..., :4, 4], T[..., :4, :4]
        self._A = np.empty(lead + (4, 4))
        self._A_T = self._A.mT
        self.mahalanobis = T[..., 4, 4]  # rᵀ S⁻¹ r, shaped x[..., 0]
        self.det = self._det[..., 0, 0]  # det S

    def innovate(self, z, R):
        """Fill T for measurement z (broadcastable to x[..., :2]) with covariance R ((2, 2), or
        broadcastable to P[..., :2, :2]); returns the views (rᵀ S⁻¹ r, det S)."""
        _sub(self._x_xy, z, self._Z_r)
        _add(self._P_xy, R, self._S)
        adj = _mul(self._S_flip, _ADJ_SIGN, self._adj)  # [[d, −c], [−b, a]]
        det = _matmul(self._S_row0, self._adj_col0, self._det)  # a d − b c
        T = _matmul(self._Z_T, _matmul(adj, self._Z, self._SZ), self._T)
        _div(T, det, T)
        return self.mahalanobis, self.det

    def correct(self, x_out, P_out):
        """Posterior of the last ``innovate`` into x_out, P_out: x⁺ = x + K r, P⁺ = P − P Hᵀ S⁻¹ H P
        re-symmetrized (without it rounding asymmetry grows and P loses positive definiteness
        after ~10³ cycles)."""
        _sub(self.x, self._T_x, x_out)
        _sub(self.P, self._T_P, self._A)
        _add(self._A, self._A_T, P_out)
        _mul(P_out, 0.5, P_out)


class IMMCycle:
    """Buffers and steps of one IMM cycle of ``lead`` tracks × r models (docs/thesis.md §2 steps 1–5).

    The posterior goes to one of two buffer sets ``sides[k] = (s, P, μ)``: a bank whose state is
    one side is updated into the other, so the inputs of a cycle are never overwritten by it.
    """

    def __init__(self, lead: tuple, r: int):
        def e(*shape):
            return np.zeros(lead + shape)

        self.lead = lead
        self._cbar = e(1, r)
        self.cbar = self._cbar[..., 0, :]
        self._cbar_col = self._cbar.mT
        self._w = e(r, r)
        self._w_ji = self._w[..., None]
        self._markov_t, self._markov_t_of = e(r, r), None  # p(Ts)ᵀ per track: same-shape products
        self.s0 = e(r, 4)  # mixed, then (in place) predicted states
        self._s0_j = self.s0[..., :, None, :]
        self._th0, self._v0 = self.s0[..., 2, None, None], self.s0[..., 3, None]
        self._dev = e(r, r, 4)
        self._dev_T = self._dev.mT
        self._wdev = e(r, r, 4)
        self._spread = e(r, 4, 4)
        self._P0 = e(r, 4, 4)
        self._P0_flat = self._P0.reshape(lead + (r, 16))
        self._F, self._F_T = e(r, 4, 4), e(r, 4, 4)
        self._F[..., _DIAG, _DIAG] = 1.0
        self._F_T[..., _DIAG, _DIAG] = 1.0
        self._F_G, self._F_T_G = self._F[..., :2, 2:], self._F_T[..., 2:, :2]
        self._G = e(r, 2, 2)
        self._G_T = self._G.mT
        self._G_th, self._G_v = self._G[..., :, 0], self._G[..., :, 1]
        self._D = e(r, 4)  # state increment [Ts V cos θ, Ts V sin θ, Ts ω_j, 0]
        self._D_xy, self._D_th = self._D[..., :2], self._D[..., 2]
        self._D_th_of = None
        self._FP = e(r, 4, 4)
        self.update = PositionUpdate(self.s0)
        self.Pp, self._Pp_aug = self.update.P, self.update.P_aug  # predicted covariances
        self._Q, self._Q_of = e(r, 4, 5), None  # Q at the shape of Pp_aug: a same-shape add
        self.mahalanobis_min = e(1)
        self.mahalanobis_min_rows = self.mahalanobis_min[..., 0]
        self._lik, self._total = e(r), e(1)
        self.sides = tuple((e(r, 4), e(r, 4, 4), e(r)) for _ in range(2))
        self._views = {  # per side buffer: the views mix_predict and combine_state take of it
            id(a): v
            for s, P, mu in self.sides
            for a, v in ((s, s[..., None, :, :]), (P, P.reshape(lead + (r, 16))), (mu, mu[..., None, :]))
        }
        self._x = e(1, 4)
        self.x = self._x[..., 0, :]

    def mix_predict(self, s, P, mu, markov, markov_t, dt, dt_omega, q_block):
        """Steps 1–2 (mixing) and the EKF prediction of step 3; returns views (s_pred, P_pred, c̄).

        markov: p(Ts) (r, r) or (..., r, r), markov_t its transpose; dt: Ts, a float or an array
        broadcastable to (..., r, 2, 2); dt_omega: Ts ω_j ((r,) or (..., r)); q_block: the (θ, V)
        process covariance diag(Q_θ, Q_V)·Ts, (2, 2) or broadcastable to (..., r, 2, 2).
        """
        views = self._views
        mrow = views.get(id(mu))
        if mrow is None:  # not a side buffer (their views keep them alive: ids are unique)
            mrow = mu[..., None, :]
        _matmul(mrow, markov, self._cbar)  # c̄_j = Σ_i p_ij μ_i
        w = _div(mrow, self._cbar_col, self._w)
        if markov_t is not self._markov_t_of:  # the same array for the same Ts (cached per Ts)
            np.copyto(self._markov_t, markov_t)
            self._markov_t_of = markov_t
        _mul(w, self._markov_t, w)  # μ_{i|j} = p_ij μ_i / c̄_j, indexed (j, i)
        s0 = _matmul(w, s, self.s0)  # s0_j = Σ_i μ_{i|j} s_i
        s_i = views.get(id(s))
        if s_i is None:
            s_i = s[..., None, :, :]
        dev = _sub(s_i, self._s0_j, self._dev)  # s_i − s0_j, (j, i, 4)
        _mul(dev, self._w_ji, self._wdev)
        P0 = self._P0  # Σ_i μ_{i|j} [P_i + (s_i − s0_j)(s_i − s0_j)ᵀ]
        P_flat = views.get(id(P))
        if P_flat is None:
            P_flat = P.reshape(P.shape[:-2] + (16,))
        _matmul(w, P_flat, self._P0_flat)
        _add(P0, _matmul(self._dev_T, self._wdev, self._spread), P0)
        # thesis eq. 3.3: F = [[I, G], [0, I]], G = Ts [[−V sin θ, cos θ], [V cos θ, sin θ]]
        G = _sub(self._th0, _G_PHASE, self._G)
        _cos(G, G)
        _mul(self._G_th, self._v0, self._G_th)
        if type(dt) is not float or dt != 1.0:
            _mul(G, dt, G)
        np.copyto(self._F_G, G)
        np.copyto(self._F_T_G, self._G_T)
        _mul(self._G_v, self._v0, self._D_xy)
        if dt_omega is not self._D_th_of:  # the same array for the same Ts (cached per Ts)
            self._D_th[...] = dt_omega
            self._D_th_of = dt_omega
        _add(s0, self._D, s0)
        _matmul(_matmul(self._F, P0, self._FP), self._F_T, self.Pp)
        if q_block is not self._Q_of:
            self._Q[..., 2:, 2:4] = q_block
            self._Q_of = q_block
        _add(self._Pp_aug, self._Q, self._Pp_aug)
        return s0, self.Pp, self.cbar

    def mode_probabilities(self, maha, det, floor, out):
        """Steps 4–5: μ_j ∝ c̄_j exp(−½ r_jᵀS_j⁻¹r_j)/√det S_j, floored, normalized, into ``out``.

        The factor exp(½ min_j r_jᵀS_j⁻¹r_j) common to all models is taken out (no underflow
        for the best-fitting model; the minimum is ``mahalanobis_min``, filled here), as is
        1/(2π). Flooring the unnormalized μ̃ at floor·Σμ̃ then normalizing equals normalizing,
        flooring at ``floor`` and renormalizing.
        """
        lik = _sub(_min_reduce(maha, -1, None, self.mahalanobis_min, True), maha, self._lik)
        _exp(lik, lik)
        _div(lik, det, lik)
        _sqrt(lik, lik)
        mu = _mul(lik, self.cbar, out)
        total = _add_reduce(mu, -1, None, self._total, True)  # Σ_j μ_j per track, in model order
        _maximum(mu, _mul(total, floor, total), out=mu)
        _div(mu, _add_reduce(mu, -1, None, self._total, True), mu)
        return mu

    def combine_state(self, s, mu):
        """Step 6, state: Σ_j μ_j s_j (..., 4) (a view of a buffer of this cycle)."""
        mrow = self._views.get(id(mu))
        _matmul(mu[..., None, :] if mrow is None else mrow, s, self._x)
        return self.x


def flip_negative_speeds(su, Pu, th_before):
    """(θ, V) → (θ + π, −V) where V < 0, re-charted within π of the pre-update course th_before."""
    neg = su[..., 3] < 0.0
    flipped = th_before + wrap(su[..., 2] + math.pi - th_before)
    su[..., 2] = np.where(neg, flipped, su[..., 2])
    su[..., 3] = np.abs(su[..., 3])
    sign = np.where(neg, -1.0, 1.0)[..., None]
    Pu[..., 3, :3] *= sign
    Pu[..., :3, 3] *= sign


def turn_rate(mu, omega):
    """ω̂ = Σ_j μ_j ω_j [rad/s] per row of mu (..., r) (docs/thesis.md §2 step 6), summed per row in
    model order (not a matrix-vector product across tracks: see "Rows are independent")."""
    return _add_reduce(mu * omega, -1)


def combine_state(s, mu):
    """docs/thesis.md §2 step 6, state: s = Σ_j μ_j s_j (n, 4), θ in the track's chart (wrap to read)."""
    return (mu[:, None, :] @ s)[:, 0, :]


def combine_covariance(s, P, mu):
    """docs/thesis.md §2 step 6, covariance: P = Σ_j μ_j [P_j + (s_j − s)(s_j − s)ᵀ] (n, 4, 4)."""
    n, r = mu.shape
    mrow = mu[:, None, :]
    dev = s - mrow @ s  # θ deviations in the track's common chart
    Pc = (mrow @ P.reshape(n, r, 16)).reshape(n, 4, 4)
    Pc += np.swapaxes(dev, 1, 2) @ (mu[:, :, None] * dev)
    return Pc
