"""Bring your own hull: a vessel ``type`` that is a vessel folder's path (assets/README.md, "Your
own hull"). The example hull (examples/my_hull) loads and sails and differs from the Otter as its
derivation says; a copy of the Otter's folder sails bit for bit as ``type = "otter"``; each broken
rule of the contract is one line naming the file, the element and the reason; a missing folder or
file names the scenario's field; trials, encounter families and the campaign digest take folders."""

import dataclasses
import json
import os
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from mjasc.campaigns.spec import CampaignError, parse_campaign_spec
from mjasc.physics.trials import run_trial
from mjasc.physics.vessel_contract import VesselContractError, check_vessel_folder
from mjasc.physics.vessels import VESSELS_DIR, load_vessel_type, resolve_vessel_type
from mjasc.runs.runner import run_scenario
from mjasc.runs.scenario import ScenarioError, load_scenario, parse_scenario
from tests.helpers import hold_shaft, make_sim

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "examples" / "my_hull"
HULL = EXAMPLE / "hulls" / "otter_payload"


def copy_vessel(src: Path, dst: Path) -> Path:
    """``src``'s vessel folder copied to ``dst`` and renamed to ``dst.name`` (file, model, default
    class, TOML name: what the contract ties to the folder's name)."""
    old, new = src.name, dst.name
    shutil.copytree(src, dst)
    xml = dst / f"{old}.xml"
    text = xml.read_text().replace(f'model="{old}"', f'model="{new}"').replace(f'class="{old}"', f'class="{new}"')
    xml.unlink()
    (dst / f"{new}.xml").write_text(text.replace(f'childclass="{old}"', f'childclass="{new}"'))
    toml = dst / "hydrodynamics.toml"
    toml.write_text(toml.read_text().replace(f'name = "{old}"', f'name = "{new}"'))
    return dst


def edit(path: Path, old: str, new: str) -> None:
    text = path.read_text()
    assert old in text, old
    path.write_text(text.replace(old, new, 1))


def one_vessel(vtype: str, duration_s: float = 4.0) -> dict:
    return {"name": "solo", "duration_s": duration_s, "outputs": {"recording": False},
            "vessels": [{"name": "v", "type": vtype, "position_m": [0.0, 0.0], "speed_m_s": 1.0,
                         "controller": {"waypoints": [[0.0, 0.0], [30.0, 10.0]], "speed_m_s": 1.5}}]}


# ---------------------------------------------------------------------- the example hull
def test_the_example_hull_keeps_the_contract_and_the_scenario_resolves_it():
    check_vessel_folder(HULL)
    sc = load_scenario(EXAMPLE / "payload_crossing.toml")
    assert sc.vessels[0].type == str(HULL.resolve()) and sc.vessels[1].type == "otter"
    vt = load_vessel_type(sc.vessels[0].type)
    assert vt.name == "otter_payload" and vt.mjcf_path == HULL.resolve() / "otter_payload.xml"


def test_the_example_scenario_sails(tmp_path):
    sc = load_scenario(EXAMPLE / "payload_crossing.toml", duration_s=6.0)
    sc = dataclasses.replace(sc, outputs=dataclasses.replace(sc.outputs, recording=False))
    result = run_scenario(sc, tmp_path, progress=False)
    summary = json.loads(result.files["summary"].read_text())
    assert summary["status"] == "completed"
    loaded = summary["vessels"]["loaded"]
    assert loaded["type"] == "otter_payload" and summary["vessels"]["otter"]["type"] == "otter"
    # from 1.5 m/s for 6 s along its path: it sails (and the heavier hull's speed decays no faster)
    assert 6.0 < loaded["distance_m"] < 10.0


