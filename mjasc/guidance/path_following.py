"""Path following for a fleet: the followers of every vessel as rows of arrays, one command for all.

The law itself — integral line-of-sight guidance, heading and speed loops, allocation to the twin
propellers, with a course override — is :mod:`mjasc.guidance.following_law`.

One copy of the law for a fleet: :class:`FleetPathFollower` holds every vessel's parameters and
loop states (γ, the LOS, speed and heading integrals) as rows of arrays and their paths stacked
(:class:`~mjasc.guidance.stacked_paths.StackedPaths`); one :meth:`~FleetPathFollower.command`
projects every vessel on its path and runs the law for all of them. The law (:func:`~mjasc.guidance.following_law.law`) is
written once over a table of operations: above :data:`SCALAR_FLEET_MAX` vessels it runs once over
arrays (the projection in one vectorized pass over each vessel's window of segments); up to it,
vessel by vessel in plain floats (each path's scalar projection), because numpy's per-call
overhead, not arithmetic, is the cost of small fleets. The plain-float form is :func:`~mjasc.guidance.following_law.law_floats`,
the float operations written out (a Python call per operation cost more than the law's arithmetic);
a test holds it to ``law(FloatOps, …)`` bit for bit on the demo. The control tick runs that form
compiled: projection, law and inverse propeller curve of every vessel in one call
(:func:`~mjasc.guidance.follow_kernel.follow_fleet`, held to :meth:`FleetPathFollower._command_floats`
bit for bit by ``tests/test_follow_kernel.py``; the Python form stays as the fallback for a
position that is not finite). Both forms give the same bits (elementwise
operations in the same order, ``x**2`` through the C library's pow in both; ``math``'s sin, cos
and atan2 equal numpy's on x86-64 without AVX-512, elsewhere they may differ in the last bit), so
a vessel's commands do not depend on the fleet it is in (``tests/test_fleet_following.py``).
:class:`PathFollower` is one vessel's follower: a row of a fleet (its own fleet of one until
:meth:`FleetPathFollower.of` gathers several followers into one, as the runner's control slot does).
"""

from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from mjasc.core.config_tables import check_params, param
from mjasc.guidance import following_law
from mjasc.guidance.following_law import GAMMA, KF, KR, LOOKAHEAD, NMAX, NMIN, WINDOW, ArrayOps, law, law_parameters
from mjasc.guidance.follow_kernel import follow_fleet
from mjasc.guidance.paths import Path
from mjasc.guidance.stacked_paths import StackedPaths
from mjasc.physics.thrusters import PropellerCoefficients, command_for_thrust_scalar
from mjasc.physics.vessels import VesselType
from mjasc.plugins.stages import ControlMethod

__all__ = ["PathFollowingConfig", "PathFollowingStatus", "FleetPathFollower", "PathFollower", "SCALAR_FLEET_MAX"]


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


#: Up to this many vessels a command runs the law vessel by vessel in plain floats (cheaper than
#: numpy's per-call overhead); above, once over arrays. Both give the same bits.
SCALAR_FLEET_MAX = 20


