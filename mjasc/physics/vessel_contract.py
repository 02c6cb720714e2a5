"""The vessel-folder contract (assets/README.md, "Vessel MJCF contract"), checked in one place.

A vessel folder ``<name>/`` holds ``<name>.xml`` and ``hydrodynamics.toml``. mjasc's code relies
on the names, joints, actuators, sensors and geom conventions listed in assets/README.md: the
world attaches the MJCF under the vessel's name, the physics writes its forces into the three
planar dofs (slide x, slide y, hinge yaw) and reads the propeller sites and the shaft-lag
activations, the range sensor casts from ``sensor_mount`` and excludes its own vessel by body,
collision prediction bounds the hull by ``radius_m``, the video follows the ``chase`` camera.
:func:`check_vessel_folder` checks all of it and raises :class:`VesselContractError`, one line
naming the file, the element or field and the reason::

    hulls/heron/heron.xml: joint 'yaw': must be a hinge about 0 0 1, got slide

The shipped vessels are held to it by tests/test_assets.py; a user's vessel folder (a scenario's
``type = "hulls/heron"``) when it is loaded (:func:`mjasc.physics.vessels.resolve_vessel_type`).
A livery material (``*_livery``) is optional: without one the video keeps the model's colours.
"""

from __future__ import annotations

import math
import tomllib
import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import numpy as np

__all__ = ["VesselContractError", "check_vessel_folder", "check_hydrodynamics_toml", "check_vessel_mjcf",
           "is_livery_material", "LIVERY_MATERIALS", "TOML_KEYS", "JOINTS", "SITES", "ACTUATORS", "SENSORS",
           "CAMERAS", "CONTACT_BAND_M"]

#: ``hydrodynamics.toml``: exactly these tables and keys (besides top-level ``name``, ``description``).
TOML_KEYS = {
    "geometry": ("length_m", "beam_m", "draft_m", "radius_m"),
    "added_mass": ("X_udot", "Y_vdot", "Y_rdot", "N_vdot", "N_rdot"),
    "damping": ("X_u", "Y_v", "N_r", "X_uu", "N_r_nonlinear_gain"),
    "cross_flow": ("enabled", "drag_coefficient_2d", "strips", "water_density_kg_m3"),
    "propellers": ("k_forward", "k_reverse", "n_max_rad_s", "n_min_rad_s", "time_constant_s"),
    "limits": ("top_speed_m_s", "cruise_speed_m_s"),
}
#: The hull's joints in order: (name, MuJoCo type, axis).
JOINTS = (("x", "slide", (1.0, 0.0, 0.0)), ("y", "slide", (0.0, 1.0, 0.0)), ("yaw", "hinge", (0.0, 0.0, 1.0)))
SITES = ("hull_centre", "imu", "port_propeller", "starboard_propeller", "sensor_mount")
ACTUATORS = ("port_propeller", "starboard_propeller")
#: name → (MuJoCo sensor type, the site it is attached to; None: any)
SENSORS = {"imu_velocity": ("VELOCIMETER", "imu"), "imu_gyro": ("GYRO", "imu"),
           "hull_position": ("FRAMEPOS", None), "hull_heading": ("FRAMEXAXIS", None)}
CAMERAS = ("chase", "onboard")
#: The materials that carry a vessel's livery besides those named ``*_livery`` (the shipped hulls'
#: own names): the video paints them in the vessel's palette colour (mjasc.runs.video_model).
LIVERY_MATERIALS = frozenset({"otter_pontoon", "delfim_red"})
#: Every collision geom spans 0 ≤ z ≤ 0.15 m (hulls meet where their footprints meet; rays at
#: z = 0.1 m see every hull).
CONTACT_BAND_M = (0.0, 0.15)
SENSOR_MOUNT_HEIGHT_M = (0.5, 1.0)
_SCENE_ONLY = ("option", "visual", "statistic")
_TOL = 1e-9


class VesselContractError(ValueError):
    """A vessel folder breaks the contract: one line naming the file, the element and the reason."""


def _fmt(v) -> str:
    a = np.atleast_1d(np.asarray(v, float))
    return " ".join(f"{x:g}" for x in a) if a.size > 1 else f"{float(a[0]):g}"


