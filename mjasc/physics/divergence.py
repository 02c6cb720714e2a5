"""Divergence of the physics, checked at every physics step: bounds per vessel type, first bad step.

A state diverges when a vessel's generalized velocity or acceleration is non-finite or beyond what
its hull can do. The bounds of vessel i (type with top speed U_i) are::

    speed over ground  √(ẋ² + ẏ²)  ≤ speed_factor · U_i + current_allowance_m_s     [m/s]
    yaw rate           |r|          ≤ yaw_rate_rad_s                                 [rad/s]
    acceleration       √(ẍ² + ÿ²)  ≤ acceleration_m_s2                              [m/s²]
    yaw acceleration   |ṙ|          ≤ yaw_acceleration_rad_s2                        [rad/s²]

(declared once in :class:`DivergenceBounds`; the acceleration bounds leave room for hull contacts).

**Cost.** Every step runs one fast test on the whole fleet, two dot products straight on MjData's
``qvel`` and ``qacc`` (no copy)::

    Σ_dofs q̇² ≤ v_fast²   and   Σ_dofs q̈² ≤ a_fast²

with v_fast = the smallest speed or yaw-rate bound, a_fast the smallest acceleration bound. Each
term of a sum is at most the sum, so passing the fast test proves every bound holds; NaN fails any
comparison, so a non-finite state always reaches the exact test. When it fails (a fleet of more
than ~10 vessels, whose sum is large; or a real divergence) a second test scales each dof by its
own bound, Σ (q̇_k / bound_k)² ≤ 1 (:meth:`DivergenceMonitor.scaled_ok`); only when that fails
too does :meth:`DivergenceMonitor.violation` check each vessel against its own bounds. Per block
of steps the state at its start is kept (``mj_getState``, 1.4 µs): on a violation the block is
replayed to the step before it, the last good state. Measured (one process, shared machine): the
per-step test costs 1.2 µs with 3 Otters (a physics step: ~60 µs, so 2 %) and 3.4 µs with 50
(the scaled test included; step ~185 µs: 1.9 %).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mjasc.core.config_tables import check_params, param

__all__ = ["DivergenceBounds", "DivergenceMonitor", "PhysicsDivergence"]


class PhysicsDivergence(RuntimeError):
    """The physics diverged: a vessel's velocity or acceleration non-finite or beyond its type's
    bounds (:class:`DivergenceMonitor`), or a MuJoCo warning; the message says when, which
    vessel and which quantity. ``last_good_state`` is the full MuJoCo integration state
    (``mj_getState``, :data:`mjasc.physics.simulation.STATE_SPEC`) at the end of the last step that
    passed the checks (raised by :meth:`mjasc.physics.simulation.Simulation.step`)."""

    def __init__(self, message: str, last_good_state: np.ndarray | None = None, last_good_time_s: float | None = None):
        super().__init__(message)
        self.last_good_state = last_good_state
        self.last_good_time_s = last_good_time_s


@dataclass(frozen=True)
class DivergenceBounds:
    """What a vessel can plausibly do; beyond it the physics has diverged (module docstring)."""

    speed_factor: float = param(5.0, positive=True, doc="speed bound in top speeds of the vessel type")
    current_allowance_m_s: float = param(10.0, nonneg=True, unit="m/s",
                                         doc="added to the speed bound: the strongest current a scenario may have")
    yaw_rate_rad_s: float = param(2 * math.pi, positive=True, unit="rad/s", doc="yaw rate bound (a turn a second)")
    acceleration_m_s2: float = param(1000.0, positive=True, unit="m/s²",
                                     doc="acceleration bound (about 100 g: far beyond propellers, room for contacts)")
    yaw_acceleration_rad_s2: float = param(1000.0, positive=True, unit="rad/s²", doc="yaw acceleration bound")

    def __post_init__(self):
        check_params(self, "divergence")


class DivergenceMonitor:
    """Tests the vessels' velocities and accelerations against their types' bounds.

    qvel, qacc: MjData's generalized velocity and acceleration arrays (nv,), kept as they are (the
    fast test reads them in place); dof_adr: (N, 3) indices of each vessel's (ẋ, ẏ, r) world-frame
    dofs in them; top_speeds_m_s: (N,) the vessel types' top speeds; names: the vessels' names.
    """

    def __init__(self, qvel: np.ndarray, qacc: np.ndarray, dof_adr, top_speeds_m_s, names,
                 bounds: DivergenceBounds | None = None):
        self.bounds = b = bounds or DivergenceBounds()
        self.names = list(names)
        self.speed_limit = b.speed_factor * np.asarray(top_speeds_m_s, dtype=float) + b.current_allowance_m_s
        self.qvel, self.qacc = qvel, qacc
        self.dof_adr = np.asarray(dof_adr, dtype=int).reshape(-1, 3)
        v = min(float(self.speed_limit.min()) if len(self.names) else np.inf, b.yaw_rate_rad_s)
        a = min(b.acceleration_m_s2, b.yaw_acceleration_rad_s2)
        self.fast_speed2, self.fast_acc2 = v * v, a * a
        # Per-dof inverse bounds for scaled_ok (dofs of no vessel: the tightest bounds).
        nv = len(qvel)
        self._inv_vel = np.full(nv, 1.0 / v if np.isfinite(v) else 0.0)
        self._inv_acc = np.full(nv, 1.0 / a)
        for i, adr in enumerate(self.dof_adr):
            self._inv_vel[adr] = [np.sqrt(2.0) / self.speed_limit[i]] * 2 + [1.0 / b.yaw_rate_rad_s]
            self._inv_acc[adr] = [np.sqrt(2.0) / b.acceleration_m_s2] * 2 + [1.0 / b.yaw_acceleration_rad_s2]
        self._buf = np.zeros(nv)

    def fast_ok(self) -> bool:
        """The fast test (module docstring): True proves every bound holds (callers inline it)."""
        return self.qvel.dot(self.qvel) <= self.fast_speed2 and self.qacc.dot(self.qacc) <= self.fast_acc2

    def scaled_ok(self) -> bool:
        """The second test, when the fast one fails: Σ (q̇ / bound)² ≤ 1 and Σ (q̈ / bound)² ≤ 1 over
        the dofs, each scaled by its own vessel's bound (per component: the speed bound / √2, so that
        both components within it keep the speed within its bound). True proves every bound holds;
        it fails only for a real violation or a fleet of ~100 vessels and more (then
        :meth:`violation` decides, at ~30 µs)."""
        np.multiply(self.qvel, self._inv_vel, out=self._buf)
        if not self._buf.dot(self._buf) <= 1.0:
            return False
        np.multiply(self.qacc, self._inv_acc, out=self._buf)
        return bool(self._buf.dot(self._buf) <= 1.0)

    def violation(self, time_s: float) -> str | None:
        """The first bound broken now, as ``"t = 1.240 s: vessel 'alpha' speed 92459 m/s beyond its
        bound 25 m/s"``; None when every vessel is within its bounds."""
        qd, qa = self.qvel[self.dof_adr], self.qacc[self.dof_adr]
        b = self.bounds
        with np.errstate(all="ignore"):
            checks = (
                ("speed", np.hypot(qd[:, 0], qd[:, 1]), self.speed_limit, "m/s"),
                ("yaw rate", np.abs(qd[:, 2]), np.full(len(qd), b.yaw_rate_rad_s), "rad/s"),
                ("acceleration", np.hypot(qa[:, 0], qa[:, 1]), np.full(len(qd), b.acceleration_m_s2), "m/s²"),
                ("yaw acceleration", np.abs(qa[:, 2]), np.full(len(qd), b.yaw_acceleration_rad_s2), "rad/s²"),
            )
        for quantity, value, limit, unit in checks:
            bad = ~(value <= limit)  # NaN is bad
            if np.any(bad):
                i = int(np.flatnonzero(bad)[0])
                what = "is non-finite" if not np.isfinite(value[i]) else \
                    f"{value[i]:.6g} {unit} beyond its bound {limit[i]:.6g} {unit}"
                return f"t = {time_s:.3f} s: vessel {self.names[i]!r} {quantity} {what}"
        return None
