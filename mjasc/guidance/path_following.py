"""Single-vessel path following: integral line-of-sight guidance, heading and speed loops.

Guidance: integral LOS (Børhaug, Pavlov & Pettersen 2008; Fossen 2021 §12.4). With γ the vessel's
projection on the path, χ_p the path's course there and e the signed cross-track error (positive
when the vessel is left of the path)::

    ψ_d = χ_p − atan((e + σ e_i) / Δ)         desired heading, lookahead Δ [m], integral gain σ
    ė_i = Δ e / (Δ² + (e + σ e_i)²)           integral of the cross-track error (bounded rate)

In a constant current the integral term settles at the crab angle that cancels the drift, so the
cross-track error converges to zero (the tests check it). Measuring the crab angle and feeding it
back instead couples the sway dynamics into the heading loop and oscillated on the Otter.

Heading loop: the yaw dynamics M_33 ṙ ≈ N + N_r r give, for a closed loop of natural frequency ω_ψ
and damping ζ, ``N = −M_33 ω_ψ² (e_ψ + ∫e_ψ/T_i) − (2ζω_ψ M_33 + N_r)(r − r_d) − N_r r_d`` with the
path's turn rate r_d = κ u as feed-forward. The integral removes the steady heading error that a
crab in a cross current causes (the Munk moment (X_u̇ − Y_v̇) u_r v_r and cross-flow drag). Speed loop: feed-forward of the damping at the desired speed
plus PI on the surge error. Allocation to the twin propellers at y = ±d:
``T_s + T_p = X``, ``d (T_s − T_p) = N`` (FLU: more starboard thrust turns left), then the inverse
propeller curve gives the normalized commands; when saturated, yaw moment has priority.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mjasc.core.config_tables import check_params, param
from mjasc.core.frames import wrap_angle
from mjasc.guidance.paths import Path
from mjasc.physics.vessels import VesselType

__all__ = ["PathFollowingConfig", "PathFollowingStatus", "PathFollower"]


@dataclass(frozen=True)
class PathFollowingConfig:
    """Gains and limits. None = derived from the vessel (lookahead 3 hull lengths, min 5 m)."""

    lookahead_m: float | None = param(None, positive=True, unit="m",
                                      doc="LOS lookahead Δ (none: 3 hull lengths, at least 5 m)")
    heading_bandwidth_rad_s: float = param(1.5, positive=True, unit="rad/s",
                                           doc="heading loop natural frequency ω_ψ (≥ 1.2 needed: the Otter "
                                               "is directionally unstable above 1.2 m/s)")
    heading_damping_ratio: float = param(0.9, positive=True, doc="heading loop damping ratio ζ")
    heading_integral_time_s: float = param(20.0, positive=True, unit="s",
                                           doc="heading integral time T_i: integral action against steady yaw "
                                               "moments (Munk, cross-flow)")
    speed_bandwidth_rad_s: float = param(0.8, positive=True, unit="rad/s", doc="speed loop bandwidth")
    speed_integral_gain_ratio: float = param(0.25, nonneg=True, unit="1/s", doc="speed loop K_i = ratio · K_p")
    integral_los_gain: float = param(0.5, positive=True, doc="σ of integral LOS")
    finish_tolerance_m: float = param(0.5, nonneg=True, unit="m",
                                      doc="the path is finished within this arc length of its end")

    def __post_init__(self):
        check_params(self, "path_following")


@dataclass(frozen=True)
class PathFollowingStatus:
    """What the follower did at one control tick (world frame, SI)."""

    gamma_m: float
    cross_track_m: float
    course_ref_rad: float  # path course χ_p at γ
    heading_ref_rad: float
    speed_ref_m_s: float
    finished: bool


class PathFollower:
    """Follows one :class:`Path` at a commanded speed with one vessel's twin propellers."""

    def __init__(self, path: Path, vessel: VesselType, total_mass: np.ndarray, lateral_offset_m: float,
                 config: PathFollowingConfig = PathFollowingConfig(), gamma0_m: float = 0.0):
        self.path = path
        self.vessel = vessel
        self.config = config
        self.lookahead_m = config.lookahead_m or max(3.0 * vessel.length_m, 5.0)
        m = np.asarray(total_mass, dtype=float)
        self._m11, self._m33 = float(m[0, 0]), float(m[2, 2])
        h = vessel.hydro
        self._xu, self._xuu, self._nr = h.X_u, h.X_uu, h.N_r
        w, z = config.heading_bandwidth_rad_s, config.heading_damping_ratio
        self._kp_psi = self._m33 * w * w
        self._kd_psi = max(2 * z * w * self._m33 + self._nr, 0.0)  # N_r < 0 already damps
        self._kp_u = self._m11 * config.speed_bandwidth_rad_s
        self._ki_u = config.speed_integral_gain_ratio * self._kp_u
        self._d = abs(float(lateral_offset_m))
        self._tmax = vessel.propellers.max_thrust_n
        self._tmin = vessel.propellers.k_reverse * vessel.propellers.n_min_rad_s**2  # reverse thrust magnitude [N]
        self.gamma_m = float(gamma0_m)
        self._xte_integral = 0.0
        self._speed_integral = 0.0
        self._heading_integral = 0.0
        self._heading_integral = 0.0
        self._n_limit = 0.5 * (self._tmax + self._tmin) * 2 * self._d  # largest yaw moment [N·m]

    def reset(self, gamma0_m: float = 0.0) -> None:
        self.gamma_m = float(gamma0_m)
        self._xte_integral = 0.0
        self._speed_integral = 0.0
        self._heading_integral = 0.0

    def set_path(self, path: Path, gamma0_m: float = 0.0) -> None:
        """Switch to a new path (e.g. a re-planned detour) keeping the loop states."""
        self.path = path
        self.gamma_m = float(gamma0_m)

    def command(self, position_m, heading_rad: float, velocity_m_s, body_velocity, speed_ref_m_s: float,
                dt_s: float) -> tuple[np.ndarray, PathFollowingStatus]:
        """Normalized (port, starboard) commands for one vessel and the tick's status.

        position_m (2,), velocity_m_s (2,) world; body_velocity (3,) = (u, v, r); dt_s control period.
        """
        path, cfg = self.path, self.config
        window = max(4.0 * self.lookahead_m, 20.0)
        self.gamma_m = path.project(position_m, gamma_hint=self.gamma_m, search_window_m=window)
        e = path.cross_track_error(position_m, self.gamma_m)
        finished = self.gamma_m >= path.length - cfg.finish_tolerance_m
        chi_p = float(path.tangent_angle(self.gamma_m))
        delta, sigma = self.lookahead_m, cfg.integral_los_gain
        e_eff = e + sigma * self._xte_integral
        psi_d = wrap_angle(chi_p - np.arctan2(e_eff, delta))
        if not finished:
            self._xte_integral += dt_s * delta * e / (delta**2 + e_eff**2)
        u, r = float(body_velocity[0]), float(body_velocity[2])
        u_d = 0.0 if finished else float(speed_ref_m_s)
        r_d = float(path.curvature(self.gamma_m)) * u
        e_psi = wrap_angle(heading_rad - psi_d)
        n_i = -self._kp_psi / cfg.heading_integral_time_s * self._heading_integral
        n_cmd = -self._kp_psi * e_psi - self._kd_psi * (r - r_d) - self._nr * r_d + n_i
        e_u = u_d - u
        x_cmd = -self._xu * u_d - self._xuu * abs(u_d) * u_d + self._kp_u * e_u + self._ki_u * self._speed_integral
        thrust, saturated = self._allocate(x_cmd, n_cmd)
        if not saturated:  # conditional integration: no wind-up while the propellers saturate
            self._speed_integral += e_u * dt_s
            if abs(e_psi) < 0.5:  # integrate only near the reference: not through large turns
                self._heading_integral += e_psi * dt_s
        if finished:
            self._speed_integral = 0.0
        cmd = self.vessel.propellers.command_for_thrust(thrust)
        status = PathFollowingStatus(self.gamma_m, e, chi_p, float(psi_d), u_d, bool(finished))
        return cmd, status

    def _allocate(self, x: float, n: float) -> tuple[np.ndarray, bool]:
        """(T_port, T_starboard) for surge force x and yaw moment n; yaw has priority."""
        half_diff = 0.5 * n / self._d
        half_diff = float(np.clip(half_diff, -(self._tmax + self._tmin) / 2, (self._tmax + self._tmin) / 2))
        lo = -self._tmin + abs(half_diff)
        hi = self._tmax - abs(half_diff)
        half_sum = 0.5 * x
        saturated = not (lo <= half_sum <= hi) or abs(0.5 * n / self._d) > abs(half_diff)
        half_sum = float(np.clip(half_sum, lo, hi))
        return np.array([half_sum - half_diff, half_sum + half_diff]), saturated
