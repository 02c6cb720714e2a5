"""The vessel and scene MJCF assets (assets/): they load, follow the contract of assets/README.md,
reproduce the published mass matrices, compose with dm_control, step without MuJoCo warnings
(Menagerie's test style) and render."""

import os

os.environ.setdefault("MUJOCO_GL", "osmesa")  # read at import time by mujoco and dm_control

import math
import tomllib
from pathlib import Path

import mujoco
import numpy as np
import pytest
from dm_control import mjcf

ASSETS = Path(__file__).resolve().parent.parent / "assets"
SCENE_XML = ASSETS / "scene" / "water.xml"
VESSELS = ["otter", "delfim"]
G = 9.81


def vessel_xml(name: str) -> Path:
    return ASSETS / "vessels" / name / f"{name}.xml"


def vessel_toml(name: str) -> dict:
    with open(ASSETS / "vessels" / name / "hydrodynamics.toml", "rb") as f:
        return tomllib.load(f)


def vessel_model(name: str) -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(vessel_xml(name)))


def rigid_body_mass_matrix(model: mujoco.MjModel) -> np.ndarray:
    """MuJoCo's 3x3 joint-space mass matrix of (x, y, yaw) at yaw = 0: M_RB about CO."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    m = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, m)
    return m


def added_mass_matrix(t: dict) -> np.ndarray:
    """M_A = −[[X_u̇, 0, 0], [0, Y_v̇, Y_ṙ], [0, N_v̇, N_ṙ]] (Fossen's sign convention)."""
    a = t["added_mass"]
    return -np.array(
        [[a["X_udot"], 0.0, 0.0], [0.0, a["Y_vdot"], a["Y_rdot"]], [0.0, a["N_vdot"], a["N_rdot"]]]
    )


def no_warnings(data: mujoco.MjData) -> dict:
    """The MuJoCo warnings raised so far, by name (empty when none)."""
    return {
        mujoco.mjtWarning(i).name: int(w.number) for i, w in enumerate(data.warning) if w.number > 0
    }


ALL_XML = [SCENE_XML] + [vessel_xml(v) for v in VESSELS] + [ASSETS / "vessels" / v / "scene.xml" for v in VESSELS]


# ---------------------------------------------------------------------------------------------
# Loading
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("path", ALL_XML, ids=lambda p: str(p.relative_to(ASSETS)))
def test_loads_in_mujoco(path):
    model = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data)
    assert not no_warnings(data)


@pytest.mark.parametrize("path", ALL_XML, ids=lambda p: str(p.relative_to(ASSETS)))
def test_loads_in_dm_control(path):
    root = mjcf.from_path(str(path))
    physics = mjcf.Physics.from_mjcf_model(root)
    try:
        physics.step()
    finally:
        physics.free()


# ---------------------------------------------------------------------------------------------
# The vessel contract (assets/README.md): checked by the library's own checker, the one a user's
# vessel folder meets when it is loaded (mjasc.physics.vessel_contract; tests/test_own_hull.py
# breaks it one rule at a time)
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", VESSELS)
def test_vessel_folder_keeps_the_contract(name):
    from mjasc.physics.vessel_contract import check_vessel_folder

    check_vessel_folder(ASSETS / "vessels" / name)


@pytest.mark.parametrize("name", VESSELS)
def test_catamaran_collision_hull_and_livery(name):
    """The shipped hulls: two pontoon boxes and a deck box collide; the livery colours at least
    two visual geoms (the video paints it in the vessel's palette colour)."""
    from mjasc.physics.vessel_contract import is_livery_material

    model = vessel_model(name)
    collision = [model.geom(i).name for i in range(model.ngeom) if model.geom(i).name.endswith("_collision")]
    assert {"port_pontoon_collision", "starboard_pontoon_collision"} <= set(collision) and len(collision) >= 3
    livery = {k for k in range(model.nmat) if is_livery_material(model.material(k).name)}
    visual = [g for g in range(model.ngeom) if model.geom_group[g] == 2]
    assert sum(model.geom_matid[g] in livery for g in visual) >= 2