def check_vessel_folder(folder: str | Path) -> None:
    """Check ``folder`` (``<name>.xml`` and ``hydrodynamics.toml``, name = the folder's name)
    against the contract; raises :class:`VesselContractError` at the first problem."""
    folder = Path(folder)
    name = folder.name
    xml, toml = folder / f"{name}.xml", folder / "hydrodynamics.toml"
    for f in (xml, toml):
        if not f.is_file():
            raise VesselContractError(f"{f}: missing (a vessel folder holds <folder name>.xml and "
                                      f"hydrodynamics.toml, assets/README.md)")
    t = check_hydrodynamics_toml(toml, name)
    check_vessel_mjcf(xml, name, t)


# ---------------------------------------------------------------------- hydrodynamics.toml
def check_hydrodynamics_toml(path: Path, name: str) -> dict:
    """The TOML's tables, keys and signs; returns the parsed document."""
    def bad(field: str, reason: str, got) -> VesselContractError:
        return VesselContractError(f"{path}: {field}: {reason}, got {got!r}")

    try:
        with open(path, "rb") as fh:
            t = tomllib.load(fh)
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise VesselContractError(f"{path}: not valid TOML: {exc}") from None
    if t.get("name") != name:
        raise bad("name", f"must be the folder's name {name!r}", t.get("name"))
    if not isinstance(t.get("description"), str):
        raise bad("description", "must be a string", t.get("description"))
    for key in t:
        if key not in ("name", "description") and key not in TOML_KEYS:
            raise bad(key, f"unknown table (allowed: {', '.join(TOML_KEYS)})", key)
    for table, keys in TOML_KEYS.items():
        sub = t.get(table)
        if not isinstance(sub, dict):
            raise bad(f"[{table}]", "missing table", sub)
        for key in sub:
            if key not in keys:
                raise bad(f"{table}.{key}", f"unknown key (allowed: {', '.join(keys)})", key)
        for key in keys:
            if key not in sub:
                raise bad(f"{table}.{key}", "missing", None)
            value = sub[key]
            ok = isinstance(value, bool) if key == "enabled" else (
                isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value))
            if not ok:
                raise bad(f"{table}.{key}", "must be a boolean" if key == "enabled" else "must be a finite number",
                          value)
    for key, value in t["added_mass"].items():
        if value > 0:
            raise bad(f"added_mass.{key}", "must be ≤ 0 (Fossen's convention: negative derivatives)", value)
    if t["added_mass"]["Y_rdot"] != t["added_mass"]["N_vdot"]:
        raise bad("added_mass.N_vdot", f"must equal Y_rdot = {t['added_mass']['Y_rdot']} (a symmetric M_A)",
                  t["added_mass"]["N_vdot"])
    for key in ("X_u", "Y_v", "N_r", "X_uu"):
        if t["damping"][key] > 0:
            raise bad(f"damping.{key}", "must be ≤ 0 (Fossen's convention)", t["damping"][key])
    for table, keys in (("geometry", TOML_KEYS["geometry"]), ("limits", TOML_KEYS["limits"]),
                        ("propellers", ("k_forward", "k_reverse", "n_max_rad_s", "time_constant_s"))):
        for key in keys:
            if t[table][key] <= 0:
                raise bad(f"{table}.{key}", "must be > 0", t[table][key])
    if t["propellers"]["n_min_rad_s"] >= 0:
        raise bad("propellers.n_min_rad_s", "must be < 0 (the reverse shaft speed)", t["propellers"]["n_min_rad_s"])
    if t["limits"]["cruise_speed_m_s"] >= t["limits"]["top_speed_m_s"]:
        raise bad("limits.cruise_speed_m_s", f"must be below top_speed_m_s = {t['limits']['top_speed_m_s']}",
                  t["limits"]["cruise_speed_m_s"])
    return t


