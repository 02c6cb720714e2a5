"""The physics step: MuJoCo rigid bodies + mjasc hydrodynamics, propellers, current and traffic.

One physics step (``Simulation.step``)::

    moving obstacles → mocap poses at t
    mj_step1             positions, velocities, mass matrix (MuJoCo)
    current V_c(p, t), V̇_c at every vessel            (currents)
    propeller thrust from the shaft-lag activations    (thrusters)
    hydrodynamic force with exact added mass           (hydrodynamics, eq. 3)
    → qfrc_applied
    mj_step2             acceleration, shaft lag, integration (MuJoCo)

All vessels are handled together on (N, ·) arrays viewed straight into MjData: no per-vessel
Python loop. Commands are set between steps with :meth:`Simulation.set_commands`. In the common
case (vessels' dofs first in MjData, a uniform steady current) the force is computed before
``mj_step1``, which neither reads nor changes what it depends on: one compiled call per step
(:mod:`mjasc.physics.step_kernels`: the previous step's divergence test, the mocap poses, the
force τ = F·G in numpy's bits, rotated into ``qfrc_applied``), then MuJoCo's
``mj_step`` (with the Euler integrator the stages of ``mj_step1`` then ``mj_step2`` in one call;
tests/test_step_kernels.py checks the bits, contacts included). The same compiled call tests
whether two bodies can touch at the step's positions; while none can, the step runs without
MuJoCo's collision detection (:mod:`mjasc.physics.contact_gate`, ``contact_gating``: the same bits).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from mjasc.physics.contact_gate import ContactGate
from mjasc.physics.currents import CurrentField, UniformCurrent
from mjasc.physics.divergence import DivergenceBounds, DivergenceMonitor, PhysicsDivergence
from mjasc.physics.hydrodynamics import Hydrodynamics, rigid_body_mass_matrix
from mjasc.physics.obstacles import MovingObstacleSet
from mjasc.physics.state_kernels import vessel_states
from mjasc.physics.step_kernels import (any_nonzero, fast_bounds_ok, prepare_step, traffic_state_at, traffic_table,
                                        write_commands)
from mjasc.physics.thrusters import Thrusters
from mjasc.physics.vessel_states import VesselStates
from mjasc.physics.world import World

__all__ = ["Simulation", "VesselStates", "PhysicsDivergence", "STATE_SPEC"]

_DSBL_CONTACT = int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
_NO_COLLISION = _DSBL_CONTACT | int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)  # (either: no collision to skip)
_NO_PAIRS = np.zeros((0, 2), dtype=np.int64)  # (the gate's pairs when it is not used: the test answers 1)
_NO_CURRENT = np.zeros((0, 2))  # (states() with a current that is not uniform and steady: computed apart)


STATE_SPEC = int(mujoco.mjtState.mjSTATE_INTEGRATION)
"""What a saved state holds: everything MuJoCo integrates (time, qpos, qvel, act, warm start,
controls, applied forces, mocap poses): ``mj_setState`` of it makes the next steps identical."""


def _rigid_body_mass(model, body_id: int) -> np.ndarray:
    """M_RB about the body origin (CO) from the compiled model's mass, CoG and inertia."""
    mass = model.body_mass[body_id]
    ipos = model.body_ipos[body_id]
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, model.body_iquat[body_id])
    rot = rot.reshape(3, 3)
    inertia = rot @ np.diag(model.body_inertia[body_id]) @ rot.T
    return rigid_body_mass_matrix(mass, ipos[:2], inertia[2, 2])


