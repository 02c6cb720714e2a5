"""Own hulls in campaigns, robustness (docs/campaigns.md, "Own hulls"): a store written before the
digest covered a hull's meshes resumes; a shipped run records its scenario as written; a Dask
worker lost mid-campaign does not lose the hull; the driver reads a hull once; two campaigns of one
process keep each other's copies."""

import os
import sqlite3
from pathlib import Path

from mjasc.campaigns import engine, hull_shipping
from mjasc.campaigns.engine import run_campaign
from mjasc.campaigns.executor import execute_in_process
from mjasc.campaigns.spec import parse_campaign_spec
from mjasc.campaigns.store import CampaignStore, record_result
from tests.test_campaign_hulls import head_on, mesh_hull
from tests.test_own_hull import HULL, copy_vessel


def test_a_campaign_stored_before_the_digest_covered_its_mesh_resumes(tmp_path, monkeypatch):
    """A store an earlier mjasc wrote holds a mesh hull's campaign under the digest of the MJCF and
    hydrodynamics.toml alone: running the campaign again resumes it (renumbered to its digest), it
    does not start it over."""
    from mjasc.physics.vessels import vessel_files

    folder = mesh_hull(tmp_path / "hulls" / "my_hull")
    assert list(vessel_files(str(folder.resolve())).core) == ["my_hull.xml", "hydrodynamics.toml"]
    spec = parse_campaign_spec({"name": "h", "families": [head_on("hulls/my_hull", runs=2)]},
                               str(tmp_path / "c.toml"), tmp_path)
    (earlier,) = spec.earlier_digests
    plain = parse_campaign_spec({"name": "h", "families": [head_on("otter")]}, str(tmp_path / "c.toml"), tmp_path)
    assert plain.earlier_digests == ()  # (nothing referenced: the digest is what it was)
    out = tmp_path / "out"
    with CampaignStore(out, earlier, name="h", runs_defined=2) as old:
        for run in spec.runs():
            record_result(old, run, {"status": "completed", "summary": {"outcome": "clear"}})
    ran = []
    monkeypatch.setattr(engine, "_run_here", lambda runs, *a, **k: ran.extend(runs))
    result = run_campaign(spec, out, workers=0, progress=False)
    assert ran == [] and result.info["already_done"] == 2
    with CampaignStore(out, spec.digest) as store:
        assert store.info()["campaigns_in_store"] == 1 and len(store.runs()) == 2
        assert store.info()["hulls"]["head_on"][0]["hull"] == "my_hull"
    assert CampaignStore.adopt_earlier(out, spec.digest, (earlier,)) is None  # (once: nothing left to adopt)


def test_a_shipped_run_s_recording_names_the_driver_s_folder_not_the_copy(tmp_path, monkeypatch):
    """A recording logs the scenario's text (``Scenario.raw``): a run sailing the shipped copy
    records the document as written — the driver's folder, as a run from the folder does — not
    this process's temporary path (which differs between processes and is gone after the campaign)."""
    import tomllib

    from mjasc.runs import runner

    folder = copy_vessel(HULL, tmp_path / "hulls" / "my_hull")
    spec = parse_campaign_spec({"name": "h", "families": [head_on("hulls/my_hull")]}, str(tmp_path / "c.toml"),
                               tmp_path)
    text = spec.run(0).scenario_toml
    seen = []

    class Captured(Exception):
        pass

    def capture(sc, *a, **k):
        seen.append(sc)
        raise Captured

    monkeypatch.setattr(runner, "Runner", capture)
    request = {"index": 0, "scenario_toml": text, "run_dir": None, "evaluate": False,
               "hulls": {str(folder.resolve()): hull_shipping.pack(str(folder.resolve()))}}
    try:
        assert execute_in_process(request)["status"] == "error"
    finally:
        hull_shipping.remove_hull_root()
    (sc,) = seen
    assert sc.raw == tomllib.loads(text) and sc.raw["vessels"][0]["type"] == str(folder.resolve())
    assert sc.vessels[0].type != str(folder.resolve()) and sc.vessels[0].type.endswith("/my_hull")  # (the copy)


