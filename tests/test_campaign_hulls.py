"""Own hulls in campaigns (assets/README.md, "Your own hull"; docs/campaigns.md): the report names the
hull each family's own vessels sailed (a built-in name; a folder's name, path and content
fingerprint, so that two folders named alike are told apart; "unknown" from a store written before
hulls were recorded), and a campaign sails a vessel folder on workers that do not have it — the
driver reads the folder (meshes included) once and ships it, each worker sails a private copy —
with results equal to runs from the folder itself."""

import shutil
import sqlite3
import struct
from pathlib import Path

import pytest

from mjasc.campaigns import dask_runs, engine, executor, hull_shipping
from mjasc.campaigns.engine import run_campaign, without_timing
from mjasc.campaigns.executor import execute_in_process
from mjasc.campaigns.hull_records import family_ticks, family_title
from mjasc.campaigns.report import format_report, report_data
from mjasc.campaigns.spec import CampaignError, parse_campaign_spec
from mjasc.campaigns.store import CampaignStore
from tests.test_own_hull import EXAMPLE, HULL, copy_vessel, edit

SHORT = {"duration_s": 2.0}


def mesh_hull(folder: Path, mesh_file: str = "box.stl", meshdir: str = "meshes") -> Path:
    """A copy of the example hull named ``folder.name`` with a visual mesh (a tetrahedron, binary
    STL) under ``meshdir`` (the mesh itself written at ``folder/meshdir/mesh_file``)."""
    copy_vessel(HULL, folder)
    v = [(0.0, 0.0, 0.3), (0.2, 0.0, 0.3), (0.0, 0.2, 0.3), (0.0, 0.0, 0.5)]
    faces = ((0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3))
    data = b"\0" * 80 + struct.pack("<I", 4) + b"".join(
        struct.pack("<12fH", 0, 0, 0, *v[a], *v[b], *v[c], 0) for a, b, c in faces)
    target = (folder / meshdir / mesh_file).resolve()
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_bytes(data)
    xml = folder / f"{folder.name}.xml"
    edit(xml, "<asset>", f'<compiler meshdir="{meshdir}"/>\n  <asset>\n    <mesh name="lid" file="{mesh_file}"/>')
    edit(xml, '<geom name="payload_box_visual"',
         '<geom name="lid_visual" class="visual" type="mesh" mesh="lid" material="otter_deck"/>\n'
         '      <geom name="payload_box_visual"')
    return folder


def head_on(vtype: str, runs: int = 1, name: str = "head_on", kind: str = "head_on") -> dict:
    return {"kind": kind, "name": name, "own": {"type": vtype}, "runs_per_point": runs, **SHORT}


# ---------------------------------------------------------------------- the report names the hulls
def test_the_report_names_each_family_s_hulls_and_tells_two_folders_of_one_name_apart(tmp_path):
    shutil.copytree(EXAMPLE, tmp_path / "ex")
    a = copy_vessel(HULL, tmp_path / "a" / "my_hull")
    b = copy_vessel(HULL, tmp_path / "b" / "my_hull")
    edit(b / "hydrodynamics.toml", "N_r_nonlinear_gain = 10.0", "N_r_nonlinear_gain = 9.0")  # another hull
    camp = {"name": "hulls", "evaluation": {"mission_cost": False}, "families": [
        head_on("a/my_hull", name="first"), head_on("b/my_hull", name="second", kind="crossing_give_way"),
        {"kind": "perturbation", "name": "payload", "scenario": "ex/payload_crossing.toml", **SHORT}]}
    spec = parse_campaign_spec(camp, str(tmp_path / "c.toml"), tmp_path)
    run_campaign(spec, tmp_path / "out", workers=0, progress=False)
    data = report_data(tmp_path / "out")
    hulls = data["hulls"]
    (fa,), (fb,) = hulls["first"], hulls["second"]
    assert (fa["hull"], fa["folder"], fa["vessels"]) == ("my_hull", str(a.resolve()), ["own"])
    assert (fb["hull"], fb["folder"]) == ("my_hull", str(b.resolve()))
    assert len(fa["fingerprint"]) == 12 and fa["fingerprint"] != fb["fingerprint"]  # told apart by content
    loaded, otter = hulls["payload"]
    assert (loaded["hull"], loaded["vessels"]) == ("otter_payload", ["loaded"])
    assert otter == {"hull": "otter", "folder": None, "fingerprint": None, "vessels": ["otter"]}
    text = format_report(data)
    assert f"| first | my_hull (folder {a.resolve()}, fingerprint {fa['fingerprint']}): own |" in text
    assert f"| second | my_hull (folder {b.resolve()}, fingerprint {fb['fingerprint']}): own |" in text
    assert "otter (built in): otter |" in text
    ticks = family_ticks(hulls, ["first", "payload"])
    assert ticks == [f"first\nmy_hull·{fa['fingerprint'][:6]}",
                     f"payload\notter_payload·{loaded['fingerprint'][:6]} + otter"]
    assert family_title(hulls, "first") == f"first (my_hull·{fa['fingerprint'][:6]})"
    assert family_ticks({"x": [otter]}, ["x"]) == ["x"]  # built-in hulls only: the plain labels
    # the same hull in another place is the same hull: its fingerprint does not depend on the path
    c = tmp_path / "c" / "my_hull"
    shutil.copytree(a, c)
    from mjasc.physics.vessels import vessel_fingerprint

    assert vessel_fingerprint(str(c)) == fa["fingerprint"] != vessel_fingerprint(str(b))


