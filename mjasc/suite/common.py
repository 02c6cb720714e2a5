"""What every mjasc suite domain shares: the Physics subclass, world composition, range sensors.

:class:`VesselPhysics` is a dm_control ``mjcf.Physics`` whose :meth:`~VesselPhysics.step` is
mjasc's physics step, :meth:`mjasc.physics.simulation.Simulation.step` (``mj_step1`` → current,
propellers, hydrodynamics with exact added mass → ``mj_step2``), run on the Physics's own live
``MjData``: the suite's physics is the simulator's, not a copy. After the step it brings the
moving obstacles to the new time and runs ``mj_step1`` (dm_control's ``legacy_step`` contract:
positions, contacts and sensors agree with ``qpos``/``qvel`` when the task reads them).

Frames and units follow docs/architecture.md: world ENU, heading CCW from east, body FLU
(u forward, v to port, r CCW), SI units.
"""

from __future__ import annotations

import collections
import dataclasses
from pathlib import Path

import mujoco
import numpy as np
from dm_control import mjcf
from dm_control.rl import control
from dm_env import specs

from mjasc.core.frames import wrap_angle
from mjasc.perception.range_sensor import RangeSensor, SensorConfig, sensor_for_vessel
from mjasc.physics.currents import CurrentField, UniformCurrent
from mjasc.physics.obstacles import PolygonObstacle
from mjasc.physics.simulation import Simulation
from mjasc.physics.vessels import load_vessel_type
from mjasc.physics.world import World, build_world
from mjasc.suite.env_kwargs import check_environment_kwargs
from mjasc.suite.gl_lifetime import track_rendering
from mjasc.suite.pixel_scene import add_hull_cameras, add_reference_pool

__all__ = ["Environment", "make_control_environment", "VesselPhysics", "compose_world", "range_sensor", "basin_walls", "world_to_body",
           "CONTROL_TIMESTEP_S"]

#: Agent decision period [s]: 5 physics steps of 0.02 s (10 Hz, a typical USV autopilot rate).
CONTROL_TIMESTEP_S = 0.1

_COPIED_SECTIONS = ("asset", "worldbody")


def world_to_body(vector_xy, heading_rad: float) -> np.ndarray:
    """A world-frame vector (2,) or points (n, 2) expressed in the body frame of heading ψ."""
    c, s = np.cos(heading_rad), np.sin(heading_rad)
    v = np.asarray(vector_xy, dtype=float)
    return np.stack([c * v[..., 0] + s * v[..., 1], -s * v[..., 0] + c * v[..., 1]], axis=-1)


def basin_walls(half_size_m: float, name: str = "basin") -> PolygonObstacle:
    """A square basin of side 2·half_size_m centred on the origin (walls along its edges)."""
    h = float(half_size_m)
    return PolygonObstacle(name, np.array([[-h, -h], [h, -h], [h, h], [-h, h]]), height_m=2.0)


def _merge_domain_xml(root: mjcf.RootElement, xml_path: Path, vessel_names) -> None:
    """Copy the domain MJCF's assets and world elements into ``root`` under their own names.

    (``attach`` would namespace them; dm_control's reward colouring looks materials up by the
    plain names ``self``/``effector``/``target``.) Also puts a ``reward_light`` site with material
    ``self`` on top of every hull's mast, which ``visualize_reward`` colours.
    """
    extra = mjcf.from_path(str(xml_path))
    for section in _COPIED_SECTIONS:
        source, target = getattr(extra, section), getattr(root, section)
        for child in source.all_children():
            if child.tag == "body":
                raise ValueError(f"{xml_path.name}: domain MJCF must not add bodies (index maps would shift)")
            if child.tag == "geom":
                raise ValueError(f"{xml_path.name}: domain MJCF must not add geoms (geom owners would shift)")
            target.add(child.tag, **child.get_attributes())
    light_material = root.asset.find("material", "self")
    for name in vessel_names:
        hull = root.find("body", f"{name}/hull")
        mount = root.find("site", f"{name}/sensor_mount").pos
        hull.add("site", name="reward_light", type="sphere", size=[0.12],
                 pos=[mount[0], mount[1], mount[2] + 0.3], material=light_material, group=0)
        add_hull_cameras(hull)  # follow (north up) and heading_up (bow up), after the vessel's own