@pytest.mark.parametrize("name", VESSELS)
def test_propeller_sites_aft_below_the_waterline(name):
    model = vessel_model(name)
    port = model.site("port_propeller").pos
    assert port[0] < 0 and port[2] < 0, "aft of CO, below the waterline"
    if name == "otter":
        assert port[1] == pytest.approx(0.395)  # Fossen's lever arm


@pytest.mark.parametrize("name", VESSELS)
def test_shaft_lag_is_first_order_with_time_constant(name):
    """act(t) = 1 − exp(−t/T_n) after a unit step of the command, zero force on the hull."""
    model = vessel_model(name)
    data = mujoco.MjData(model)
    tau = vessel_toml(name)["propellers"]["time_constant_s"]
    data.ctrl[:] = [1.0, -0.5]
    steps = 25
    for _ in range(steps):
        mujoco.mj_step(model, data)
    t = steps * model.opt.timestep
    assert data.act == pytest.approx(np.array([1.0, -0.5]) * (1 - math.exp(-t / tau)), rel=1e-9)
    assert np.allclose(data.qvel, 0.0) and np.allclose(data.actuator_force, 0.0)


# ---------------------------------------------------------------------------------------------
# Mass, inertia and the hydrodynamic coefficients
# ---------------------------------------------------------------------------------------------

def test_otter_mass_matrix_matches_fossen():
    """Fossen's model: M = M_RB + M_A ≈ diag(85.5, 162.5, 42.65), sway–yaw coupling m·x_g = 12.25."""
    model = vessel_model("otter")
    assert model.body("hull").mass[0] == pytest.approx(80.0)
    m_total = rigid_body_mass_matrix(model) + added_mass_matrix(vessel_toml("otter"))
    assert np.diag(m_total) == pytest.approx([85.5, 162.5, 42.65], rel=0.01)
    assert m_total[1, 2] == pytest.approx(12.25, rel=0.01)
    assert m_total[2, 1] == pytest.approx(12.25, rel=0.01)
    assert m_total[0, 1] == m_total[0, 2] == 0.0


def test_delfim_mass_matrix_is_the_documented_scaling():
    """README: M_RB from 320 kg, x_g = 0.268 m, Izz_CG = 245.0; M_A as the Otter's fractions."""
    model = vessel_model("delfim")
    assert model.body("hull").mass[0] == pytest.approx(320.0)
    m_total = rigid_body_mass_matrix(model) + added_mass_matrix(vessel_toml("delfim"))
    assert np.diag(m_total) == pytest.approx([342.0, 650.0, 684.48], rel=0.005)
    assert m_total[1, 2] == pytest.approx(320 * 0.268, rel=0.005)
    # Added-mass fractions of the displacement mass equal the Otter's.
    otter, delfim = vessel_toml("otter")["added_mass"], vessel_toml("delfim")["added_mass"]
    for key in ("X_udot", "Y_vdot"):
        assert delfim[key] / 320 == pytest.approx(otter[key] / 80, rel=1e-3), key


@pytest.mark.parametrize("name", VESSELS)
def test_damping_time_constants(name):
    """Fossen's recipe: Y_v = −M_22/T_sway, N_r = −M_33/T_yaw, T = 1 s for the Otter, √1.75 s scaled."""
    t = vessel_toml(name)
    m_total = rigid_body_mass_matrix(vessel_model(name)) + added_mass_matrix(t)
    expected_t = 1.0 if name == "otter" else math.sqrt(3.5 / 2.0)
    assert m_total[1, 1] / -t["damping"]["Y_v"] == pytest.approx(expected_t, rel=0.01)
    assert m_total[2, 2] / -t["damping"]["N_r"] == pytest.approx(expected_t, rel=0.01)


@pytest.mark.parametrize("name", VESSELS)
def test_full_thrust_steady_speed_is_top_speed(name):
    """Linear damping only: u = 2 k n_max² / |X_u| (the hand check in assets/vessels/otter/README.md)."""
    t = vessel_toml(name)
    p = t["propellers"]
    u = 2 * p["k_forward"] * p["n_max_rad_s"] ** 2 / -t["damping"]["X_u"]
    assert u == pytest.approx(t["limits"]["top_speed_m_s"], rel=0.01)