def test_a_store_from_before_hulls_were_recorded_reports_them_unknown(tmp_path):
    db = sqlite3.connect(tmp_path / "campaign.sqlite")  # (the previous schema: no hulls column)
    db.executescript("""CREATE TABLE campaigns (digest TEXT PRIMARY KEY, name TEXT NOT NULL, source TEXT,
        file_text TEXT, runs_defined INTEGER NOT NULL, created_unix_s REAL NOT NULL, run_unix_s REAL);
        CREATE TABLE runs (digest TEXT NOT NULL, idx INTEGER NOT NULL, family TEXT, parameters TEXT, seed INTEGER,
        scenario TEXT, status TEXT NOT NULL, attempts INTEGER NOT NULL, error TEXT, metrics TEXT, wall_time_s REAL,
        worker TEXT, finished_unix_s REAL, method TEXT NOT NULL DEFAULT '', PRIMARY KEY (digest, idx, method));
        INSERT INTO campaigns VALUES ('old', 'c', '', '', 1, 1.0, 1.0);
        INSERT INTO runs VALUES ('old', 0, 'head_on', '{}', 0, '', 'completed', 1, NULL, '{}', 1.0, 'w', 1.0, '');""")
    db.commit()
    db.close()
    data = report_data(tmp_path)
    assert data["hulls"] == {"head_on": None} and data["runs_recorded"] == 1
    assert "| head_on | unknown (the store was written before mjasc recorded the hulls) |" in format_report(data)
    assert family_ticks(data["hulls"], ["head_on"]) == ["head_on"]
    # the campaign run again by a command of this version: its hulls are recorded from then on
    rec = {"head_on": [{"hull": "otter", "folder": None, "fingerprint": None, "vessels": ["own"]}]}
    with CampaignStore(tmp_path, "old", name="c", runs_defined=1, hulls=rec) as s:
        assert s.info()["hulls"] == rec
    with CampaignStore(tmp_path, "old", name="c", runs_defined=1) as s:  # (a writer that does not say: kept)
        assert s.info()["hulls"] == rec
    assert "| head_on | otter (built in): own |" in format_report(report_data(tmp_path))


# ---------------------------------------------------------------------- workers without the folder
def _moved_after_reading(monkeypatch, folder: Path) -> Path:
    """The driver reads the hulls (and all else it reads), then ``folder`` is renamed away before
    any run starts: as on a worker without the folder. Returns where it went."""
    gone = folder.with_name(folder.name + "_elsewhere")
    real = engine.execute_runs

    def move_then_execute(runs, *args, **kwargs):
        if kwargs.get("hulls"):
            folder.rename(gone)
        return real(runs, *args, **kwargs)

    monkeypatch.setattr(engine, "execute_runs", move_then_execute)
    return gone


def _from_the_folder(spec, reference: bool = True) -> list:
    """Each run's summary, run from the original folder in this process (nothing shipped)."""
    return [without_timing(execute_in_process({"index": r.index, "scenario_toml": r.scenario_toml, "run_dir": None,
                                               "evaluate": True, "reference": reference})["summary"])
            for r in spec.runs()]