def test_the_example_mass_matrix_is_its_derivation():
    """README.md of the example: M = diag(110.5, 187.5, 43.058), coupling m x_g = 13.5; the sway and
    yaw damping keep Fossen's 1 s time constants; the draft is Fossen's displacement formula."""
    sim = make_sim(str(HULL.resolve()))
    m = sim.hydro.total_mass[0]
    np.testing.assert_allclose(np.diag(m), [110.5, 187.5, 43.058], rtol=2e-4)
    assert m[1, 2] == pytest.approx(13.5, rel=1e-5) and m[2, 1] == pytest.approx(13.5, rel=1e-5)
    vt = load_vessel_type(str(HULL.resolve()))
    assert m[1, 1] / -vt.hydro.Y_v == pytest.approx(1.0, rel=1e-3)
    assert m[2, 2] / -vt.hydro.N_r == pytest.approx(1.0, rel=1e-3)
    assert vt.draft_m == pytest.approx((105 / 1025) / (2 * 0.4 * 0.25 * 2.0), rel=1e-3)


def surge_run(vessel: str, command: float, steps: int) -> np.ndarray:
    """Surge speed after each of ``steps`` physics steps from rest, shafts held at ``command``."""
    sim = make_sim(vessel)
    hold_shaft(sim, [[command, command]])
    out = []
    for _ in range(steps):
        sim.step()
        out.append(sim.states().body_velocity[0])
    return np.array(out)


def test_against_physics_same_top_speed_slower_acceleration_by_the_surge_masses():
    """Same propellers and X_u (README.md of the example): M_11 u̇ = T − |X_u| u, so the steady
    speed T/|X_u| is the Otter's and MuJoCo's Euler step gives u_k = U (1 − (1 − h|X_u|/M_11)^k)
    with M_11 = m − X_u̇ = 105 + 5.5 = 110.5 kg against the Otter's 80 + 5.5 = 85.5 kg: the
    acceleration from rest is slower in the ratio 85.5 / 110.5."""
    heavy = str(HULL.resolve())
    vt, otter = load_vessel_type(heavy), load_vessel_type("otter")
    c, steps = 0.6, 750  # 15 s: ~10 surge time constants of the loaded hull
    u_heavy, u_otter = surge_run(heavy, c, steps), surge_run("otter", c, steps)
    thrust = 2 * vt.propellers.k_forward * (c * vt.propellers.n_max_rad_s) ** 2
    damping = abs(vt.hydro.X_u)
    h, k = 0.02, np.arange(1, steps + 1)
    for u, m11 in ((u_heavy, 110.5), (u_otter, 85.5)):
        closed = thrust / damping * (1 - (1 - h * damping / m11) ** k)
        np.testing.assert_allclose(u[:, 0], closed, rtol=1e-6)
        assert np.abs(u[:, 1:]).max() < 1e-9  # straight ahead: no sway, no yaw
    assert u_heavy[0, 0] / u_otter[0, 0] == pytest.approx(85.5 / 110.5, rel=1e-9)
    assert u_heavy[-1, 0] == pytest.approx(u_otter[-1, 0], rel=1e-3)  # the same steady speed
    assert u_heavy[-1, 0] == pytest.approx(thrust / abs(otter.hydro.X_u), rel=1e-3)


def test_trial_accepts_a_folder(monkeypatch):
    monkeypatch.chdir(ROOT)
    heavy = run_trial("speed", "examples/my_hull/hulls/otter_payload", port=0.6, starboard=0.6)
    otter = run_trial("speed", "otter", port=0.6, starboard=0.6)
    assert heavy["steady_speed"] == pytest.approx(otter["steady_speed"], rel=1e-3)
    assert heavy["t63"] > otter["t63"] * 1.2  # τ = M_11/|X_u|: 1.42 s against 1.10 s (plus the shaft lag)
    with pytest.raises(ValueError, match=r"^--vessel: no such vessel folder"):
        run_trial("speed", "examples/nowhere")