class Simulation:
    """Steps a :class:`World` under hydrodynamics and a current field."""

    def __init__(self, world: World, current: CurrentField | None = None, hydrodynamics: bool = True):
        self.world = world
        self.model = world.model
        self.data = world.data
        self.current = current if current is not None else UniformCurrent((0.0, 0.0))
        self.hydrodynamics_enabled = hydrodynamics
        # Keep a diverged state as it is (MuJoCo would otherwise reset MjData on a bad acceleration,
        # hiding when and where the run failed): check_divergence reports it instead.
        self.model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_AUTORESET)
        n = world.n_vessels
        self.n_vessels = n
        m_rb = np.stack([_rigid_body_mass(self.model, b) for b in world.hull_body_id]) if n else np.zeros((0, 3, 3))
        self.hydro = Hydrodynamics(m_rb, [t.hydro for t in world.vessel_types])
        self.thrusters = Thrusters([t.propellers for t in world.vessel_types], world.propeller_lateral_m)
        self.hydro.attach_propellers(self.thrusters.feature_weights())
        self.hydro.allocate_buffers()
        self.traffic = MovingObstacleSet(world.moving_obstacles)
        d = self.data
        # Views into MjData (no copies) when each vessel owns a contiguous block, else index arrays.
        if world.contiguous_vessel_dofs():
            self._qpos3 = d.qpos[: 3 * n].reshape(n, 3)
            self._qvel3 = d.qvel[: 3 * n].reshape(n, 3)
            self._qfrc3 = d.qfrc_applied[: 3 * n].reshape(n, 3)
            self._views = True
        else:
            self._views = False
        act = world.act_adr
        self._act_view = (
            d.act[: 2 * n].reshape(n, 2) if n and np.array_equal(act, np.arange(2 * n).reshape(n, 2)) else None
        )
        self._current_uniform_steady = self.current.is_uniform and self.current.is_steady
        self._qfrc_buffer = np.zeros((n, 3))
        self._bound = self._views and self._act_view is not None
        if self._bound:
            self.hydro.bind(self._qpos3, self._qvel3, self._act_view, self._qfrc3)
        self._mocap_rows = [int(k) for k in self.world.mocap_id]
        # The compiled step's inputs (mjasc.physics.step_kernels): MjData's arrays, whole, and the
        # traffic's constants as arrays.
        self._traffic_table, self._traffic_samples = traffic_table(self.traffic.constants(), self._mocap_rows,
                                                                   MovingObstacleSet.PATH_SAMPLE_M)
        self._mj_arrays = (d.qpos, d.qvel, d.qacc, d.act, d.mocap_pos, d.mocap_quat)
        self._propellers = self.thrusters.step_arrays()
        # what states() reads: MjData's qpos, qvel and act, whole, and the propellers
        self._state_arrays = (d.qpos, d.qvel, d.act, self._propellers)
        self._uniform_current = self.current.velocity(np.zeros((n, 2)), 0.0) if self._current_uniform_steady else None
        tau, rot2, feats, cf_x, self._linear_form = self.hydro.step_arrays()
        self._step_arrays = (tau, rot2, feats, cf_x, self._qfrc3 if self._views else None,
                             *self._mj_arrays, self._traffic_table, self._traffic_samples)
        self._command_shape = (n, 2)
        self._ctrl, self._ctrl_adr = d.ctrl, np.ascontiguousarray(world.ctrl_adr, dtype=np.intp).reshape(n, 2)
        self._warning_counts = d.warning.number  # (a view of MjData's warning counters)
        self.divergence_checks = True
        self.monitor = DivergenceMonitor(d.qvel, d.qacc, world.dof_adr, [t.top_speed_m_s for t in world.vessel_types],
                                         world.vessel_names, DivergenceBounds())
        self._block_state = np.zeros(mujoco.mj_stateSize(self.model, STATE_SPEC))
        # With the Euler integrator (the water scene's), mj_step runs mj_step1's stages then
        # mj_step2's, in their order: the common case's step calls it once (RK4 would differ)
        self._euler = self.model.opt.integrator == int(mujoco.mjtIntegrator.mjINT_EULER)
        #: The common case's steps skip MuJoCo's collision detection while no two bodies can touch
        #: (:mod:`mjasc.physics.contact_gate`: the same bits); False runs it every step.
        self.contact_gating = True
        self.contact_gate = ContactGate(self.model)
        #: Geom pairs (geom1, geom2) in contact at any physics step since :meth:`drain_touches`, each
        #: with the first such step's time [s]: a bump between two record ticks lasts a step or two
        #: (MuJoCo's contacts are instants), and the record tick's look at ``data.contact`` missed it.
        self.touches: dict[tuple[int, int], float] = {}
        self._opt = self.model.opt  # (MjOption, a reference into the model: its flags are toggled per step)

    # ------------------------------------------------------------------ state access
    @property
    def time_s(self) -> float:
        return float(self.data.time)

    @property
    def timestep_s(self) -> float:
        return float(self.model.opt.timestep)

    def _qpos(self) -> np.ndarray:
        return self._qpos3 if self._views else self.data.qpos[self.world.qpos_adr]

    def _qvel(self) -> np.ndarray:
        return self._qvel3 if self._views else self.data.qvel[self.world.dof_adr]

    def _act(self) -> np.ndarray:
        return self._act_view if self._act_view is not None else self.data.act[self.world.act_adr]

    def reset(self, poses=None, body_velocities=None, time_s: float = 0.0) -> None:
        """Put vessels at ``poses`` (N, 3) = (x, y, ψ) with body velocities (N, 3) = (u, v, r)."""
        mujoco.mj_resetData(self.model, self.data)
        self.data.time = time_s
        n = self.n_vessels
        if poses is not None:
            poses = np.asarray(poses, dtype=float).reshape(n, 3)
            self.data.qpos[self.world.qpos_adr] = poses
        if body_velocities is not None:
            nu = np.asarray(body_velocities, dtype=float).reshape(n, 3)
            psi = self.data.qpos[self.world.qpos_adr][:, 2]
            c, s = np.cos(psi), np.sin(psi)
            qv = np.stack([c * nu[:, 0] - s * nu[:, 1], s * nu[:, 0] + c * nu[:, 1], nu[:, 2]], axis=-1)
            self.data.qvel[self.world.dof_adr] = qv
        self._update_traffic()
        mujoco.mj_forward(self.model, self.data)

    def set_commands(self, commands) -> None:
        """Normalized propeller commands (N, 2) in [−1, 1], port then starboard (clipped)."""
        c = commands
        if not (type(c) is np.ndarray and c.dtype == np.float64 and c.shape == self._command_shape):
            c = np.asarray(commands, dtype=float).reshape(self.n_vessels, 2)  # (the runner's are (N, 2) floats)
        if not write_commands(c, self._ctrl, self._ctrl_adr):  # (check, clip and write in one compiled call)
            raise ValueError(f"commands: must be finite, got {c.tolist()}")

    def states(self) -> VesselStates:
        """Every vessel's true state now (new arrays, read-only: the onboard stages are handed rows of
        them — their navigation — and the record slot reads them after the stages, so a stage that
        wrote into its position would change the recorded truth), in one compiled pass when the
        vessels' dofs are MjData's first (:mod:`mjasc.physics.state_kernels`)."""
        if not self._bound:
            return self._states_numpy()
        n = self.n_vessels
        qpos, qvel, act, propellers = self._state_arrays
        pairs, body, heading = np.empty((5, n, 2)), np.empty((n, 3)), np.empty(n)  # (state_kernels.vessel_states)
        uniform = self._current_uniform_steady  # (the same everywhere, always: the kernel copies it into the fifth row)
        vessel_states(qpos, qvel, act, propellers, self._uniform_current if uniform else _NO_CURRENT, pairs, body,
                      heading)
        for a in (pairs, body, heading):  # (read-only: every stage reads these rows, the record slot after them)
            a.flags.writeable = False
        pos, vel, shaft, thrust = pairs[0], pairs[1], pairs[2], pairs[3]
        t = float(self.data.time)
        if uniform:
            current = pairs[4]
        else:
            current = self.current.velocity(np.array(self._qpos3)[:, :2], t)  # (the numpy form's layout)
        out = object.__new__(VesselStates)  # (VesselStates(...) without the frozen __init__'s eight setattr calls)
        out.__dict__.update(time_s=t, position_m=pos, heading_rad=heading, velocity_m_s=vel, body_velocity=body,
                            current_m_s=current, shaft_speed=shaft, thrust_n=thrust)
        return out

    def _states_numpy(self) -> VesselStates:
        """:meth:`states` in numpy (any layout of the vessels' dofs; the compiled form's reference)."""
        q = np.array(self._qpos())
        qd = np.array(self._qvel())
        psi = q[:, 2]
        c, s = np.cos(psi), np.sin(psi)
        nu = np.stack([c * qd[:, 0] + s * qd[:, 1], -s * qd[:, 0] + c * qd[:, 1], qd[:, 2]], axis=-1)
        act = np.array(self._act())
        t = self.time_s
        out = VesselStates(
            time_s=t,
            position_m=q[:, :2].copy(),
            heading_rad=np.mod(psi + np.pi, 2 * np.pi) - np.pi,
            velocity_m_s=qd[:, :2].copy(),
            body_velocity=nu,
            current_m_s=self.current.velocity(q[:, :2], t) if self.n_vessels else np.zeros((0, 2)),
            shaft_speed=act,
            thrust_n=self.thrusters.thrust(act),
        )
        for a in (out.position_m, out.heading_rad, out.velocity_m_s, out.body_velocity):
            a.flags.writeable = False
        return out

    def traffic_state(self):
        """(positions (M, 2), headings (M,), velocities (M, 2)) of the moving obstacles now (new
        arrays: :meth:`MovingObstacleSet.state`'s numbers in one compiled call,
        :func:`~mjasc.physics.step_kernels.traffic_state_at`)."""
        pv, heading = traffic_state_at(float(self.data.time), self._traffic_table, self._traffic_samples)
        return pv[0], heading, pv[1]  # (no traffic: empty arrays of the same shapes)

    # ------------------------------------------------------------------ stepping
    def _update_traffic(self) -> None:
        if len(self.traffic) == 0:
            return
        # plain floats per obstacle (a step's numpy calls on (M, 2) arrays cost more than MuJoCo's step)
        mp, mq = self.data.mocap_pos, self.data.mocap_quat
        for k, (x, y, h, _, _) in zip(self._mocap_rows, self.traffic.rows(float(self.data.time))):
            mp[k, 0] = x
            mp[k, 1] = y
            mq[k, 0] = math.cos(0.5 * h)
            mq[k, 1] = mq[k, 2] = 0.0
            mq[k, 3] = math.sin(0.5 * h)

    def _apply_forces(self) -> None:
        q, qd = self._qpos(), self._qvel()
        t = float(self.data.time)
        pos = q[:, :2]
        vc = self.current.velocity(pos, t)
        rate = None if self._current_uniform_steady else self.current.acceleration(pos, qd[:, :2], t)
        out = self._qfrc3 if self._views else self._qfrc_buffer
        if self.hydrodynamics_enabled:
            if self._bound:
                self.hydro.compute_bound(vc, rate)
            else:
                self.hydro.generalized_forces(q, qd, vc, rate, self._act(), out)
        else:  # propellers only (for comparisons): thrust along the hull, yaw moment
            tau = self.thrusters.body_force(self.thrusters.thrust(np.asarray(self._act())))
            c, s = np.cos(q[:, 2]), np.sin(q[:, 2])
            out[:] = np.stack([c * tau[:, 0], s * tau[:, 0], tau[:, 2]], axis=-1)
        if not self._views:
            self.data.qfrc_applied[self.world.dof_adr] = out

    def get_state(self) -> np.ndarray:
        """The full integration state now (:data:`STATE_SPEC`), a new array: save it with ``np.save``."""
        state = np.zeros(mujoco.mj_stateSize(self.model, STATE_SPEC))
        mujoco.mj_getState(self.model, self.data, state, STATE_SPEC)
        return state

    def set_state(self, state: np.ndarray) -> None:
        """Restore a state from :meth:`get_state` (or a saved ``last_good_state.npy``): the next
        steps repeat the original ones exactly (same commands, same model)."""
        state = np.asarray(state, dtype=float)
        if state.shape != (mujoco.mj_stateSize(self.model, STATE_SPEC),):
            raise ValueError(f"state: expected {mujoco.mj_stateSize(self.model, STATE_SPEC)} values for this model, "
                             f"got shape {list(state.shape)}")
        mujoco.mj_setState(self.model, self.data, state, STATE_SPEC)
        mujoco.mj_forward(self.model, self.data)

    def step(self, n_steps: int = 1) -> None:
        """Advance ``n_steps`` physics steps. With ``divergence_checks`` every step is tested
        (:mod:`mjasc.physics.divergence`) and :class:`PhysicsDivergence` raised at the first bad
        one, carrying the state before it; the diverged state is left in MjData as it is."""
        if not self.divergence_checks:
            self._advance(n_steps, None)
            return
        m, d = self.model, self.data
        mujoco.mj_getState(m, d, self._block_state, STATE_SPEC)  # known good: the last block passed
        t0 = float(d.time)
        bad = self._advance(n_steps, self.monitor)
        if bad is not None:
            k, message = bad
            self._raise_divergence(k, message, t0)
        counts = self._warning_counts
        if any_nonzero(counts):  # (compiled: np.any costs 8 µs here, more than a physics step's checks)
            i = int(np.flatnonzero(counts)[0])
            kind = mujoco.mjtWarning(i).name
            raise PhysicsDivergence(f"physics diverged between t = {t0:.3f} and {d.time:.3f} s: MuJoCo warning "
                                    f"{kind} (info {d.warning[i].lastinfo})", self._block_state.copy(), t0)

    def _note_touches(self) -> None:
        """The geom pairs in contact after this step into :attr:`touches` (first time kept)."""
        d, touches = self.data, self.touches
        for g1, g2 in d.contact.geom.tolist():
            touches.setdefault((g1, g2), float(d.time))

    def drain_touches(self) -> dict[tuple[int, int], float]:
        """:attr:`touches` since the last call (then cleared): every geom pair in contact at a physics
        step of that time, with the first step's time [s]."""
        out, self.touches = self.touches, {}
        return out

    def _raise_divergence(self, k: int, message: str, t0: float) -> None:
        """Step k of the block failed: rebuild the state before it (replaying k steps from the
        block's start, which is deterministic), then leave the diverged state and raise."""
        m, d = self.model, self.data
        diverged = self.get_state()
        mujoco.mj_setState(m, d, self._block_state, STATE_SPEC)
        self._advance(k, None)
        good, t_good = self.get_state(), float(d.time)
        mujoco.mj_setState(m, d, diverged, STATE_SPEC)
        raise PhysicsDivergence(f"physics diverged at {message} (last good state t = {t_good:.3f} s)", good, t_good)

    def _advance(self, n_steps: int, monitor: DivergenceMonitor | None) -> tuple[int, str] | None:
        """``n_steps`` physics steps; with a monitor, stop at the first step k (0-based) that breaks
        a bound and return (k, what broke); None when all passed."""
        m, d = self.model, self.data
        if self._bound and self.hydrodynamics_enabled and self._current_uniform_steady:
            # The common case, one compiled call per step before MuJoCo's two (mjasc.physics.step_kernels):
            # the previous step's fast divergence test, the traffic's mocap poses and the force
            # τ = F·G rotated into qfrc_applied; then mj_step1, mj_step2.
            vc, g = self._uniform_current, self._linear_form
            tau, rot, feats, cf_x, out, qpos, qvel, qacc, act, mocap_pos, mocap_quat, table, samples = self._step_arrays
            prepare = prepare_step
            step1, step2 = mujoco.mj_step1, mujoco.mj_step2
            whole = mujoco.mj_step if self._euler else None  # (Euler: mj_step is mj_step1 then mj_step2)
            checking = monitor is not None
            v2, a2 = (monitor.fast_speed2, monitor.fast_acc2) if checking else (math.inf, math.inf)
            # The contact gate: prepare_step answers 1 when no two bodies can touch at the step's
            # positions, then the step runs with contacts disabled; the model's flags are restored
            # after the block (whoever runs MuJoCo between blocks sees them as they were).
            opt, gate = self._opt, self.contact_gate
            flags = opt.disableflags
            gating = self.contact_gating and gate.usable and not flags & _NO_COLLISION
            bounds, pairs = gate.table, gate.pairs if gating else _NO_PAIRS
            closed, closed_flags = False, flags | _DSBL_CONTACT
            try:
                for k in range(n_steps):
                    ready = prepare(checking and k > 0, qpos, qvel, qacc, act, v2, a2, d.time, table, samples,
                                    mocap_pos, mocap_quat, vc, cf_x, feats, rot, g, tau, out, bounds, pairs)
                    if not ready:
                        what = self._exact_check(monitor)  # (None: the bounds hold after all)
                        if what is not None:
                            return k - 1, what
                        ready = prepare(False, qpos, qvel, qacc, act, v2, a2, d.time, table, samples, mocap_pos,
                                        mocap_quat, vc, cf_x, feats, rot, g, tau, out, bounds, pairs)
                    if gating and (ready == 1) is not closed:
                        closed = ready == 1
                        opt.disableflags = closed_flags if closed else flags
                    if whole is not None:
                        whole(m, d)
                    else:
                        step1(m, d)
                        step2(m, d)
                    if not closed and d.ncon:  # (a contact: its pairs noted for the record slot's check)
                        self._note_touches()
            finally:
                if closed:
                    opt.disableflags = flags
            if checking and not fast_bounds_ok(qvel, qacc, v2, a2):  # (prepare_step's test, after the last step)
                what = self._exact_check(monitor)
                if what is not None:
                    return n_steps - 1, what
            return None
        traffic = len(self.traffic) > 0
        if monitor is not None:
            vel, acc, v2, a2 = monitor.qvel, monitor.qacc, monitor.fast_speed2, monitor.fast_acc2
            vdot, adot = vel.dot, acc.dot
        for k in range(n_steps):
            if traffic:
                self._update_traffic()
            mujoco.mj_step1(m, d)
            if self.n_vessels:
                self._apply_forces()
            mujoco.mj_step2(m, d)
            if d.ncon:
                self._note_touches()
            if monitor is not None and not (vdot(vel) <= v2 and adot(acc) <= a2) and not monitor.scaled_ok():
                what = monitor.violation(float(d.time))
                if what is not None:
                    return k, what
        return None

    def _exact_check(self, monitor: DivergenceMonitor) -> str | None:
        """The divergence tests after a failed fast test: None when the bounds hold."""
        if monitor.fast_ok() or monitor.scaled_ok():
            return None
        return monitor.violation(float(self.data.time))

    def check_divergence(self) -> None:
        """Raise :class:`PhysicsDivergence` if a vessel's state is beyond its bounds now, or MuJoCo warned."""
        d = self.data
        what = self.monitor.violation(float(d.time))
        if what is not None or not (np.all(np.isfinite(d.qpos)) and np.all(np.isfinite(d.qvel))):
            raise PhysicsDivergence(f"physics diverged at {what or f't = {d.time:.3f} s: non-finite state'}")
        counts = d.warning.number
        if np.any(counts):
            i = int(np.flatnonzero(counts)[0])
            kind = mujoco.mjtWarning(i).name
            raise PhysicsDivergence(
                f"physics diverged at t = {d.time:.3f} s: MuJoCo warning {kind} (info {d.warning[i].lastinfo})"
            )
