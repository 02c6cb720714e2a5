"""Compose one MuJoCo model from the water scene, the vessels and the obstacles of a run.

Composition uses dm_control's MJCF object model (the same route the dm_control suite takes), so
the simulator and the suite share one model builder. Every element is named: vessel elements are
namespaced ``<vessel name>/<element>`` (``alpha/hull``, ``alpha/yaw``, ``alpha/port_propeller``),
obstacles ``obstacle_<name>…`` (dm_control reserves ``/`` for attached models). Geom groups (assets/README.md): 0 obstacles, 1 water, 2 vessel
visuals, 3 vessel collision hulls. Range sensors see groups 0 and 3 only.

Static polygons become walls along their edges (one box per edge): ray casts hit the true outline
and hull contacts happen at the true boundary, which a single convex mesh could not give for a
non-convex dock. Moving obstacles are mocap bodies (kinematic, position set every physics step).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from dm_control import mjcf

from mjasc.physics.obstacles import CircleObstacle, MovingObstacle, PolygonObstacle
from mjasc.physics.vessels import SCENE_XML, VesselType

__all__ = ["World", "build_world", "SENSOR_GEOM_GROUPS"]

#: Geom groups a range sensor sees: obstacles (0) and vessel collision hulls (3).
SENSOR_GEOM_GROUPS = np.array([1, 0, 0, 1, 0, 0], dtype=np.uint8)
OBSTACLE_RGBA = "0.55 0.45 0.35 1"
MOVING_RGBA = "0.85 0.2 0.2 1"
WALL_THICKNESS_M = 0.4


@dataclass
class World:
    """A compiled model plus the index maps everything else uses.

    physics: a dm_control ``mjcf.Physics`` (``physics.model.ptr`` / ``physics.data.ptr`` are the
    raw MjModel / MjData). vessel_names / vessel_types: in model order.
    qpos_adr: (N, 3) qpos addresses of (x, y, yaw) per vessel; dof_adr likewise for qvel;
    act_adr: (N, 2) activation addresses of (port, starboard) shaft lag; ctrl_adr: (N, 2).
    hull_body_id: (N,) body id of each hull; mocap_id: (M,) mocap index per moving obstacle.
    """

    mjcf_model: mjcf.RootElement
    physics: mjcf.Physics
    vessel_names: list[str]
    vessel_types: list[VesselType]
    static_obstacles: list
    moving_obstacles: list[MovingObstacle]
    qpos_adr: np.ndarray
    dof_adr: np.ndarray
    act_adr: np.ndarray
    ctrl_adr: np.ndarray
    hull_body_id: np.ndarray
    mocap_id: np.ndarray
    propeller_lateral_m: np.ndarray
    geom_owner: list  # per geom: the vessel or obstacle name it belongs to ("" for the scene)

    @property
    def model(self):
        return self.physics.model.ptr

    @property
    def data(self):
        return self.physics.data.ptr

    @property
    def n_vessels(self) -> int:
        return len(self.vessel_names)

    def contiguous_vessel_dofs(self) -> bool:
        """True when vessel i owns qpos/qvel [3i, 3i+3) — lets the physics step use reshaped views."""
        n = self.n_vessels
        expected = np.arange(3 * n).reshape(n, 3)
        return bool(np.array_equal(self.qpos_adr, expected) and np.array_equal(self.dof_adr, expected))


def _add_polygon(root: mjcf.RootElement, obstacle: PolygonObstacle) -> None:
    body = root.worldbody.add("body", name=f"obstacle_{obstacle.name}")
    v = obstacle.vertices
    h = obstacle.height_m
    for k in range(len(v)):
        a, b = v[k], v[(k + 1) % len(v)]
        d = b - a
        length = float(np.hypot(*d))
        if length < 1e-9:
            raise ValueError(f"{obstacle.name}.vertices[{k}]: repeats the next vertex")
        mid = 0.5 * (a + b)
        # Pull the wall half its thickness inward so its outer face lies on the polygon edge: the
        # obstacle is exactly the declared polygon (counter-clockwise polygon: the outward normal
        # is the edge direction turned clockwise).
        n_out = np.array([d[1], -d[0]]) / length
        centre = mid - 0.5 * WALL_THICKNESS_M * n_out
        body.add(
            "geom",
            name=f"obstacle_{obstacle.name}_wall{k}",
            type="box",
            size=[0.5 * length + 0.5 * WALL_THICKNESS_M, 0.5 * WALL_THICKNESS_M, 0.5 * h],
            pos=[centre[0], centre[1], 0.5 * h - 0.5],
            euler=[0, 0, float(np.arctan2(d[1], d[0]))],
            rgba=OBSTACLE_RGBA,
            group=0,
        )


def build_world(
    vessels: list[tuple[str, VesselType]],
    static_obstacles: list[PolygonObstacle | CircleObstacle] = (),
    moving_obstacles: list[MovingObstacle] = (),
    timestep_s: float | None = None,
) -> World:
    """Build and compile the model of a run. ``vessels`` is a list of (unique name, type)."""
    names = [n for n, _ in vessels]
    if len(set(names)) != len(names):
        raise ValueError(f"vessels: names must be unique, got {names}")
    for n in names:
        if not n or "/" in n or n.startswith("obstacle") or not n.replace("_", "").replace("-", "").isalnum():
            raise ValueError(f"vessels: invalid vessel name {n!r} (letters, digits, '_' or '-'; not 'obstacle…')")
    root = mjcf.from_path(str(SCENE_XML))
    root.model = "mjasc_world"
    if timestep_s is not None:
        if not timestep_s > 0:
            raise ValueError(f"timestep_s: must be > 0, got {timestep_s}")
        root.option.timestep = timestep_s
    for name, vtype in vessels:
        vm = mjcf.from_path(str(vtype.mjcf_path))
        vm.model = name
        root.attach(vm)
    for obstacle in static_obstacles:
        if isinstance(obstacle, PolygonObstacle):
            _add_polygon(root, obstacle)
        elif isinstance(obstacle, CircleObstacle):
            root.worldbody.add(
                "geom",
                name=f"obstacle_{obstacle.name}",
                type="cylinder",
                size=[obstacle.radius_m, 0.5 * obstacle.height_m],
                pos=[obstacle.centre[0], obstacle.centre[1], 0.5 * obstacle.height_m - 0.5],
                rgba=OBSTACLE_RGBA,
                group=0,
            )
        else:
            raise TypeError(f"static_obstacles: unsupported obstacle {obstacle!r}")
    for obstacle in moving_obstacles:
        body = root.worldbody.add(
            "body", name=f"obstacle_{obstacle.name}", mocap="true", pos=[*obstacle.position_m, 0.0]
        )
        body.add(
            "geom",
            name=f"obstacle_{obstacle.name}_hull",
            type="cylinder",
            size=[obstacle.radius_m, 0.75],
            pos=[0, 0, 0.25],
            rgba=MOVING_RGBA,
            group=0,
        )
        body.add("geom", name=f"obstacle_{obstacle.name}_bow", type="box", size=[0.3 * obstacle.radius_m, 0.1, 0.05],
                 pos=[0.7 * obstacle.radius_m, 0, 1.05], rgba="1 1 1 1", group=0, contype=0, conaffinity=0)

    # Before reset() places them, every vessel sits at the origin: compile with contacts off so
    # that construction does not report thousands of spurious overlaps, then switch them on.
    root.option.flag.contact = "disable"
    physics = mjcf.Physics.from_mjcf_model(root)
    root.option.flag.contact = "enable"
    import mujoco

    m = physics.model.ptr
    m.opt.disableflags &= ~int(mujoco.mjtDisableBit.mjDSBL_CONTACT)

    def jid(name):
        i = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name)
        if i < 0:
            raise ValueError(f"vessel MJCF: joint {name!r} missing (contract in assets/README.md)")
        return i

    def aid(name):
        i = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, name)
        if i < 0:
            raise ValueError(f"vessel MJCF: actuator {name!r} missing (contract in assets/README.md)")
        return i

    joints = np.array([[jid(f"{n}/{j}") for j in ("x", "y", "yaw")] for n in names], dtype=int).reshape(-1, 3)
    acts = np.array([[aid(f"{n}/{a}") for a in ("port_propeller", "starboard_propeller")] for n in names], dtype=int).reshape(-1, 2)
    lateral = np.zeros((len(names), 2))
    for i, n in enumerate(names):
        for k, side in enumerate(("port_propeller", "starboard_propeller")):
            sid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, f"{n}/{side}")
            if sid < 0:
                raise ValueError(f"vessel MJCF: site {n}/{side} missing")
            lateral[i, k] = m.site_pos[sid][1]
    hull = np.array([mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, f"{n}/hull") for n in names], dtype=int)
    mocap = np.array(
        [m.body_mocapid[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, f"obstacle_{o.name}")] for o in moving_obstacles],
        dtype=int,
    )
    owner = [""] * m.ngeom
    body_owner = {int(b): n for b, n in zip(hull, names)}
    for o in list(static_obstacles) + list(moving_obstacles):
        for g in range(m.ngeom):
            gname = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or ""
            if gname == f"obstacle_{o.name}" or gname.startswith(f"obstacle_{o.name}_"):
                owner[g] = o.name
    for g in range(m.ngeom):
        if int(m.geom_bodyid[g]) in body_owner:
            owner[g] = body_owner[int(m.geom_bodyid[g])]
    return World(
        geom_owner=owner,
        mjcf_model=root,
        physics=physics,
        vessel_names=names,
        vessel_types=[t for _, t in vessels],
        static_obstacles=list(static_obstacles),
        moving_obstacles=list(moving_obstacles),
        qpos_adr=m.jnt_qposadr[joints] if joints.size else np.zeros((0, 3), int),
        dof_adr=m.jnt_dofadr[joints] if joints.size else np.zeros((0, 3), int),
        act_adr=m.actuator_actadr[acts] if acts.size else np.zeros((0, 2), int),
        ctrl_adr=acts,
        hull_body_id=hull,
        mocap_id=mocap,
        propeller_lateral_m=lateral,
    )
