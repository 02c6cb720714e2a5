"""IMMTracker: the IMM tracker of one target behind a scalar API (thesis §3.2.1, docs/thesis.md §2) — a
one-track :class:`mjasc.perception.imm.bank.IMMBank`, read only through the bank's public methods.

For tests, benchmarks and single-target use; the multi-target tracker
(:mod:`mjasc.perception.tracking`) drives a bank directly. Rejected measurements are logged at
debug level on the logger ``mjasc.perception.imm``.
"""

from __future__ import annotations

import logging
import math
from dataclasses import replace

import numpy as np

from mjasc.core.estimates import TrackEstimate
from mjasc.perception.imm.bank import NON_FINITE, REJECTION_REASONS, IMMBank
from mjasc.perception.imm.config import IMMConfig

logger = logging.getLogger("mjasc.perception.imm")

__all__ = ["IMMTracker"]


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
        return len(self._bank) == 1

    @property
    def velocity_initialized(self) -> bool:
        """True once the track runs in the IMM (course and speed determined)."""
        return self.initialized and bool(self._bank.velocity_initialized[0])

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
        if len(bank) == 0:
            if not math.isfinite(t):
                raise ValueError(f"t: must be finite, got {t!r}")
            if not np.isfinite(zz).all():
                self._reason = REJECTION_REASONS[NON_FINITE]
                logger.debug("IMM tracker: rejected first measurement %s (%s)", z, self._reason)
                return False
            bank.add_track(zz[0], t, track_id=0)
            self._reason = ""
            return True
        if math.isfinite(zz[0, 0]) and math.isfinite(zz[0, 1]):
            ok = bank.update_finite(zz, t)
            if ok is None:
                self._reason = ""
                return True
            used = bool(ok[0])
        else:
            used = bool(bank.update(zz, t)[0])
        self._reason = "" if used else bank.rejection_reasons[0]
        return used

    def predict(self, t: float) -> None:
        """Coast to time t [s] without a measurement (no-op before initialization)."""
        if self.initialized:
            self._bank.predict(t)

    def _row(self):
        if len(self._bank) == 0:
            raise ValueError("IMMTracker: no estimate before the first measurement (call update)")

    @property
    def time_s(self) -> float:
        """Time of the last cycle [s]."""
        self._row()
        return float(self._bank.times_s[0])

    @property
    def state(self) -> np.ndarray:
        """(4,) combined [x, y, θ, V]."""
        self._row()
        return self._bank.states[0]

    @property
    def position(self) -> np.ndarray:
        """(2,) world-frame position [m]."""
        self._row()
        return self._bank.positions[0]

    @property
    def speed(self) -> float:
        """Speed over ground V ≥ 0 [m/s]."""
        self._row()
        return float(self._bank.speeds[0])

    @property
    def heading(self) -> float:
        """Course over ground θ [rad], CCW from east, in (−π, π]."""
        self._row()
        return float(self._bank.headings[0])

    @property
    def turn_rate(self) -> float:
        """ω̂ = Σ_j μ_j ω_j [rad/s] (0 before the IMM starts)."""
        self._row()
        return float(self._bank.turn_rates[0])

    @property
    def mode_probabilities(self) -> np.ndarray:
        """(r,) μ_j."""
        self._row()
        return self._bank.mode_probabilities[0]

    @property
    def position_covariance(self) -> np.ndarray:
        """(2, 2) position covariance [m²]."""
        self._row()
        return self._bank.position_covariances[0]

    @property
    def state_covariance(self) -> np.ndarray:
        """(4, 4) covariance over x, y, heading, speed."""
        self._row()
        return self._bank.state_covariances[0]

    def estimate(self, track_id: int = 0, radius_m: float = 0.0, **fields) -> TrackEstimate:
        """The current estimate as a :class:`TrackEstimate`."""
        self._row()
        return replace(self._bank.estimate(0, radius_m, **fields), track_id=int(track_id))