def test_a_dask_worker_lost_mid_campaign_does_not_lose_the_hull(tmp_path, monkeypatch):
    """A worker process killed mid-campaign (its nanny starts another): the packs are computed again
    for the new worker and every run completes (scattered packs were lost with the worker, and every
    run left, retries too, was cancelled for lost dependencies)."""
    import signal
    import threading
    import time

    from distributed import Client, LocalCluster

    copy_vessel(HULL, tmp_path / "hulls" / "my_hull")
    spec = parse_campaign_spec({"name": "h", "evaluation": {"mission_cost": False},
                                "families": [head_on("hulls/my_hull", runs=6)]}, str(tmp_path / "c.toml"), tmp_path)
    (tmp_path / "tmp").mkdir()  # (the killed worker's copies stay behind: here, not in the system's folder)
    monkeypatch.setenv("TMPDIR", str(tmp_path / "tmp"))
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        (pid,) = client.run(os.getpid).values()

        def kill_after_the_first_run() -> None:
            for _ in range(1200):
                time.sleep(0.1)
                try:
                    with sqlite3.connect(tmp_path / "out" / "campaign.sqlite") as db:
                        if db.execute("SELECT COUNT(*) FROM runs").fetchone()[0]:
                            break
                except sqlite3.Error:
                    pass
            os.kill(pid, signal.SIGKILL)

        killer = threading.Thread(target=kill_after_the_first_run, daemon=True)
        killer.start()
        result = run_campaign(spec, tmp_path / "out", scheduler=client, progress=False)
        killer.join()
        assert pid not in client.run(os.getpid).values()  # (the worker was restarted)
    assert [r.status for r in result.runs] == ["completed"] * 6, [r.error for r in result.runs]
    left = [p for p in (tmp_path / "tmp").iterdir() if p.name.startswith(hull_shipping.HULL_ROOT_PREFIX)]
    assert len(left) <= 1  # (the killed worker's at most: the new worker's went with the campaign)


def test_the_driver_reads_an_own_hull_once_for_a_campaign_and_for_a_search(tmp_path, monkeypatch):
    """The campaign command reads the folder once for its records and its runs (the records take
    the packs' fingerprints), the search once for all its batches."""
    from mjasc.campaigns import search
    from mjasc.campaigns.search import SearchConfig, search_failures
    from mjasc.physics import hull_files

    copy_vessel(HULL, tmp_path / "hulls" / "my_hull")
    camp = {"name": "h", "evaluation": {"mission_cost": False}, "families": [{
        **head_on("hulls/my_hull"), "parameters": {"dcpa_m": {"uniform": [-5.0, 5.0]}}}]}
    spec = parse_campaign_spec(camp, str(tmp_path / "c.toml"), tmp_path)
    reads = []
    real = hull_files.referenced_files
    monkeypatch.setattr(hull_files, "referenced_files", lambda xml: reads.append(xml) or real(xml))
    monkeypatch.setattr(engine, "_run_here", lambda *a, **k: None)  # (no run: only what the driver reads)
    run_campaign(spec, tmp_path / "out", workers=0, progress=False)
    assert len(reads) == 1, reads
    reads.clear()
    monkeypatch.setattr(search, "execute_runs", lambda *a, **k: {})
    search_failures(spec, "head_on", tmp_path / "search", SearchConfig(budget=6, batch=2), workers=0)
    assert len(reads) == 2, reads  # (its records, then its runs: once for its three batches)


def test_a_campaign_starting_as_the_last_one_ends_keeps_its_copy(tmp_path, monkeypatch):
    """Two campaigns of one process: the second holds the copies just after the first released
    them, before the first removed them — its copy is in a new folder, not in the one removed."""
    folder = copy_vessel(HULL, tmp_path / "hulls" / "my_hull")
    request = {"hulls": {str(folder): hull_shipping.pack(str(folder))}}
    second = []

    def second_starts() -> None:
        hull_shipping.hold_hull_root()
        second.append(Path(hull_shipping.localise(request)["vessel_paths"][str(folder)]))

    real = hull_shipping.remove_hull_root
    monkeypatch.setattr(hull_shipping, "remove_hull_root", lambda: (second_starts(), real()))  # (in between)
    try:
        hull_shipping.hold_hull_root()
        hull_shipping.localise(request)
        hull_shipping.release_hull_root()  # (the first campaign ends)
        if not second:
            second_starts()
        assert (second[0] / "my_hull.xml").is_file()
    finally:
        hull_shipping.release_hull_root()
    assert hull_shipping._ROOT is None and not second[0].exists()


def test_copies_a_killed_process_left_go_when_another_process_makes_its_own(tmp_path, monkeypatch):
    """A process killed mid-campaign (SIGKILL, SIGTERM) cannot remove its copies: the next process
    of the host to make its folder removes those of processes that no longer run — not those of a
    running process or of another host."""
    import subprocess
    import sys
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    gone = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    tag = hull_shipping.HULL_ROOT_PREFIX + hull_shipping._owner_tag()
    stale = tmp_path / f"{tag}{int(gone.stdout)}-abcd" / ("0" * 64) / "my_hull"
    alive = tmp_path / f"{tag}{os.getppid()}-efgh"
    other_host = tmp_path / f"{hull_shipping.HULL_ROOT_PREFIX}elsewhere.example-{int(gone.stdout)}-ijkl"
    for folder in (stale, alive, other_host):
        folder.mkdir(parents=True)
    folder = copy_vessel(HULL, tmp_path / "hulls" / "my_hull")
    try:
        copy = Path(hull_shipping.localise({"hulls": {str(folder): hull_shipping.pack(str(folder))}})[
            "vessel_paths"][str(folder)])
        assert copy.parent.parent.name.startswith(f"{tag}{os.getpid()}-")
        assert not stale.parent.parent.exists() and alive.is_dir() and other_host.is_dir()
    finally:
        hull_shipping.remove_hull_root()