class FleetPathFollower:
    """The path followers of n vessels: parameters (n_params, n) and loop states (4, n) as arrays,
    the paths stacked. Build it from followers with :meth:`of`."""

    def __init__(self, params: np.ndarray, states: np.ndarray, paths):
        self._P = np.array(params, dtype=float).reshape(19, -1)
        self._S = np.array(states, dtype=float).reshape(4, -1)
        self.paths = StackedPaths(paths)
        self._members: list = []
        self._prop = self._propellers(None)
        self._P_cols = self._P.T.tolist()
        self._all_rows = np.arange(self._S.shape[1], dtype=np.intp)
        self._scratch = None  # command_all's speed and course (n,) and status (n, 6) arrays

    def __len__(self) -> int:
        return self._S.shape[1]

    def _propellers(self, rows):
        """The propeller coefficients as (k, 1) columns, for the inverse propeller curve."""
        P = self._P if rows is None else self._P[:, rows]
        return SimpleNamespace(k_forward=P[KF, :, None], k_reverse=P[KR, :, None],
                               n_max_rad_s=P[NMAX, :, None], n_min_rad_s=P[NMIN, :, None])

    @classmethod
    def of(cls, followers) -> "FleetPathFollower":
        """The one fleet whose rows are ``followers`` in order: theirs if they already form one,
        else a new fleet that takes over their states and paths (they become its rows)."""
        followers = list(followers)
        fleet = followers[0]._fleet if followers else None
        if fleet is not None and fleet._members == followers:
            for f in followers:  # (a loop, not all() of a generator: the control slot asks every tick)
                if f._fleet is not fleet:
                    break
            else:
                return fleet
        params = np.column_stack([f._fleet._P[:, f._row] for f in followers]) if followers else np.zeros((19, 0))
        states = np.column_stack([f._fleet._S[:, f._row] for f in followers]) if followers else np.zeros((4, 0))
        new = cls(params, states, [f.path for f in followers])
        new._members = followers
        for k, f in enumerate(followers):
            f._fleet, f._row = new, k
        return new

    @property
    def gamma_m(self) -> np.ndarray:
        """Each vessel's γ on its current path (n,) [m] (read-only view)."""
        v = self._S[GAMMA].view()
        v.flags.writeable = False
        return v

    def guidance_rows(self) -> tuple[list, list[float]]:
        """Each row's path followed now and γ on it [m] (lists in row order; what each follower's
        ``path`` and ``gamma_m`` give, read once for the fleet)."""
        return self.paths.paths, self._S[GAMMA].tolist()

    def set_path(self, i: int, path: Path, gamma0_m: float = 0.0) -> None:
        """Vessel i switches to ``path`` at γ = gamma0_m (e.g. a re-planned detour), keeping its loop states."""
        self.paths.set_path(i, path)
        self._S[GAMMA, i] = float(gamma0_m)

    def command(self, position_m, heading_rad, body_velocity, speed_ref_m_s, dt_s: float,
                rows=None, course_override_rad=None) -> tuple[np.ndarray, list[PathFollowingStatus]]:
        """Normalized (port, starboard) commands (k, 2) and each vessel's status at this tick, for
        the vessels ``rows`` (k,) (None: all n, in order).

        position_m (k, 2) world [m]; heading_rad (k,); body_velocity (k, 3) = (u, v, r);
        speed_ref_m_s (k,) [m/s]; dt_s the control period [s]; course_override_rad (k,) [rad, ENU,
        CCW from east] or None: a vessel with a finite entry steers that course instead of its LOS
        course (collision avoidance's steering, e.g. velocity obstacles) while γ keeps following its
        path, so it returns to the path when the override ends; NaN = no override (the same bits as
        without the argument).
        """
        pos = np.asarray(position_m, dtype=float)
        bv = np.asarray(body_velocity, dtype=float)
        idx = range(len(self)) if rows is None else [int(i) for i in rows]
        course = (np.full(len(idx), np.nan) if course_override_rad is None
                  else np.asarray(course_override_rad, dtype=float).reshape(len(idx)))
        if len(idx) <= SCALAR_FLEET_MAX:
            done = self._command_compiled(idx, pos, heading_rad, bv, speed_ref_m_s, dt_s, course, rows)
            if done is not None:
                return done
            thrust, statuses = self._command_floats(idx, pos.tolist(), np.asarray(heading_rad, dtype=float).tolist(),
                                                    bv.tolist(), np.asarray(speed_ref_m_s, dtype=float).tolist(), dt_s,
                                                    course.tolist())
            cols = self._P_cols
            return np.array([[command_for_thrust_scalar(t, *cols[i][KF:NMIN + 1]) for t in pair]
                             for i, pair in zip(idx, thrust)]).reshape(-1, 2), statuses  # the inverse curve
        else:
            thrust, statuses = self._command_arrays(rows, pos, np.asarray(heading_rad, dtype=float), bv,
                                                    np.asarray(speed_ref_m_s, dtype=float), dt_s, course)
        prop = self._prop if rows is None else self._propellers(rows)
        return PropellerCoefficients.command_for_thrust(prop, thrust), statuses  # the inverse curve, per vessel

    def reference_arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """The fleet's own (n,) arrays of speed references [m/s] and course overrides [rad] that
        :meth:`command_all` reads: a caller fills them row by row and hands them to it as they are
        (no copy; their values are overwritten by the next call's)."""
        n = self._S.shape[1]
        scratch = self._scratch
        if scratch is None or scratch[0].shape[0] != n:
            scratch = self._scratch = (np.empty(n), np.empty(n), np.empty((n, 6)))
        return scratch[0], scratch[1]

    def command_all(self, position_m: np.ndarray, heading_rad: np.ndarray, body_velocity: np.ndarray, speed_ref_m_s,
                    course_override_rad, dt_s: float) -> tuple[np.ndarray, list[PathFollowingStatus]]:
        """:meth:`command` for every row in order (``rows`` None), the control slot's call: position
        (n, 2), heading (n,) and body velocity (n, 3) float arrays as they are; the speed references
        [m/s] and course overrides [rad] (NaN: none) as the fleet's :meth:`reference_arrays`, or as
        sequences of n floats copied into them. The same commands, statuses and states as
        :meth:`command`, in one compiled call without its argument conversions."""
        speed, course = self.reference_arrays()
        status = self._scratch[2]
        n = speed.shape[0]
        if speed_ref_m_s is not speed:
            speed[:] = speed_ref_m_s
        if course_override_rad is not course:
            course[:] = course_override_rad
        if n > SCALAR_FLEET_MAX or self._all_rows.size != n or \
                type(self)._command_compiled is not _COMMAND_COMPILED:  # (a replaced compiled form: command's)
            return self.command(position_m, heading_rad, body_velocity, speed.copy(), dt_s,
                                course_override_rad=course.copy())
        commands = np.empty((n, 2))
        if not follow_fleet(*self.paths.segment_arrays(), self._P, self._S, self._all_rows, position_m, heading_rad,
                            body_velocity, speed, course, float(dt_s), 2.0, commands, status):
            return self.command(position_m, heading_rad, body_velocity, speed.copy(), dt_s,
                                course_override_rad=course.copy())
        new_status = object.__new__
        statuses = [None] * n
        for k, (g, e, chi_p, psi_d, u_d, finished) in enumerate(status.tolist()):
            statuses[k] = st = new_status(PathFollowingStatus)  # without the frozen dataclass's __init__
            st.__dict__.update(gamma_m=g, cross_track_m=e, course_ref_rad=chi_p, heading_ref_rad=psi_d,
                               speed_ref_m_s=u_d, finished=finished != 0.0)
        return commands, statuses

    def _command_compiled(self, idx, pos, heading, bv, speed, dt_s, course, rows):
        """:meth:`_command_floats` and the inverse propeller curve in one compiled call
        (:func:`~mjasc.guidance.follow_kernel.follow_fleet`, the same bits): (commands (k, 2),
        statuses), or None when the kernel declines (a position not finite: the Python form raises)."""
        k = len(idx)
        if rows is None:
            at = self._all_rows
            if at.size != k:
                at = self._all_rows = np.arange(k, dtype=np.intp)
        else:
            at = np.array(idx, dtype=np.intp)
        pos = pos.reshape(k, 2)
        commands = np.empty((k, 2))
        status = np.empty((k, 6))
        if not follow_fleet(*self.paths.segment_arrays(), self._P, self._S, at, pos,
                            np.asarray(heading, dtype=float).reshape(k), bv.reshape(k, 3),
                            np.asarray(speed, dtype=float).reshape(k), course, float(dt_s), 2.0, commands, status):
            return None
        new_status = object.__new__
        statuses = []
        for g, e, chi_p, psi_d, u_d, finished in status.tolist():
            st = new_status(PathFollowingStatus)  # PathFollowingStatus(...) without the frozen dataclass's __init__
            st.__dict__.update(gamma_m=g, cross_track_m=e, course_ref_rad=chi_p, heading_ref_rad=psi_d,
                               speed_ref_m_s=u_d, finished=finished != 0.0)
            statuses.append(st)
        return commands, statuses

    def _command_floats(self, idx, pos, heading, bv, speed, dt_s, course):
        """The law vessel by vessel in plain floats (:func:`~mjasc.guidance.following_law.law_floats`); the projection by each
        path's scalar query."""
        thrust = []
        statuses = []
        S = self._S
        paths = self.paths.paths
        cols = self._P_cols
        new_status = object.__new__
        for k, i in enumerate(idx):
            P = cols[i]
            s = S[:, i].tolist()
            x, y = pos[k][0], pos[k][1]
            path = paths[i]
            g = path.project_near(x, y, s[GAMMA], P[WINDOW])
            qx, qy, chi_p, kappa = path.at(g)
            t_p, t_s, new, (e, psi_d, u_d, finished) = following_law.law_floats(P, s, x, y, heading[k], bv[k][0], bv[k][2],
                                                                    speed[k], dt_s, g, qx, qy, chi_p, kappa,
                                                                    path.length, course[k])
            thrust.append((t_p, t_s))
            S[:, i] = new
            # PathFollowingStatus(g, e, chi_p, psi_d, u_d, finished) without the frozen dataclass's __init__
            status = new_status(PathFollowingStatus)
            status.__dict__.update(gamma_m=g, cross_track_m=e, course_ref_rad=chi_p, heading_ref_rad=psi_d,
                                   speed_ref_m_s=u_d, finished=finished)
            statuses.append(status)
        return thrust, statuses

    def _command_arrays(self, rows, pos, heading, bv, speed, dt_s, course):
        """The law once over arrays; the projection in one pass over the stacked paths."""
        P = self._P if rows is None else self._P[:, rows]
        S = self._S if rows is None else self._S[:, rows]
        px, py = pos[:, 0], pos[:, 1]
        q = self.paths.project(px, py, S[GAMMA], P[WINDOW], rows)
        t_p, t_s, new, (e, psi_d, u_d, finished) = law(ArrayOps, P, S, px, py, heading, bv[:, 0], bv[:, 2], speed,
                                                         dt_s, q.gamma_m, q.x_m, q.y_m, q.course_rad, q.curvature_1_m,
                                                         q.length_m, course)
        if rows is None:
            for j in range(4):
                self._S[j] = new[j]
        else:
            self._S[:, rows] = np.stack(new)
        statuses = [PathFollowingStatus(*v) for v in zip(q.gamma_m.tolist(), e.tolist(), q.course_rad.tolist(),
                                                          psi_d.tolist(), u_d.tolist(), finished.tolist())]
        return np.stack([t_p, t_s], axis=-1), statuses


