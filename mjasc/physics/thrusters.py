"""Twin fixed propellers: shaft speed → thrust → body-frame force, for all vessels at once.

Command: each propeller takes a normalized shaft-speed command c ∈ [−1, 1]. MuJoCo's actuator of
that propeller (``dyntype="filterexact"``, time constant T_n) integrates the first-order shaft lag
exactly, so its activation ``act`` is the normalized shaft speed and lives in MjData with the rest
of the state. Shaft speed ``n = act · n_max`` for act ≥ 0 and ``act · |n_min|`` for act < 0
(saturation is the [−1, 1] control range). Thrust (Fossen's Otter)::

    T = k_f n|n|  (n ≥ 0),     T = k_r n|n|  (n < 0)                       [N]

Each propeller pushes along the body x axis at its site (x_i, y_i), so the body force is
``X = Σ T_i``, ``Y = 0``, ``N = −Σ y_i T_i`` (FLU: the port propeller at +y turns the hull clockwise).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from mjasc.core.config_tables import ConfigError, check_params, param, show

__all__ = ["PropellerCoefficients", "Thrusters", "command_for_thrust_scalar"]


@dataclass(frozen=True)
class PropellerCoefficients:
    """Propeller model of one vessel (both propellers identical): the ``[propellers]`` table of a
    vessel's ``hydrodynamics.toml``."""

    k_forward: float = param(positive=True, unit="N/(rad/s)²", doc="thrust coefficient k_f for n ≥ 0")
    k_reverse: float = param(positive=True, unit="N/(rad/s)²", doc="thrust coefficient k_r for n < 0")
    n_max_rad_s: float = param(positive=True, unit="rad/s", doc="largest forward shaft speed (command +1)")
    n_min_rad_s: float = param(unit="rad/s", doc="largest reverse shaft speed (command −1), < 0")
    time_constant_s: float = param(positive=True, unit="s", doc="first-order shaft lag T_n")

    def __post_init__(self):
        check_params(self, "propellers")
        self.check(self, "propellers")

    @staticmethod
    def check(config: "PropellerCoefficients", where: str) -> None:
        """The reverse shaft-speed limit is negative."""
        if not config.n_min_rad_s < 0:
            raise ConfigError(f"{where}.n_min_rad_s: must be < 0, got {show(config.n_min_rad_s)}")

    @property
    def max_thrust_n(self) -> float:
        """Forward thrust of one propeller at full shaft speed [N]."""
        return self.k_forward * self.n_max_rad_s**2

    def shaft_speed(self, command) -> np.ndarray:
        """Shaft speed [rad/s] for a normalized command/activation in [−1, 1]."""
        c = np.clip(np.asarray(command, dtype=float), -1.0, 1.0)
        return np.where(c >= 0, c * self.n_max_rad_s, -c * self.n_min_rad_s)

    def thrust(self, command) -> np.ndarray:
        """Steady thrust [N] of one propeller at a normalized shaft speed."""
        n = self.shaft_speed(command)
        return np.where(n >= 0, self.k_forward, self.k_reverse) * n * np.abs(n)

    def command_for_thrust(self, thrust_n) -> np.ndarray:
        """Inverse of :meth:`thrust`: the normalized command giving ``thrust_n`` (saturated)."""
        t = np.asarray(thrust_n, dtype=float)
        n = np.where(t >= 0, np.sqrt(np.abs(t) / self.k_forward), -np.sqrt(np.abs(t) / self.k_reverse))
        return np.clip(np.where(n >= 0, n / self.n_max_rad_s, n / -self.n_min_rad_s), -1.0, 1.0)


def command_for_thrust_scalar(thrust_n: float, k_forward: float, k_reverse: float, n_max_rad_s: float,
                              n_min_rad_s: float) -> float:
    """:meth:`PropellerCoefficients.command_for_thrust` for one thrust [N] in plain floats: the same
    operations (IEEE division and square root round alike in both), without numpy's cost per call."""
    n = math.sqrt(abs(thrust_n) / k_forward) if thrust_n >= 0 else -math.sqrt(abs(thrust_n) / k_reverse)
    c = n / n_max_rad_s if n >= 0 else n / -n_min_rad_s
    c = c if c >= -1.0 or c != c else -1.0  # np.clip: NaN stays NaN
    return c if c <= 1.0 or c != c else 1.0


class Thrusters:
    """Body-frame propeller forces of N twin-propeller vessels from their (N, 2) activations."""

    def __init__(self, propellers: Sequence[PropellerCoefficients], lateral_offsets_m: np.ndarray):
        """lateral_offsets_m: (N, 2) body-frame y of the port and starboard propellers [m]."""
        self.n_vessels = len(propellers)
        self._y = np.asarray(lateral_offsets_m, dtype=float).reshape(self.n_vessels, 2)
        col = lambda name: np.array([getattr(p, name) for p in propellers], dtype=float)[:, None]  # noqa: E731
        self._n_pos, self._n_neg = col("n_max_rad_s"), -col("n_min_rad_s")
        self._k_f, self._k_r = col("k_forward"), col("k_reverse")

    def step_arrays(self) -> np.ndarray:
        """The constants a compiled step reads, a new (N, 4) array: (n_max, −n_min, k_forward,
        k_reverse) per vessel (:func:`mjasc.physics.state_kernels.vessel_states`)."""
        return np.ascontiguousarray(np.column_stack([self._n_pos, self._n_neg, self._k_f, self._k_r]), dtype=float)

    def thrust(self, activation: np.ndarray) -> np.ndarray:
        """Thrust [N] of each propeller, (N, 2), from normalized shaft speeds (N, 2)."""
        a = activation
        pos = a >= 0
        n = a * np.where(pos, self._n_pos, self._n_neg)
        return np.where(pos, self._k_f, self._k_r) * n * np.abs(n)

    def feature_weights(self) -> np.ndarray:
        """(N, 4, 3) body force (X, Y, N) per unit of the features (max(a|a|, 0) port, starboard,
        min(a|a|, 0) port, starboard), a = normalized shaft speed: T = k n_lim² a|a| per side."""
        fwd = (self._k_f * self._n_pos**2)[:, 0]
        rev = (self._k_r * self._n_neg**2)[:, 0]
        w = np.zeros((self.n_vessels, 4, 3))
        for k, (gain, side) in enumerate(((fwd, 0), (fwd, 1), (rev, 0), (rev, 1))):
            w[:, k, 0] = gain
            w[:, k, 2] = -self._y[:, side] * gain
        return w

    def body_force(self, thrust_n: np.ndarray) -> np.ndarray:
        """(X, Y, N) body-frame force of each vessel, (N, 3), from per-propeller thrust (N, 2)."""
        out = np.zeros((self.n_vessels, 3))
        out[:, 0] = thrust_n.sum(axis=1)
        out[:, 2] = -(self._y * thrust_n).sum(axis=1)
        return out