# ---------------------------------------------------------------------- <name>.xml
def check_vessel_mjcf(path: Path, name: str, hydro: dict) -> None:
    """The MJCF's structure (as written) and its compiled model against the contract."""
    def bad(what: str, reason: str, got="") -> VesselContractError:
        return VesselContractError(f"{path}: {what}: {reason}" + (f", got {got}" if got != "" else ""))

    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise bad("XML", "not well-formed", exc) from None
    if root.tag != "mujoco" or root.get("model") != name:
        raise bad("<mujoco model>", f"must be <mujoco model=\"{name}\"> (the folder's name)",
                  f"<{root.tag} model=\"{root.get('model')}\">")
    compiler = root.find("compiler")
    if compiler is None or compiler.get("angle") != "radian":
        raise bad("<compiler angle>", "must be \"radian\"", None if compiler is None else compiler.get("angle"))
    for tag in _SCENE_ONLY:
        if root.find(tag) is not None:
            raise bad(f"<{tag}>", "belongs to the scene (scene/water.xml), not to a vessel", f"<{tag}>")
    if root.findall(".//light"):
        raise bad("<light>", "lights belong to the scene, not to a vessel", f"{len(root.findall('.//light'))} light(s)")
    default = root.find("default")
    top = default.find("default") if default is not None else None
    if top is None or top.get("class") != name:
        raise bad("<default class>", f"needs a default class {name!r} (layered defaults)",
                  None if top is None else top.get("class"))
    classes = {d.get("class") for d in top.findall("default")}
    if not {"visual", "collision"} <= classes:
        raise bad(f"<default class=\"{name}\">", "needs sub-classes 'visual' and 'collision'",
                  sorted(map(str, classes)))
    world = root.find("worldbody")
    children = [] if world is None else list(world)
    if [c.tag for c in children] != ["body"]:
        raise bad("<worldbody>", "must hold exactly one body (the hull) and nothing else",
                  [c.tag for c in children])
    hull = children[0]
    if hull.get("name") != "hull":
        raise bad("top-level body", "must be named 'hull'", repr(hull.get("name")))
    if hull.findall("body"):
        raise bad("body 'hull'", "must be one rigid body (no child bodies: all geoms in the hull)",
                  [b.get("name") for b in hull.findall("body")])
    known = {d.get("class") for d in default.iter("default")}
    for el in hull.iter():
        if el.get("childclass") is not None and el.get("childclass") not in known:
            raise bad(f"<{el.tag} name={el.get('name')!r} childclass>", f"must name a default class (the folder's "
                      f"name {name!r})", repr(el.get("childclass")))
    inertial = hull.find("inertial")
    if inertial is None or inertial.get("mass") is None or inertial.get("diaginertia") is None:
        raise bad("body 'hull'", "needs an explicit <inertial pos mass diaginertia> (inertia about the CG)",
                  "none" if inertial is None else ET.tostring(inertial, encoding="unicode").strip())
    try:
        model = mujoco.MjModel.from_xml_path(str(path))
    except ValueError as exc:
        # (all of MuJoCo's lines: the second names the element and the line, "Element 'body', line 41")
        raise bad("MuJoCo", "does not compile", "; ".join(exc.args[0].strip().splitlines()) if exc.args
                  else exc) from None
    _check_model(model, bad, hydro)


