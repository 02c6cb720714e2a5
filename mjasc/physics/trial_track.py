"""A manoeuvring trial's vessel (:mod:`mjasc.physics.trials`): one hull alone in still water, from
rest at the origin heading east, with the time history of every physics step, sailed under constant
commands until steady (:class:`SteadyStateCriterion`), and the "rudder amidships" command of a
differential pair (the equal command on both shafts with the same total thrust)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mjasc.core.config_tables import check_params, param
from mjasc.physics.simulation import Simulation
from mjasc.physics.vessels import load_vessel_type, resolve_vessel_type
from mjasc.physics.world import build_world

__all__ = ["SteadyStateCriterion", "STEADY", "TrialTrack", "new_track", "amidships_command"]


@dataclass(frozen=True)
class SteadyStateCriterion:
    """When a constant-command phase counts as steady (see the module docstring)."""

    window_s: float = param(3.0, positive=True, unit="s", doc="the spreads are taken over this last window")
    sample_s: float = param(0.25, positive=True, unit="s", doc="sampling period of the check")
    velocity_tol_m_s: float = param(1e-4, positive=True, unit="m/s", doc="largest spread of u and v")
    yaw_rate_tol_rad_s: float = param(1e-4, positive=True, unit="rad/s", doc="largest spread of r")
    min_time_s: float = param(3.0, nonneg=True, unit="s", doc="a phase lasts at least this long")
    max_time_s: float = param(600.0, positive=True, unit="s", doc="a phase gives up after this long")

    def __post_init__(self):
        check_params(self, "steady_state")


STEADY = SteadyStateCriterion()


class TrialTrack:
    """One vessel's simulation with the time history of every physics step.

    Columns: t [s], x, y [m] (world ENU), ψ [rad] unwrapped (continuous), u, v [m/s], r [rad/s].
    """

    def __init__(self, sim: Simulation):
        self.sim = sim
        self.rows: list[tuple] = []
        self._psi_unwrapped = 0.0
        self._record()

    def _record(self) -> None:
        s = self.sim.states()
        psi = float(s.heading_rad[0])
        if self.rows:
            d = psi - self._psi_wrapped
            self._psi_unwrapped += (d + math.pi) % (2.0 * math.pi) - math.pi
        else:
            self._psi_unwrapped = psi
        self._psi_wrapped = psi
        u, v, r = (float(a) for a in s.body_velocity[0])
        x, y = (float(a) for a in s.position_m[0])
        self.rows.append((s.time_s, x, y, self._psi_unwrapped, u, v, r))

    @property
    def last(self) -> tuple:
        return self.rows[-1]

    def command(self, port: float, starboard: float) -> None:
        self.sim.set_commands([[port, starboard]])

    def step(self, n: int = 1) -> None:
        for _ in range(n):
            self.sim.step(1)
            self._record()

    def array(self, start: int = 0) -> np.ndarray:
        """(K, 7) array of the rows from index ``start`` on."""
        return np.array(self.rows[start:], dtype=float)

    def sail_until_steady(self, criterion: SteadyStateCriterion = STEADY) -> bool:
        """Step under the current commands until steady (True) or ``max_time_s`` (False)."""
        dt = self.sim.timestep_s
        k = max(1, round(criterion.sample_s / dt))
        n_window = max(2, math.ceil(criterion.window_s / (k * dt)) + 1)
        t0 = self.last[0]
        samples: list[tuple] = []
        tol = np.array([criterion.velocity_tol_m_s, criterion.velocity_tol_m_s, criterion.yaw_rate_tol_rad_s])
        while True:
            self.step(k)
            samples.append(self.last[4:7])
            if len(samples) > n_window:
                samples.pop(0)
            elapsed = self.last[0] - t0
            if elapsed >= criterion.min_time_s and len(samples) == n_window:
                spread = np.ptp(np.array(samples), axis=0)
                if np.all(spread < tol):
                    return True
            if elapsed >= criterion.max_time_s:
                return False


def new_track(vessel_name: str) -> TrialTrack:
    """A lone hull of ``vessel_name`` (a built-in name or a vessel folder's path, relative to the
    current folder) at rest at the origin."""
    vtype = load_vessel_type(resolve_vessel_type(vessel_name))
    # (named "trial", not after the type: a folder's name need not be a valid vessel name, tern.v2)
    sim = Simulation(build_world([("trial", vtype)]))
    sim.reset(np.zeros((1, 3)))
    return TrialTrack(sim)


def amidships_command(track: TrialTrack, p: float, s: float) -> float:
    """"Rudder amidships" for the pair (p, s): the equal command on both shafts giving the same
    total thrust, 2 T(c₀) = T(p) + T(s), rounded to 4 decimals."""
    props = track.sim.world.vessel_types[0].propellers
    mean_thrust = 0.5 * float(props.thrust(p) + props.thrust(s))
    return round(float(props.command_for_thrust(mean_thrust)), 4)