def test_otter_propellers_are_fossens_bollard_figures():
    """k n_max² = 24.4 g / 2 forward and k |n_min|² = 13.6 g / 2 reverse, per propeller."""
    p = vessel_toml("otter")["propellers"]
    assert p["k_forward"] * p["n_max_rad_s"] ** 2 == pytest.approx(0.5 * 24.4 * G, rel=0.002)
    assert p["k_reverse"] * p["n_min_rad_s"] ** 2 == pytest.approx(0.5 * 13.6 * G, rel=0.002)


@pytest.mark.parametrize("name", VESSELS)
def test_geometry_matches_model(name):
    """The draft is Fossen's displacement formula (Cb = 0.4); the contract checks that radius_m
    bounds every geom."""
    t = vessel_toml(name)["geometry"]
    model = vessel_model(name)
    hull_beam = 2 * model.geom("port_pontoon_collision").size[1]
    displaced = model.body("hull").mass[0] / 1025.0
    assert t["draft_m"] == pytest.approx(displaced / (2 * 0.4 * hull_beam * t["length_m"]), rel=0.01)
    length = 2 * model.geom("port_pontoon_collision").size[0]
    assert length == pytest.approx(t["length_m"])
    beam = 2 * (model.geom("port_pontoon_collision").pos[1] + model.geom("port_pontoon_collision").size[1])
    assert beam == pytest.approx(t["beam_m"], rel=0.05)


# ---------------------------------------------------------------------------------------------
# Composition with dm_control: several vessels on the water scene
# ---------------------------------------------------------------------------------------------


def build_fleet(placements):
    """The water scene with vessels attached under their own namespaces at (x, y, yaw)."""
    scene = mjcf.from_path(str(SCENE_XML))
    for namespace, kind, (x, y, yaw) in placements:
        vessel = mjcf.from_path(str(vessel_xml(kind)))
        vessel.model = namespace
        frame = scene.attach(vessel)
        frame.pos = [x, y, 0.0]
        frame.euler = [0.0, 0.0, yaw]
    return mjcf.Physics.from_mjcf_model(scene)


def test_fleet_steps_without_warnings_and_stays_at_the_waterline():
    physics = build_fleet(
        [("alpha", "otter", (0, 0, 0)), ("bravo", "otter", (6, 0, math.pi)), ("charlie", "delfim", (0, 10, 0.5))]
    )
    try:
        model, data = physics.model.ptr, physics.data.ptr
        assert model.nu == 6 and model.na == 6 and model.nq == 9
        names = [model.actuator(i).name for i in range(model.nu)]
        assert names[:2] == ["alpha/port_propeller", "alpha/starboard_propeller"]
        hulls = [model.body(f"{v}/hull").id for v in ("alpha", "bravo", "charlie")]
        assert model.opt.timestep == 0.02 and model.opt.integrator == mujoco.mjtIntegrator.mjINT_EULER
        rng = np.random.default_rng(0)
        for step in range(1000):
            data.ctrl[:] = rng.uniform(-1, 1, model.nu)
            if step % 50 == 0:  # random shoves in the plane so that hulls move, turn and collide
                data.xfrc_applied[hulls, :] = 0.0
                data.xfrc_applied[hulls, :2] = rng.normal(0, 150, (3, 2))
                data.xfrc_applied[hulls, 5] = rng.normal(0, 30, 3)
                data.xfrc_applied[hulls[0], 0] = 300.0  # alpha heads for bravo
            mujoco.mj_step(model, data)
        assert not no_warnings(data)
        assert np.all(np.isfinite(data.qpos)) and np.all(np.abs(data.act) <= 1.0)
        assert np.allclose(data.xpos[hulls, 2], 0.0), "the joint set keeps every hull at the waterline"
        assert np.allclose(data.xquat[hulls][:, 1:3], 0.0), "no roll or pitch"
    finally:
        physics.free()