def _check_model(model, bad, hydro: dict) -> None:
    hull = 1
    if not np.allclose(model.body_pos[hull], 0.0):
        raise bad("body 'hull'", "must be at pos 0 0 0 (origin = CO, midships at the waterline)",
                  _fmt(model.body_pos[hull]))
    if abs(model.body_ipos[hull][1]) > _TOL:
        raise bad("body 'hull' <inertial pos>", "must be x_g 0 z_g (the CG on the centre line)",
                  _fmt(model.body_ipos[hull]))
    names = [model.joint(j).name for j in range(model.njnt)]
    if names != [j[0] for j in JOINTS]:
        raise bad("joints", "must be x, y, yaw in this order", ", ".join(names) or "none")
    for j, (jname, kind, axis) in enumerate(JOINTS):
        what = f"joint '{jname}'"
        got = mujoco.mjtJoint(model.jnt_type[j]).name.removeprefix("mjJNT_").lower()
        if got != kind:
            raise bad(what, f"must be a {kind} about {_fmt(axis)}", got)
        if not np.allclose(model.jnt_axis[j], axis):
            raise bad(what, f"must be a {kind} about {_fmt(axis)}", f"axis {_fmt(model.jnt_axis[j])}")
        if not np.allclose(model.jnt_pos[j], 0.0):
            raise bad(what, "must be at pos 0 0 0", _fmt(model.jnt_pos[j]))
        for field, value in (("limited", float(model.jnt_limited[j])), ("stiffness", model.jnt_stiffness[j]),
                             ("damping", model.dof_damping[j]), ("armature", model.dof_armature[j]),
                             ("frictionloss", model.dof_frictionloss[j])):
            if value != 0:
                raise bad(what, f"must have no {field} (mjasc adds all hydrodynamic forces)", f"{field} {value:g}")
    sites = {model.site(i).name: model.site_pos[i] for i in range(model.nsite)}
    for s in SITES:
        if s not in sites:
            raise bad(f"site '{s}'", "missing", "none")
    if not np.allclose(sites["hull_centre"], 0.0):
        raise bad("site 'hull_centre'", "must be at CO, pos 0 0 0", _fmt(sites["hull_centre"]))
    if not np.allclose(sites["imu"][:2], 0.0):
        raise bad("site 'imu'", "must be on the yaw axis (x = y = 0)", _fmt(sites["imu"]))
    port, stbd = sites["port_propeller"], sites["starboard_propeller"]
    if not port[1] > 0:
        raise bad("site 'port_propeller'", "must be at +y (FLU: port is +y)", _fmt(port))
    if not np.allclose(port * [1, -1, 1], stbd):
        raise bad("site 'starboard_propeller'", f"must mirror port_propeller ({_fmt(port * [1, -1, 1])})", _fmt(stbd))
    lo, hi = SENSOR_MOUNT_HEIGHT_M
    if not lo <= sites["sensor_mount"][2] <= hi:
        raise bad("site 'sensor_mount'", f"must be {lo:g}–{hi:g} m up", f"z = {sites['sensor_mount'][2]:g}")
    _check_actuators(model, bad, hydro["propellers"]["time_constant_s"])
    sensors = {model.sensor(i).name: i for i in range(model.nsensor)}
    for s, (kind, site) in SENSORS.items():
        if s not in sensors:
            raise bad(f"sensor '{s}'", "missing", "none")
        i = sensors[s]
        got = mujoco.mjtSensor(model.sensor_type[i]).name.removeprefix("mjSENS_")
        if got != kind:
            raise bad(f"sensor '{s}'", f"must be a {kind.lower()}", got.lower())
        if site is not None and model.sensor_objid[i] != model.site(site).id:
            raise bad(f"sensor '{s}'", f"must be attached to site '{site}'", f"object {model.sensor_objid[i]}")
    cams = {model.camera(i).name for i in range(model.ncam)}
    for c in CAMERAS:
        if c not in cams:
            raise bad(f"camera '{c}'", "missing", "none")
    _check_geoms(model, bad, hydro["geometry"])


def _check_actuators(model, bad, time_constant_s: float) -> None:
    names = [model.actuator(i).name for i in range(model.nu)]
    if names != list(ACTUATORS):
        raise bad("actuators", "must be exactly port_propeller, starboard_propeller (port first)",
                  ", ".join(names) or "none")
    for i, side in enumerate(ACTUATORS):
        what = f"actuator '{side}'"
        checks = (
            (model.actuator_trntype[i] == mujoco.mjtTrn.mjTRN_SITE
             and model.actuator_trnid[i, 0] == model.site(side).id,
             f"must act at site '{side}'", f"transmission {int(model.actuator_trntype[i])}"),
            (np.allclose(model.actuator_gear[i], [1, 0, 0, 0, 0, 0]), "must have gear 1 0 0 0 0 0",
             _fmt(model.actuator_gear[i])),
            (model.actuator_dyntype[i] == mujoco.mjtDyn.mjDYN_FILTEREXACT, "must have dyntype filterexact",
             mujoco.mjtDyn(model.actuator_dyntype[i]).name.removeprefix("mjDYN_").lower()),
            (math.isclose(model.actuator_dynprm[i, 0], time_constant_s, rel_tol=1e-9),
             f"dynprm must be the propellers' time_constant_s = {time_constant_s:g}",
             f"{model.actuator_dynprm[i, 0]:g}"),
            (model.actuator_gaintype[i] == mujoco.mjtGain.mjGAIN_FIXED and not model.actuator_gainprm[i].any(),
             "must have gaintype fixed, gainprm 0 (zero force: mjasc applies the thrust k n|n|)",
             _fmt(model.actuator_gainprm[i][:3])),
            (model.actuator_biastype[i] == mujoco.mjtBias.mjBIAS_NONE, "must have biastype none",
             mujoco.mjtBias(model.actuator_biastype[i]).name.removeprefix("mjBIAS_").lower()),
            (model.actuator_ctrllimited[i] and np.allclose(model.actuator_ctrlrange[i], [-1, 1]),
             "must have ctrlrange -1 1 (ctrllimited)", _fmt(model.actuator_ctrlrange[i])),
        )
        for ok, reason, got in checks:
            if not ok:
                raise bad(what, reason, got)
    if model.na != 2:
        raise bad("actuators", "must have one activation each (the shaft speeds)", f"na = {model.na}")


