"""Interacting Multiple Model (IMM) tracking of obstacles (thesis §3.2.1, digest §2).

State of a tracked object ``s = [x, y, θ, V]``: world-frame ENU position [m], course over ground
θ (CCW from east) [rad], speed over ground V ≥ 0 [m/s].

Model j of r has a fixed turn rate ω_j; its discrete process with sample time Ts (here the time
since the previous cycle, which may vary) is thesis eq. 3.3 / digest §2::

    x⁺ = x + Ts·V·cos θ
    y⁺ = y + Ts·V·sin θ
    θ⁺ = θ + Ts·ω_j + w_θ·√Ts        w_θ ~ N(0, Q_θ)   →  process covariance Q = diag(0, 0, Q_θ·Ts, Q_V·Ts)
    V⁺ = V + w_V·√Ts                 w_V ~ N(0, Q_V)

Each model is an EKF with the transition Jacobian
``[[1,0,−Ts V sinθ, Ts cosθ],[0,1,Ts V cosθ, Ts sinθ],[0,0,1,0],[0,0,0,1]]`` evaluated at the mixed
estimate, and the linear measurement ``z = [x, y] + v``, ``v ~ N(0, R)``, ``R = σ²·I₂``.

One IMM cycle (Bar-Shalom, Li & Kirubarajan 2001; digest §2, steps 1–6):

1. ``c̄_j = Σ_i p_ij μ_i``, ``μ_{i|j} = p_ij μ_i / c̄_j``;
2. ``s0_j = Σ_i μ_{i|j} s_i``, ``P0_j = Σ_i μ_{i|j} [P_i + (s_i − s0_j)(s_i − s0_j)ᵀ]``;
3. per-model EKF predict and update from ``(s0_j, P0_j)``: innovation ``r_j``, covariance ``S_j``;
4. ``L_j = exp(−½ r_jᵀ S_j⁻¹ r_j) / √det(2π S_j)`` — the Gaussian density with the measurement
   dimension 2 (thesis eq. 3.10 is wrong, see digest §2); evaluated in the log domain (the common
   factor 1/(2π) cancels in step 5);
5. ``μ_j ∝ L_j c̄_j``, then floored at the minimum probability and renormalized;
6. ``s = Σ_j μ_j s_j``, ``P = Σ_j μ_j [P_j + (s_j − s)(s_j − s)ᵀ]`` and ``ω̂ = Σ_j μ_j ω_j``.

**Angles are mixed as angles.** The models' courses are kept *unwrapped in one common chart* per
track (they are mixed every cycle, so they stay within a fraction of a radian of each other);
then the plain weighted sums of steps 2 and 6 equal the sums of wrapped differences
``θ_j + Σ_i μ_{i|j} wrap(θ_i − θ_j)`` whenever the courses span less than π, and cost nothing.
Only what leaves the filter is wrapped to (−π, π]. The one operation that moves a course by π
(the speed flip below) re-charts that course next to its pre-update value.

Choices beyond the thesis (all parameters of :class:`IMMConfig`):

* **Variable sample time.** The Markov matrix ``p`` is given per ``markov_reference_dt_s`` (1 s,
  the thesis's Ts); a cycle of Ts uses ``p^(Ts/T_ref)`` (matrix power through the eigen-
  decomposition), so a cycle with Ts = 0 mixes nothing (predict(t) then update(z, t) is one cycle).
* **Coasting.** A cycle without a measurement (missed, occluded, or rejected) is steps 1–2, the
  prediction of step 3, and ``μ_j = c̄_j``.
* **Negative speed.** After an update, a model whose V came out negative is re-parametrized
  exactly, ``(θ, V) → (θ + π, −V)`` (the same velocity vector), with the V row and column of its
  covariance negated (Jacobian ``diag(1, 1, 1, −1)``; P_VV unchanged). The combined V is a convex
  combination of non-negative speeds, hence ≥ 0.
* **Initialization.** An EKF in (θ, V) started with a course that is unknown diverges easily (the
  linearization in θ is poor when σ_θ ~ 1 rad). So a new track first runs a linear
  constant-velocity Kalman filter on [x, y, vx, vy] (position from the first measurement,
  velocity 0 ± ``initial_speed_std_m_s`` per axis, white-acceleration noise
  ``init_acceleration_noise_m2_s3``), and hands over to the IMM — θ = atan2(v), V = |v| with the
  first-order covariance — as soon as the speed is well determined (|v̂| ≥ ``init_speed_snr``·σ_v)
  or after ``init_max_updates`` measurements (a static target: θ then has the variance of a
  uniform angle, π²/3, at most). With two measurements and a diffuse prior this is the classical
  two-point differencing.
* **Gating.** A measurement is rejected (the track coasts) if it is not finite, or if it lies
  outside the chi-square (2 dof) gate ``−2 ln(1 − gate_probability)`` of *every* model's predicted
  measurement (the union of the model gates holds at least ``gate_probability`` of the IMM's
  predictive mixture). After ``restart_after_gated`` consecutive gated measurements the track is
  restarted from the latest one (a lost track heals itself).

Hot path: no Python loop over models or tracks; a bank's arrays have shapes (n, r, 4) and
(n, r, 4, 4), and one cycle is ~40 numpy calls on them (:class:`_IMMCycle`), the same code for one
track (:class:`IMMTracker` is a one-track bank) and for many. At 7 models the arithmetic is
negligible and the cost is numpy's per-call overhead (~0.3 µs for a same-shape contiguous
operation, ~1 µs with broadcasting or strided views, ~1.3 µs for a stacked matmul), so the cycle
writes into buffers allocated once per bank size through views made once, uses F = [[I, G], [0, I]]
with reused F and Fᵀ, does the whole Kalman update with one product (:class:`_PositionUpdate`),
and caches what depends only on Ts (p(Ts), Ts ω_j, Q). benchmarks/bench_imm.py: ≥ 20× fewer µs
per update than filterpy's IMMEstimator on the same bank and data, same estimates to ~1e-13.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np

from mjasc.core.config_tables import ConfigError, dataclass_from_table, integer, number, show
from mjasc.core.estimates import TrackEstimate

logger = logging.getLogger(__name__)

__all__ = ["IMMConfig", "IMMBank", "IMMTracker", "REJECTION_REASONS", "filterpy_imm", "parse_imm_options"]

_TWO_PI = 2.0 * math.pi
_UNIFORM_ANGLE_VAR = math.pi**2 / 3.0  # variance of an angle uniform on (−π, π]
_TINY_PROB = 1e-300  # floor when min_mode_probability = 0: keeps every μ_j, c̄_j > 0 (no 0/0)
_G_PHASE = np.array([[-0.5 * math.pi, 0.0], [0.0, 0.5 * math.pi]])  # cos(θ − ·) = [[−sin, cos], [cos, sin]]
_DIAG = np.arange(4)
_EYE2 = np.eye(2)
_ADJ_SIGN = np.array([[1.0, -1.0], [-1.0, 1.0]])  # adj([[a, b], [b, d]]) = [[d, −b], [−b, a]]

# codes of IMMBank.rejection_codes (index into REJECTION_REASONS)
_ACCEPTED, _NOT_MEASURED, _NON_FINITE, _GATED, _RESTARTED = 0, 1, 2, 3, 4
REJECTION_REASONS = (
    "",
    "no measurement for this track",
    "measurement is not finite",
    "measurement outside the chi-square gate of every model",
    "track restarted from this measurement after consecutive gated measurements",
)


def _wrap(angle):
    """Wrap to (−π, π] (same convention as ``frames.wrap_angle``, fewer numpy calls)."""
    return math.pi - np.mod(math.pi - angle, _TWO_PI)


@dataclass(frozen=True)
class IMMConfig:
    """Parameters of the IMM tracker. Defaults: thesis Table 6.1 where it gives a value.

    turn_rates_rad_s: ω_j of the r models [rad/s] (Table 6.1: 7 models, −0.05 … 0.05).
    initial_mode_probabilities: μ_j at hand-over to the IMM (None: 1/r each, Table 6.1).
    min_mode_probability: floor of every μ_j after an update (Table 6.1: 2·10⁻³); 0 disables it.
    measurement_variance_m2: σ² of the position measurement per axis, R = σ²·I₂ (§6.1: 0.1 m²).
    heading_noise_rad2_s: Q_θ, intensity of the course random walk [rad²/s]. Default 1e-5
        (1-σ course drift 0.003 rad in 1 s): small, so that models 0.02 rad/s apart are told
        apart within tens of seconds, yet NEES-consistent for targets between two models.
        Tuned by the NEES tests in tests/test_imm.py.
    speed_noise_m2_s3: Q_V, intensity of the speed random walk [m²/s³]. Default 1e-4 (1-σ speed
        change 0.01 m/s in 1 s: a small craft's gentle accelerations), tuned with Q_θ.
    markov_stay_probability: p_jj of the Markov switching matrix per ``markov_reference_dt_s``;
        the rest, 1 − p_jj, is spread evenly over the other models. Default 0.98: a mean sojourn
        of 50 s in a mode, the time scale of a small craft's turns (the thesis gives no value;
        0.9–0.98 is usual). Lower values switch faster but leak probability to the 6 wrong
        models every cycle, which biases ω̂ toward 0.
    markov_matrix: optional explicit r×r matrix p_ij (row i: from model i), replacing the uniform
        one; rows must sum to 1, eigenvalues real and positive (so p^(Ts/T_ref) exists).
    markov_reference_dt_s: time step the Markov matrix refers to [s] (the thesis's Ts = 1 s).
    initial_speed_std_m_s: prior 1-σ of each velocity component of a new track [m/s]; with the
        gate it bounds the jump between a track's first two measurements (≈ 4.3·σ·Ts).
    init_acceleration_noise_m2_s3: white-acceleration intensity of the start-up constant-velocity
        filter [m²/s³]; 0.01 covers the turn acceleration V·ω of 2 m/s at 0.05 rad/s over 1 s.
    init_speed_snr: hand a new track over to the IMM once |v̂| ≥ this × σ_v (3 → σ_θ ≲ 1/3 rad,
        where the EKF's linearization in θ is good).
    init_max_updates: hand over after this many measurements at the latest (1: at once, course
        unknown; 2: two-point differencing).
    gate_probability: chi-square (2 dof) gate probability; gate −2 ln(1 − p) (0.9999 → 18.4).
        1.0 disables the gate.
    restart_after_gated: restart a track from the measurement after this many consecutive gated
        ones (0: never).
    """

    turn_rates_rad_s: tuple[float, ...] = (-0.05, -0.03, -0.01, 0.0, 0.01, 0.03, 0.05)
    initial_mode_probabilities: tuple[float, ...] | None = None
    min_mode_probability: float = 2e-3
    measurement_variance_m2: float = 0.1
    heading_noise_rad2_s: float = 1e-5
    speed_noise_m2_s3: float = 1e-4
    markov_stay_probability: float = 0.98
    markov_matrix: tuple[tuple[float, ...], ...] | None = None
    markov_reference_dt_s: float = 1.0
    initial_speed_std_m_s: float = 2.0
    init_acceleration_noise_m2_s3: float = 0.01
    init_speed_snr: float = 3.0
    init_max_updates: int = 10
    gate_probability: float = 0.9999
    restart_after_gated: int = 5

    def __post_init__(self):
        _check_imm(self, "imm")

    @property
    def n_models(self) -> int:
        return len(self.turn_rates_rad_s)

    @property
    def gate_threshold(self) -> float:
        """Squared-Mahalanobis gate −2 ln(1 − p) (chi-square, 2 dof); inf when p = 1."""
        p = self.gate_probability
        return math.inf if p >= 1.0 else -2.0 * math.log1p(-p)

    def markov_matrix_array(self) -> np.ndarray:
        """(r, r) switching matrix p_ij per ``markov_reference_dt_s`` (row i: from model i)."""
        r = self.n_models
        if self.markov_matrix is not None:
            return np.asarray(self.markov_matrix, dtype=float)
        if r == 1:
            return np.ones((1, 1))
        off = (1.0 - self.markov_stay_probability) / (r - 1)
        return np.full((r, r), off) + np.eye(r) * (self.markov_stay_probability - off)


_IMM_POSITIVE = ("measurement_variance_m2", "markov_reference_dt_s", "initial_speed_std_m_s", "init_speed_snr")
_IMM_NONNEG = ("heading_noise_rad2_s", "speed_noise_m2_s3", "init_acceleration_noise_m2_s3")


def _float_array(value) -> np.ndarray | None:
    """``value`` as a float array, or None when it is not numeric (a string, a ragged list …)."""
    if isinstance(value, (str, bytes)):
        return None
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return None


def _check_imm(c: IMMConfig, where: str) -> None:
    """Validate an :class:`IMMConfig` (ConfigError, a ValueError, naming ``f"{where}.{key}"``)."""
    def bad(key, reason, value):
        raise ConfigError(f"{where}.{key}: {reason}, got {show(value)}")

    w = _float_array(c.turn_rates_rad_s)
    if w is None or w.ndim != 1 or w.size < 1 or not np.all(np.isfinite(w)):
        bad("turn_rates_rad_s", "must be a non-empty list of finite turn rates [rad/s]", c.turn_rates_rad_s)
    r = w.size
    if c.initial_mode_probabilities is not None:
        mu = _float_array(c.initial_mode_probabilities)
        if mu is None or mu.shape != (r,) or not np.all(mu >= 0) or not np.isclose(mu.sum(), 1.0):
            bad("initial_mode_probabilities", f"must be {r} non-negative values summing to 1",
                c.initial_mode_probabilities)
    number(c.min_mode_probability, f"{where}.min_mode_probability", nonneg=True)
    if not c.min_mode_probability < 1.0 / r:
        bad("min_mode_probability", f"must be < 1/r = {1.0 / r:.4g} (r = {r} models)", c.min_mode_probability)
    for key in _IMM_POSITIVE:
        number(getattr(c, key), f"{where}.{key}", positive=True)
    for key in _IMM_NONNEG:
        number(getattr(c, key), f"{where}.{key}", nonneg=True)
    integer(c.init_max_updates, f"{where}.init_max_updates", minimum=1)
    integer(c.restart_after_gated, f"{where}.restart_after_gated", minimum=0)
    number(c.gate_probability, f"{where}.gate_probability", positive=True, maximum=1.0)
    number(c.markov_stay_probability, f"{where}.markov_stay_probability")
    if c.markov_matrix is None:
        if r > 1 and not 1.0 / r < c.markov_stay_probability <= 1.0:
            bad("markov_stay_probability", f"must be in (1/r, 1] = ({1.0 / r:.4g}, 1] so that the matrix has "
                "positive eigenvalues", c.markov_stay_probability)
    else:
        p = _float_array(c.markov_matrix)
        if p is None or p.shape != (r, r) or not np.all(p >= 0) or not np.allclose(p.sum(axis=1), 1.0):
            bad("markov_matrix", f"must be an {r}×{r} non-negative matrix whose rows sum to 1", c.markov_matrix)
        lam = np.linalg.eigvals(p)
        if np.any(np.abs(lam.imag) > 1e-12) or np.any(lam.real <= 0):
            bad("markov_matrix", "must have real, positive eigenvalues (fractional powers for a variable "
                "sample time need them)", c.markov_matrix)


def parse_imm_options(table: Mapping | None, where: str = "imm") -> IMMConfig:
    """A scenario's ``imm`` table (None: all defaults) → :class:`IMMConfig`; unknown keys, wrong types
    and out-of-range values raise ValueError naming ``f"{where}.{key}"``
    (:func:`mjasc.core.config_tables.dataclass_from_table`)."""
    return dataclass_from_table(IMMConfig, {} if table is None else table, where, check=_check_imm)


class _MarkovPower:
    """p(Ts) = p^(Ts/T_ref) = V diag(λ^(Ts/T_ref)) V⁻¹, vectorized over tracks, cached per scalar Ts."""

    def __init__(self, config: IMMConfig):
        p = config.markov_matrix_array()
        lam, vec = np.linalg.eig(p)
        self._lam = lam.real
        self._vec = vec.real
        self._vec_inv = np.linalg.inv(vec).real
        self._t_ref = config.markov_reference_dt_s
        self._p_ref = p
        self._cache: dict[float, np.ndarray] = {}

    def _from_power(self, dt: np.ndarray) -> np.ndarray:
        powers = self._lam ** (np.asarray(dt, dtype=float)[..., None] / self._t_ref)  # (..., r)
        m = (self._vec * powers[..., None, :]) @ self._vec_inv
        m = np.clip(m, 0.0, None)
        return m / m.sum(axis=-1, keepdims=True)

    def scalar(self, dt: float) -> np.ndarray:
        """(r, r) matrix for one Ts (exactly the given matrix at T_ref, identity at 0)."""
        m = self._cache.get(dt)
        if m is None:
            if dt == self._t_ref:
                m = self._p_ref
            elif dt == 0.0:
                m = np.eye(self._lam.size)
            else:
                m = self._from_power(dt)
            if len(self._cache) > 256:
                self._cache.clear()
            self._cache[dt] = m
        return m

    def per_track(self, dt: np.ndarray) -> np.ndarray:
        """(n, r, r) matrices for per-track Ts."""
        return self._from_power(dt)


# ufuncs called with a positional ``out`` (cheaper than the keyword, which counts at ~40 calls
# per cycle on arrays of a few dozen numbers)
_add, _sub, _mul, _div, _matmul = np.add, np.subtract, np.multiply, np.divide, np.matmul
_cos, _exp, _sqrt, _maximum, _min_reduce = np.cos, np.exp, np.sqrt, np.maximum, np.minimum.reduce

# ---------------------------------------------------------------------------------------------
# The IMM cycle on stacked arrays: per-model states (..., r, 4), covariances (..., r, 4, 4) and
# probabilities (..., r); the leading axes are a bank's tracks (n,). At 7 models the arithmetic
# is nothing, the cost is numpy's per-call overhead: so every step writes into buffers allocated
# once per bank size, through views made once, with as few calls as the algebra allows (~45 per
# cycle; the block structure of F and H is used instead of full products where it saves calls).
# ---------------------------------------------------------------------------------------------


class _PositionUpdate:
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


class _IMMCycle:
    """Buffers and steps of one IMM cycle of ``lead`` tracks × r models (digest §2 steps 1–5).

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
        self.update = _PositionUpdate(self.s0)
        self.Pp, self._Pp_aug = self.update.P, self.update.P_aug  # predicted covariances
        self._Q, self._Q_of = e(r, 4, 5), None  # Q at the shape of Pp_aug: a same-shape add
        self.mahalanobis_min = e(1)
        self.mahalanobis_min_rows = self.mahalanobis_min[..., 0]
        self._lik, self._total, self._ones = e(r), e(r), np.ones((r, r))
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
        total = _matmul(mu, self._ones, self._total)  # Σ_j μ_j in every column (same-shape ops)
        _maximum(mu, _mul(total, floor, total), out=mu)
        _div(mu, _matmul(mu, self._ones, self._total), mu)
        return mu

    def combine_state(self, s, mu):
        """Step 6, state: Σ_j μ_j s_j (..., 4) (a view of a buffer of this cycle)."""
        mrow = self._views.get(id(mu))
        _matmul(mu[..., None, :] if mrow is None else mrow, s, self._x)
        return self.x


def _flip_negative_speeds(su, Pu, th_before):
    """(θ, V) → (θ + π, −V) where V < 0, re-charted within π of the pre-update course th_before."""
    neg = su[..., 3] < 0.0
    flipped = th_before + _wrap(su[..., 2] + math.pi - th_before)
    su[..., 2] = np.where(neg, flipped, su[..., 2])
    su[..., 3] = np.abs(su[..., 3])
    sign = np.where(neg, -1.0, 1.0)[..., None]
    Pu[..., 3, :3] *= sign
    Pu[..., :3, 3] *= sign


def _combine_state(s, mu):
    """Digest §2 step 6, state: s = Σ_j μ_j s_j (n, 4), θ in the track's chart (wrap to read)."""
    return (mu[:, None, :] @ s)[:, 0, :]


def _combine_covariance(s, P, mu):
    """Digest §2 step 6, covariance: P = Σ_j μ_j [P_j + (s_j − s)(s_j − s)ᵀ] (n, 4, 4)."""
    n, r = mu.shape
    mrow = mu[:, None, :]
    dev = s - mrow @ s  # θ deviations in the track's common chart
    Pc = (mrow @ P.reshape(n, r, 16)).reshape(n, 4, 4)
    Pc += np.swapaxes(dev, 1, 2) @ (mu[:, :, None] * dev)
    return Pc


# ---- start-up constant-velocity filter on [x, y, vx, vy] ------------------------------------


def _cv_predict(xc, Pc, dt, q):
    """Constant-velocity prediction with white acceleration of intensity q; dt (k,)."""
    k = dt.shape[0]
    F = np.broadcast_to(np.eye(4), (k, 4, 4)).copy()
    F[:, 0, 2] = F[:, 1, 3] = dt
    xp = (F @ xc[..., None])[..., 0]
    Pp = F @ Pc @ np.swapaxes(F, 1, 2)
    q3, q2, q1 = q * dt**3 / 3.0, q * dt**2 / 2.0, q * dt
    Pp[:, 0, 0] += q3
    Pp[:, 1, 1] += q3
    Pp[:, 0, 2] += q2
    Pp[:, 2, 0] += q2
    Pp[:, 1, 3] += q2
    Pp[:, 3, 1] += q2
    Pp[:, 2, 2] += q1
    Pp[:, 3, 3] += q1
    return xp, Pp


def _cv_to_polar(xc, Pc):
    """[x, y, vx, vy] (k, 4) and covariance → [x, y, θ, V] and its first-order covariance.

    θ = atan2(vy, vx), V = |v|; Jacobian rows ∂θ/∂v = u⊥/V, ∂V/∂v = u (u = v/V, u⊥ = (−u_y, u_x)).
    If σ_θ² exceeds π²/3 (the variance of a uniform angle), the θ row and column are scaled down
    to it (a congruence: P stays positive semi-definite). At V = 0, u = (1, 0).
    """
    k = xc.shape[0]
    vx, vy = xc[:, 2], xc[:, 3]
    speed = np.hypot(vx, vy)
    moving = speed > 0
    safe = np.where(moving, speed, 1.0)
    ux = np.where(moving, vx / safe, 1.0)
    uy = np.where(moving, vy / safe, 0.0)
    inv_v = np.where(moving, 1.0 / safe, 1e150)
    J = np.zeros((k, 4, 4))
    J[:, 0, 0] = J[:, 1, 1] = 1.0
    J[:, 2, 2], J[:, 2, 3] = -uy * inv_v, ux * inv_v
    J[:, 3, 2], J[:, 3, 3] = ux, uy
    P = J @ Pc @ np.swapaxes(J, 1, 2)
    scale = np.sqrt(np.minimum(1.0, _UNIFORM_ANGLE_VAR / P[:, 2, 2]))
    P[:, 2, :] *= scale[:, None]
    P[:, :, 2] *= scale[:, None]
    s = np.stack([xc[:, 0], xc[:, 1], np.arctan2(vy, vx), speed], axis=-1)
    return s, 0.5 * (P + np.swapaxes(P, 1, 2))


class IMMBank:
    """Many IMM trackers updated in one call: arrays (n_tracks, r, 4) and (n_tracks, r, 4, 4).

    Each track has an integer id (``track_ids``), its own last time, model states, covariances and
    mode probabilities; all share one :class:`IMMConfig`. Rows of every per-track array follow
    ``track_ids``. Typical use by a track manager::

        bank.predict(t)                              # coast every track to t
        d2 = bank.mahalanobis_squared(detections)    # (n_tracks, m), for data association
        ok = bank.gate(detections)                   # d2 ≤ chi-square gate
        ... assign detections → z (n_tracks, 2), mask (n_tracks,) ...
        accepted = bank.update(z, t, mask)           # unmeasured / rejected tracks coast
        tid = bank.add_track(z_new, t); bank.remove_track(tid)
        estimates = bank.estimates(radius_m=...)     # list[TrackEstimate]

    A new track starts in a constant-velocity start-up filter and joins the IMM once its speed is
    determined (``velocity_initialized``); its estimate is meaningful from the first measurement.
    """

    def __init__(self, config: IMMConfig = IMMConfig()):
        if not isinstance(config, IMMConfig):
            raise ValueError(f"config: expected an IMMConfig, got {type(config).__name__}")
        self.config = config
        r = config.n_models
        self._r = r
        self._omega = np.asarray(config.turn_rates_rad_s, dtype=float)
        mu0 = (
            np.full(r, 1.0 / r)
            if config.initial_mode_probabilities is None
            else np.asarray(config.initial_mode_probabilities, dtype=float)
        )
        mu0 = np.maximum(mu0, _TINY_PROB)
        self._mu0 = mu0 / mu0.sum()
        self._markov = _MarkovPower(config)
        self._R = float(config.measurement_variance_m2)
        self._q_unit = np.diag([config.heading_noise_rad2_s, config.speed_noise_m2_s3])
        self._R_cov = self._R * _EYE2
        self._Pc_stale = False  # combined covariances are computed when read
        self._cyc = None  # _IMMCycle buffers for the current number of tracks
        self._steps: dict[float, tuple] = {}  # per Ts: p(Ts), its transpose, Ts ω_j, Q block
        self._t_common = None  # the time of every track's last cycle when they share it [s]
        self._n_warm = 0  # number of tracks in the start-up filter
        self._flagged = True  # _n_gated or _reasons may be non-zero
        self._floor = max(config.min_mode_probability, _TINY_PROB)
        self._gate = config.gate_threshold
        self._snr2 = config.init_speed_snr**2
        self._next_id = 0
        self._ids = np.zeros(0, dtype=np.int64)
        self._s = np.zeros((0, r, 4))  # per-model states, θ unwrapped in a common chart per track
        self._P = np.zeros((0, r, 4, 4))
        self._mu = np.zeros((0, r))
        self._t = np.zeros(0)
        self._x = np.zeros((0, 4))  # combined estimate, kept current; θ unwrapped (wrap to read)
        self._Pc = np.zeros((0, 4, 4))
        self._warm = np.zeros(0, dtype=bool)  # in the start-up CV filter
        self._cv_x = np.zeros((0, 4))
        self._cv_P = np.zeros((0, 4, 4))
        self._n_meas = np.zeros(0, dtype=np.int64)
        self._n_gated = np.zeros(0, dtype=np.int64)
        self._reasons = np.zeros(0, dtype=np.int8)
        self._mv = None  # per-row measurement variances of the current update (None: config's)

    _PER_TRACK = (
        "_ids", "_s", "_P", "_mu", "_t", "_x", "_Pc", "_warm", "_cv_x", "_cv_P", "_n_meas",
        "_n_gated", "_reasons",
    )  # fmt: skip

    # ------------------------------------------------------------------ track list
    def __len__(self) -> int:
        return self._ids.size

    @property
    def track_ids(self) -> np.ndarray:
        """(n,) integer ids, in the row order of every per-track array."""
        return self._ids.copy()

    def index_of(self, track_id: int) -> int:
        """Row of ``track_id``; ValueError if unknown."""
        rows = np.flatnonzero(self._ids == track_id)
        if rows.size == 0:
            raise ValueError(f"track_id: no track with id {track_id}")
        return int(rows[0])

    def add_track(self, z, t_s: float, track_id: int | None = None, measurement_variance: float | None = None) -> int:
        """Start a track from its first position measurement z (2,) [m] at time t_s [s].

        Returns its id (``track_id`` if given, else the next free integer). ValueError if z or
        t_s is not finite or the id is taken. ``measurement_variance``: σ² of z [m²] (default
        the config's ``measurement_variance_m2``).
        """
        z = np.asarray(z, dtype=float).reshape(-1)
        if z.shape != (2,) or not np.all(np.isfinite(z)):
            raise ValueError(f"z: need a finite [x, y] position in metres, got {z!r}")
        if not np.isfinite(t_s):
            raise ValueError(f"t_s: must be finite, got {t_s!r}")
        if track_id is None:
            track_id = self._next_id
        elif np.any(self._ids == track_id):
            raise ValueError(f"track_id: {track_id} is already in the bank")
        track_id = int(track_id)
        self._next_id = max(self._next_id, track_id + 1)
        r = self._r
        grow = {
            "_ids": np.array([track_id]),
            "_s": np.zeros((1, r, 4)),
            "_P": np.zeros((1, r, 4, 4)),
            "_mu": self._mu0[None].copy(),
            "_t": np.array([float(t_s)]),
            "_x": np.zeros((1, 4)),
            "_Pc": np.zeros((1, 4, 4)),
            "_warm": np.ones(1, dtype=bool),
            "_cv_x": np.zeros((1, 4)),
            "_cv_P": np.zeros((1, 4, 4)),
            "_n_meas": np.zeros(1, dtype=np.int64),
            "_n_gated": np.zeros(1, dtype=np.int64),
            "_reasons": np.zeros(1, dtype=np.int8),
        }
        n_before = self._ids.size
        for name in self._PER_TRACK:
            setattr(self, name, np.concatenate([getattr(self, name), grow[name]]))
        tc = self._t_common
        self._t_common = float(t_s) if n_before == 0 or tc == float(t_s) else None
        row = np.array([self._ids.size - 1])
        self._start(row, z[None, :], None if measurement_variance is None else np.array([float(measurement_variance)]))
        return track_id

    def _start(self, rows, z, meas_var=None):
        """(Re)start tracks ``rows`` from measurements z (k, 2): CV filter at z, v = 0 ± σ_v0;
        meas_var (k,) per-row σ² of z, or None for the config's."""
        self._warm[rows] = True
        self._cv_x[rows] = 0.0
        self._cv_x[rows, :2] = z
        sv2 = self.config.initial_speed_std_m_s**2
        self._cv_P[rows] = np.diag([self._R, self._R, sv2, sv2])
        if meas_var is not None:
            self._cv_P[rows, 0, 0] = self._cv_P[rows, 1, 1] = meas_var
        self._n_meas[rows] = 1
        self._n_gated[rows] = 0
        self._handover(rows)
        self._n_warm = int(np.count_nonzero(self._warm))

    def _handover(self, rows):
        """Refresh the estimate of start-up tracks ``rows``; move those ready into the IMM."""
        s, P = _cv_to_polar(self._cv_x[rows], self._cv_P[rows])
        self._x[rows] = s
        self._Pc[rows] = P
        v2 = s[:, 3] ** 2
        Pv = self._cv_P[rows][:, 2:, 2:]
        half_tr = 0.5 * (Pv[:, 0, 0] + Pv[:, 1, 1])
        lam_max = half_tr + np.sqrt(
            (0.5 * (Pv[:, 0, 0] - Pv[:, 1, 1])) ** 2 + Pv[:, 0, 1] ** 2
        )
        ready = (v2 >= self._snr2 * lam_max) | (self._n_meas[rows] >= self.config.init_max_updates)
        if ready.any():
            done = rows[ready]
            self._s[done] = s[ready][:, None, :]
            self._P[done] = P[ready][:, None, :, :]
            self._mu[done] = self._mu0
            self._warm[done] = False
            self._n_warm = int(np.count_nonzero(self._warm))

    def add_process_noise(self, rows, heading_var_rad2=0.0, speed_var_m2_s2=0.0) -> None:
        """Manoeuvre handling: add ``heading_var_rad2`` to P_θθ and ``speed_var_m2_s2`` to P_VV of
        every model of the tracks in ``rows`` (bool (n,) or indices), as an extra process-noise
        input ΔQ = diag(0, 0, Δθ², ΔV²) at this cycle (Bar-Shalom, Li & Kirubarajan 2001, §11.2:
        adjustable-level process noise, switched on by a manoeuvre detector; see
        :mod:`mjasc.perception.tracking`). Scalars or one value per selected row. A track in the start-up
        constant-velocity filter gets ``speed_var_m2_s2`` on both velocity components. Tracks not
        selected, and the equations of the cycle, are unchanged."""
        idx = np.arange(self._ids.size)[rows]
        if idx.size == 0:
            return
        dth = np.broadcast_to(np.asarray(heading_var_rad2, dtype=float), idx.shape)
        dv = np.broadcast_to(np.asarray(speed_var_m2_s2, dtype=float), idx.shape)
        if not (np.all(np.isfinite(dth)) and np.all(dth >= 0) and np.all(np.isfinite(dv)) and np.all(dv >= 0)):
            raise ValueError("add_process_noise: heading_var_rad2 and speed_var_m2_s2 must be finite and ≥ 0")
        warm = self._warm[idx]
        full = idx[~warm]
        if full.size:
            self._P[full, :, 2, 2] += dth[~warm, None]
            self._P[full, :, 3, 3] += dv[~warm, None]
            self._Pc_stale = True
        w = idx[warm]
        if w.size:
            self._cv_P[w, 2, 2] += dv[warm]
            self._cv_P[w, 3, 3] += dv[warm]
            self._Pc[w] = _cv_to_polar(self._cv_x[w], self._cv_P[w])[1]

    def remove_track(self, track_id: int) -> None:
        """Drop a track (ValueError if unknown)."""
        keep = np.ones(self._ids.size, dtype=bool)
        keep[self.index_of(track_id)] = False
        for name in self._PER_TRACK:
            setattr(self, name, getattr(self, name)[keep])
        self._n_warm = int(np.count_nonzero(self._warm))
        if self._ids.size == 0:
            self._t_common = None

    # ------------------------------------------------------------------ time handling
    def _times(self, t_s):
        """Time step of a cycle to t_s (scalar or (n,) absolute times [s]).

        Returns (t0, t, dt, dtm, step): t0 the float time when it is one for all tracks (else
        None); t (n,) and dt (n,) the new times and steps, or None when t0 is given and every
        track's last cycle was at the same time (then dtm = that common step; the caller builds
        the arrays only if it needs them); dtm the step as a float when all tracks share it, else
        an (n, 1, 1, 1) array; step the matching (p(Ts), p(Ts)ᵀ, Ts ω_j, Q block).
        """
        t_last = self._t
        if type(t_s) is float or np.ndim(t_s) == 0:
            t0 = float(t_s)
            if not math.isfinite(t0):
                raise ValueError(f"t_s: must be finite, got {t_s!r}")
            tc = self._t_common
            if tc is not None:
                d = t0 - tc
                if d < 0.0:
                    raise ValueError(f"t_s: earlier than the last cycle of track(s) {self._ids.tolist()}")
                return t0, None, None, d, self._step(d)
            t = np.full(t_last.shape, t0)
        else:
            t0 = None
            t = np.asarray(t_s, dtype=float)
            if t.shape != t_last.shape:
                raise ValueError(
                    f"t_s: need a scalar or one time per track {t_last.shape}, got shape {t.shape}"
                )
            if not np.all(np.isfinite(t)):
                raise ValueError("t_s: times must be finite")
        dt = t - t_last
        lo, hi = dt.min(), dt.max()
        if lo < 0.0:
            bad = self._ids[dt < 0]
            raise ValueError(f"t_s: earlier than the last cycle of track(s) {bad.tolist()}")
        if lo == hi:
            d = float(lo)
            return t0, t, dt, d, self._step(d)
        markov = self._markov.per_track(dt)
        col = dt[:, None, None, None]
        return t0, t, dt, col, (markov, markov.mT, dt[:, None] * self._omega, col * self._q_unit)

    def _step(self, dt: float) -> tuple:
        """(p(Ts), p(Ts)ᵀ, Ts ω_j, diag(Q_θ, Q_V)·Ts) for one Ts, cached."""
        step = self._steps.get(dt)
        if step is None:
            markov = self._markov.scalar(dt)
            step = (markov, np.ascontiguousarray(markov.T), dt * self._omega, self._q_unit * dt)
            if len(self._steps) > 256:
                self._steps.clear()
            self._steps[dt] = step
        return step

    def _cycle_buffers(self) -> _IMMCycle:
        cyc = self._cyc
        if cyc is None or cyc.lead[0] != self._ids.size:
            cyc = self._cyc = _IMMCycle((self._ids.size,), self._r)
        return cyc

    def _mix_predict(self, dtm, step):
        """Mixed and predicted (s, P, c̄) of every track: views of work buffers, valid until the
        next cycle (copy what is kept)."""
        markov, markov_t, dt_omega, q_block = step
        return self._cycle_buffers().mix_predict(
            self._s, self._P, self._mu, markov, markov_t, dtm, dt_omega, q_block
        )

    def _covariances(self) -> np.ndarray:
        """(n, 4, 4) combined covariances, computed on first read after a cycle."""
        if self._Pc_stale:
            Pc = _combine_covariance(self._s, self._P, self._mu)
            full = ~self._warm
            self._Pc[full] = Pc[full]
            self._Pc_stale = False
        return self._Pc

    # ------------------------------------------------------------------ public cycle
    def predict(self, t_s) -> None:
        """Coast every track to time t_s (scalar or (n,) absolute times [s]): an IMM cycle
        without measurement (μ_j ← c̄_j); start-up tracks run their CV prediction."""
        if self._ids.size == 0:
            return
        t0, t, dt, dtm, step = self._times(t_s)
        warm = self._warm
        sp, Pp, cbar = self._mix_predict(dtm, step)
        x = _combine_state(sp, cbar)
        self._Pc_stale = True
        if self._n_warm:
            if t is None:
                dt = np.full(self._ids.size, dtm)
            keep = ~warm
            self._s[keep], self._P[keep], self._mu[keep] = sp[keep], Pp[keep], cbar[keep]
            self._x[keep] = x[keep]
            rows = np.flatnonzero(warm)
            self._cv_x[rows], self._cv_P[rows] = _cv_predict(
                self._cv_x[rows], self._cv_P[rows], dt[rows], self.config.init_acceleration_noise_m2_s3
            )
            s, P = _cv_to_polar(self._cv_x[rows], self._cv_P[rows])
            self._x[rows], self._Pc[rows] = s, P
        else:
            self._s, self._P, self._mu, self._x = sp.copy(), Pp.copy(), cbar.copy(), x
        self._set_times(t0, t)

    def _set_times(self, t0, t):
        """Record the time of the cycle just run (see ``_times``)."""
        if t is None:
            self._t.fill(t0)
        else:
            self._t = t
        self._t_common = t0

    def _predictive_models(self, t_s):
        """Per-track, per-model predicted measurement (n, k, 2), inverse det and S⁻¹ (n, k, 2, 2),
        and weights (n, k): the IMM's models with c̄_j, or the start-up filter (k = 1 padded)."""
        _, _, dt, dtm, step = self._times(self._t if t_s is None else t_s)
        sp, Pp, cbar = self._mix_predict(dtm, step)
        zj = sp[..., :2].copy()
        S = Pp[..., :2, :2] + self._R_cov
        w = cbar.copy()
        if self._n_warm:
            rows = np.flatnonzero(self._warm)
            xc, Pcv = _cv_predict(
                self._cv_x[rows], self._cv_P[rows], dt[rows], self.config.init_acceleration_noise_m2_s3
            )
            zj[rows] = xc[:, None, :2]
            S[rows] = Pcv[:, None, :2, :2] + self._R_cov
            w[rows] = 1.0 / self._r
        return zj, S, w

    def predicted_measurements(self, t_s=None) -> tuple[np.ndarray, np.ndarray]:
        """Moment-matched predicted measurement ẑ (n, 2) [m] and its covariance S (n, 2, 2) [m²]
        of every track at t_s (default: each track's current time), without changing the bank:
        ``ẑ = Σ c̄_j ẑ_j``, ``S = Σ c̄_j [S_j + (ẑ_j − ẑ)(ẑ_j − ẑ)ᵀ]``."""
        if self._ids.size == 0:
            return np.zeros((0, 2)), np.zeros((0, 2, 2))
        zj, S, w = self._predictive_models(t_s)
        zhat = (w[:, None, :] @ zj)[:, 0, :]
        d = zj - zhat[:, None, :]
        Sm = np.einsum("nk,nkab->nab", w, S) + np.swapaxes(d, 1, 2) @ (w[..., None] * d)
        return zhat, Sm

    def mahalanobis_squared(self, detections, t_s=None) -> np.ndarray:
        """(n_tracks, m) squared Mahalanobis distance of detections (m, 2) [m] to each track at
        t_s (default: current times): the smallest over the track's models of rᵀS_j⁻¹r — the
        quantity ``update`` gates on. Non-finite detections give inf."""
        zs = np.asarray(detections, dtype=float).reshape(-1, 2)
        if self._ids.size == 0:
            return np.zeros((0, zs.shape[0]))
        zj, S, _ = self._predictive_models(t_s)
        y = zs[None, None, :, :] - zj[:, :, None, :]  # (n, k, m, 2)
        a, b, d = S[..., 0, 0, None], S[..., 0, 1, None], S[..., 1, 1, None]
        y0, y1 = y[..., 0], y[..., 1]
        d2 = (d * y0 * y0 - 2.0 * b * y0 * y1 + a * y1 * y1) / (a * d - b * b)
        d2 = d2.min(axis=1)
        return np.where(np.isfinite(d2), d2, np.inf)

    def log_likelihoods(self, detections, t_s=None) -> np.ndarray:
        """(n_tracks, m) log of the IMM predictive density Σ_j c̄_j N(z; ẑ_j, S_j) of each
        detection (m, 2) — an association score; −inf for non-finite detections."""
        zs = np.asarray(detections, dtype=float).reshape(-1, 2)
        if self._ids.size == 0:
            return np.zeros((0, zs.shape[0]))
        zj, S, w = self._predictive_models(t_s)
        y = zs[None, None, :, :] - zj[:, :, None, :]
        a, b, d = S[..., 0, 0, None], S[..., 0, 1, None], S[..., 1, 1, None]
        det = a * d - b * b
        y0, y1 = y[..., 0], y[..., 1]
        d2 = (d * y0 * y0 - 2.0 * b * y0 * y1 + a * y1 * y1) / det
        with np.errstate(divide="ignore", invalid="ignore"):
            logp = np.log(w)[..., None] - 0.5 * (d2 + np.log(det)) - math.log(_TWO_PI)
            top = logp.max(axis=1)
            out = top + np.log(np.exp(logp - top[:, None, :]).sum(axis=1))
        return np.where(np.isfinite(out), out, -np.inf)

    def gate(self, detections, t_s=None) -> np.ndarray:
        """(n_tracks, m) bool: the detection is inside the chi-square gate of the track."""
        return self.mahalanobis_squared(detections, t_s) <= self._gate

    def update(self, z, t_s, mask=None, measurement_variance=None) -> np.ndarray:
        """One IMM cycle for every track at time t_s (scalar or (n,) [s]).

        z: (n, 2) measured positions [m], one row per track (row order of ``track_ids``).
        mask: (n,) bool, True where the row carries a measurement (default: all rows). Rows that
        are unmeasured, not finite or outside the gate are not used: the track coasts to t_s.
        Returns (n,) bool, True where the row was used (updated, or restarted from it after
        ``restart_after_gated`` gated rows in a row); ``rejection_reasons`` says why not.
        measurement_variance: optional (n,) σ² per row [m²] (R = σ² I₂ for that row's
        measurement, e.g. from the detection that produced it); default the config's.
        """
        n = self._ids.size
        z = np.asarray(z, dtype=float)
        if z.shape != (n, 2):
            raise ValueError(f"z: need shape ({n}, 2) (one [x, y] per track), got {z.shape}")
        if n == 0:
            return np.zeros(0, dtype=bool)
        if measurement_variance is not None:
            mv = np.asarray(measurement_variance, dtype=float)
            if mv.shape != (n,):
                raise ValueError(f"measurement_variance: need shape ({n},), got {mv.shape}")
            mv = np.where(np.isfinite(mv) & (mv > 0), mv, self._R)  # unusable rows: config's σ²
            self._mv = mv
        else:
            self._mv = None
        finite = np.isfinite(z).all(axis=1)
        if mask is None:
            measured = np.ones(n, dtype=bool)
        else:
            measured = np.asarray(mask, dtype=bool)
            if measured.shape != (n,):
                raise ValueError(f"mask: need shape ({n},), got {measured.shape}")
        use = measured & finite
        try:
            if use.all():
                ok = self._cycle(z, t_s)
                return np.ones(n, dtype=bool) if ok is None else ok
            return self._cycle(np.where(use[:, None], z, 0.0), t_s, use, finite, measured, z)
        finally:
            self._mv = None

    def _cycle(self, zs, t_s, use=None, finite=None, measured=None, z=None):
        """The IMM cycle behind ``update``; ``use`` None means every row is a finite measurement.
        Returns the (n,) bool array of used rows, or None when every row was used."""
        n = self._ids.size
        t0, t, dt, dtm, step = self._times(t_s)
        cyc = self._cyc
        if cyc is None or cyc.lead[0] != n:
            cyc = self._cycle_buffers()
        sp, Pp, cbar = cyc.mix_predict(self._s, self._P, self._mu, step[0], step[1], dtm, step[2], step[3])
        mv = self._mv
        maha, det = cyc.update.innovate(zs[:, None, :], self._R_cov if mv is None else mv[:, None, None, None] * _EYE2)
        su, Pu, mu = cyc.sides[1] if self._s is cyc.sides[0][0] else cyc.sides[0]  # not the inputs
        cyc.update.correct(su, Pu)
        if np.minimum.reduce(su[..., 3], axis=None) < 0.0:
            _flip_negative_speeds(su, Pu, sp[..., 2])
        cyc.mode_probabilities(maha, det, self._floor, mu)
        maha_min = cyc.mahalanobis_min_rows

        if (
            use is None
            and not self._n_warm
            and (maha_min.item() if n == 1 else np.maximum.reduce(maha_min)) <= self._gate
        ):  # the common case: every track measured and accepted
            self._s, self._P, self._mu = su, Pu, mu
            self._x = cyc.combine_state(su, mu)
            self._Pc_stale = True
            if self._flagged:  # some track has consecutive gated rows or a rejection reason
                self._n_gated.fill(0)
                self._reasons.fill(0)
                self._flagged = False
            if t is None:
                self._t.fill(t0)
            else:
                self._t = t
            self._t_common = t0
            return None

        # general case: mix of updated, coasting, start-up and restarted tracks
        if t is None:
            t, dt = np.full(n, t0), np.full(n, dtm)
        all_measured = use is None or bool(measured.all())
        if use is None:
            use = finite = measured = np.ones(n, dtype=bool)
        if z is None:
            z = zs
        inside = maha_min <= self._gate
        warm = self._warm
        any_warm = self._n_warm > 0
        ok = use & inside
        if any_warm:
            rows = np.flatnonzero(warm)
            xc, Pcv = _cv_predict(
                self._cv_x[rows], self._cv_P[rows], dt[rows], self.config.init_acceleration_noise_m2_s3
            )
            cv_update = _PositionUpdate(xc)
            np.copyto(cv_update.P, Pcv)
            d2, _ = cv_update.innovate(zs[rows], self._R_cov if mv is None else mv[rows, None, None] * _EYE2)
            xu, Pcu = np.empty_like(xc), np.empty_like(Pcv)
            cv_update.correct(xu, Pcu)
            ok_w = use[rows] & (d2 <= self._gate)
            ok[rows] = ok_w
            inside[rows] = ok_w | ~use[rows]
            self._cv_x[rows] = np.where(ok_w[:, None], xu, xc)
            self._cv_P[rows] = np.where(ok_w[:, None, None], Pcu, Pcv)
            self._n_meas[rows] += ok_w
        full = ~warm
        upd = ok & full
        s_new = np.where(upd[:, None, None], su, sp)
        P_new = np.where(upd[:, None, None, None], Pu, Pp)
        mu_new = np.where(upd[:, None], mu, cbar)
        self._s[full], self._P[full], self._mu[full] = s_new[full], P_new[full], mu_new[full]
        self._x[full] = _combine_state(s_new, mu_new)[full]
        self._Pc_stale = True

        reasons = np.zeros(n, dtype=np.int8)
        reasons[~finite] = _NON_FINITE
        gated = use & ~inside
        reasons[gated] = _GATED
        if not all_measured:
            reasons[~measured] = _NOT_MEASURED
        self._n_gated = np.where(gated, self._n_gated + 1, np.where(ok, 0, self._n_gated))
        limit = self.config.restart_after_gated
        restart = gated & (self._n_gated >= limit) if limit > 0 else np.zeros(n, dtype=bool)
        self._set_times(t0, t)
        if any_warm:
            self._handover(np.flatnonzero(self._warm))
        if restart.any():
            rows = np.flatnonzero(restart)
            self._start(rows, zs[rows], None if mv is None else mv[rows])
            reasons[rows] = _RESTARTED
            for k in rows:
                logger.info(
                    "IMM track %d restarted at t=%.3f s from z=%s after %d gated measurements",
                    self._ids[k], t[k], z[k], limit,
                )
        self._reasons = reasons
        self._flagged = True
        if logger.isEnabledFor(logging.DEBUG):
            for k in np.flatnonzero(measured & ~finite):
                logger.debug(
                    "IMM track %d at t=%.3f s: rejected z=%s (%s)",
                    self._ids[k], t[k], z[k], REJECTION_REASONS[_NON_FINITE],
                )
            for k in np.flatnonzero(gated & ~restart):
                logger.debug(
                    "IMM track %d at t=%.3f s: rejected z=%s (%s; min d²=%.4g > gate %.4g)",
                    self._ids[k], t[k], z[k], REJECTION_REASONS[_GATED], maha[k].min(), self._gate,
                )
        return ok | restart

    # ------------------------------------------------------------------ read-only views
    @property
    def rejection_reasons(self) -> list[str]:
        """Per track, why the last ``update`` did not use its row ('' if it did)."""
        return [REJECTION_REASONS[c] for c in self._reasons]

    @property
    def rejection_codes(self) -> np.ndarray:
        """(n,) int8 index into ``REJECTION_REASONS`` for the last ``update``."""
        return self._reasons.copy()

    @property
    def consecutive_gated(self) -> np.ndarray:
        """(n,) number of consecutive gated measurements per track (for track deletion)."""
        return self._n_gated.copy()

    @property
    def times_s(self) -> np.ndarray:
        """(n,) time of each track's last cycle [s]."""
        return self._t.copy()

    @property
    def velocity_initialized(self) -> np.ndarray:
        """(n,) bool: the track runs in the IMM (False while in the start-up CV filter)."""
        return ~self._warm

    @property
    def states(self) -> np.ndarray:
        """(n, 4) combined [x, y, θ, V] per track (θ in (−π, π])."""
        x = self._x.copy()
        x[:, 2] = _wrap(x[:, 2])
        return x

    @property
    def positions(self) -> np.ndarray:
        """(n, 2) combined position [m]."""
        return self._x[:, :2].copy()

    @property
    def headings(self) -> np.ndarray:
        """(n,) combined course θ [rad], in (−π, π]."""
        return _wrap(self._x[:, 2])

    @property
    def speeds(self) -> np.ndarray:
        """(n,) combined speed V ≥ 0 [m/s]."""
        return self._x[:, 3].copy()

    @property
    def turn_rates(self) -> np.ndarray:
        """(n,) ω̂ = Σ_j μ_j ω_j [rad/s] (0 for start-up tracks)."""
        return np.where(self._warm, 0.0, self._mu @ self._omega)

    @property
    def mode_probabilities(self) -> np.ndarray:
        """(n, r) μ_j per track."""
        return self._mu.copy()

    @property
    def state_covariances(self) -> np.ndarray:
        """(n, 4, 4) combined covariance over x, y, θ, V."""
        return self._covariances().copy()

    @property
    def position_covariances(self) -> np.ndarray:
        """(n, 2, 2) combined covariance of the position [m²]."""
        return self._covariances()[:, :2, :2].copy()

    @property
    def model_states(self) -> np.ndarray:
        """(n, r, 4) per-model states, θ wrapped (diagnostics)."""
        s = self._s.copy()
        s[..., 2] = _wrap(s[..., 2])
        return s

    @property
    def model_covariances(self) -> np.ndarray:
        """(n, r, 4, 4) per-model covariances (diagnostics)."""
        return self._P.copy()

    def estimate(self, track_id: int, radius_m: float = 0.0, **fields) -> TrackEstimate:
        """The :class:`TrackEstimate` of one track; further fields (is_static, team_member,
        outline_m) are passed through."""
        k = self.index_of(track_id)
        x = self._x[k]
        return TrackEstimate(
            track_id=int(track_id),
            time_s=float(self._t[k]),
            position_m=x[:2].copy(),
            heading_rad=float(_wrap(x[2])),
            speed_m_s=float(x[3]),
            turn_rate_rad_s=0.0 if self._warm[k] else float(self._mu[k] @ self._omega),
            radius_m=float(radius_m),
            position_covariance=self._covariances()[k, :2, :2].copy(),
            **fields,
        )

    def estimates(self, radius_m: float | Mapping[int, float] = 0.0) -> list[TrackEstimate]:
        """TrackEstimate of every track; radius_m a scalar or a {track_id: radius} mapping."""
        out = []
        for tid in self._ids.tolist():
            rad = radius_m.get(tid, 0.0) if isinstance(radius_m, Mapping) else radius_m
            out.append(self.estimate(tid, rad))
        return out


class IMMTracker:
    """IMM tracker of one target (thesis §3.2.1): a one-track :class:`IMMBank` behind a scalar API.

    ``update(z, t)`` feeds a position measurement z = [x, y] [m] taken at time t [s] (the first
    call initializes) and returns whether it was used; a rejected measurement (not finite, outside
    the gate) is logged at debug level, explained by ``last_rejection_reason``, and the tracker
    coasts to t. ``predict(t)`` coasts without a measurement.
    """

    def __init__(self, config: IMMConfig = IMMConfig()):
        self._bank = IMMBank(config)
        self._z = np.empty((1, 2))
        self._reason = ""

    @property
    def config(self) -> IMMConfig:
        return self._bank.config

    @property
    def bank(self) -> IMMBank:
        """The underlying one-track bank (read it, don't modify it)."""
        return self._bank

    @property
    def initialized(self) -> bool:
        """True once a first finite measurement was taken."""
        return self._bank._ids.size == 1

    @property
    def velocity_initialized(self) -> bool:
        """True once the track runs in the IMM (course and speed determined)."""
        return self.initialized and not bool(self._bank._warm[0])

    @property
    def last_rejection_reason(self) -> str:
        """Why the last ``update`` rejected its measurement ('' if it was used)."""
        return self._reason

    def update(self, z, t: float) -> bool:
        """Process measurement z (2,) [m] taken at time t [s]; True if it was used.

        ValueError if t is not finite or earlier than the last cycle, or z is not two numbers
        (programming errors); a non-finite or implausible z is rejected, not raised.
        """
        if type(z) is np.ndarray and z.dtype == np.float64:
            if z.shape != (2,):
                raise ValueError(f"z: need [x, y] in metres, got {z!r}")
            zz = z[None]  # a view: the bank only reads it
        else:
            if np.shape(z) != (2,):
                raise ValueError(f"z: need [x, y] in metres, got {z!r}")
            zz = self._z
            zz[0] = z
        bank = self._bank
        if bank._ids.size == 0:
            if not math.isfinite(t):
                raise ValueError(f"t: must be finite, got {t!r}")
            if not np.isfinite(zz).all():
                self._reason = REJECTION_REASONS[_NON_FINITE]
                logger.debug("IMM tracker: rejected first measurement %s (%s)", z, self._reason)
                return False
            bank.add_track(zz[0], t, track_id=0)
            self._reason = ""
            return True
        if math.isfinite(zz[0, 0]) and math.isfinite(zz[0, 1]):
            ok = bank._cycle(zz, t)
            if ok is None:
                self._reason = ""
                return True
            used = bool(ok[0])
        else:
            used = bool(bank.update(zz, t)[0])
        self._reason = "" if used else REJECTION_REASONS[bank._reasons[0]]
        return used

    def predict(self, t: float) -> None:
        """Coast to time t [s] without a measurement (no-op before initialization)."""
        if self.initialized:
            self._bank.predict(t)

    def _row(self):
        if self._bank._ids.size == 0:
            raise ValueError("IMMTracker: no estimate before the first measurement (call update)")

    @property
    def time_s(self) -> float:
        """Time of the last cycle [s]."""
        self._row()
        return float(self._bank._t[0])

    @property
    def state(self) -> np.ndarray:
        """(4,) combined [x, y, θ, V]."""
        self._row()
        x = self._bank._x[0].copy()
        x[2] = _wrap(x[2])
        return x

    @property
    def position(self) -> np.ndarray:
        """(2,) world-frame position [m]."""
        self._row()
        return self._bank._x[0, :2].copy()

    @property
    def speed(self) -> float:
        """Speed over ground V ≥ 0 [m/s]."""
        self._row()
        return float(self._bank._x[0, 3])

    @property
    def heading(self) -> float:
        """Course over ground θ [rad], CCW from east, in (−π, π]."""
        self._row()
        return math.pi - (math.pi - float(self._bank._x[0, 2])) % _TWO_PI  # wrap, as _wrap

    @property
    def turn_rate(self) -> float:
        """ω̂ = Σ_j μ_j ω_j [rad/s] (0 before the IMM starts)."""
        self._row()
        return float(self._bank.turn_rates[0])

    @property
    def mode_probabilities(self) -> np.ndarray:
        """(r,) μ_j."""
        self._row()
        return self._bank._mu[0].copy()

    @property
    def position_covariance(self) -> np.ndarray:
        """(2, 2) position covariance [m²]."""
        self._row()
        return self._bank._covariances()[0, :2, :2].copy()

    @property
    def state_covariance(self) -> np.ndarray:
        """(4, 4) covariance over x, y, heading, speed."""
        self._row()
        return self._bank._covariances()[0].copy()

    def estimate(self, track_id: int = 0, radius_m: float = 0.0, **fields) -> TrackEstimate:
        """The current estimate as a :class:`TrackEstimate`."""
        self._row()
        return replace(self._bank.estimate(0, radius_m, **fields), track_id=int(track_id))


def filterpy_imm(config: IMMConfig, state, covariance, dt_s: float = 1.0, mode_probabilities=None):
    """The same model bank built with filterpy (reference for tests and benchmarks).

    An ``IMMEstimator`` of r ``KalmanFilter`` subclasses whose ``predict`` is the EKF prediction
    of thesis eq. 3.3 for a fixed Ts = ``dt_s``, all started at ``state`` (4,) / ``covariance``
    (4, 4), with the config's Markov matrix at ``dt_s``. filterpy mixes θ as a plain number and
    has no probability floor: compare where the courses span less than π and the floor does not
    bind (or floor the probabilities after its update yourself).
    """
    from filterpy.kalman import IMMEstimator, KalmanFilter

    class _TurnModelKF(KalmanFilter):
        def __init__(self, omega):
            super().__init__(dim_x=4, dim_z=2)
            self.omega = omega
            self.Q = np.diag([0.0, 0.0, config.heading_noise_rad2_s * dt_s, config.speed_noise_m2_s3 * dt_s])
            self.H = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]])
            self.R = config.measurement_variance_m2 * np.eye(2)

        def predict(self, u=None, B=None, F=None, Q=None):
            x, y, th, v = self.x[:, 0]
            c, s = math.cos(th), math.sin(th)
            self.F = np.array(
                [[1, 0, -dt_s * v * s, dt_s * c], [0, 1, dt_s * v * c, dt_s * s], [0, 0, 1, 0], [0, 0, 0, 1.0]]
            )
            self.x = np.array([[x + dt_s * v * c], [y + dt_s * v * s], [th + dt_s * self.omega], [v]])
            self.P = self.F @ self.P @ self.F.T + self.Q
            self.x_prior, self.P_prior = self.x.copy(), self.P.copy()

    filters = []
    for w in config.turn_rates_rad_s:
        f = _TurnModelKF(w)
        f.x = np.asarray(state, dtype=float).reshape(4, 1).copy()
        f.P = np.asarray(covariance, dtype=float).copy()
        filters.append(f)
    r = config.n_models
    mu = np.full(r, 1.0 / r) if mode_probabilities is None else np.asarray(mode_probabilities)
    return IMMEstimator(filters, mu, _MarkovPower(config).scalar(float(dt_s)))