def compose_world(vessels, static_obstacles=(), moving_obstacles=(), domain_xml: Path | None = None,
                  reference_lines: int = 1, reference_slots: int = 0) -> World:
    """:func:`mjasc.physics.world.build_world`, the domain's MJCF (cameras, markers, materials), the
    pool of reference markers for ``reference_lines`` lines and ``reference_slots`` slots
    (:mod:`mjasc.suite.pixel_scene`), compiled again into a :class:`VesselPhysics` of its own.

    ``vessels`` is a list of (name, vessel type name). The domain MJCF may add assets, cameras,
    sites and lights but no bodies or geoms, and the pool comes after every body and geom, so every
    index map of the World stays valid (checked)."""
    world = build_world([(n, load_vessel_type(t)) for n, t in vessels], list(static_obstacles), list(moving_obstacles))
    if domain_xml is not None:
        _merge_domain_xml(world.mjcf_model, Path(domain_xml), [n for n, _ in vessels])
    added = add_reference_pool(world.mjcf_model, reference_lines, reference_slots)
    old = world.model
    physics = VesselPhysics.from_mjcf_model(world.mjcf_model)
    new = physics.model.ptr
    for size in ("nq", "nv", "nu", "na", "nbody", "ngeom", "nmocap"):
        if getattr(old, size) + added.get(size, 0) != getattr(new, size):
            raise RuntimeError(f"domain MJCF changed model size {size}: {getattr(old, size)} -> {getattr(new, size)}")
    world = dataclasses.replace(world, physics=physics)
    physics.attach_world(world)
    return world


def make_control_environment(physics: "VesselPhysics", task, time_limit: float,
                             environment_kwargs=None) -> "Environment":
    """The suite's :class:`Environment` of ``task`` on ``physics``: ``environment_kwargs`` go to
    ``control.Environment`` and may replace the default control timestep (CONTROL_TIMESTEP_S) with
    their own ``control_timestep`` or ``n_sub_steps``; the time limit is a task argument."""
    kwargs = check_environment_kwargs(environment_kwargs, physics.timestep(), CONTROL_TIMESTEP_S)
    return Environment(physics, task, time_limit=time_limit, **kwargs)