def test_hulls_collide_with_each_other_but_not_with_the_water():
    physics = build_fleet([("alpha", "otter", (0, 0, 0)), ("bravo", "delfim", (4, 0, 0))])
    try:
        model, data = physics.model.ptr, physics.data.ptr
        alpha, bravo = model.body("alpha/hull").id, model.body("bravo/hull").id
        water = model.geom("water").id
        touched = False
        for _ in range(200):
            data.xfrc_applied[alpha, 0] = 200.0
            data.xfrc_applied[alpha, 1] = 0.0
            mujoco.mj_step(model, data)
            for c in data.contact[: data.ncon]:
                assert water not in (c.geom1, c.geom2)
                bodies = {model.geom_bodyid[c.geom1], model.geom_bodyid[c.geom2]}
                touched |= bodies == {alpha, bravo}
        assert touched
        # Alpha's bow (1.0 m ahead of CO) does not sink into bravo's stern (1.75 m behind its CO).
        penetration = (data.xpos[alpha, 0] + 1.0) - (data.xpos[bravo, 0] - 1.75)
        assert penetration < 0.05
        assert data.xpos[bravo, 0] > 4.0, "alpha pushed bravo ahead"

        assert not no_warnings(data)
    finally:
        physics.free()


def test_scene_geom_groups():
    model = mujoco.MjModel.from_xml_path(str(SCENE_XML))
    water = model.geom("water")
    assert water.type[0] == mujoco.mjtGeom.mjGEOM_PLANE
    assert (water.group[0], water.contype[0], water.conaffinity[0]) == (1, 0, 0)
    assert {model.camera(i).name for i in range(model.ncam)} == {"top_down", "overview"}
    assert model.nlight >= 1 and model.vis.global_.offwidth == 1280 and model.vis.global_.offheight == 720
    assert model.vis.quality.shadowsize == 0 and model.vis.quality.offsamples == 0
    # top_down looks straight down from high up, with a ~300 m field of view.
    cam = model.camera("top_down")
    assert np.allclose(_zaxis(cam.quat), [0, 0, 1]), "camera looks along -z"
    span = 2 * cam.pos[2] * math.tan(math.radians(model.cam_fovy[cam.id] / 2))
    assert span == pytest.approx(300, rel=0.05)
    zfar = model.vis.map.zfar * model.stat.extent
    assert zfar > cam.pos[2], "the water must lie inside the far clipping plane"


def _zaxis(quat):
    mat = np.zeros(9)
    mujoco.mju_quat2Mat(mat, quat)
    return mat.reshape(3, 3)[:, 2]


# ---------------------------------------------------------------------------------------------
# Rendering (software GL)
# ---------------------------------------------------------------------------------------------


def _render(model, data, camera, height=240, width=320):
    with mujoco.Renderer(model, height, width) as renderer:
        renderer.update_scene(data, camera=camera)
        return renderer.render().astype(float) / 255.0


def test_top_down_render_is_not_uniform():
    model = mujoco.MjModel.from_xml_path(str(ASSETS / "vessels" / "otter" / "scene.xml"))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    image = _render(model, data, "top_down")
    assert image.shape == (240, 320, 3)
    assert image.std(axis=(0, 1)).max() > 0.005


# Pixel tests for the hull's colour in the chase view: Otter yellow, Delfim white hulls, red trim.
HULL_COLOUR = {
    "otter": lambda im: (im[..., 0] > 0.55) & (im[..., 1] > 0.40) & (im[..., 2] < 0.25),
    "delfim": lambda im: (im[..., 0] > 0.45) & (im[..., 1] < 0.2) & (im[..., 2] < 0.2),
}


@pytest.mark.parametrize("name", VESSELS)
def test_chase_camera_sees_the_hull(name):
    model = mujoco.MjModel.from_xml_path(str(ASSETS / "vessels" / name / "scene.xml"))
    data = mujoco.MjData(model)
    data.qpos[2] = 1.0  # the chase camera turns with the hull
    mujoco.mj_forward(model, data)
    image = _render(model, data, "chase")
    hull = HULL_COLOUR[name](image)
    assert hull.mean() > 0.01, "hull colour missing from the chase view"
    rows, cols = np.nonzero(hull)
    assert abs(cols.mean() / image.shape[1] - 0.5) < 0.15, "hull centred left-right"
    assert rows.mean() / image.shape[0] > 0.4, "hull in the lower part of the frame (camera looks down)"