def _check_geoms(model, bad, geometry: dict) -> None:
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    draft, radius = geometry["draft_m"], geometry["radius_m"]
    band_lo, band_hi = CONTACT_BAND_M
    n_collision = 0
    livery = _livery_materials(model)
    for i in range(model.ngeom):
        g = model.geom(i)
        if not g.name:
            raise bad(f"geom {i}", "must be named *_visual or *_collision", "no name")
        what = f"geom '{g.name}'"
        if model.geom_bodyid[i] != 1:
            raise bad(what, "must be in body 'hull'", model.body(model.geom_bodyid[i]).name or "the world")
        kinds = (int(g.group[0]), int(g.contype[0]), int(g.conaffinity[0]))
        centre, half = model.geom_aabb[i, :3], model.geom_aabb[i, 3:]
        rot = data.geom_xmat[i].reshape(3, 3)
        for corner in np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).T.reshape(-1, 3):
            p = data.geom_xpos[i] + rot @ (centre + corner * half)
            if math.hypot(p[0], p[1]) > radius + 1e-9:
                raise bad(what, f"must lie inside geometry.radius_m = {radius:g} of hydrodynamics.toml",
                          f"a corner {math.hypot(p[0], p[1]):.3f} m from CO")
        if g.name.endswith("_visual"):
            if kinds != (2, 0, 0):
                raise bad(what, "a visual geom must have group 2, contype 0, conaffinity 0",
                          "group {}, contype {}, conaffinity {}".format(*kinds))
            continue
        if not g.name.endswith("_collision"):
            raise bad(what, "must be named *_visual or *_collision", repr(g.name))
        if kinds != (3, 1, 1):
            raise bad(what, "a collision geom must have group 3, contype 1, conaffinity 1",
                      "group {}, contype {}, conaffinity {}".format(*kinds))
        if model.geom_matid[i] in livery:
            raise bad(what, "a livery material is for visual geoms only", model.material(model.geom_matid[i]).name)
        if model.geom_type[i] != mujoco.mjtGeom.mjGEOM_BOX:
            raise bad(what, "a collision geom must be a box",
                      mujoco.mjtGeom(model.geom_type[i]).name.removeprefix("mjGEOM_").lower())
        bottom = data.geom_xpos[i, 2] + rot[2] @ centre - np.abs(rot[2]) @ half
        top = data.geom_xpos[i, 2] + rot[2] @ centre + np.abs(rot[2]) @ half
        if bottom < -draft - 1e-9:
            raise bad(what, f"must not reach below the draft (geometry.draft_m = {draft:g})",
                      f"bottom z = {bottom:.3f}")
        if bottom > band_lo + 1e-9 or top < band_hi - 1e-9:
            raise bad(what, f"must span the contact band {band_lo:g} ≤ z ≤ {band_hi:g} m",
                      f"z {bottom:.3f} to {top:.3f}")
        n_collision += 1
    if n_collision == 0:
        raise bad("geoms", "need at least one *_collision box (the footprint other vessels see and touch)", "none")


def is_livery_material(name: str) -> bool:
    """A material (its name in the vessel's MJCF) the video paints in the vessel's palette colour."""
    return name in LIVERY_MATERIALS or name.endswith("_livery")


def _livery_materials(model) -> set[int]:
    return {k for k in range(model.nmat) if is_livery_material(model.material(k).name)}