def test_a_campaign_sails_its_hull_where_the_folder_is_not_with_the_same_results(tmp_path, monkeypatch):
    folder = mesh_hull(tmp_path / "hulls" / "my_hull")  # (a mesh: the driver ships it too)
    spec = parse_campaign_spec({"name": "h", "families": [head_on("hulls/my_hull", runs=2)]},
                               str(tmp_path / "c.toml"), tmp_path)
    assert set(hull_shipping.pack(str(folder))["files"]) == {"my_hull.xml", "hydrodynamics.toml", "meshes/box.stl"}
    texts = [r.scenario_toml for r in spec.runs()]
    expected = _from_the_folder(spec)
    assert all(s["status"] == "completed" and s["evaluation"]["cost_reference"]["kind"] == "no_traffic"
               for s in expected)
    gone = _moved_after_reading(monkeypatch, folder)
    result = run_campaign(spec, tmp_path / "out", workers=0, progress=False)  # (each run in a child process)
    assert not folder.exists() and gone.is_dir()
    assert [r.status for r in result.runs] == ["completed", "completed"], [r.error for r in result.runs]
    assert [without_timing(r.metrics) for r in result.runs] == expected  # bit for bit, the mission cost too
    assert [r.scenario for r in result.runs] == texts  # (the stored texts name the original folder)
    assert hull_shipping._ROOT is None  # (the temporary copies removed when the campaign ended)
    assert report_data(tmp_path / "out")["hulls"]["head_on"][0]["folder"] == str(folder.resolve())


def test_a_dask_cluster_gets_the_hull_once_per_worker(tmp_path, monkeypatch):
    """A given Dask client (as a remote cluster's): the packs go to the cluster once (a task's
    result each worker fetches once), each worker writes its copy and removes it when the last
    campaign sailing it there ends."""
    from distributed import Client, LocalCluster

    folder = copy_vessel(HULL, tmp_path / "hulls" / "my_hull")
    spec = parse_campaign_spec({"name": "h", "evaluation": {"mission_cost": False},
                                "families": [head_on("hulls/my_hull", runs=2)]}, str(tmp_path / "c.toml"), tmp_path)
    expected = _from_the_folder(spec, reference=False)
    other = copy_vessel(HULL, tmp_path / "other" / "their_hull")  # (another campaign sails it on the same worker)
    hull_shipping.hold_hull_root()
    theirs = Path(hull_shipping.localise({"hulls": {str(other): hull_shipping.pack(str(other))}})["vessel_paths"][
        str(other)])
    _moved_after_reading(monkeypatch, folder)
    shipped = []
    real = dask_runs.ship_to_cluster
    monkeypatch.setattr(dask_runs, "ship_to_cluster",
                        lambda client, packs, tag: shipped.append(set(packs)) or real(client, packs, tag))
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        try:
            result = run_campaign(spec, tmp_path / "out", scheduler=client, progress=False)
        finally:
            child = executor._EXECUTORS.pop(None, None)  # (the worker's run process: this test's to close)
            if child is not None:
                child.close()
    assert shipped == [{str(folder.resolve())}]  # (once for the campaign, not with each run)
    assert [r.status for r in result.runs] == ["completed", "completed"], [r.error for r in result.runs]
    assert [without_timing(r.metrics) for r in result.runs] == expected
    assert theirs.is_dir()  # (the other campaign's copy stays while it runs)
    hull_shipping.release_hull_root()  # (the other campaign ends: the worker's copies go)
    assert hull_shipping._ROOT is None and not theirs.exists()


def test_built_in_hulls_ship_nothing(tmp_path):
    spec = parse_campaign_spec({"name": "b", "families": [head_on("otter", runs=2)]}, str(tmp_path / "c.toml"),
                               tmp_path)
    assert hull_shipping.pack_hulls(list(spec.runs())) == {}
    request = {"index": 0, "scenario_toml": spec.run(0).scenario_toml}
    assert hull_shipping.localise(request) is request


def test_a_shipped_copy_is_written_once_and_checked(tmp_path):
    folder = mesh_hull(tmp_path / "hulls" / "my_hull", meshdir="assets/meshes")
    p = hull_shipping.pack(str(folder))
    try:
        first = hull_shipping.localise({"hulls": {str(folder): p}})["vessel_paths"][str(folder)]
        copy = Path(first)
        assert copy.name == "my_hull" and copy.parent.name == p["key"]
        assert (copy / "assets" / "meshes" / "box.stl").read_bytes() == (folder / "assets/meshes/box.stl").read_bytes()
        assert oct(copy.parent.parent.stat().st_mode & 0o777) == "0o700"  # (private)
        assert hull_shipping.localise({"hulls": {str(folder): p}})["vessel_paths"][str(folder)] == first  # reused
        damaged = {**p, "key": "0" * 64}
        with pytest.raises(ValueError, match="do not match their key"):
            hull_shipping.localise({"hulls": {"x": damaged}})
        sneaky = {**p, "key": "1" * 64, "files": {"../evil.xml": ""}}
        with pytest.raises(ValueError, match="not a path inside its folder, got '../evil.xml'"):
            hull_shipping.localise({"hulls": {"x": sneaky}})
        elsewhere = tmp_path / "elsewhere" / "my_hull"  # (a key or name leading out of the folder: refused)
        elsewhere.mkdir(parents=True)
        for bad in ({"key": f"../../../../../../..{elsewhere.parent}"}, {"name": "../my_hull"}, {"name": ".."}):
            with pytest.raises(ValueError, match="not a pack"):
                hull_shipping.localise({"hulls": {"x": {**p, **bad}}})
        hull_shipping.hold_hull_root()  # two campaigns of this process sail it: the copy stays until both end
        hull_shipping.hold_hull_root()
        hull_shipping.release_hull_root()
        assert copy.is_dir()
        hull_shipping.release_hull_root()
        assert not copy.exists()
    finally:
        hull_shipping.remove_hull_root()
    assert not copy.exists()