# ---------------------------------------------------------------------- a copy of the Otter is the Otter
def test_trial_takes_a_folder_whose_name_is_no_vessel_name(tmp_path, monkeypatch):
    """A scenario sails a folder named tern.v2 (its vessels have names of their own); the trial
    refused it with "vessels: invalid vessel name 'tern.v2'", a name the user never gave."""
    copy_vessel(VESSELS_DIR / "otter", tmp_path / "tern.v2")
    monkeypatch.chdir(tmp_path)
    assert parse_scenario(one_vessel("./tern.v2"), str(tmp_path / "s.toml")).vessels[0].type.endswith("tern.v2")
    mine, otter = run_trial("speed", "./tern.v2"), run_trial("speed", "otter")
    assert mine["vessel"] == "./tern.v2"
    assert mine["steady_speed"] == otter["steady_speed"] and mine["t63"] == otter["t63"]


def test_a_copy_of_the_otter_sails_bit_for_bit_as_the_otter(tmp_path):
    copy_vessel(VESSELS_DIR / "otter", tmp_path / "hulls" / "my_otter")
    summaries = []
    for vtype in ("otter", "hulls/my_otter"):
        sc = parse_scenario(one_vessel(vtype), str(tmp_path / "s.toml"))
        result = run_scenario(sc, tmp_path / vtype.replace("/", "_"), progress=False)
        s = json.loads(result.files["summary"].read_text())
        v = s["vessels"]["v"]
        assert v.pop("type") == ("otter" if vtype == "otter" else "my_otter")
        summaries.append({k: v for k, v in s.items() if not k.startswith(("wall", "real_time", "timing"))})
    assert summaries[0] == summaries[1]


# ---------------------------------------------------------------------- the contract, one rule at a time
XML, TOML = "my_otter.xml", "hydrodynamics.toml"
BROKEN = {  # (file, old, new) → the error's tail after "<file>: "
    "yaw_slide": (XML, '<joint name="yaw" type="hinge"', '<joint name="yaw" type="slide"',
                  "joint 'yaw': must be a hinge about 0 0 1, got slide"),
    "joint_damping": (XML, '<joint name="x" type="slide" axis="1 0 0" pos="0 0 0"/>',
                      '<joint name="x" type="slide" axis="1 0 0" pos="0 0 0" damping="3"/>',
                      "joint 'x': must have no damping (mjasc adds all hydrodynamic forces), got damping 3"),
    "no_sensor_mount": (XML, 'site name="sensor_mount"', 'site name="mount"', "site 'sensor_mount': missing, got none"),
    "wrong_lag": (XML, 'dynprm="0.1"', 'dynprm="0.2"',
                  "actuator 'port_propeller': dynprm must be the propellers' time_constant_s = 0.1, got 0.2"),
    "scene_option": (XML, "<compiler", '<option timestep="0.01"/>\n  <compiler',
                     "<option>: belongs to the scene (scene/water.xml), not to a vessel, got <option>"),
    "no_chase": (XML, 'camera name="chase"', 'camera name="behind"', "camera 'chase': missing, got none"),
    "toml_key": (TOML, "X_uu = 0.0", "X_uuu = 0.0", "damping.X_uuu: unknown key"),
    "toml_sign": (TOML, "X_u = -77.55", "X_u = 77.55", "damping.X_u: must be ≤ 0 (Fossen's convention), got 77.55"),
    # the default class renamed, the body's childclass not (MuJoCo's own message names neither)
    "stale_childclass": (XML, 'childclass="my_otter"', 'childclass="otter"',
                         "<body name='hull' childclass>: must name a default class (the folder's name 'my_otter'), "
                         "got 'otter'"),
    # MuJoCo's error keeps its second line, the element and the line number
    "unknown_class": (XML, 'class="visual" type="box" material="otter_deck"',
                      'class="visuals" type="box" material="otter_deck"',
                      "MuJoCo: does not compile, got XML Error: unknown default class name 'visuals'; "
                      "Element 'geom', line "),
    # (the geom is in the MJCF: the error names that file, and the TOML's field)
    "radius": (TOML, "radius_m = 1.2", "radius_m = 0.9", f"@{XML}: geom 'port_pontoon_visual': must lie inside "
                                                         "geometry.radius_m = 0.9 of hydrodynamics.toml, got a corner"),
}


