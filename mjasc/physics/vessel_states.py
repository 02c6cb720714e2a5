"""The true states of a run's vessels at one time, as :meth:`mjasc.physics.simulation.Simulation.states`
gives them (world ENU / body FLU, SI; docs/architecture.md, "Conventions")."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["VesselStates"]


@dataclass(frozen=True)
class VesselStates:
    """True states of all vessels at ``time_s`` (world ENU / body FLU, SI). Arrays are copies.

    position_m (N, 2); heading_rad (N,); velocity_m_s (N, 2) world-frame velocity of CO;
    body_velocity (N, 3) = (u, v, r); current_m_s (N, 2) water velocity at each vessel (world);
    shaft_speed (N, 2) normalized port/starboard shaft speeds; thrust_n (N, 2).
    """

    time_s: float
    position_m: np.ndarray
    heading_rad: np.ndarray
    velocity_m_s: np.ndarray
    body_velocity: np.ndarray
    current_m_s: np.ndarray
    shaft_speed: np.ndarray
    thrust_n: np.ndarray

    @property
    def speed_m_s(self) -> np.ndarray:
        """Speed over ground [m/s]."""
        return np.hypot(self.velocity_m_s[:, 0], self.velocity_m_s[:, 1])

    @property
    def relative_body_velocity(self) -> np.ndarray:
        """(u_r, v_r, r): body velocity relative to the water."""
        c, s = np.cos(self.heading_rad), np.sin(self.heading_rad)
        uc = c * self.current_m_s[:, 0] + s * self.current_m_s[:, 1]
        vc = -s * self.current_m_s[:, 0] + c * self.current_m_s[:, 1]
        out = self.body_velocity.copy()
        out[:, 0] -= uc
        out[:, 1] -= vc
        return out
