"""A hull's steady states in still water, and the tightest steady turn it can sail at a given speed.

Under constant propeller commands a hull settles where the hydrodynamic forces balance the
propellers' (the manoeuvring model of :mod:`mjasc.physics.hydrodynamics`, its eq. (3) with
ν̇ = 0 and no current)::

    τ_prop(a_port, a_starboard) + τ_hyd(ν) − C_RB(ν) ν = 0,        ν = (u, v, r)

:func:`steady_state` solves these three equations for ν (scipy's ``root``, started from the
straight run at the total thrust, or from a nearby steady state). A steady turn has the speed
over ground ``U = √(u² + v²)``, the yaw rate ``r`` and the radius ``R = U / |r|``.

**The tightest turn at a speed** (:func:`tightest_turn`): at a given U the steady states form a
one-parameter family (two commands, one speed condition); the yaw rate grows with the
difference of the commands, so the tightest turn has one propeller at a limit — the outer one at
full ahead, or, at speeds below what full ahead against full astern gives, the inner one at full
astern. The other command is found by following the turning branch of steady states in small
command steps (continuation) and then bisecting on the speed between two steps (``brentq``). Both
propeller's limits are those of the hull's ``[propellers]`` table (commands in [−1, 1]); the
shaft lag does not matter in a steady state. The answer is the *hull's* limit: a path follower
that keeps a margin of thrust for control turns wider, and a current drifts the turn.

By the hull's mirror symmetry (both propellers alike, at ±y) a turn to starboard is the mirror
image of the turn to port computed here. Used by the scenario check of go-to-formation's
``turn_radius_m`` (:mod:`mjasc.runs.plausibility`): a Dubins transit with arcs tighter than the
hull can sail at its cruise speed is not a plan the vessel can keep.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq, root

__all__ = ["SteadyTurn", "steady_state", "tightest_turn", "tightest_turn_of_type", "smallest_turn_radius_m"]


@dataclass(frozen=True)
class SteadyTurn:
    """A steady turn to port in still water (body frame FLU, SI units)."""

    speed_m_s: float         #: speed over ground U = √(u² + v²) [m/s]
    surge_m_s: float         #: u [m/s]
    sway_m_s: float          #: v [m/s] (to port)
    yaw_rate_rad_s: float    #: r [rad/s], > 0 (counter-clockwise)
    commands: tuple          #: (port, starboard) normalized shaft speeds in [−1, 1]

    @property
    def radius_m(self) -> float:
        """Radius of the turning circle the hull's reference point sails [m]."""
        return self.speed_m_s / self.yaw_rate_rad_s if self.yaw_rate_rad_s > 0 else math.inf


def _residual(hydro, tau: np.ndarray, nu: np.ndarray) -> np.ndarray:
    zero2 = np.zeros((1, 2))
    nu_dot, _ = hydro.body_acceleration(nu.reshape(1, 3), zero2, zero2, tau)
    return nu_dot[0]


def steady_state(hydro, thrusters, commands, guess=None) -> np.ndarray | None:
    """The steady body velocity ν = (u, v, r) [m/s, m/s, rad/s] of vessel 0 of ``hydro`` /
    ``thrusters`` (:class:`~mjasc.physics.hydrodynamics.Hydrodynamics`,
    :class:`~mjasc.physics.thrusters.Thrusters` of one vessel) under the constant normalized
    ``commands`` (port, starboard), in still water; None when the solve does not converge.
    ``guess``: a nearby steady state to start from (default: the straight run whose surge damping
    balances the total thrust)."""
    a = np.asarray(commands, dtype=float).reshape(1, 2)
    tau = thrusters.body_force(thrusters.thrust(a))
    if guess is None:
        guess = _straight_guess(hydro, tau)
    sol = root(lambda x: _residual(hydro, tau, x), np.asarray(guess, dtype=float), method="hybr",
               options={"xtol": 1e-12})
    if not sol.success or not np.all(np.isfinite(sol.x)):
        return None
    scale = np.abs(np.diag(hydro.total_mass[0]))  # residual in accelerations: compare as forces
    if np.max(np.abs(_residual(hydro, tau, sol.x)) * scale) > 1e-6 * max(1.0, abs(float(tau[0, 0]))):
        return None
    return sol.x


def _straight_guess(hydro, tau: np.ndarray) -> np.ndarray:
    """(u, 0, 0) with the surge equation balanced under the body force ``tau`` (1, 3) [N, N, N·m]
    (sway and yaw left to the full solve): the surge damping grows with |u|, so a bracket doubles
    out from 1 m/s until it holds the root."""
    surge = lambda u: _residual(hydro, tau, np.array([u, 0.0, 0.0]))[0]  # noqa: E731
    f0 = surge(0.0)
    if f0 == 0.0:
        return np.zeros(3)
    side = math.copysign(1.0, f0)
    hi = side
    while (surge(hi) > 0.0) == (f0 > 0.0):
        hi *= 2.0
        if abs(hi) > 1e3:  # (no damping that stops it: let the full solve fail)
            return np.array([side, 0.0, 0.0])
    return np.array([brentq(surge, 0.0, hi, xtol=1e-12), 0.0, 0.0])


