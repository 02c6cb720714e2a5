"""Velocity correction: stay on the path, change speed to keep out of the obstructed stretch.

Digest §5 (thesis §4.2, eqs. 4.36–4.42). Collision prediction reports that the obstacle occupies
the stretch [γ_A, γ_B] of the vessel's path during [t_i, t_f]; the vessel avoids it if
γ(t) ∉ [γ_A, γ_B] for all t ∈ [t_i, t_f] (thesis eq. 4.37). A *virtual target* moves along the
path at constant speed from (γ₀, t₀) to a goal (γ_g, t_g):

    V_d = (γ_g − γ₀)/(t_g − t₀),   γ_d(t) = γ₀ + V_d (t − t₀)
    v_cmd = sat(V_d − k (γ − γ_d))                (error γ − γ_d decays as e^(−k t))

saturated to the vessel's speed range [speed_min, speed_max]. Goal (γ_A, t_f) slows down and lets
the obstacle pass (:meth:`VelocityCorrection.yield_to`); goal (γ_B, t_i) speeds up and passes first
(:meth:`VelocityCorrection.pass_first`), which may need more speed than the vessel has: the
correction records how long its command was saturated so that the caller can see it failing.

Path parameter γ in metres of arc length, speeds in m/s along the path, absolute times in s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mjasc.core.compiled import clip_float


def _finite(value, name: str) -> float:
    v = float(value)
    if not np.isfinite(v):
        raise ValueError(f"{name}: must be finite, got {value}")
    return v


class VelocityCorrection:
    """The virtual-target speed law of thesis eq. 4.42 for one conflict.

    Parameters are read-only; :meth:`command` also keeps a record of saturation (the time the
    command spent clipped at a speed limit since the first call), see :attr:`saturated_fraction`.
    """

    __slots__ = (
        "_g0", "_t0", "_gg", "_tg", "_k", "_vmin", "_vmax", "_vd",
        "_last_t", "_last_sat", "_sat_time", "_run_time",
    )

    def __init__(self, gamma0, t0, gamma_goal, t_goal, gain_k, speed_min, speed_max):
        self._g0 = _finite(gamma0, "gamma0")
        self._t0 = _finite(t0, "t0")
        self._gg = _finite(gamma_goal, "gamma_goal")
        self._tg = _finite(t_goal, "t_goal")
        self._k = _finite(gain_k, "gain_k")
        self._vmin = _finite(speed_min, "speed_min")
        self._vmax = _finite(speed_max, "speed_max")
        if self._tg <= self._t0:
            raise ValueError(f"t_goal: must be later than t0 ({t0}), got {t_goal}")
        if self._k <= 0.0:
            raise ValueError(f"gain_k: must be > 0, got {gain_k}")
        if self._vmax <= self._vmin:
            raise ValueError(f"speed_max: must exceed speed_min ({speed_min}), got {speed_max}")
        self._vd = (self._gg - self._g0) / (self._tg - self._t0)  # thesis eq. 4.38
        self._last_t = None
        self._last_sat = False
        self._sat_time = 0.0
        self._run_time = 0.0

    # ------------------------------------------------------------------ constructors
    @classmethod
    def yield_to(cls, conflict, gamma_now, t_now, gain_k, speed_min, speed_max, margin_m=0.0):
        """Slow down: reach γ_A − margin at t_f, letting the obstacle pass first.

        ``conflict``: a :class:`~mjasc.avoidance.prediction.PredictedConflict` (anything with
        gamma_a, gamma_b, t_i, t_f)."""
        g_a, t_f = _finite(conflict.gamma_a, "conflict.gamma_a"), float(conflict.t_f)
        if not np.isfinite(t_f):
            raise ValueError("conflict.t_f: infinite (a static obstruction): re-plan instead")
        g_goal = g_a - float(margin_m)
        if g_goal <= float(gamma_now):
            raise ValueError(
                f"conflict.gamma_a: the vessel (γ = {float(gamma_now):g} m) is already at or past "
                f"γ_A − margin = {g_goal:g} m; slowing down cannot keep it out"
            )
        if t_f <= float(t_now):
            raise ValueError(f"conflict.t_f: {t_f:g} s is not after t_now = {float(t_now):g} s")
        return cls(gamma_now, t_now, g_goal, t_f, gain_k, speed_min, speed_max)

    @classmethod
    def pass_first(cls, conflict, gamma_now, t_now, gain_k, speed_min, speed_max, margin_m=0.0):
        """Speed up: reach γ_B + margin at t_i, passing before the obstacle arrives."""
        g_b, t_i = _finite(conflict.gamma_b, "conflict.gamma_b"), _finite(conflict.t_i, "conflict.t_i")
        if t_i <= float(t_now):
            raise ValueError(f"conflict.t_i: {t_i:g} s is not after t_now = {float(t_now):g} s")
        g_goal = g_b + float(margin_m)
        if g_goal <= float(gamma_now):
            raise ValueError(f"conflict.gamma_b: the vessel (γ = {float(gamma_now):g} m) is already past it")
        return cls(gamma_now, t_now, g_goal, t_i, gain_k, speed_min, speed_max)

    # ------------------------------------------------------------------ the law
    gamma0 = property(lambda self: self._g0)
    t0 = property(lambda self: self._t0)
    gamma_goal = property(lambda self: self._gg)
    t_goal = property(lambda self: self._tg)
    gain_k = property(lambda self: self._k)
    speed_min = property(lambda self: self._vmin)
    speed_max = property(lambda self: self._vmax)

    @property
    def desired_speed(self) -> float:
        """V_d [m/s], the virtual target's constant speed (thesis eq. 4.38)."""
        return self._vd

    @property
    def feasible(self) -> bool:
        """speed_min ≤ V_d ≤ speed_max: the goal is reachable without saturating in steady state."""
        return self._vmin <= self._vd <= self._vmax

    def gamma_desired(self, t):
        """γ_d(t) = γ₀ + V_d (t − t₀) [m] (thesis eq. 4.39); scalar or array."""
        if type(t) is float:  # (the record tick's and the commands' scalar: the same operations on floats)
            return self._g0 + self._vd * (t - self._t0)
        g = self._g0 + self._vd * (np.asarray(t, dtype=float) - self._t0)
        return float(g) if np.ndim(g) == 0 else g

    def unsaturated_command(self, gamma, t):
        """V_d − k (γ − γ_d(t)) [m/s] before saturation (thesis eq. 4.42)."""
        u = self._vd - self._k * (np.asarray(gamma, dtype=float) - self.gamma_desired(t))
        return float(u) if np.ndim(u) == 0 else u

    def command(self, gamma: float, t: float) -> float:
        """Speed command [m/s] = sat(V_d − k (γ − γ_d(t))) at the vessel's γ and time t.

        Each call also advances the saturation record: the interval since the previous call
        counts as saturated if the previous command was saturated (zero-order hold)."""
        t = float(t)
        # unsaturated_command(γ, t) and np.clip in plain floats (the same operations; the control
        # tick asks once per vessel in a correction)
        u = self._vd - self._k * (float(gamma) - (self._g0 + self._vd * (t - self._t0)))
        v = clip_float(u, self._vmin, self._vmax)
        if self._last_t is not None and t > self._last_t:
            dt = t - self._last_t
            self._run_time += dt
            if self._last_sat:
                self._sat_time += dt
        self._last_t = t
        self._last_sat = v != u
        return v

    def is_saturated(self, gamma: float, t: float) -> bool:
        """Whether the command at (γ, t) is clipped at a speed limit (does not touch the record)."""
        u = self.unsaturated_command(float(gamma), float(t))
        return not (self._vmin <= u <= self._vmax)

    @property
    def saturated_now(self) -> bool:
        """Whether the last command was saturated."""
        return self._last_sat

    @property
    def saturated_time_s(self) -> float:
        """Time [s] the command spent saturated, between the first and the last call."""
        return self._sat_time

    @property
    def saturated_fraction(self) -> float:
        """Fraction of the time between the first and the last call spent saturated (0 before)."""
        return self._sat_time / self._run_time if self._run_time > 0.0 else 0.0

    def finished(self, t: float) -> bool:
        """The goal time has been reached: the conflict is over, the mission speed may resume."""
        return float(t) >= self._tg

    def __repr__(self) -> str:
        return (
            f"VelocityCorrection(γ0={self._g0:g}, t0={self._t0:g} → γg={self._gg:g}, tg={self._tg:g}; "
            f"V_d={self._vd:.4g} m/s, k={self._k:g}, speed ∈ [{self._vmin:g}, {self._vmax:g}])"
        )