@pytest.mark.parametrize("case", list(BROKEN), ids=list(BROKEN))
def test_each_broken_rule_is_one_line_naming_file_element_and_reason(tmp_path, case):
    file, old, new, tail = BROKEN[case]
    folder = copy_vessel(VESSELS_DIR / "otter", tmp_path / "hulls" / "my_otter")
    edit(folder / file, old, new)
    if tail.startswith("@"):  # the error names another file than the one edited
        file, tail = tail[1:].split(": ", 1)
    with pytest.raises(VesselContractError) as direct:
        check_vessel_folder(folder)
    assert str(direct.value).startswith(f"{folder / file}: {tail}"), str(direct.value)
    # through a scenario: the field, then the file as the scenario wrote it
    with pytest.raises(ScenarioError) as err:
        parse_scenario(one_vessel("hulls/my_otter"), str(tmp_path / "s.toml"))
    msg = str(err.value)
    assert msg.startswith(f"vessels[0].type: hulls/my_otter/{file}: {tail}"), msg
    assert "\n" not in msg


def test_a_hull_without_livery_keeps_its_own_colours(tmp_path):
    """The livery is optional: the video's render model then keeps the model's colours."""
    import mujoco

    from mjasc.physics.world import build_world
    from mjasc.runs.video_model import render_model

    folder = copy_vessel(VESSELS_DIR / "otter", tmp_path / "plain")
    edit(folder / "plain.xml", 'name="otter_pontoon"', 'name="plain_pontoon"')
    (folder / "plain.xml").write_text((folder / "plain.xml").read_text().replace('"otter_pontoon"', '"plain_pontoon"'))
    check_vessel_folder(folder)
    world = build_world([("a", load_vessel_type(str(folder))), ("b", load_vessel_type("otter"))])
    painted = render_model(world.model)
    mat = {mujoco.mj_id2name(world.model, mujoco.mjtObj.mjOBJ_MATERIAL, k): k for k in range(world.model.nmat)}
    assert np.array_equal(painted.mat_rgba[mat["a/plain_pontoon"]], world.model.mat_rgba[mat["a/plain_pontoon"]])
    assert not np.array_equal(painted.mat_rgba[mat["b/otter_pontoon"]], world.model.mat_rgba[mat["b/otter_pontoon"]])


# ---------------------------------------------------------------------- what the scenario's field says
def test_missing_folder_or_file_names_the_scenario_field(tmp_path):
    with pytest.raises(ScenarioError, match=r"^vessels\[0\]\.type: no such vessel folder \(relative to the file's "
                                            r"folder: .*\), got 'hulls/heron'$"):
        parse_scenario(one_vessel("hulls/heron"), str(tmp_path / "s.toml"))
    (tmp_path / "hulls" / "heron").mkdir(parents=True)
    (tmp_path / "hulls" / "heron" / "hydrodynamics.toml").write_text("")
    with pytest.raises(ScenarioError, match=r"^vessels\[0\]\.type: the vessel folder has no heron\.xml"):
        parse_scenario(one_vessel("hulls/heron"), str(tmp_path / "s.toml"))
    # a bare name that is neither built in nor a folder beside the file: no hint of a folder
    with pytest.raises(ScenarioError, match=r"^vessels\[0\]\.type: must be one of delfim, otter or a vessel "
                                            r"folder's path, got 'heron2'$"):
        parse_scenario(one_vessel("heron2"), str(tmp_path / "s.toml"))
    # a folder of that name beside the file: how to write it
    (tmp_path / "heron").mkdir()
    with pytest.raises(ScenarioError, match=r"^vessels\[0\]\.type: must be one of delfim, otter or a vessel "
                                            r"folder's path; a folder named so here is written \./heron, got 'heron'$"):
        parse_scenario(one_vessel("heron"), str(tmp_path / "s.toml"))
    # through load_scenario: the file first
    path = tmp_path / "s.toml"
    path.write_text('duration_s = 2.0\n[[vessels]]\nname = "v"\ntype = "hulls/nothing"\n'
                    'controller = { waypoints = [[0.0, 0.0], [10.0, 0.0]] }\n')
    with pytest.raises(ScenarioError, match=rf"^{re.escape(str(path))}: vessels\[0\]\.type: no such vessel folder"):
        load_scenario(path)


