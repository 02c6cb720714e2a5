"""Compose one MuJoCo model from the water scene, the vessels and the obstacles of a run.

Composition uses dm_control's MJCF object model (the same route the dm_control suite takes), so
the simulator and the suite share one model builder. Every element is named: vessel elements are
namespaced ``<vessel name>/<element>`` (``alpha/hull``, ``alpha/yaw``, ``alpha/port_propeller``),
obstacles ``obstacle_<name>…`` (dm_control reserves ``/`` for attached models). Geom groups (assets/README.md): 0 obstacles, 1 water, 2 vessel
visuals, 3 vessel collision hulls. Range sensors see groups 0 and 3 only.

Static polygons become walls along their edges (one box per edge): ray casts hit the true outline
and hull contacts happen at the true boundary, which a single convex mesh could not give for a
non-convex dock. Moving obstacles are mocap bodies (kinematic, position set every physics step).

A process keeps the last few compiled models by what they were built from (:func:`build_world`):
a campaign's runs that share a world (the demo campaign's perturb starts, not the scene) compile it
once and copy it (``mj_copyModel``: the same bits) instead of parsing, composing and compiling
~0.1 s of MJCF per run; such a world composes its MJCF tree only when it is read.
"""

from __future__ import annotations

import os
import threading
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np
from dm_control import mjcf

from mjasc.physics.obstacles import CircleObstacle, MovingObstacle, PolygonObstacle
from mjasc.physics.vessels import SCENE_XML, VesselType

__all__ = ["World", "build_world", "SENSOR_GEOM_GROUPS"]

#: Geom groups a range sensor sees: obstacles (0) and vessel collision hulls (3).
SENSOR_GEOM_GROUPS = np.array([1, 0, 0, 1, 0, 0], dtype=np.uint8)
#: How MuJoCo draws structures (brown) and traffic (dark grey with a white bow mark: apart from the
#: red of predicted conflicts, the vessel colours and the water; the video's legend shows both).
#: Colours only: neither enters the physics nor the range sensor.
OBSTACLE_RGBA = "0.55 0.45 0.35 1"
MOVING_RGBA = "0.22 0.22 0.25 1"
WALL_THICKNESS_M = 0.4
#: Compiled models a process keeps (:func:`build_world`).
MODEL_CACHE_SIZE = 4


class _Tree:
    """``World.mjcf_model``: the MJCF tree, or for a world copied from the model cache the recipe
    that composes it (:class:`_Deferred`), composed at its first read."""

    def __set_name__(self, owner, name):
        self._attr = f"_{name}"

    def __get__(self, world, owner=None):
        if world is None:
            raise AttributeError("mjcf_model")  # (a dataclass field without a default)
        tree = world.__dict__[self._attr]
        if isinstance(tree, _Deferred):
            tree = world.__dict__[self._attr] = tree.compose()
        return tree

    def __set__(self, world, tree):
        world.__dict__[self._attr] = tree


@dataclass(frozen=True)
class _Deferred:
    """The arguments of :func:`_compose`: the tree of a world built from the model cache."""

    vessels: tuple
    static_obstacles: tuple
    moving_obstacles: tuple
    timestep_s: float | None

    def compose(self) -> mjcf.RootElement:
        root = _compose(self.vessels, self.static_obstacles, self.moving_obstacles, self.timestep_s)
        root.option.flag.contact = "enable"  # as build_world leaves it after compiling
        return root


@dataclass
class World:
    """A compiled model plus the index maps everything else uses.

    physics: a dm_control ``mjcf.Physics`` (``physics.model.ptr`` / ``physics.data.ptr`` are the
    raw MjModel / MjData). vessel_names / vessel_types: in model order.
    qpos_adr: (N, 3) qpos addresses of (x, y, yaw) per vessel; dof_adr likewise for qvel;
    act_adr: (N, 2) activation addresses of (port, starboard) shaft lag; ctrl_adr: (N, 2).
    hull_body_id: (N,) body id of each hull; mocap_id: (M,) mocap index per moving obstacle.
    """

    mjcf_model: mjcf.RootElement = _Tree()
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


def _files(path) -> tuple:
    """(name, modification time [ns], size) of every file in ``path``'s folder: a model's key
    changes when its MJCF or an asset next to it does."""
    with os.scandir(os.path.dirname(os.fspath(path))) as it:
        return tuple(sorted((e.name, e.stat().st_mtime_ns, e.stat().st_size) for e in it if e.is_file()))


