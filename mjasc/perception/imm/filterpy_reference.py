"""The reference IMM built with filterpy: the same model bank as :mod:`mjasc.perception.imm` from
filterpy's ``IMMEstimator`` and ``KalmanFilter`` (thesis eq. 3.3 EKF prediction), for tests and
benchmarks to compare against (tests/test_imm.py, benchmarks/bench_imm.py) and as the filter of
each track of the ``filterpy_imm`` tracking method (:mod:`mjasc.perception.tracking.filterpy_tracker`).

This is the only module of mjasc that imports filterpy: the IMM's hot modules (kernel, bank,
tracker) and the built-in tracking never load it. filterpy mixes θ as a plain number and has no
probability floor, no gate and no start-up filter: compare where the courses span less than π and
the floor does not bind (``min_mode_probability = 0``, ``gate_probability = 1``).

* :func:`filterpy_imm` — the filterpy ``IMMEstimator`` itself, started from a given state, at a
  fixed sample time;
* :class:`FilterpyIMMTracker` — the same as a one-target tracker with the update / estimate
  interface of :class:`mjasc.perception.imm.tracker.IMMTracker` (its start-up filter is the
  bank's; at hand-over the filterpy IMM takes over), so that it can stand in for it; at a fixed
  sample time (the reference) or at any (each cycle's Ts, per-measurement σ², coasting, floor).
"""

from __future__ import annotations

import math

import numpy as np
from filterpy.kalman import IMMEstimator, KalmanFilter

from mjasc.core.estimates import TrackEstimate
from mjasc.perception.imm.bank import IMMBank
from mjasc.perception.imm.config import IMMConfig
from mjasc.perception.imm.compiled_cycle import wrap
from mjasc.perception.imm.markov import MarkovPower

__all__ = ["filterpy_imm", "FilterpyIMMTracker"]


class _TurnModelKF(KalmanFilter):
    """One model of the bank in filterpy: a ``KalmanFilter`` whose ``predict`` is the EKF
    prediction of thesis eq. 3.3 with turn rate ``omega`` over the sample time ``dt_s``
    (:meth:`set_sample_time` changes it, with Q = diag(0, 0, Q_θ·Ts, Q_V·Ts))."""

    def __init__(self, omega: float, config: IMMConfig, dt_s: float):
        super().__init__(dim_x=4, dim_z=2)
        self.omega = omega
        self._noise = (config.heading_noise_rad2_s, config.speed_noise_m2_s3)
        self.H = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]])
        self.R = config.measurement_variance_m2 * np.eye(2)
        self.set_sample_time(dt_s)

    def set_sample_time(self, dt_s: float) -> None:
        self.dt_s = dt_s
        self.Q = np.diag([0.0, 0.0, self._noise[0] * dt_s, self._noise[1] * dt_s])

    def predict(self, u=None, B=None, F=None, Q=None):
        dt_s = self.dt_s
        x, y, th, v = self.x[:, 0]
        c, s = math.cos(th), math.sin(th)
        self.F = np.array(
            [[1, 0, -dt_s * v * s, dt_s * c], [0, 1, dt_s * v * c, dt_s * s], [0, 0, 1, 0], [0, 0, 0, 1.0]]
        )
        self.x = np.array([[x + dt_s * v * c], [y + dt_s * v * s], [th + dt_s * self.omega], [v]])
        self.P = self.F @ self.P @ self.F.T + self.Q
        self.x_prior, self.P_prior = self.x.copy(), self.P.copy()