def test_a_copied_folder_whose_mjcf_keeps_the_old_name_says_which_file_to_rename(tmp_path, monkeypatch):
    """The first rename of four forgotten (hulls/tern/otter.xml): the error names the file found.
    A missing ~ or absolute folder is not "relative to the current folder"."""
    folder = tmp_path / "hulls" / "tern"
    shutil.copytree(VESSELS_DIR / "otter", folder)
    with pytest.raises(ScenarioError, match=r"^vessels\[0\]\.type: the vessel folder has no tern\.xml \(.*; it has "
                                            r"otter\.xml: rename it to tern\.xml, the folder's name\), "
                                            r"got 'hulls/tern'$"):
        parse_scenario(one_vessel("hulls/tern"), str(tmp_path / "s.toml"))
    monkeypatch.setenv("HOME", str(tmp_path))
    with pytest.raises(ValueError, match=rf"^no such vessel folder \({re.escape(str(tmp_path.resolve()))}/boats/x\), "
                                         r"got '~/boats/x'$"):
        resolve_vessel_type("~/boats/x")


def test_naming_the_mjcf_instead_of_its_folder_says_so(tmp_path, monkeypatch):
    """`--vessel hulls/tern/tern.xml` (or `tern.xml` from inside the folder) said "no such vessel
    folder" or "a folder here: ./tern.xml"; it names a file, and the folder to give instead."""
    folder = copy_vessel(VESSELS_DIR / "otter", tmp_path / "hulls" / "tern")
    held = re.escape(str(folder.resolve()))
    want = rf"^names a file; a vessel type is the path of the vessel folder that holds it \({held}\)"
    with pytest.raises(ValueError, match=want + r", got 'hulls/tern/tern\.xml'$"):
        resolve_vessel_type("hulls/tern/tern.xml", tmp_path)
    monkeypatch.chdir(folder)
    with pytest.raises(ValueError, match=want + r", got 'tern\.xml'$"):
        resolve_vessel_type("tern.xml")
    with pytest.raises(ScenarioError, match=r"^vessels\[0\]\.type: names a file; "):
        parse_scenario(one_vessel("hulls/tern/hydrodynamics.toml"), str(tmp_path / "s.toml"))


def test_a_folder_path_is_relative_to_the_scenario_file_and_expands_home(tmp_path, monkeypatch):
    copy_vessel(VESSELS_DIR / "otter", tmp_path / "home" / "boats" / "mine")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert resolve_vessel_type("~/boats/mine") == str((tmp_path / "home" / "boats" / "mine").resolve())
    sub = tmp_path / "scenarios"
    sub.mkdir()
    sc = parse_scenario(one_vessel("../home/boats/mine"), str(sub / "s.toml"))
    assert sc.vessels[0].type == str((tmp_path / "home" / "boats" / "mine").resolve())
    assert os.path.isabs(sc.vessels[0].type)


# ---------------------------------------------------------------------- campaigns
def family_campaign(tmp_path: Path, vtype: str) -> dict:
    return {"name": "c", "families": [{"kind": "head_on", "own": {"type": vtype}}]}


