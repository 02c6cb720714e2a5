"""A seeded, slowly varying uniform current: the first-order Gauss–Markov model (Fossen 2011, §8.3).

``V(t) = V_mean + x(t)``, each of x's two components an independent stationary first-order
Gauss–Markov (Ornstein–Uhlenbeck) process ``ẋ + x/τ = w`` with time constant τ [s] and standard
deviation σ [m/s]. It is a deterministic function of (t, seed, parameters): sampled on a fixed
grid by the exact discretization and interpolated linearly (see :class:`GaussMarkovCurrent`).
World frame ENU, SI units.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from mjasc.core.config_tables import ConfigError, check_params, integer, param, show
from mjasc.physics.currents.arrays import vector2
from mjasc.physics.currents.base import CurrentField, points_and_velocities, read_parameters

__all__ = ["GAUSS_MARKOV_STARTS", "GaussMarkovConfig", "GaussMarkovCurrent"]

GAUSS_MARKOV_STARTS = ("stationary", "mean")
"""How the process starts: x(0) ~ N(0, σ²) (default) or x(0) = 0."""

_SEED_PHRASE = "must be an integer >= 0"


def read_seed(value: Any, where: str) -> int:
    """Reader of a noise seed: an integer ≥ 0 (one wording for a non-integer and a negative one)."""
    try:
        return integer(value, where, minimum=0)
    except ConfigError:
        raise ConfigError(f"{where}: {_SEED_PHRASE}, got {show(value)}") from None


@dataclass(frozen=True)
class GaussMarkovConfig:
    """The parameters of a :class:`GaussMarkovCurrent` (``[current]`` of ``type = "gauss_markov"``).

    ``seed`` may be left out of a scenario's table: ``current_from_config`` then derives one from
    the scenario's seed (``describe()`` shows it)."""

    mean_velocity_m_s: np.ndarray = param(reader=vector2, unit="m/s", doc="V_mean, the mean current")
    time_constant_s: float = param(minimum=1.0, unit="s",
                                   doc="τ, the correlation time of the variation (≥ 1 s: a current's, not a wave's)")
    sigma_m_s: float = param(nonneg=True, phrase="must be >= 0", unit="m/s",
                             doc="σ, the standard deviation of each component's variation")
    seed: int | None = param(None, nonneg=True, reader=read_seed, phrase=_SEED_PHRASE,
                             doc="seed of the noise (none: derived from the scenario's seed)")
    step_s: float | None = param(None, minimum=0.01, unit="s",
                                 doc="Δ, the sample grid (none: min(τ/50, 1 s); ≥ 0.01 s, a day of it ~140 MB)")
    start: str = param("stationary", choices=GAUSS_MARKOV_STARTS, phrase="must be one of 'stationary', 'mean'",
                       doc="stationary: x(0) ~ N(0, σ²); mean: x(0) = 0")

    def __post_init__(self):
        check_params(self, "GaussMarkovCurrent")