class Environment(control.Environment):
    """dm_control's ``control.Environment`` whose :meth:`close` frees the physics.

    ``control.Environment.close`` does nothing, and dm_control then prints "cannot schedule new
    futures after shutdown" at interpreter exit after any ``physics.render()``; freeing the
    physics releases its GL context first. The environment must not be used after ``close()``.
    (A physics that is never closed frees its contexts from an exit hook: also silent.)
    """

    @property
    def step_limit(self) -> float:
        """Control steps in one episode (the time limit / control timestep; inf without a limit)."""
        return self._step_limit

    def observation_spec(self):
        """The task's declared spec (computing an observation would draw noise from the task's
        RandomState and shift the episode), flattened like the observations when asked to."""
        spec = self._task.observation_spec(self._physics)
        if self._flat_observation:
            size = sum(int(np.prod(s.shape)) for s in spec.values())
            key = control.FLAT_OBSERVATION_KEY
            return collections.OrderedDict([(key, specs.Array((size,), np.float64, name=key))])
        return spec

    def reset(self):
        """dm_control's reset; a clear error once :meth:`close` has freed the physics."""
        self._check_open()
        return super().reset()

    def step(self, action):
        """dm_control's step (an error after :meth:`close`); a contact at the time limit: discount 0."""
        self._check_open()
        time_step = super().step(action)
        if time_step.last() and time_step.discount == 1.0 and self._task.get_termination(self._physics) == 0.0:
            time_step = time_step._replace(discount=0.0)
        return time_step

    def _check_open(self) -> None:
        if getattr(self._physics, "_data", None) is None:
            raise RuntimeError("environment: closed (close() freed its physics); load a new one")

    def close(self):
        """Release the physics's GL contexts and native data (idempotent)."""
        physics = self._physics
        if getattr(physics, "_data", None) is not None:
            physics.free()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class VesselPhysics(mjcf.Physics):
    """dm_control Physics stepping mjasc's vessels: hydrodynamics, propellers, current, traffic."""

    _world: World | None = None
    _sim: Simulation | None = None
    _touched: dict = {}  # (geom pairs in contact at a step of the last step(): in_contact; replaced, never changed)

    def _make_rendering_contexts(self):
        """dm_control's contexts, freed at interpreter exit if the environment was never closed,
        and when the garbage collector frees this physics (:mod:`mjasc.suite.gl_lifetime`)."""
        super()._make_rendering_contexts()
        self._buffer_size = (self.model.vis.global_.offwidth, self.model.vis.global_.offheight)
        track_rendering(self)

    def render(self, height=240, width=320, *args, **kwargs):
        """dm_control's; a frame larger than the first render's buffer is an error (it rendered black)."""
        vis = self.model.vis.global_
        w, h = getattr(self, "_buffer_size", None) or (vis.offwidth, vis.offheight)
        if width > w or height > h:
            raise ValueError(f"render: {width}x{height} is larger than the offscreen buffer, {w}x{h}; set "
                             "physics.model.vis.global_.offwidth / offheight before the first render")
        return super().render(height, width, *args, **kwargs)

    # ------------------------------------------------------------------ set-up
    def attach_world(self, world: World, current: CurrentField | None = None) -> None:
        """Bind the index maps of ``world`` (whose physics is this one) and build the step."""
        self._world = dataclasses.replace(world, physics=self)
        self._current = current if current is not None else UniformCurrent((0.0, 0.0))
        self._build_simulation(self._world.moving_obstacles)
        n = self._world.n_vessels
        self._heading_buf = np.zeros(n)

    def _build_simulation(self, moving_obstacles) -> None:
        world = dataclasses.replace(self._world, moving_obstacles=list(moving_obstacles))
        self._sim = Simulation(world, self._current)
        self._sim.divergence_checks = False  # dm_control's check_invalid_state reports warnings

    def configure_episode(self, current: CurrentField, moving_obstacles=None) -> None:
        """Set this episode's current field and traffic motions (same names/radii as built)."""
        if moving_obstacles is not None:
            moving_obstacles = list(moving_obstacles)
            built = self._world.moving_obstacles
            if [o.name for o in moving_obstacles] != [o.name for o in built]:
                raise ValueError("moving_obstacles: must keep the names and order of the built world")
        self._current = current
        self._build_simulation(self._sim.traffic.obstacles if moving_obstacles is None else moving_obstacles)
        self._update_traffic()

    def set_control(self, control):
        """dm_control's, but a wrong shape (``np.copyto`` broadcast (1,) and (1, 2) actions) or a NaN
        is an error before anything is stepped (MuJoCo took a NaN control for 0, stepped, and raised
        its own instability error: the episode lost a step); ±inf act as ±1, as any value beyond."""
        shape = np.shape(control)
        if shape != (self.model.nu,):
            raise ValueError(f"action: must have shape ({self.model.nu},) (port, starboard per vessel), got {shape}")
        if np.isnan(np.asarray(control, dtype=float)).any():
            raise ValueError(f"action: must not be NaN, got {np.asarray(control, dtype=float).tolist()}")
        super().set_control(control)

    def copy(self, share_model=False):
        """A copy with its own MjData (and MjModel unless ``share_model``) and its own step."""
        new = super().copy(share_model=share_model)
        new._world = dataclasses.replace(self._world, physics=new)
        new._current = self._current
        new._build_simulation(self._sim.traffic.obstacles)
        new._heading_buf = np.zeros(self._world.n_vessels)
        return new

    # ------------------------------------------------------------------ pickling
    def __getstate__(self):
        """dm_control pickles a Physics as its MjData only; add what the step needs: the World's
        names and index maps (without its MJCF object model, which dm_control cannot pickle),
        this episode's current field and traffic motions."""
        data = super().__getstate__()
        if self._world is None:
            return data
        world = dataclasses.replace(self._world, physics=None, mjcf_model=None)
        return {"data": data, "world": world, "current": self._current, "traffic": list(self._sim.traffic.obstacles)}

    def __setstate__(self, state):
        """Rebuild the physics from its MjData, then its simulator (bound to the new MjData)."""
        if not isinstance(state, dict):
            super().__setstate__(state)
            return
        super().__setstate__(state["data"])
        self._world = dataclasses.replace(state["world"], physics=self)
        self._current = state["current"]
        self._build_simulation(state["traffic"])
        self._heading_buf = np.zeros(self._world.n_vessels)

    # ------------------------------------------------------------------ stepping
    def step(self, nstep: int = 1) -> None:
        """``nstep`` physics steps of :class:`mjasc.physics.simulation.Simulation`, then sync kinematics."""
        with self.check_invalid_state():
            self._sim.step(nstep)
            self._touched = self._sim.drain_touches()  # (the contacts of these steps: in_contact)
            if self.legacy_step:
                self._update_traffic()
                mujoco.mj_step1(self.model.ptr, self.data.ptr)

    def _update_traffic(self) -> None:
        """Moving obstacles (mocap bodies) to their poses at the current time."""
        if len(self._sim.traffic) == 0:
            return
        pos, head, _ = self._sim.traffic.state(float(self.data.time))
        mid = self._world.mocap_id
        d = self.data.ptr
        d.mocap_pos[mid, :2] = pos
        d.mocap_quat[mid] = np.stack([np.cos(0.5 * head), 0 * head, 0 * head, np.sin(0.5 * head)], axis=-1)

    def after_reset(self):
        """Traffic to the reset time, then dm_control's forward pass without actuation."""
        if self._sim is not None:
            self._update_traffic()
            self._sim.drain_touches()  # (a new episode: the last one's contacts are not its own)
        self._touched = {}
        super().after_reset()

    # ------------------------------------------------------------------ named getters
    @property
    def world(self) -> World:
        """The World (names, vessel types, index maps) this physics steps."""
        return self._world

    @property
    def simulation(self) -> Simulation:
        """mjasc's physics step bound to this physics's MjData."""
        return self._sim

    @property
    def current_field(self) -> CurrentField:
        """This episode's water current field."""
        return self._current

    @property
    def n_vessels(self) -> int:
        """Number of vessels in the model."""
        return self._world.n_vessels

    def set_pose(self, i: int, x_m: float, y_m: float, heading_rad: float, surge_m_s: float = 0.0) -> None:
        """Place vessel ``i`` at (x, y, ψ) moving forward at ``surge_m_s`` (for episode resets)."""
        adr = self._world.qpos_adr[i]
        self.data.qpos[adr] = [x_m, y_m, heading_rad]
        dof = self._world.dof_adr[i]
        self.data.qvel[dof] = [surge_m_s * np.cos(heading_rad), surge_m_s * np.sin(heading_rad), 0.0]

    def position(self, i: int = 0) -> np.ndarray:
        """World position (x, y) of vessel ``i``'s CO [m]."""
        return self.data.qpos[self._world.qpos_adr[i, :2]].copy()

    def heading(self, i: int = 0) -> float:
        """Heading ψ of vessel ``i`` [rad], wrapped to (−π, π]."""
        return float(wrap_angle(self.data.qpos[self._world.qpos_adr[i, 2]]))

    def world_velocity(self, i: int = 0) -> np.ndarray:
        """Velocity over ground (ẋ, ẏ) of vessel ``i`` [m/s], world frame."""
        return self.data.qvel[self._world.dof_adr[i, :2]].copy()

    def body_velocity(self, i: int = 0) -> np.ndarray:
        """(u, v, r) of vessel ``i``: body-frame velocity over ground [m/s, m/s, rad/s]."""
        qd = self.data.qvel[self._world.dof_adr[i]]
        uv = world_to_body(qd[:2], float(self.data.qpos[self._world.qpos_adr[i, 2]]))
        return np.array([uv[0], uv[1], qd[2]])

    def shaft_speed(self, i: int = 0) -> np.ndarray:
        """Normalized (port, starboard) propeller shaft speeds of vessel ``i`` in [−1, 1]."""
        return self.data.act[self._world.act_adr[i]].copy()

    def current_world(self, i: int = 0) -> np.ndarray:
        """Water current over ground at vessel ``i`` [m/s], world frame."""
        return self._current.velocity(self.position(i)[None, :], float(self.data.time))[0]

    def current_body(self, i: int = 0) -> np.ndarray:
        """Water current at vessel ``i`` in its body frame (u_c, v_c) [m/s]."""
        return world_to_body(self.current_world(i), self.heading(i))

    def traffic_positions(self) -> np.ndarray:
        """(M, 2) world positions of the moving obstacles now [m]."""
        return self._sim.traffic.state(float(self.data.time))[0]

    def in_contact(self, i: int = 0) -> bool:
        """True when any collision geom of vessel ``i`` touches anything at the last kinematics or at
        any physics step of the last :meth:`step` (a bump of a step or two between two decisions —
        MuJoCo's contacts are instants — went unseen at the decision's kinematics alone)."""
        hull = int(self._world.hull_body_id[i])
        d, m = self.data.ptr, self.model.ptr
        touched = self._touched
        if touched:
            g = np.array(list(touched), dtype=np.int64)
            if np.any(m.geom_bodyid[g] == hull):
                return True
        if d.ncon == 0:
            return False
        g1, g2 = d.contact.geom1[: d.ncon], d.contact.geom2[: d.ncon]
        bodies = np.concatenate([m.geom_bodyid[g1], m.geom_bodyid[g2]])
        return bool(np.any(bodies == hull))


def range_sensor(physics: VesselPhysics, vessel: int, config: SensorConfig) -> RangeSensor:
    """Vessel ``vessel``'s :class:`mjasc.perception.range_sensor.RangeSensor` on this physics: the project's one
    ray-casting sensor (``mj_multiRay`` from the hull's ``sensor_mount`` at ``config.ray_height_m``,
    geom groups 0 and 3, the own hull excluded; noise, dropout and clutter in ``scan``)."""
    return sensor_for_vessel(physics.world, vessel, config)
