"""The start-up filter of a new IMM track: a linear constant-velocity Kalman filter on
[x, y, vx, vy] and its hand-over to the IMM's polar state [x, y, θ, V] (world ENU, SI).

An EKF in (θ, V) started with a course that is unknown diverges easily (the linearization in θ is
poor when σ_θ ~ 1 rad). So a new track first runs a linear constant-velocity Kalman filter on
[x, y, vx, vy] (position from the first measurement, velocity 0 ± ``initial_speed_std_m_s`` per
axis, white-acceleration noise ``init_acceleration_noise_m2_s3``), and hands over to the IMM —
θ = atan2(v), V = |v| with the first-order covariance — as soon as the speed is well determined
(|v̂| ≥ ``init_speed_snr``·σ_v, σ_v² the largest eigenvalue of the velocity covariance) or after
``init_max_updates`` measurements (a static target: θ then has the variance of a uniform angle,
π²/3, at most). With two measurements and a diffuse prior this is the classical two-point
differencing. The filter's measurement update is the IMM's own
(:func:`mjasc.perception.imm.compiled_cycle.position_update`). :class:`StartupFilters` holds the filters
of a bank's tracks (:class:`mjasc.perception.imm.bank.IMMBank`), one row per bank row.
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.compiled import kernel, minimum
from mjasc.perception.imm.config import IMMConfig
from mjasc.perception.imm.compiled_cycle import position_update

__all__ = ["StartupFilters", "cv_predict", "cv_to_polar", "ready_for_handover"]

_UNIFORM_ANGLE_VAR = math.pi**2 / 3.0  # variance of an angle uniform on (−π, π]
_EYE4 = np.eye(4)[None]
_NO_VAR = np.zeros(0)


def cv_predict(xc, Pc, dt, q):
    """Constant-velocity prediction with white acceleration of intensity q; dt (k,). The
    transition matrices and the noise added are compiled loops (:func:`_cv_transitions`,
    :func:`_add_cv_noise`, which forms ``q·dt³/3``, ``q·dt²/2`` and ``q·dt`` itself: dt² is numpy's
    ``dt**2``, a square, ``dt·dt``); the products and dt³ (numpy's ``pow``) stay numpy's
    (tests/test_imm_row_store.py keeps the all-numpy form as the reference, bit for bit)."""
    F = _cv_transitions(dt)
    xp = (F @ xc[..., None])[..., 0]
    Pp = F @ Pc @ np.swapaxes(F, 1, 2)
    _add_cv_noise(Pp, dt**3, dt, float(q))
    return xp, Pp


@kernel
def _cv_transitions(dt):
    """(k, 4, 4) constant-velocity transitions: the identity with dt in (0, 2) and (1, 3)."""
    k = dt.shape[0]
    F = np.zeros((k, 4, 4))
    for i in range(k):
        for a in range(4):
            F[i, a, a] = 1.0
        F[i, 0, 2] = dt[i]
        F[i, 1, 3] = dt[i]
    return F


@kernel
def _add_cv_noise(P, dt3, dt, q):
    """The white-acceleration noise of intensity q added to P (k, 4, 4) in place: q3 = q·dt³/3 (dt3 (k,)
    the cubes) to (0, 0), (1, 1); q2 = q·(dt·dt)/2 to (0, 2), (2, 0), (1, 3), (3, 1); q1 = q·dt to
    (2, 2), (3, 3)."""
    for i in range(P.shape[0]):
        d = dt[i]
        q3 = q * dt3[i] / 3.0
        q2 = q * (d * d) / 2.0
        q1 = q * d
        P[i, 0, 0] += q3
        P[i, 1, 1] += q3
        P[i, 0, 2] += q2
        P[i, 2, 0] += q2
        P[i, 1, 3] += q2
        P[i, 3, 1] += q2
        P[i, 2, 2] += q1
        P[i, 3, 3] += q1


def cv_to_polar(xc, Pc):
    """[x, y, vx, vy] (k, 4) and covariance → [x, y, θ, V] and its first-order covariance.

    θ = atan2(vy, vx), V = |v|; Jacobian rows ∂θ/∂v = u⊥/V, ∂V/∂v = u (u = v/V, u⊥ = (−u_y, u_x)).
    If σ_θ² exceeds π²/3 (the variance of a uniform angle), the θ row and column are scaled down
    to it (a congruence: P stays positive semi-definite). At V = 0, u = (1, 0).

    The Jacobians and the scaling are compiled loops (:func:`_polar_jacobians`,
    :func:`_polar_finish`); |v|, atan2 and the products J P Jᵀ stay numpy's (tests/test_imm_startup.py
    keeps the all-numpy form as the reference, bit for bit).
    """
    vx, vy = xc[:, 2], xc[:, 3]
    speed = np.hypot(vx, vy)
    J = _polar_jacobians(xc, speed)
    return _polar_finish(xc, speed, np.arctan2(vy, vx), J @ Pc @ np.swapaxes(J, 1, 2))


@kernel
def _polar_jacobians(xc, speed):
    """(k, 4, 4) Jacobians of (x, y, vx, vy) → (x, y, θ, V) at xc (k, 4) with |v| = speed (k,)
    (u = (1, 0) and 1/V = 1e150 where V is not > 0)."""
    k = xc.shape[0]
    J = np.zeros((k, 4, 4))
    for i in range(k):
        v = speed[i]
        if v > 0.0:
            ux, uy, inv_v = xc[i, 2] / v, xc[i, 3] / v, 1.0 / v
        else:
            ux, uy, inv_v = 1.0, 0.0, 1e150
        J[i, 0, 0] = 1.0
        J[i, 1, 1] = 1.0
        J[i, 2, 2] = -uy * inv_v
        J[i, 2, 3] = ux * inv_v
        J[i, 3, 2] = ux
        J[i, 3, 3] = uy
    return J


@kernel
def _polar_finish(xc, speed, theta, P):
    """s = [x, y, θ, V] (k, 4) and the covariance P (k, 4, 4) (changed in place) with its θ row and
    column scaled to σ_θ² ≤ π²/3, symmetrized as ½ (P + Pᵀ) into a new array."""
    k = xc.shape[0]
    s = np.empty((k, 4))
    out = np.empty((k, 4, 4))
    for i in range(k):
        sc = math.sqrt(minimum(1.0, _UNIFORM_ANGLE_VAR / P[i, 2, 2]))
        for a in range(4):
            P[i, 2, a] *= sc
        for a in range(4):
            P[i, a, 2] *= sc
        for a in range(4):
            for b in range(4):
                out[i, a, b] = 0.5 * (P[i, a, b] + P[i, b, a])
        s[i, 0] = xc[i, 0]
        s[i, 1] = xc[i, 1]
        s[i, 2] = theta[i]
        s[i, 3] = speed[i]
    return s, out


def ready_for_handover(s, cv_P, n_meas, snr2: float, max_updates: int) -> np.ndarray:
    """(k,) bool: start-up tracks ready for the IMM — speed determined, ``V² ≥ snr2·λ_max`` with
    λ_max the largest eigenvalue of the velocity covariance (``snr2 = init_speed_snr²``), or
    ``n_meas ≥ max_updates``. s (k, 4) the polar state (:func:`cv_to_polar`), cv_P (k, 4, 4).
    (Compiled, :func:`_ready`; tests/test_imm_row_store.py keeps the numpy form.)"""
    out = np.empty(s.shape[0], dtype=bool)
    _ready(s, cv_P, n_meas, float(snr2), int(max_updates), out)
    return out


@kernel
def _ready(s, cv_P, n_meas, snr2, max_updates, out):
    """:func:`ready_for_handover` per row into out (k,): ``V·V ≥ snr2·λ_max`` or enough updates,
    λ_max = ½(P_vx + P_vy) + √((½(P_vx − P_vy))² + P_vxvy²)."""
    for k in range(s.shape[0]):
        a, b, c = cv_P[k, 2, 2], cv_P[k, 3, 3], cv_P[k, 2, 3]
        half_tr = 0.5 * (a + b)
        d = 0.5 * (a - b)
        lam_max = half_tr + math.sqrt(d * d + c * c)
        v = s[k, 3]
        out[k] = (v * v >= snr2 * lam_max) or (n_meas[k] >= max_updates)


class StartupFilters:
    """The start-up filters of a bank's tracks, one row per bank row (the bank keeps the rows
    aligned: :meth:`append`, :meth:`keep`). ``active`` (n,) bool: the row is in its start-up filter
    (else in the IMM; its values here are stale); ``x`` (n, 4) [x, y, vx, vy] [m, m/s] and ``P``
    (n, 4, 4) the filter's estimate; ``n_meas`` (n,) measurements taken; ``n_active`` the number of
    active rows."""

    def __init__(self, config: IMMConfig):
        self.acceleration_noise = config.init_acceleration_noise_m2_s3
        self.speed_var0 = config.initial_speed_std_m_s**2
        self.snr2 = config.init_speed_snr**2
        self.max_updates = config.init_max_updates
        self.active = np.zeros(0, dtype=bool)
        self.x = np.zeros((0, 4))
        self.P = np.zeros((0, 4, 4))
        self.n_meas = np.zeros(0, dtype=np.int64)
        self.n_active = 0

    def append(self, k: int = 1) -> None:
        """k more rows (active; :meth:`start` fills them)."""
        self.active = np.concatenate([self.active, np.ones(k, dtype=bool)])
        self.x = np.concatenate([self.x, np.zeros((k, 4))])
        self.P = np.concatenate([self.P, np.zeros((k, 4, 4))])
        self.n_meas = np.concatenate([self.n_meas, np.zeros(k, dtype=np.int64)])

    def append_started(self, z, measurement_variance: float, meas_var=None) -> tuple[np.ndarray, np.ndarray]:
        """k more rows, :meth:`start`-ed from z (k, 2) at once (what :meth:`append` then
        :meth:`start` make of them); returns their x (k, 4) and P (k, 4, 4)."""
        k = z.shape[0]
        R = float(measurement_variance)
        per_row = meas_var is not None
        self.active, self.x, self.P, self.n_meas = _appended_started(
            self.active, self.x, self.P, self.n_meas, np.ascontiguousarray(z, dtype=float), R, float(self.speed_var0),
            np.ascontiguousarray(meas_var, dtype=float) if per_row else _NO_VAR, per_row)
        self.n_active += k
        n = self.x.shape[0] - k
        return self.x[n:], self.P[n:]

    def take(self, rows) -> "StartupFilters":
        """A copy holding only ``rows`` (for an update of some of a bank's tracks)."""
        sub = object.__new__(StartupFilters)
        sub.__dict__.update(self.__dict__)
        sub.active, sub.x, sub.P, sub.n_meas = self.active[rows], self.x[rows], self.P[rows], self.n_meas[rows]
        sub.n_active = int(np.count_nonzero(sub.active))
        return sub

    def put(self, rows, sub: "StartupFilters") -> None:
        """Write back the rows of a :meth:`take` copy."""
        self.active[rows], self.x[rows], self.P[rows], self.n_meas[rows] = sub.active, sub.x, sub.P, sub.n_meas
        self.n_active = int(np.count_nonzero(self.active))

    def keep(self, keep: np.ndarray) -> None:
        """Keep the rows where ``keep`` (n,) is True (one compiled pass, :func:`_kept_started`)."""
        if type(keep) is np.ndarray and keep.dtype == np.bool_ and keep.shape == self.active.shape:
            self.active, self.x, self.P, self.n_meas, self.n_active = _kept_started(keep, self.active, self.x, self.P,
                                                                                    self.n_meas)
            return
        self.active, self.x, self.P, self.n_meas = self.active[keep], self.x[keep], self.P[keep], self.n_meas[keep]
        self.n_active = int(np.count_nonzero(self.active))

    def start(self, rows, z, measurement_variance: float, meas_var=None) -> None:
        """(Re)start rows from measurements z (k, 2): position z, velocity 0 ± σ_v0 per axis;
        the position variance is ``measurement_variance`` [m²], or meas_var (k,) per row."""
        self.active[rows] = True
        self.x[rows] = 0.0
        self.x[rows, :2] = z
        sv2 = self.speed_var0
        R = measurement_variance
        self.P[rows] = np.diag([R, R, sv2, sv2])
        if meas_var is not None:
            self.P[rows, 0, 0] = self.P[rows, 1, 1] = meas_var
        self.n_meas[rows] = 1
        self.n_active = int(np.count_nonzero(self.active))

    def polar(self, rows) -> tuple[np.ndarray, np.ndarray]:
        """[x, y, θ, V] (k, 4) and covariance (k, 4, 4) of rows (:func:`cv_to_polar`)."""
        return cv_to_polar(self.x[rows], self.P[rows])

    def hand_over(self, rows, s, cv_P=None) -> np.ndarray:
        """(k,) bool: rows ready for the IMM (:func:`ready_for_handover`, s their polar states;
        cv_P their filters' covariances ``P[rows]`` when the caller has them), made inactive. The
        bank hands over with the compiled :func:`mjasc.perception.imm.startup_rows.handover_rows`;
        this is its readable form, the tests' reference."""
        ready = ready_for_handover(s, self.P[rows] if cv_P is None else cv_P, self.n_meas[rows], self.snr2,
                                   self.max_updates)
        if ready.any():
            self.active[rows[ready]] = False
            self.n_active = int(np.count_nonzero(self.active))
        return ready

    def predicted(self, rows, dt) -> tuple[np.ndarray, np.ndarray]:
        """Rows' estimate predicted by dt (k,) [s], without storing it."""
        return cv_predict(self.x[rows], self.P[rows], dt, self.acceleration_noise)

    def predict(self, rows, dt) -> None:
        """Predict rows by dt (k,) [s] (coasting)."""
        self.x[rows], self.P[rows] = self.predicted(rows, dt)

    def update(self, rows, dt, z, var, use, gate: float) -> np.ndarray:
        """Predict rows by dt (k,) [s], then update those where ``use`` (k,) with z (k, 2), of
        variance var ((1,) or (k,) [m²], R = σ² I₂), if inside the chi-square gate; returns (k,)
        bool of the rows updated (the others coast)."""
        return self.update_rows(rows, dt, z, var, use, gate)[0]

    def update_rows(self, rows, dt, z, var, use, gate: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`update`, returning also the rows' new x (k, 4) and P (k, 4, 4) (copies of
        ``x[rows]``, ``P[rows]``): (ok, x, P)."""
        xc, Pcv = self.predicted(rows, dt)
        d2 = np.empty(xc.shape[0])
        position_update(xc, Pcv, z, var, use, gate, d2)  # in place where used and inside the gate
        ok = use & (d2 <= gate)
        self.x[rows], self.P[rows] = xc, Pcv
        self.n_meas[rows] += ok
        return ok, xc, Pcv

    def add_speed_variance(self, rows, dv) -> None:
        """Add dv [m²/s²] (k,) to both velocity variances of rows (manoeuvre process noise)."""
        self.P[rows, 2, 2] += dv
        self.P[rows, 3, 3] += dv


@kernel
def _appended_started(active, x, P, n_meas, z, R, sv2, meas_var, per_row):
    """:meth:`StartupFilters.append_started`'s arrays, each a new array with k = len(z) rows appended
    (one compiled call instead of building the rows and four concatenations): active, one
    measurement, x = [z, 0, 0], P = diag(R, R, sv2, sv2) with meas_var[j] (if ``per_row``) in
    place of R."""
    n = active.size
    k = z.shape[0]
    m = n + k
    a2 = np.empty(m, dtype=np.bool_)
    x2 = np.zeros((m, 4))
    P2 = np.zeros((m, 4, 4))
    c2 = np.empty(m, dtype=np.int64)
    for i in range(n):
        a2[i] = active[i]
        c2[i] = n_meas[i]
        for a in range(4):
            x2[i, a] = x[i, a]
            for b in range(4):
                P2[i, a, b] = P[i, a, b]
    for j in range(k):
        i = n + j
        a2[i] = True
        c2[i] = 1
        x2[i, 0] = z[j, 0]
        x2[i, 1] = z[j, 1]
        r = meas_var[j] if per_row else R
        P2[i, 0, 0] = r
        P2[i, 1, 1] = r
        P2[i, 2, 2] = sv2
        P2[i, 3, 3] = sv2
    return a2, x2, P2, c2


@kernel
def _kept_started(keep, active, x, P, n_meas):
    """:meth:`StartupFilters.keep`'s arrays, each a new array of the rows where ``keep`` (n,) bool
    (``a[keep]``), and the number of active rows among them."""
    m = 0
    for k in range(keep.size):
        m += keep[k]
    a2 = np.empty(m, dtype=np.bool_)
    x2 = np.empty((m, 4))
    P2 = np.empty((m, 4, 4))
    c2 = np.empty(m, dtype=n_meas.dtype)
    c = 0
    n_active = 0
    for k in range(keep.size):
        if not keep[k]:
            continue
        a2[c] = active[k]
        n_active += active[k]
        c2[c] = n_meas[k]
        for a in range(4):
            x2[c, a] = x[k, a]
            for b in range(4):
                P2[c, a, b] = P[k, a, b]
        c += 1
    return a2, x2, P2, c2, n_active