class GaussMarkovCurrent(CurrentField):
    """A slowly varying uniform current: ``V(t) = V_mean + x(t)`` (Fossen 2011, §8.3: the
    first-order Gauss–Markov model ``ẋ + x/τ = w`` of current speed, here for both components).

    Each component of x is an independent stationary Gauss–Markov (Ornstein–Uhlenbeck) process
    with time constant τ [s] and standard deviation σ [m/s] (autocorrelation σ²·e^{−|Δt|/τ}). It
    is sampled on the fixed grid t_k = k·Δ by the exact discretization
    ``x_{k+1} = e^{−Δ/τ} x_k + σ·√(1 − e^{−2Δ/τ}) w_k``, w_k ~ N(0, 1) drawn from
    ``numpy.random.default_rng(seed)`` in fixed blocks of ``BLOCK_STEPS`` steps, extended lazily
    as later times are asked for, and interpolated linearly between samples. So V is a pure
    function of (t, seed, parameters): the same whatever was queried before or in which order.
    The realisation depends on (seed, Δ): ``describe()`` records both. Linear interpolation
    lowers the variance between samples by at most (1 − e^{−Δ/τ})/2 (1 % at the default
    Δ = min(τ/50, 1 s)). Times before 0 hold x(0).

    start: "stationary" draws x(0) ~ N(0, σ²) (default); "mean" starts at x(0) = 0.
    Acceleration: the slope of the interpolant (exact for it; uniform, so no spatial term)."""

    is_steady = False
    is_uniform = True
    BLOCK_STEPS = 1024

    def __init__(
        self,
        mean_velocity_m_s: Any,
        time_constant_s: float,
        sigma_m_s: float,
        seed: int,
        step_s: float | None = None,
        start: str = "stationary",
    ) -> None:
        self._setup(read_parameters(GaussMarkovConfig, "GaussMarkovCurrent", mean_velocity_m_s=mean_velocity_m_s,
                                    time_constant_s=time_constant_s, sigma_m_s=sigma_m_s, seed=seed,
                                    step_s=step_s, start=start))

    def _setup(self, config: GaussMarkovConfig) -> None:
        if config.seed is None:
            raise ConfigError("GaussMarkovCurrent.seed: missing")
        self._mean = np.array(config.mean_velocity_m_s, dtype=float)
        self._tau = config.time_constant_s
        self._sigma = config.sigma_m_s
        self._seed = config.seed
        self._step = min(self._tau / 50.0, 1.0) if config.step_s is None else config.step_s
        self._start = config.start
        self._a = math.exp(-self._step / self._tau)
        self._b = self._sigma * math.sqrt(-math.expm1(-2.0 * self._step / self._tau))
        self._rng = np.random.default_rng(self._seed)
        first = self._rng.standard_normal(2)
        self._samples = np.empty((self.BLOCK_STEPS + 1, 2))
        self._samples[0] = first * (self._sigma if self._start == "stationary" else 0.0)
        self._count = 1
        self._cached_t = math.nan
        self._cached_v = self._mean.copy()

    def _ensure(self, index: int) -> None:
        """Make sure samples x_0 … x_index exist (block by block, same stream whatever index)."""
        from scipy.signal import lfilter  # lazy: scipy.signal takes ~0.6 s to import

        while self._count <= index:
            noise = self._rng.standard_normal((self.BLOCK_STEPS, 2))
            previous = self._samples[self._count - 1]
            block, _ = lfilter(
                [self._b], [1.0, -self._a], noise, axis=0, zi=(self._a * previous)[None, :]
            )
            end = self._count + self.BLOCK_STEPS
            if end > len(self._samples):
                grown = np.empty((max(end, 2 * len(self._samples)), 2))
                grown[: self._count] = self._samples[: self._count]
                self._samples = grown
            self._samples[self._count : end] = block
            self._count = end

    def _segment(self, t_s: float) -> tuple[int, float]:
        if not t_s > 0.0:  # also catches NaN → hold x(0)
            self._ensure(1)
            return 0, 0.0
        u = t_s / self._step
        k = int(u)
        self._ensure(k + 1)
        return k, u - k

    def _value(self, t_s: float) -> np.ndarray:
        if t_s != self._cached_t:
            k, w = self._segment(t_s)
            x0 = self._samples[k]
            self._cached_v = self._mean + x0 + w * (self._samples[k + 1] - x0)
            self._cached_t = t_s
        return self._cached_v

    @property
    def mean_velocity_m_s(self) -> np.ndarray:
        """V_mean [m/s], (2,) world frame: what the current varies about (a copy)."""
        return self._mean.copy()

    def velocity_at_times(self, times_s: Any) -> np.ndarray:
        """(m, 2) current velocities [m/s] at times ``times_s`` (m,) — for plots and analysis."""
        times = np.atleast_1d(np.asarray(times_s, dtype=float))
        u = np.where(times > 0.0, times, 0.0) / self._step
        k = np.floor(u).astype(np.int64)
        if k.size:
            self._ensure(int(k.max()) + 1)
        w = (u - k)[:, None]
        x0 = self._samples[k]
        return self._mean + x0 + w * (self._samples[k + 1] - x0)

    def velocity(self, points_m: np.ndarray, t_s: float) -> np.ndarray:
        points = np.asarray(points_m, dtype=float)
        if points.ndim != 2 or points.shape[1] != 2:
            raise ValueError(f"points_m: must have shape (n, 2), got shape {points.shape}")
        out = np.empty(points.shape)
        out[:] = self._value(float(t_s))
        return out

    def acceleration(self, points_m, velocities_m_s, t_s) -> np.ndarray:
        points, _ = points_and_velocities(points_m, velocities_m_s)
        out = np.empty(points.shape)
        if not t_s >= 0.0:  # before the start x(t) is held: no rate
            out[:] = 0.0
            return out
        k, _ = self._segment(float(t_s))  # at a sample time: the slope of the segment after it
        out[:] = (self._samples[k + 1] - self._samples[k]) / self._step
        return out

    def describe(self) -> dict[str, Any]:
        return {
            "type": "gauss_markov",
            "mean_velocity_m_s": self._mean.tolist(),
            "time_constant_s": self._tau,
            "sigma_m_s": self._sigma,
            "seed": self._seed,
            "step_s": self._step,
            "start": self._start,
        }