_SWEEP_STEP = 0.02
"""Command step of the continuation along the turning branch (:func:`tightest_turn`)."""


def _branch(hydro, thrusters, commands_of, start_nu) -> list:
    """Steady states along ``commands_of(x)`` for x from 0 to 1 in steps of :data:`_SWEEP_STEP`,
    each solved from the previous one (continuation: the sweep stays on one branch of steady
    states — a course-unstable hull also has a near-straight branch under the same commands).
    Returns [(x, ν)] up to the first command where no steady state is found."""
    out, nu = [], start_nu
    for x in np.linspace(0.0, 1.0, int(round(1.0 / _SWEEP_STEP)) + 1):
        nu = steady_state(hydro, thrusters, commands_of(float(x)), nu)
        if nu is None:
            break
        out.append((float(x), nu))
    return out


def tightest_turn(hydro, thrusters, speed_m_s: float) -> SteadyTurn | None:
    """The tightest steady turn (to port) of vessel 0 at the speed over ground ``speed_m_s``
    [m/s] in still water (module docstring), or None when the hull sails no steady turn at that
    speed (too fast for any turn, or a hull whose steady states the solve does not find)."""
    target = float(speed_m_s)
    if not (math.isfinite(target) and target > 0):
        raise ValueError(f"speed_m_s: must be finite and > 0, got {speed_m_s}")
    signed = lambda nu: math.copysign(math.hypot(nu[0], nu[1]), nu[0])  # noqa: E731  (< 0: astern)
    spin = steady_state(hydro, thrusters, (-1.0, 1.0))  # full astern against full ahead
    if spin is None:  # (a hull without a steady turn: nothing balances its yaw moment)
        return None
    if signed(spin) <= target:  # the outer (starboard) propeller at full ahead, the inner one eased up
        commands_of = lambda x: (-1.0 + 2.0 * x, 1.0)  # noqa: E731
    else:  # the inner at full astern, the outer eased down (the hull ends going astern)
        commands_of = lambda x: (-1.0, 1.0 - 2.0 * x)  # noqa: E731
    branch = _branch(hydro, thrusters, commands_of, spin)
    for (x0, nu0), (x1, nu1) in zip(branch, branch[1:]):
        f0, f1 = signed(nu0) - target, signed(nu1) - target
        if f0 == 0.0 or (f0 < 0.0) != (f1 < 0.0):
            break
    else:
        return None  # never that fast on the branch: the hull cannot turn at that speed (or sail it)

    def gap(x):
        nu = steady_state(hydro, thrusters, commands_of(x), nu0)
        if nu is None:
            raise ArithmeticError(f"no steady state under the commands {commands_of(x)}")
        return signed(nu) - target

    try:
        x = brentq(gap, x0, x1, xtol=1e-13) if f0 != 0.0 else x0
    except ArithmeticError:  # (no steady state between two that were found: treated as none)
        return None
    commands = tuple(float(c) for c in commands_of(x))
    nu = steady_state(hydro, thrusters, commands, nu0)
    if nu is None:
        return None
    u, v, r = (float(c) for c in nu)
    return SteadyTurn(speed_m_s=math.hypot(u, v), surge_m_s=u, sway_m_s=v, yaw_rate_rad_s=r, commands=commands)


@functools.lru_cache(maxsize=64)
def _tightest_of(vessel_type, speed_m_s: float):
    from mjasc.physics.simulation import Simulation
    from mjasc.physics.world import build_world

    sim = Simulation(build_world([("turn", vessel_type)]))
    return tightest_turn(sim.hydro, sim.thrusters, speed_m_s)


def tightest_turn_of_type(vessel_type, speed_m_s: float) -> SteadyTurn | None:
    """:func:`tightest_turn` of a :class:`~mjasc.physics.vessels.VesselType` (its compiled MJCF's
    rigid-body mass, its hydrodynamics and propellers), memoised per type and speed."""
    return _tightest_of(vessel_type, float(speed_m_s))


def smallest_turn_radius_m(turn: SteadyTurn) -> float:
    """The turn's radius rounded *up* to the centimetre [m]: the smallest go-to-formation
    ``turn_radius_m`` written to two decimals that the scenario check accepts (the value its error
    and ``mjasc trial tightest-turn`` name)."""
    limit = math.ceil(turn.radius_m * 100.0) / 100.0
    return limit + 0.01 if limit < turn.radius_m else limit  # (x·100 rounded down to a whole number)
