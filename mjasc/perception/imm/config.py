"""IMM parameters: :class:`IMMConfig`, each parameter declared once (bounds, unit, doc), and the
reader of a scenario's ``imm`` table (:func:`parse_imm_options`).

Defaults are the thesis's Table 6.1 where it gives a value (7 models, ω_j from −0.05 to 0.05 rad/s,
uniform initial mode probabilities, floor 2·10⁻³, σ² = 0.1 m² in §6.1); the process-noise
intensities, the Markov stay probability and the start-up and gating parameters are mjasc's
choices, tuned by the NEES tests in tests/test_imm.py (see :mod:`mjasc.perception.imm`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from mjasc.core.config_tables import ConfigError, check_params, dataclass_from_table, param, show

__all__ = ["IMMConfig", "parse_imm_options", "check_imm"]


@dataclass(frozen=True)
class IMMConfig:
    """Parameters of the IMM tracker (SI). Defaults: thesis Table 6.1 where it gives a value.

    Each field's bounds, unit and meaning are declared with it (``describe_params(IMMConfig)``
    lists them); the checks that relate fields (probabilities against the number of models r,
    the Markov matrix's shape and eigenvalues) are :func:`check_imm`.
    """

    turn_rates_rad_s: tuple[float, ...] = param(
        (-0.05, -0.03, -0.01, 0.0, 0.01, 0.03, 0.05), unit="rad/s",
        doc="ω_j of the r models (Table 6.1: 7 models, −0.05 … 0.05)")
    initial_mode_probabilities: tuple[float, ...] | None = param(
        None, doc="μ_j at hand-over to the IMM (None: 1/r each, Table 6.1); r non-negative values summing to 1")
    min_mode_probability: float = param(
        2e-3, nonneg=True, doc="floor of the μ_j after an update (Table 6.1: 2·10⁻³): each is raised to it, then "
                               "all are renormalised (a raised one ends slightly below it); 0 disables it; < 1/r")
    measurement_variance_m2: float = param(
        0.1, positive=True, unit="m²",
        doc="σ² of the position measurement per axis, R = σ²·I₂ (§6.1: 0.1 m²)")
    heading_noise_rad2_s: float = param(
        1e-5, nonneg=True, unit="rad²/s",
        doc="Q_θ, intensity of the course random walk. Default 1e-5 (1-σ course drift 0.003 rad in 1 s): "
            "small, so that models 0.02 rad/s apart are told apart within tens of seconds, yet "
            "NEES-consistent for targets between two models. Tuned by the NEES tests in tests/test_imm.py")
    speed_noise_m2_s3: float = param(
        1e-4, nonneg=True, unit="m²/s³",
        doc="Q_V, intensity of the speed random walk. Default 1e-4 (1-σ speed change 0.01 m/s in 1 s: a "
            "small craft's gentle accelerations), tuned with Q_θ")
    markov_stay_probability: float = param(
        0.98, doc="p_jj of the Markov switching matrix per markov_reference_dt_s; the rest, 1 − p_jj, is "
                  "spread evenly over the other models; in (1/r, 1]. Default 0.98: a mean sojourn of 50 s in "
                  "a mode, the time scale of a small craft's turns (the thesis gives no value; 0.9–0.98 is "
                  "usual). Lower values switch faster but leak probability to the 6 wrong models every "
                  "cycle, which biases ω̂ toward 0")
    markov_matrix: tuple[tuple[float, ...], ...] | None = param(
        None, doc="optional explicit r×r matrix p_ij (row i: from model i), replacing the uniform one; rows "
                  "must sum to 1, eigenvalues real and positive (so p^(Ts/T_ref) exists)")
    markov_reference_dt_s: float = param(
        1.0, positive=True, unit="s", doc="time step the Markov matrix refers to (the thesis's Ts = 1 s)")
    initial_speed_std_m_s: float = param(
        2.0, positive=True, unit="m/s",
        doc="prior 1-σ of each velocity component of a new track; with the gate it bounds the jump between "
            "a track's first two measurements (≈ 4.3·σ·Ts)")
    init_acceleration_noise_m2_s3: float = param(
        0.01, nonneg=True, unit="m²/s³",
        doc="white-acceleration intensity of the start-up constant-velocity filter; 0.01 covers the turn "
            "acceleration V·ω of 2 m/s at 0.05 rad/s over 1 s")
    init_speed_snr: float = param(
        3.0, positive=True,
        doc="hand a new track over to the IMM once |v̂| ≥ this × σ_v (3 → σ_θ ≲ 1/3 rad, where the EKF's "
            "linearization in θ is good)")
    init_max_updates: int = param(
        10, minimum=1, doc="hand over after this many measurements at the latest (1: at once, course unknown; "
                           "2: two-point differencing)")
    gate_probability: float = param(
        0.9999, positive=True, maximum=1.0,
        doc="chi-square (2 dof) gate probability; gate −2 ln(1 − p) (0.9999 → 18.4). 1.0 disables the gate")
    restart_after_gated: int = param(
        5, minimum=0, doc="restart a track from the measurement after this many consecutive gated ones (0: never)")

    def __post_init__(self):
        check_params(self, "imm")
        check_imm(self, "imm")

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


def _float_array(value) -> np.ndarray | None:
    """``value`` as a float array, or None when it is not numeric (a string, a ragged list …)."""
    if isinstance(value, (str, bytes)):
        return None
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return None


def check_imm(c: IMMConfig, where: str) -> None:
    """The checks of an :class:`IMMConfig` that relate its fields (the single-field bounds are
    declared with the fields): the turn rates set r, which the probabilities and the Markov matrix
    must fit. ConfigError (a ValueError) naming ``f"{where}.{key}"``."""
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
    if not c.min_mode_probability < 1.0 / r:
        bad("min_mode_probability", f"must be < 1/r = {1.0 / r:.4g} (r = {r} models)", c.min_mode_probability)
    if c.markov_matrix is None:
        if r > 1 and not 1.0 / r < c.markov_stay_probability <= 1.0:
            bad("markov_stay_probability", f"must be in (1/r, 1] = ({1.0 / r:.4g}, 1] so that the matrix has "
                "positive eigenvalues", c.markov_stay_probability)
    else:
        p = _float_array(c.markov_matrix)
        if p is None or p.shape != (r, r) or not np.all(p >= 0) or not np.allclose(p.sum(axis=1), 1.0):
            bad("markov_matrix", f"must be a non-negative {r}×{r} matrix whose rows sum to 1", c.markov_matrix)
        lam = np.linalg.eigvals(p)
        if np.any(np.abs(lam.imag) > 1e-12) or np.any(lam.real <= 0):
            bad("markov_matrix", "must have real, positive eigenvalues (fractional powers for a variable "
                "sample time need them)", c.markov_matrix)


def parse_imm_options(table: Mapping | None, where: str = "imm") -> IMMConfig:
    """A scenario's ``imm`` table (None: all defaults) → :class:`IMMConfig`; unknown keys, wrong types
    and out-of-range values raise ValueError naming ``f"{where}.{key}"``
    (:func:`mjasc.core.config_tables.dataclass_from_table`)."""
    return dataclass_from_table(IMMConfig, {} if table is None else table, where, check=check_imm)