_COMMAND_COMPILED = FleetPathFollower._command_compiled  # (command_all's kernel call is its body)


class PathFollower(ControlMethod):
    """Integral line-of-sight path following with heading and speed loops and thrust allocation.

    Follows one :class:`Path` at a commanded speed with one vessel's twin propellers: one row of a
    :class:`FleetPathFollower` (a fleet of one until it is gathered with others). Registered as the
    control method ``"path_following"`` (options: :class:`PathFollowingConfig`); the runner's
    control slot commands all such followers of a fleet in one call.
    """

    method = "path_following"
    Options = PathFollowingConfig

    @classmethod
    def from_context(cls, context, options) -> "PathFollower":
        """The follower of one vessel from its :class:`~mjasc.plugins.context.StageContext`."""
        return cls(context.mission_path, context.vessel, context.total_mass, context.propeller_lateral_m,
                   PathFollowingConfig() if options is None else options)

    def __init__(self, path: Path, vessel: VesselType, total_mass: np.ndarray, lateral_offset_m: float,
                 config: PathFollowingConfig = PathFollowingConfig(), gamma0_m: float = 0.0):
        self.vessel = vessel
        self.config = config
        states = [float(gamma0_m), 0.0, 0.0, 0.0]
        self._fleet = FleetPathFollower(np.array(law_parameters(vessel, total_mass, lateral_offset_m, config))[:, None],
                                        np.array(states)[:, None], [path])
        self._fleet._members = [self]
        self._row = 0

    @property
    def fleet(self) -> FleetPathFollower:
        """The fleet this follower is a row of."""
        return self._fleet

    @property
    def path(self) -> Path:
        """The path followed now."""
        return self._fleet.paths.paths[self._row]

    @property
    def gamma_m(self) -> float:
        """Progress γ along the path followed now [m]."""
        return float(self._fleet._S[GAMMA, self._row])

    @gamma_m.setter
    def gamma_m(self, value: float) -> None:
        self._fleet._S[GAMMA, self._row] = float(value)

    @property
    def lookahead_m(self) -> float:
        """LOS lookahead Δ [m]."""
        return float(self._fleet._P[LOOKAHEAD, self._row])

    def reset(self, gamma0_m: float = 0.0) -> None:
        self._fleet._S[:, self._row] = (float(gamma0_m), 0.0, 0.0, 0.0)

    def set_path(self, path: Path, gamma0_m: float = 0.0) -> None:
        """Switch to a new path (e.g. a re-planned detour) keeping the loop states."""
        self._fleet.set_path(self._row, path, gamma0_m)

    def command(self, position_m, heading_rad: float, velocity_m_s, body_velocity, speed_ref_m_s: float,
                dt_s: float, course_override_rad: float | None = None) -> tuple[np.ndarray, PathFollowingStatus]:
        """Normalized (port, starboard) commands (2,) for this vessel and the tick's status.

        position_m (2,), velocity_m_s (2,) world; body_velocity (3,) = (u, v, r); dt_s control period;
        course_override_rad: steer this course [rad] instead of the LOS course (None: no override).
        """
        fleet = self._fleet
        rows = None if len(fleet) == 1 else np.array([self._row])
        cmd, status = fleet.command(np.asarray(position_m, dtype=float).reshape(1, -1)[:, :2],
                                    np.array([float(heading_rad)]),
                                    np.asarray(body_velocity, dtype=float).reshape(1, 3),
                                    np.array([float(speed_ref_m_s)]), dt_s, rows,
                                    None if course_override_rad is None else np.array([float(course_override_rad)]))
        return cmd[0], status[0]

    def steer(self, nav, guidance, speed_ref_m_s: float, course_ref_rad: float | None, dt_s: float):
        """The :class:`~mjasc.plugins.stages.ControlMethod` call: :meth:`command` on ``nav``."""
        return self.command(nav.position_m, nav.heading_rad, nav.velocity_m_s, nav.body_velocity, speed_ref_m_s, dt_s,
                            course_ref_rad)
