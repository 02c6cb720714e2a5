"""A vessel's own navigation solution: the only thing its onboard stages know of its own motion.

World frame ENU, body frame FLU, SI units. :class:`FleetNavigation` holds every vessel's solution
as arrays over vessels (what the runner reads once per tick); :meth:`FleetNavigation.vessel` is
one vessel's :class:`OwnNavigation`, the value each onboard stage receives. A stage never sees
another body's true state: other vessels reach it through its sensor and its comms link.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["OwnNavigation", "FleetNavigation", "NavigationList"]


@dataclass(frozen=True)
class OwnNavigation:
    """One vessel's navigation solution at ``time_s`` [s].

    position_m (2,) world x, y [m]; heading_rad yaw ψ, CCW from east [rad]; velocity_m_s (2,)
    world-frame velocity over ground [m/s]; body_velocity (3,) = (u [m/s] forward, v [m/s] to
    port, r [rad/s] CCW)."""

    time_s: float
    position_m: np.ndarray
    heading_rad: float
    velocity_m_s: np.ndarray
    body_velocity: np.ndarray


@dataclass(frozen=True)
class FleetNavigation:
    """Every vessel's navigation solution at ``time_s`` [s], arrays over vessels (n = fleet size):
    position_m (n, 2), heading_rad (n,), velocity_m_s (n, 2), body_velocity (n, 3); frames and
    units as :class:`OwnNavigation`."""

    time_s: float
    position_m: np.ndarray
    heading_rad: np.ndarray
    velocity_m_s: np.ndarray
    body_velocity: np.ndarray

    @classmethod
    def from_states(cls, states) -> "FleetNavigation":
        """From the simulator's :class:`~mjasc.physics.simulation.VesselStates` (a perfect
        navigation system: the vessels' true own states)."""
        fleet = object.__new__(cls)  # (cls(...) without the frozen __init__'s five setattr calls)
        fleet.__dict__.update(time_s=states.time_s, position_m=states.position_m, heading_rad=states.heading_rad,
                              velocity_m_s=states.velocity_m_s, body_velocity=states.body_velocity)
        return fleet

    def __len__(self) -> int:
        return int(self.heading_rad.shape[0])

    def vessel(self, i: int) -> OwnNavigation:
        """Vessel ``i``'s own navigation solution."""
        return OwnNavigation(self.time_s, self.position_m[i], float(self.heading_rad[i]), self.velocity_m_s[i],
                             self.body_velocity[i])

    def vessels(self) -> "NavigationList":
        """Every vessel's :meth:`vessel`, in order (the same values; built without the frozen
        ``__init__``'s five ``setattr`` calls per vessel: the runner asks at every tick), as a
        :class:`NavigationList` that knows this fleet."""
        t, new = self.time_s, object.__new__
        headings = self.heading_rad.tolist()
        out = NavigationList([None] * len(headings))  # (filled by index: no append per vessel)
        out.fleet = self
        for k, (pos, heading, vel, body) in enumerate(zip(self.position_m, headings, self.velocity_m_s,
                                                          self.body_velocity)):
            out[k] = nav = new(OwnNavigation)
            nav.__dict__.update(time_s=t, position_m=pos, heading_rad=heading, velocity_m_s=vel, body_velocity=body)
        return out


class NavigationList(list):
    """The list of every vessel's :class:`OwnNavigation` that :meth:`FleetNavigation.vessels`
    makes; ``fleet`` is the :class:`FleetNavigation` whose rows they are (a fleet stage reads its
    arrays instead of stacking the vessels' values again; do not change the list)."""

    __slots__ = ("fleet",)