# ---------------------------------------------------------------------- bad input
@pytest.mark.parametrize("where", ["outside", "absolute"])
def test_a_mesh_a_copy_of_the_folder_would_miss_is_a_one_line_error_and_nothing_is_written(tmp_path, where):
    folder = tmp_path / "hulls" / "my_hull"
    mesh = tmp_path / "hulls" / "common" / "box.stl" if where == "outside" else folder / "meshes" / "box.stl"
    mesh_hull(folder, mesh_file="../common/box.stl" if where == "outside" else str(mesh), meshdir=".")
    spec = parse_campaign_spec({"name": "h", "families": [head_on("hulls/my_hull")]}, str(tmp_path / "c.toml"),
                               tmp_path)  # (a scenario sails it: the file is where MuJoCo looks)
    with pytest.raises(CampaignError) as err:
        run_campaign(spec, tmp_path / "out", workers=0, progress=False)
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith("family 'head_on' (run 0) vessels[0].type: ")
    reason = "lies outside the vessel folder" if where == "outside" else "is an absolute path"
    assert f"{folder.resolve()}/my_hull.xml: mesh 'lid' file: {mesh.resolve()} {reason}" in msg
    assert not (tmp_path / "out").exists()


def test_a_folder_gone_when_the_driver_reads_it_is_a_one_line_error(tmp_path):
    folder = copy_vessel(HULL, tmp_path / "hulls" / "my_hull")
    spec = parse_campaign_spec({"name": "h", "families": [head_on("hulls/my_hull")]}, str(tmp_path / "c.toml"),
                               tmp_path)
    runs = list(spec.runs())
    (folder / "hydrodynamics.toml").unlink()
    with pytest.raises(CampaignError, match=r"^family 'head_on' \(run 0\) vessels\[0\]\.type: .*/my_hull/"
                                            r"hydrodynamics\.toml: cannot be read \(No such file or directory\)$"):
        hull_shipping.pack_hulls(runs)


def test_the_digest_covers_a_mesh(tmp_path):
    folder = mesh_hull(tmp_path / "hulls" / "my_hull")
    camp = {"name": "h", "families": [head_on("hulls/my_hull")]}
    before = parse_campaign_spec(camp, str(tmp_path / "c.toml"), tmp_path).digest
    stl = folder / "meshes" / "box.stl"
    stl.write_bytes(stl.read_bytes()[:-2] + b"\1\0")  # (the last facet's attribute bytes: still a valid mesh)
    assert parse_campaign_spec(camp, str(tmp_path / "c.toml"), tmp_path).digest != before


def test_the_campaign_command_says_it_in_one_line_with_status_2(tmp_path, capsys):
    from mjasc.cli import main

    mesh_hull(tmp_path / "hulls" / "my_hull", mesh_file="../common/box.stl", meshdir=".")
    (tmp_path / "c.toml").write_text('name = "h"\n[[families]]\nkind = "head_on"\nduration_s = 2.0\n'
                                     'own = { type = "hulls/my_hull" }\n')
    assert main(["campaign", str(tmp_path / "c.toml"), "--workers", "0", "--out", str(tmp_path / "out"),
                 "--no-progress"]) == 2
    err = capsys.readouterr().err.strip()
    head = f"mjasc: invalid campaign: {tmp_path / 'c.toml'}: family 'head_on' (run 0) vessels[0].type: "
    assert err.startswith(head), err
    assert "\n" not in err and "lies outside the vessel folder" in err
    assert not (tmp_path / "out").exists()  # (the command made the folder to check it writable, and removed it)