@dataclass(frozen=True)
class SpeedTrackingResult:
    """Output of :func:`simulate_speed_tracking`: arrays (n,) on the simulation grid."""

    times: np.ndarray
    gammas: np.ndarray
    speeds: np.ndarray
    commands: np.ndarray

    def gamma_at(self, t):
        return np.interp(t, self.times, self.gammas)


def simulate_speed_tracking(
    correction: VelocityCorrection,
    gamma0: float,
    speed0: float,
    t0: float,
    t_end: float,
    dt: float = 0.05,
    time_constant_s: float = 0.0,
    control_period_s: float | None = None,
) -> SpeedTrackingResult:
    """A kinematic stand-in for the vessel, for tests and quick studies: γ̇ = v, and the speed
    follows the command instantly (``time_constant_s`` = 0) or with a first-order lag
    τ v̇ = u − v (exact discretization). The command is recomputed every ``control_period_s``
    (default: every step) and held in between.

    With instant response and control period T the error obeys e_{n+1} = (1 − kT) e_n: stable
    for kT < 2, dead-beat at kT = 1, and an undamped oscillation at kT = 2 (thesis k = 2, Ts = 1).
    """
    dt = float(dt)
    if not np.isfinite(dt) or dt <= 0.0:
        raise ValueError(f"dt: must be finite and > 0, got {dt}")
    if float(t_end) <= float(t0):
        raise ValueError(f"t_end: must be later than t0 ({t0}), got {t_end}")
    tau = float(time_constant_s)
    if not np.isfinite(tau) or tau < 0.0:
        raise ValueError(f"time_constant_s: must be finite and ≥ 0, got {time_constant_s}")
    period = dt if control_period_s is None else float(control_period_s)
    if not np.isfinite(period) or period < dt - 1e-12:
        raise ValueError(f"control_period_s: must be ≥ dt ({dt}), got {control_period_s}")
    n = int(np.ceil((float(t_end) - float(t0)) / dt - 1e-9)) + 1
    times = float(t0) + dt * np.arange(n)
    gammas, speeds, commands = np.empty(n), np.empty(n), np.empty(n)
    g, v = float(gamma0), float(speed0)
    alpha = 1.0 if tau == 0.0 else 1.0 - np.exp(-dt / tau)
    u, next_control = None, times[0]
    for i, t in enumerate(times):
        if u is None or t >= next_control - 1e-9:
            u = correction.command(g, t)
            next_control += period
        if tau == 0.0:
            v = u
        gammas[i], speeds[i], commands[i] = g, v, u
        # exact over the step for a held command: v(s) = u + (v − u) e^(−s/τ)
        g += u * dt + ((v - u) * tau * alpha if tau > 0.0 else 0.0)
        v = v + alpha * (u - v)
    return SpeedTrackingResult(times, gammas, speeds, commands)