def test_an_encounter_family_sails_a_folder_and_the_digest_covers_its_files(tmp_path):
    folder = copy_vessel(VESSELS_DIR / "otter", tmp_path / "hulls" / "my_otter")
    spec = parse_campaign_spec(family_campaign(tmp_path, "hulls/my_otter"), str(tmp_path / "c.toml"), tmp_path)
    sc = spec.run(0).scenario()
    assert sc.vessels[0].type == str(folder.resolve())
    same = parse_campaign_spec(family_campaign(tmp_path, "hulls/my_otter"), str(tmp_path / "c.toml"), tmp_path)
    assert same.digest == spec.digest
    edit(folder / "hydrodynamics.toml", "N_r_nonlinear_gain = 10.0", "N_r_nonlinear_gain = 9.0")
    edited = parse_campaign_spec(family_campaign(tmp_path, "hulls/my_otter"), str(tmp_path / "c.toml"), tmp_path)
    assert edited.digest != spec.digest  # an edited hull is a new campaign
    with pytest.raises(CampaignError, match=r"^families\[0\]\.own\.type: no such vessel folder"):
        parse_campaign_spec(family_campaign(tmp_path, "hulls/none"), str(tmp_path / "c.toml"), tmp_path)


def test_documenting_the_hull_is_not_a_new_campaign(tmp_path):
    """The digest covers what the runs read (<name>.xml, hydrodynamics.toml) by content: the
    derivation written into the hull's README.md or comments, or its viewer scene.xml edited, keep
    the campaign (a resumed campaign would otherwise recompute every run); a number does not."""
    folder = copy_vessel(VESSELS_DIR / "otter", tmp_path / "hulls" / "my_otter")
    digest = lambda: parse_campaign_spec(family_campaign(tmp_path, "hulls/my_otter"), str(tmp_path / "c.toml"),
                                         tmp_path).digest
    before = digest()
    (folder / "README.md").write_text("# my_otter\n\nDerivation: ...\n")
    edit(folder / "scene.xml", "<mujoco", "<!-- my boat -->\n<mujoco")
    edit(folder / "hydrodynamics.toml", "X_uu = 0.0", "X_uu = 0.0  # measured, 2026 sea trial")
    edit(folder / "my_otter.xml", "<worldbody>", "<!-- checked against the drawings -->\n  <worldbody>")
    assert digest() == before
    edit(folder / "hydrodynamics.toml", "X_uu = 0.0", "X_uu = -1.0")
    assert digest() != before


def test_a_perturbed_scenario_keeps_its_folder_and_the_digest_covers_it(tmp_path):
    folder = copy_vessel(VESSELS_DIR / "otter", tmp_path / "hulls" / "my_otter")
    doc = one_vessel("hulls/my_otter")
    del doc["outputs"]
    lines = ['name = "solo"', "duration_s = 4.0", "[[vessels]]", 'name = "v"', 'type = "hulls/my_otter"',
             "position_m = [0.0, 0.0]", "speed_m_s = 1.0",
             "controller = { waypoints = [[0.0, 0.0], [30.0, 10.0]], speed_m_s = 1.5 }"]
    (tmp_path / "s.toml").write_text("\n".join(lines) + "\n")
    camp = {"name": "p", "families": [{"kind": "perturbation", "scenario": "s.toml", "runs_per_point": 2}]}
    spec = parse_campaign_spec(camp, str(tmp_path / "c.toml"), tmp_path)
    assert spec.run(1).scenario().vessels[0].type == str(folder.resolve())
    edit(folder / "my_otter.xml", 'rgba="0.96 0.72 0.08 1"', 'rgba="0.9 0.7 0.1 1"')
    assert parse_campaign_spec(camp, str(tmp_path / "c.toml"), tmp_path).digest != spec.digest


@pytest.mark.parametrize("value, reason", [("x" * 5000, "File name too long"), ("x/" * 3000, "File name too long"),
                                           ("~no_such_user_zz/boat", "Could not determine home directory"),
                                           ("a\x00b", "it holds a NUL character")])
def test_a_type_the_file_system_cannot_take_is_a_one_line_error(tmp_path, value, reason):
    """A type too long for the file system, under an unknown user's ~, or holding a NUL: the
    scenario's field and the reason in one line (the fuzz test met OSError: File name too long)."""
    with pytest.raises(ScenarioError, match=rf"^vessels\[0\]\.type: not a (readable )?vessel folder's path "
                                            rf"\({re.escape(reason)}\)") as info:
        parse_scenario(one_vessel(value), str(tmp_path / "s.toml"))
    assert "\n" not in str(info.value)