def _model_key(vessels, static_obstacles, moving_obstacles, timestep_s) -> tuple:
    """Everything :func:`_compose` reads, as plain values: equal keys compose the same tree."""
    def arr(a):
        a = np.asarray(a)
        return a.dtype.str, a.shape, a.tobytes()

    def num(x):
        return type(x).__name__, float(x)

    statics = []
    for o in static_obstacles:
        if isinstance(o, PolygonObstacle):
            statics.append(("polygon", o.name, arr(o.vertices), num(o.height_m)))
        elif isinstance(o, CircleObstacle):
            statics.append(("circle", o.name, arr(o.centre), num(o.radius_m), num(o.height_m)))
        else:
            return None  # (an unsupported obstacle: _compose raises)
    return (_files(SCENE_XML), None if timestep_s is None else num(timestep_s),
            tuple((name, str(vt.mjcf_path), _files(vt.mjcf_path)) for name, vt in vessels), tuple(statics),
            tuple((o.name, num(o.radius_m), arr(o.position_m)) for o in moving_obstacles))


_MODELS: OrderedDict = OrderedDict()  # model key → (compiled model as compiled, World index fields)
_MODELS_LOCK = threading.Lock()


def _compose(vessels, static_obstacles, moving_obstacles, timestep_s) -> mjcf.RootElement:
    """The MJCF tree of a run's world (:func:`build_world`)."""
    root = mjcf.from_path(str(SCENE_XML))
    root.model = "mjasc_world"
    if timestep_s is not None:
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
    return root


def is_valid_vessel_name(name: str) -> bool:
    """A vessel's name in the model: letters, digits, '_' or '-', not starting with 'obstacle'."""
    return bool(name) and not name.startswith("obstacle") and name.replace("_", "").replace("-", "").isalnum()


def build_world(
    vessels: list[tuple[str, VesselType]],
    static_obstacles: list[PolygonObstacle | CircleObstacle] = (),
    moving_obstacles: list[MovingObstacle] = (),
    timestep_s: float | None = None,
) -> World:
    """Build and compile the model of a run. ``vessels`` is a list of (unique name, type).

    A world built before in this process from the same values (the model cache, module docstring)
    is copied from its compiled model: the same model and data, bit for bit (tests/test_world_cache.py)."""
    names = [n for n, _ in vessels]
    if len(set(names)) != len(names):
        raise ValueError(f"vessels: names must be unique, got {names}")
    for n in names:
        if not is_valid_vessel_name(n):
            raise ValueError(f"vessels: invalid vessel name {n!r} (letters, digits, '_' or '-'; not 'obstacle…')")
    if timestep_s is not None and not timestep_s > 0:
        raise ValueError(f"timestep_s: must be > 0, got {timestep_s}")
    import mujoco

    key = _model_key(vessels, static_obstacles, moving_obstacles, timestep_s)
    with _MODELS_LOCK:
        cached = _MODELS.get(key) if key is not None else None
        if cached is not None:
            _MODELS.move_to_end(key)
    if cached is not None:
        compiled, fields = cached
        # Before reset() places them, every vessel sits at the origin: the model is compiled (and
        # its data made) with contacts off, then they are switched on — as below.
        physics = mjcf.Physics.from_model(compiled.copy())
        physics.model.ptr.opt.disableflags &= ~int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
        tree = _Deferred(tuple(vessels), tuple(static_obstacles), tuple(moving_obstacles), timestep_s)
        return World(mjcf_model=tree, physics=physics, vessel_names=names, vessel_types=[t for _, t in vessels],
                     static_obstacles=list(static_obstacles), moving_obstacles=list(moving_obstacles),
                     **{k: (list(v) if isinstance(v, list) else v.copy()) for k, v in fields.items()})
    root = _compose(vessels, static_obstacles, moving_obstacles, timestep_s)

    # Before reset() places them, every vessel sits at the origin: compile with contacts off so
    # that construction does not report thousands of spurious overlaps, then switch them on.
    root.option.flag.contact = "disable"
    physics = mjcf.Physics.from_mjcf_model(root)
    compiled = physics.model.copy() if key is not None else None
    root.option.flag.contact = "enable"

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
    fields = dict(
        geom_owner=owner,
        qpos_adr=m.jnt_qposadr[joints] if joints.size else np.zeros((0, 3), int),
        dof_adr=m.jnt_dofadr[joints] if joints.size else np.zeros((0, 3), int),
        act_adr=m.actuator_actadr[acts] if acts.size else np.zeros((0, 2), int),
        ctrl_adr=acts,
        hull_body_id=hull,
        mocap_id=mocap,
        propeller_lateral_m=lateral,
    )
    if key is not None:
        with _MODELS_LOCK:
            _MODELS[key] = (compiled, {k: (list(v) if isinstance(v, list) else v.copy()) for k, v in fields.items()})
            while len(_MODELS) > MODEL_CACHE_SIZE:
                _MODELS.popitem(last=False)
    return World(mjcf_model=root, physics=physics, vessel_names=names, vessel_types=[t for _, t in vessels],
                 static_obstacles=list(static_obstacles), moving_obstacles=list(moving_obstacles), **fields)
