"""The reference IMM built with filterpy: the same model bank as :mod:`mjasc.perception.imm` from
filterpy's ``IMMEstimator`` and ``KalmanFilter`` (thesis eq. 3.3 EKF prediction at a fixed sample
time), for tests and benchmarks to compare against (tests/test_imm.py, benchmarks/bench_imm.py).

This is the only module of mjasc that imports filterpy: the IMM's hot modules (kernel, bank,
tracker) and tracking never load it. filterpy mixes θ as a plain number, has no probability floor,
no gate, no start-up filter and a fixed sample time: compare where the courses span less than π and
the floor does not bind (``min_mode_probability = 0``, ``gate_probability = 1``).

* :func:`filterpy_imm` — the filterpy ``IMMEstimator`` itself, started from a given state;
* :class:`FilterpyIMMTracker` — the same as a one-target tracker with the update / estimate
  interface of :class:`mjasc.perception.imm.tracker.IMMTracker` (its start-up filter is
  IMMTracker's; at hand-over the filterpy IMM takes over), so that it can stand in for it.
"""

from __future__ import annotations

import math

import numpy as np
from filterpy.kalman import IMMEstimator, KalmanFilter

from mjasc.core.estimates import TrackEstimate
from mjasc.perception.imm.config import IMMConfig
from mjasc.perception.imm.kernel import wrap
from mjasc.perception.imm.markov import MarkovPower
from mjasc.perception.imm.tracker import IMMTracker

__all__ = ["filterpy_imm", "FilterpyIMMTracker"]


def filterpy_imm(config: IMMConfig, state, covariance, dt_s: float = 1.0, mode_probabilities=None):
    """The same model bank built with filterpy (reference for tests and benchmarks).

    An ``IMMEstimator`` of r ``KalmanFilter`` subclasses whose ``predict`` is the EKF prediction
    of thesis eq. 3.3 for a fixed Ts = ``dt_s``, all started at ``state`` (4,) / ``covariance``
    (4, 4), with the config's Markov matrix at ``dt_s``. filterpy mixes θ as a plain number and
    has no probability floor: compare where the courses span less than π and the floor does not
    bind (or floor the probabilities after its update yourself).
    """
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
    return IMMEstimator(filters, mu, MarkovPower(config).scalar(float(dt_s)))


class FilterpyIMMTracker:
    """The filterpy reference IMM as a one-target tracker: ``update(z, t)`` → bool, ``estimate()``,
    and the read-outs of :class:`mjasc.perception.imm.tracker.IMMTracker` (``state``, ``position``,
    ``heading``, ``speed``, ``turn_rate``, ``mode_probabilities``, covariances, ``time_s``).

    Until the course and speed are determined the measurements go to an :class:`IMMTracker` (the
    start-up filter); then :func:`filterpy_imm` takes over from its state, covariance and mode
    probabilities, and every later measurement must come ``dt_s`` after the previous one and be
    finite (the reference has neither a variable sample time nor a gate: ValueError otherwise).
    With ``min_mode_probability = 0`` and ``gate_probability = 1`` its estimates are IMMTracker's to
    rounding (tests/test_imm.py).
    """

    def __init__(self, config: IMMConfig = IMMConfig(), dt_s: float = 1.0):
        self.config = config
        self.dt_s = float(dt_s)
        self._startup = IMMTracker(config)
        self._imm: IMMEstimator | None = None
        self._t = math.nan
        self._omega = np.asarray(config.turn_rates_rad_s, dtype=float)

    @property
    def initialized(self) -> bool:
        return self._startup.initialized

    @property
    def velocity_initialized(self) -> bool:
        return self._imm is not None

    @property
    def imm(self) -> IMMEstimator | None:
        """The filterpy ``IMMEstimator`` once it has taken over (None before)."""
        return self._imm

    def update(self, z, t: float) -> bool:
        """Process measurement z (2,) [m] taken at time t [s]; True if it was used."""
        if self._imm is None:
            used = self._startup.update(z, t)
            s = self._startup
            if s.velocity_initialized:
                self._imm = filterpy_imm(self.config, s.state, s.state_covariance, self.dt_s, s.mode_probabilities)
                self._t = s.time_s
            return used
        z = np.asarray(z, dtype=float).reshape(-1)
        if z.shape != (2,) or not np.all(np.isfinite(z)):
            raise ValueError(f"z: the filterpy reference takes finite [x, y] measurements only, got {z!r}")
        if not math.isclose(t - self._t, self.dt_s, rel_tol=1e-9, abs_tol=1e-12):
            raise ValueError(f"t: the filterpy reference runs at a fixed sample time {self.dt_s} s, got "
                             f"{t - self._t} s after the last cycle")
        self._imm.predict()
        self._imm.update(z)
        self._t = float(t)
        return True

    @property
    def time_s(self) -> float:
        return self._startup.time_s if self._imm is None else self._t

    @property
    def state(self) -> np.ndarray:
        """(4,) combined [x, y, θ, V], θ in (−π, π]."""
        if self._imm is None:
            return self._startup.state
        x = self._imm.x[:, 0].copy()
        x[2] = wrap(x[2])
        return x

    @property
    def state_covariance(self) -> np.ndarray:
        return self._startup.state_covariance if self._imm is None else self._imm.P.copy()

    @property
    def mode_probabilities(self) -> np.ndarray:
        return self._startup.mode_probabilities if self._imm is None else np.asarray(self._imm.mu, dtype=float).copy()

    @property
    def position(self) -> np.ndarray:
        return self.state[:2]

    @property
    def heading(self) -> float:
        return float(self.state[2])

    @property
    def speed(self) -> float:
        return float(self.state[3])

    @property
    def turn_rate(self) -> float:
        """ω̂ = Σ_j μ_j ω_j [rad/s] (0 before the IMM starts)."""
        return self._startup.turn_rate if self._imm is None else float(self.mode_probabilities @ self._omega)

    @property
    def position_covariance(self) -> np.ndarray:
        return self.state_covariance[:2, :2]

    def estimate(self, track_id: int = 0, radius_m: float = 0.0, **fields) -> TrackEstimate:
        """The current estimate as a :class:`TrackEstimate`."""
        x = self.state
        return TrackEstimate(track_id=int(track_id), time_s=float(self.time_s), position_m=x[:2].copy(),
                             heading_rad=float(x[2]), speed_m_s=float(x[3]), turn_rate_rad_s=self.turn_rate,
                             radius_m=float(radius_m), position_covariance=self.position_covariance.copy(), **fields)