def filterpy_imm(config: IMMConfig, state, covariance, dt_s: float = 1.0, mode_probabilities=None):
    """The same model bank built with filterpy (reference for tests and benchmarks).

    An ``IMMEstimator`` of r ``KalmanFilter`` subclasses whose ``predict`` is the EKF prediction
    of thesis eq. 3.3 for a fixed Ts = ``dt_s``, all started at ``state`` (4,) / ``covariance``
    (4, 4), with the config's Markov matrix at ``dt_s``. filterpy mixes θ as a plain number and
    has no probability floor: compare where the courses span less than π and the floor does not
    bind (or floor the probabilities after its update yourself).
    """
    filters = []
    for w in config.turn_rates_rad_s:
        f = _TurnModelKF(w, config, dt_s)
        f.x = np.asarray(state, dtype=float).reshape(4, 1).copy()
        f.P = np.asarray(covariance, dtype=float).copy()
        filters.append(f)
    r = config.n_models
    mu = np.full(r, 1.0 / r) if mode_probabilities is None else np.asarray(mode_probabilities)
    return IMMEstimator(filters, mu, MarkovPower(config).scalar(float(dt_s)))


class FilterpyIMMTracker:
    """The filterpy reference IMM as a one-target tracker: ``update(z, t)`` → bool, ``predict(t)``
    (coast), ``estimate()``, and the read-outs of :class:`mjasc.perception.imm.tracker.IMMTracker`
    (``state``, ``position``, ``heading``, ``speed``, ``turn_rate``, ``mode_probabilities``,
    covariances, ``time_s``).

    Until the course and speed are determined the measurements go to a one-track
    :class:`~mjasc.perception.imm.bank.IMMBank` (the project's start-up filter); then
    :func:`filterpy_imm` takes over from its state, covariance and mode probabilities.

    * ``dt_s`` a number: the reference at a fixed sample time; every later measurement must come
      ``dt_s`` after the previous one and be finite (ValueError otherwise). With
      ``min_mode_probability = 0`` and ``gate_probability = 1`` its estimates are IMMTracker's to
      rounding (tests/test_imm.py).
    * ``dt_s = None``: any sample time, as the bank: each cycle's F, Q and Markov matrix p(Ts)
      (:class:`~mjasc.perception.imm.markov.MarkovPower`) for its own Ts; ``predict(t)`` coasts
      (mixing and prediction, μ_j ← c̄_j). This is the filter of each track of the filterpy
      multi-target tracker (:mod:`mjasc.perception.tracking.filterpy_tracker`).

    ``update(z, t, measurement_variance)`` uses R = σ²·I₂ for that measurement (default the
    config's σ²); the config's probability floor ``min_mode_probability`` is applied after each
    update as the bank does (floor, renormalize). filterpy has no gate: association gates.
    """

    def __init__(self, config: IMMConfig = IMMConfig(), dt_s: float | None = 1.0):
        self.config = config
        self.dt_s = None if dt_s is None else float(dt_s)
        self._startup = IMMBank(config)
        self._imm: IMMEstimator | None = None
        self._t = math.nan
        self._omega = np.asarray(config.turn_rates_rad_s, dtype=float)
        self._markov = MarkovPower(config)
        self._floor = float(config.min_mode_probability)
        self._R = float(config.measurement_variance_m2)
        self._dt_now = self.dt_s

    @property
    def initialized(self) -> bool:
        return len(self._startup) == 1

    @property
    def velocity_initialized(self) -> bool:
        return self._imm is not None

    @property
    def imm(self) -> IMMEstimator | None:
        """The filterpy ``IMMEstimator`` once it has taken over (None before)."""
        return self._imm

    def _startup_cycle(self, z, t: float, var) -> bool:
        b = self._startup
        if len(b) == 0:
            if not np.all(np.isfinite(z)):
                return False
            b.add_track(z, t, track_id=0, measurement_variance=var)
            used = True
        elif z is None:
            b.predict(t)
            used = False
        else:
            used = bool(b.update(z[None], t, None, None if var is None else np.array([float(var)]))[0])
        if b.velocity_initialized[0]:
            self._imm = filterpy_imm(self.config, b.states[0], b.state_covariances[0], self._dt_now or 1.0,
                                     b.mode_probabilities[0])
            self._t = float(b.times_s[0])
        return used

    def _advance(self, t: float) -> None:
        """Mixing and prediction of every model to t (filterpy's ``predict`` at Ts = t − last)."""
        dt = t - self._t
        if self.dt_s is not None:
            if not math.isclose(dt, self.dt_s, rel_tol=1e-9, abs_tol=1e-12):
                raise ValueError(f"t: the filterpy reference runs at a fixed sample time {self.dt_s} s, got "
                                 f"{dt} s after the last cycle")
        elif dt < 0 or not math.isfinite(dt):
            raise ValueError(f"t: must be finite and not before the last cycle ({self._t} s), got {t!r}")
        elif dt != self._dt_now:  # the sample time changed: each model's Q and the Markov matrix p(Ts)
            self._dt_now = dt
            for f in self._imm.filters:
                f.set_sample_time(dt)
            self._imm.M = self._markov.scalar(dt)
            self._imm._compute_mixing_probabilities()
        self._imm.predict()
        self._t = float(t)

    def update(self, z, t: float, measurement_variance: float | None = None) -> bool:
        """Process measurement z (2,) [m] taken at time t [s] with σ² ``measurement_variance``
        [m²] (default the config's); True if it was used."""
        z = np.asarray(z, dtype=float).reshape(-1)
        if self._imm is None:
            return self._startup_cycle(z, t, measurement_variance)
        if z.shape != (2,) or not np.all(np.isfinite(z)):
            raise ValueError(f"z: the filterpy reference takes finite [x, y] measurements only, got {z!r}")
        imm = self._imm
        self._advance(t)
        var = self._R if measurement_variance is None else float(measurement_variance)
        if self.dt_s is None or measurement_variance is not None:
            R = var * np.eye(2)
            for f in imm.filters:
                f.R = R
        imm.update(z)
        if self._floor > 0.0:
            mu = np.maximum(imm.mu, self._floor)
            imm.mu = mu / mu.sum()
            imm._compute_mixing_probabilities()
            imm._compute_state_estimate()
        return True

    def predict(self, t: float) -> None:
        """Coast to t [s] without a measurement: mixing, prediction, μ_j ← c̄_j (as the bank)."""
        if self._imm is None:
            if self.initialized:
                self._startup_cycle(None, t, None)
            return
        imm = self._imm
        self._advance(t)
        imm.mu = imm.cbar.copy()
        imm._compute_mixing_probabilities()
        imm._compute_state_estimate()

    @property
    def time_s(self) -> float:
        return float(self._startup.times_s[0]) if self._imm is None else self._t

    @property
    def state(self) -> np.ndarray:
        """(4,) combined [x, y, θ, V], θ in (−π, π] (V as filterpy has it: it may be < 0)."""
        if self._imm is None:
            return self._startup.states[0]
        x = self._imm.x[:, 0].copy()
        x[2] = wrap(x[2])
        return x

    @property
    def state_covariance(self) -> np.ndarray:
        return self._startup.state_covariances[0] if self._imm is None else self._imm.P.copy()

    @property
    def mode_probabilities(self) -> np.ndarray:
        if self._imm is None:
            return self._startup.mode_probabilities[0]
        return np.asarray(self._imm.mu, dtype=float).copy()

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
        return float(self._startup.turn_rates[0]) if self._imm is None else float(self.mode_probabilities @ self._omega)

    @property
    def position_covariance(self) -> np.ndarray:
        return self.state_covariance[:2, :2]

    def estimate(self, track_id: int = 0, radius_m: float = 0.0, **fields) -> TrackEstimate:
        """The current estimate as a :class:`TrackEstimate`."""
        x = self.state
        return TrackEstimate(track_id=int(track_id), time_s=float(self.time_s), position_m=x[:2].copy(),
                             heading_rad=float(x[2]), speed_m_s=float(x[3]), turn_rate_rad_s=self.turn_rate,
                             radius_m=float(radius_m), position_covariance=self.position_covariance.copy(), **fields)
