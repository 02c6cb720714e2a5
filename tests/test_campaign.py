"""Campaigns end to end: the same campaign gives the same stored results in this process and on a
LocalCluster of 2 worker processes; results are stored as each run finishes, so a campaign cut short
(or whose driver is SIGKILLed) resumes without losing, duplicating or recomputing a run; a worker
killed mid-campaign costs nothing; a diverged run is a result, not a crash; every stored run replays
exactly from its scenario text; the Wilson interval matches its closed form; exports and the CLI;
each run's mission cost against its reference without traffic lands in the store and the report."""

import json
import os
import signal
import subprocess
import sys
import threading
import time
import tomllib

import pyarrow.parquet as pq
import pytest

from mjasc.campaigns.engine import run_campaign, without_timing
from mjasc.campaigns.spec import load_campaign_spec
from mjasc.campaigns.statistics import wilson_interval
from mjasc.campaigns.store import CampaignStore
from mjasc.cli import main
from mjasc.runs.runner import run_scenario
from mjasc.runs.scenario import parse_scenario

#: An eddy of 10⁹ m/s beside the start: the hydrodynamic forces overflow within a few steps.
#: One Otter; the test that uses it tightens the divergence bounds so that its first step diverges
#: (an absurd current, as this test once used, is now rejected when the scenario loads).
WILD = """
duration_s = 3.0
[[vessels]]
name = "alpha"
type = "otter"
speed_m_s = 1.0
controller = { type = "path_following", waypoints = [[0.0, 0.0], [100.0, 0.0]] }
"""

#: Two Otters in a cross current, one with a noisy range sensor and an IMM tracker, a ferry crossing.
SHORT = """
name = "short"
duration_s = 8.0
seed = 0
[current]
type = "uniform"
velocity_m_s = [0.0, 0.2]
[[vessels]]
name = "alpha"
type = "otter"
speed_m_s = 1.0
controller = { type = "path_following", waypoints = [[0.0, 0.0], [200.0, 0.0]], speed_m_s = 1.5 }
[vessels.sensor]
[vessels.tracking]
[[vessels]]
name = "bravo"
type = "otter"
position_m = [0.0, -12.0]
speed_m_s = 1.0
controller = { type = "path_following", waypoints = [[0.0, -12.0], [200.0, -12.0]], speed_m_s = 1.5 }
[[moving_obstacles]]
name = "ferry"
radius_m = 4.0
position_m = [30.0, 25.0]
heading_deg = -90.0
speed_m_s = 1.2
"""

CAMPAIGN = """
name = "short"
base_seed = 5
[outputs]
recordings = {recordings}
{evaluation}
[[families]]
kind = "perturbation"
scenario = "short.toml"
runs_per_point = {runs}
duration_s = {duration}
[families.randomize]
vessel_position_sigma_m = 2.0
vessel_heading_sigma_deg = 5.0
traffic_speed_sigma_m_s = 0.1
"""


def write_campaign(folder, runs=4, duration=6.0, recordings=False, scenario=SHORT, mission_cost=None):
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "short.toml").write_text(scenario)
    path = folder / "c.toml"
    evaluation = "" if mission_cost is None else f"[evaluation]\nmission_cost = {str(mission_cost).lower()}"
    path.write_text(CAMPAIGN.format(runs=runs, duration=duration, recordings=str(recordings).lower(),
                                    evaluation=evaluation))
    return path


def results(result):
    return {r.index: (r.status, without_timing(r.metrics)) for r in result.runs}


@pytest.fixture(scope="module")
def cluster():
    """One LocalCluster of 2 single-threaded worker processes for the module."""
    from distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0") as c:
        yield c


@pytest.fixture(scope="module")
def here(tmp_path_factory):
    folder = tmp_path_factory.mktemp("here")
    spec = load_campaign_spec(write_campaign(folder))
    return spec, run_campaign(spec, folder / "out", workers=0, progress=False)


# ---------------------------------------------------------------------- statistics in closed form
def test_wilson_interval_solves_the_score_equation():
    """The Wilson bounds are the two roots p of (p̂ − p)² = z² p(1 − p)/n."""
    z = 1.959963984540054
    for c, n in [(0, 20), (5, 20), (20, 20), (37, 1000), (1, 3)]:
        lo, hi = wilson_interval(c, n)
        ph = c / n
        for p in (lo, hi):
            if 0.0 < p < 1.0:
                assert (ph - p) ** 2 == pytest.approx(z * z * p * (1 - p) / n, rel=1e-9, abs=1e-15)
        assert lo <= ph <= hi
    assert wilson_interval(0, 0) is None


def test_per_vessel_samples_read_cost_cross_track_and_formation():
    """Per vessel: the cost from evaluation.cost, the cross-track error from the run's metrics, the
    formation error from the vessel's coordination summary; quantiles over every vessel of the runs."""
    from mjasc.campaigns.statistics import aggregate, vessel_samples
    from mjasc.campaigns.store import StoredRun

    def summary(pc, tc, xte, lead):
        return {"vessels": {"a": {"mean_cross_track_m": xte, "max_cross_track_m": 2 * xte, "max_mission_offset_m": 7.0,
                                  "coordination": {"mean_abs_error_m": lead, "max_abs_error_m": 3 * lead}},
                            "b": {"mean_cross_track_m": None}},
                "evaluation": {"cost": {"a": {"path_cost": pc, "time_cost_s": tc, "progress_short_m": None,
                                              "progress_lost_m": 0.0},
                                        "b": {"path_cost": 0.5, "time_cost_s": None, "progress_short_m": 2.0,
                                              "progress_lost_m": 31.0}}}}

    s = vessel_samples(summary(0.1, 4.0, 0.3, 1.5))
    assert s == {"path_cost": [0.1, 0.5], "time_cost_s": [4.0], "progress_lost_m": [0.0, 31.0],
                 "mean_cross_track_m": [0.3], "max_cross_track_m": [0.6], "max_mission_offset_m": [7.0],
                 "formation_error_m": [1.5], "formation_max_error_m": [4.5], "reference_short": 1, "behind": 1}
    runs = [StoredRun(index=k, family="f", parameters={}, seed=k, scenario="", status="completed", attempts=1,
                      error=None, metrics=summary(0.1 * k, float(k), 0.1, 1.0), wall_time_s=0.0, worker="w")
            for k in range(1, 4)]
    pv = aggregate(runs)["families"]["f"]["per_vessel"]
    assert pv["path_cost"]["n"] == 6 and pv["path_cost"]["p50"] == pytest.approx(0.4)
    assert pv["time_cost_s"]["p50"] == 2.0 and pv["reference_short"] == 3 and pv["behind"] == 3
    # a store made before progress_lost_m existed: how many are behind is unknown, not 0
    old = summary(0.1, 4.0, 0.3, 1.5)
    for c in old["evaluation"]["cost"].values():
        c.pop("progress_lost_m")
    assert vessel_samples(old)["behind"] is None


def test_colreg_compliance_counts_only_the_encounters_with_a_role(tmp_path):
    """An encounter without risk of collision (role `none`) asks nothing of the vessel: it is neither
    compliant nor not. It was counted compliant, so a campaign with wide passes looked more compliant
    (1 of 2 judged encounters complied, reported as 3 of 4), and the per-role figure had a `none` bar."""
    from mjasc.campaigns.statistics import aggregate
    from mjasc.campaigns.store import StoredRun

    enc = [{"role": "head_on", "compliant": True}, {"role": "crossing_give_way", "compliant": False},
           {"role": "none", "compliant": True}, {"role": "none", "compliant": True}]
    runs = [StoredRun(index=0, family="f", parameters={}, seed=0, scenario="", status="completed", attempts=1,
                      error=None, metrics={"vessels": {}, "evaluation": {"encounters": enc}}, wall_time_s=0.0,
                      worker="w")]
    colreg = aggregate(runs)["families"]["f"]["colreg"]
    assert colreg["encounters"] == 4 and colreg["roles"]["none"] == 2
    assert colreg["compliant"]["count"] == 1 and colreg["compliant"]["n"] == 2


def test_the_campaign_s_colreg_thresholds_judge_its_runs(tmp_path):
    """The [colreg] table was used to draw the families' roles but the runs were judged with the
    defaults: a campaign asking that risk of collision start at a 3 m CPA still saw its 6 m head-on
    passes judged head-on (default 20 m)."""
    from mjasc.campaigns.engine import run_campaign
    from mjasc.campaigns.spec import parse_campaign_spec

    def roles(colreg: dict) -> list:
        spec = parse_campaign_spec({"name": "c", "evaluation": {"mission_cost": False}, "colreg": colreg,
                                    "families": [{"kind": "head_on", "duration_s": 8.0, "runs_per_point": 1,
                                                  "parameters": {"dcpa_m": 6.0, "tcpa_s": 20.0}}]})
        res = run_campaign(spec, tmp_path / str(len(colreg)), workers=0, progress=False)
        return [e["role"] for r in res.runs for e in r.metrics["evaluation"]["encounters"]]

    assert roles({}) == ["head_on"]
    assert roles({"risk_cpa_m": 3.0}) == ["none"]


# ---------------------------------------------------------------------- engine
def test_local_cluster_gives_the_in_process_results(here, cluster, tmp_path):
    spec, sync = here
    assert [r.status for r in sync.runs] == ["completed"] * 4
    clients = set(cluster.scheduler.clients)
    dist = run_campaign(spec, tmp_path, scheduler=cluster.scheduler_address, progress=False)
    assert results(dist) == results(sync)
    assert dist.info["scheduler"].startswith("tcp://") and dist.info["workers"] == 2
    # the campaign's client of the scheduler is closed (it was left connected: when the cluster
    # later shut down it tried to reconnect, with tracebacks on stderr); the cluster runs on
    t0 = time.time()
    while set(cluster.scheduler.clients) != clients and time.time() - t0 < 30:
        time.sleep(0.1)
    assert set(cluster.scheduler.clients) == clients and cluster.scheduler.status.name == "running"


def test_own_local_cluster_gives_the_in_process_results_and_closes_its_children(here, tmp_path):
    from mjasc.campaigns import executor

    spec, sync = here
    before = dict(executor._EXECUTORS)
    dist = run_campaign(spec, tmp_path, workers=2, progress=False)
    assert results(dist) == results(sync)
    assert dist.info["scheduler"] == "local" and dist.info["workers"] == 2
    # every run in a child of its own worker: two children, not this process
    workers = {r.worker for r in dist.runs}
    assert len(workers) == 2 and not any(w.endswith(f":{os.getpid()}") for w in workers)
    assert executor._EXECUTORS == before  # the workers' children were closed and forgotten
    for w in workers:  # and have left
        pid = int(w.rsplit(":", 1)[1])
        t0 = time.time()
        while time.time() - t0 < 10:
            try:
                os.kill(pid, 0)
            except ProcessLookupError:
                break
            time.sleep(0.05)
        else:
            raise AssertionError(f"child {pid} still running")


def test_a_child_that_cannot_start_stops_the_campaign_before_any_run(tmp_path, monkeypatch):
    from mjasc.campaigns import executor, forked

    spec = load_campaign_spec(write_campaign(tmp_path, runs=2, duration=2.0))
    for cls in (executor.IsolatedExecutor, forked.ForkedExecutor):  # a new interpreter's child or a fork
        monkeypatch.setattr(cls, "wait_ready", lambda self, timeout_s=None: False)
    with pytest.raises(RuntimeError, match="did not start"):
        run_campaign(spec, tmp_path / "out", workers=1, progress=False)
    with CampaignStore(tmp_path / "out", spec.digest) as s:
        assert s.runs() == []  # nothing recorded as crashed: the same command later does every run


def test_every_stored_run_replays_exactly_from_its_scenario_text(here):
    spec, sync = here
    r = sync.runs[2]
    replay = run_scenario(parse_scenario(tomllib.loads(r.scenario)), None, progress=False).summary
    stored = dict(r.metrics)
    stored.pop("evaluation")
    assert without_timing(replay) == without_timing(stored)
    assert r.scenario == spec.run(2).scenario_toml and r.seed == spec.run(2).seed


def test_outputs_on_disk(here):
    spec, sync = here
    out = sync.out_dir
    doc = json.loads((out / "campaign.json").read_text())
    assert doc["aggregate"]["runs_defined"] == 4 and doc["aggregate"]["runs_recorded"] == 4
    assert doc["campaign"]["digest"] == spec.digest
    rows = pq.read_table(out / "runs.parquet").to_pylist()
    assert [r["index"] for r in rows] == [0, 1, 2, 3] and "metric.any_collision" in rows[0]
    assert (out / "runs.csv").read_text().count("\n") == 5
    enc = sync.runs[0].metrics["evaluation"]["encounters"]
    assert enc and enc[0]["other"] == "ferry"
    assert "metric.evaluation.cost.alpha.path_cost" in rows[0]


def test_mission_cost_against_the_run_without_traffic(here, tmp_path):
    """Neither vessel avoids and the ferry never touches one: without the ferry each vessel sails
    exactly the same, so every cost is 0 exactly (the reference did run: its kind says so); the
    aggregate has one sample per vessel and run. With ``mission_cost = false`` there is no reference."""
    _, sync = here
    for r in sync.runs:
        ev = r.metrics["evaluation"]
        assert ev["cost_reference"]["kind"] == "no_traffic" and ev["cost_reference"]["status"] == "completed"
        assert set(ev["cost"]) == {"alpha", "bravo"}
        for c in ev["cost"].values():
            assert c["path_cost"] == 0.0 and c["time_cost_s"] == 0.0 and c["progress_m"] > 4.0
            assert c["distance_m"] == c["ref_distance_m"] and c["reached_s"] == c["ref_reached_s"]
    pv = sync.aggregate["families"]["perturbation"]["per_vessel"]
    assert pv["path_cost"]["n"] == 8 and pv["path_cost"]["p95"] == 0.0 and pv["time_cost_s"]["p50"] == 0.0
    assert pv["mean_cross_track_m"]["n"] == 8 and pv["formation_error_m"] is None  # no coordination here
    spec = load_campaign_spec(write_campaign(tmp_path, runs=1, duration=2.0, mission_cost=False))
    assert not spec.evaluation.mission_cost
    off = run_campaign(spec, tmp_path / "out", workers=0, progress=False)
    assert "cost" not in off.runs[0].metrics["evaluation"]
    assert off.aggregate["per_vessel"]["path_cost"] is None


def test_a_campaign_cut_short_resumes_without_recomputing(tmp_path):
    spec = load_campaign_spec(write_campaign(tmp_path, duration=3.0))
    first = run_campaign(spec.with_overrides(runs=2), tmp_path / "out", workers=0, progress=False)
    assert first.info["runs_to_do"] == 2 and len(first.runs) == 2
    before = {r.index: r.worker for r in first.runs}
    full = run_campaign(spec, tmp_path / "out", workers=0, progress=False)
    assert full.info["runs_to_do"] == 2 and full.info["already_done"] == 2
    assert [r.index for r in full.runs] == [0, 1, 2, 3] and all(r.attempts == 1 for r in full.runs)
    assert {k: w for k, w in ((r.index, r.worker) for r in full.runs) if k < 2} == before
    again = run_campaign(spec, tmp_path / "out", workers=0, progress=False)
    assert again.info["runs_to_do"] == 0 and results(again) == results(full)


def test_the_report_counts_the_runs_the_campaign_was_asked_for_after_a_resume(tmp_path):
    """``--runs 2`` then the whole file: the report, its JSON and campaign.json all say 4 of 4 (the
    largest extent asked), and a later shorter call does not shrink it."""
    from mjasc.campaigns.report import report_data

    spec = load_campaign_spec(write_campaign(tmp_path, duration=2.0))
    out = tmp_path / "out"
    run_campaign(spec.with_overrides(runs=2), out, workers=0, progress=False)
    assert (report_data(out)["runs_recorded"], report_data(out)["runs_defined"]) == (2, 2)
    run_campaign(spec, out, workers=0, progress=False)
    doc = json.loads((out / "campaign.json").read_text())
    assert (report_data(out)["runs_recorded"], report_data(out)["runs_defined"]) == (4, 4)
    assert doc["campaign"]["runs_defined"] == doc["aggregate"]["runs_defined"] == 4
    run_campaign(spec.with_overrides(runs=1), out, workers=0, progress=False)
    assert report_data(out)["runs_defined"] == 4
    assert json.loads((out / "campaign.json").read_text())["campaign"]["runs_defined"] == 4


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_a_diverging_run_is_a_result_and_the_campaign_goes_on(tmp_path, monkeypatch):
    from mjasc.physics import divergence, simulation

    # speed bound 0.5 m/s + 0.001 × top speed: the Otter starting at 1 m/s diverges at its first step
    monkeypatch.setattr(simulation, "DivergenceBounds",
                        lambda: divergence.DivergenceBounds(speed_factor=1e-3, current_allowance_m_s=0.5))
    spec = load_campaign_spec(write_campaign(tmp_path, runs=2, duration=3.0, scenario=WILD))
    res = run_campaign(spec, tmp_path / "out", workers=0, progress=False, isolate=False)  # (the patch is here)
    assert [r.status for r in res.runs] == ["diverged", "diverged"]
    assert "physics diverged" in res.runs[0].error and res.runs[0].attempts == 1  # not retried
    diverged = res.runs[0].metrics  # the summary up to the divergence is kept, with its evaluation
    assert diverged["status"] == "diverged" and diverged["sim_time_s"] < 3.0 and "evaluation" in diverged
    assert res.aggregate["runs_failed"] == 2 and res.aggregate["collision"]["rate"] is None
    # the report says which runs failed and why (it only counted them)
    from mjasc.campaigns.report import format_report, report_data

    data = report_data(tmp_path / "out")
    assert [(f["index"], f["status"]) for f in data["failed"]] == [(0, "diverged"), (1, "diverged")]
    md = format_report(data)
    assert "Failed runs (2;" in md and "| 0 | — | " in md and "physics diverged" in md


def test_killing_a_worker_mid_campaign_loses_no_run(tmp_path):
    from distributed import Client, LocalCluster

    spec = load_campaign_spec(write_campaign(tmp_path, runs=6, duration=6.0))
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0") as cl, \
            Client(cl) as client:
        pids = list(client.run(os.getpid).values())

        def kill_one():  # once the first result is in the store, kill a worker process
            store = tmp_path / "out" / "campaign.sqlite"
            t0 = time.time()
            while time.time() - t0 < 120:
                if store.exists():
                    with CampaignStore(tmp_path / "out", spec.digest) as s:
                        if s.runs():
                            break
                time.sleep(0.2)
            os.kill(pids[0], signal.SIGKILL)

        killer = threading.Thread(target=kill_one)
        killer.start()
        res = run_campaign(spec, tmp_path / "out", scheduler=client, progress=False)
        killer.join()
    assert [r.index for r in res.runs] == list(range(6))
    assert all(r.status == "completed" for r in res.runs), [(r.status, r.error) for r in res.runs]


def test_sigkill_of_the_driver_then_the_same_command_resumes(tmp_path):
    # enough runs that the kill lands mid-campaign however fast a run is (the store is polled every 0.2 s;
    # a 6-s run takes ~0.1 s on a fast host: the 28 left after the second take seconds, not a poll)
    path = write_campaign(tmp_path, runs=30, duration=6.0)
    cmd = [sys.executable, "-m", "mjasc", "campaign", str(path), "--workers", "0", "--out", str(tmp_path / "out"),
           "--no-progress"]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    spec = load_campaign_spec(path)
    t0 = time.time()
    n = 0
    while time.time() - t0 < 180 and n < 2:
        if (tmp_path / "out" / "campaign.sqlite").exists():
            with CampaignStore(tmp_path / "out", spec.digest) as s:
                n = len(s.runs())
        time.sleep(0.2)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    with CampaignStore(tmp_path / "out", spec.digest) as s:
        before = {r.index: r.worker for r in s.runs()}
    assert 2 <= len(before) < 30
    assert subprocess.run(cmd, env=env, capture_output=True).returncode == 0
    with CampaignStore(tmp_path / "out", spec.digest) as s:
        after = s.runs()
    assert [r.index for r in after] == list(range(30)) and all(r.attempts == 1 for r in after)
    assert {r.index: r.worker for r in after if r.index in before} == before  # not recomputed


def test_recordings_are_kept_per_run_when_asked(tmp_path):
    spec = load_campaign_spec(write_campaign(tmp_path, runs=2, duration=2.0, recordings=True))
    res = run_campaign(spec, tmp_path / "out", workers=0, progress=False)
    for k in (0, 1):
        assert (tmp_path / "out" / "runs" / str(k) / "recording.rrd").stat().st_size > 0
        s = json.loads((tmp_path / "out" / "runs" / str(k) / "summary.json").read_text())
        stored = dict(res.runs[k].metrics)  # (the run's evaluation in its summary.json too, since session 67 …
        # … except the mission cost, which needs the reference run made after it: in the store only)
        stored["evaluation"] = {key: v for key, v in stored["evaluation"].items() if key not in ("cost", "cost_reference")}
        assert s["seed"] == 5 + k and without_timing(s) == without_timing(stored) and "tracking" in s["evaluation"]


def test_bad_engine_arguments_name_the_field(here, tmp_path):
    spec, _ = here
    with pytest.raises(ValueError, match="^workers: must be ≥ 0, got -1$"):
        run_campaign(spec, tmp_path, workers=-1, progress=False)
    with pytest.raises(ValueError, match="^workers: only for a local cluster"):
        run_campaign(spec, tmp_path, scheduler="tcp://127.0.0.1:1", workers=2, progress=False)


def test_cli_campaign_prints_the_aggregate(tmp_path, capsys):
    path = write_campaign(tmp_path, runs=2, duration=2.0)
    assert main(["campaign", str(path), "--workers", "0", "--out", str(tmp_path / "out"), "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "2 run(s) done now" in out and "collision" in out and "perturbation" in out
    assert main(["campaign", str(path), "--workers", "0", "--out", str(tmp_path / "out"), "--no-progress"]) == 0
    assert "0 run(s) done now, 2 already in the store" in capsys.readouterr().out


def test_report_on_a_campaign_and_as_json(here, tmp_path, capsys):
    _, sync = here
    out = tmp_path / "report"
    assert main(["report", str(sync.out_dir), "--out", str(out), "--format", "png", "svg"]) == 0
    text = capsys.readouterr().out
    assert "| perturbation | 4 |" in text and "COLREG" in text
    assert "path cost [%]" in text and "| perturbation | 8 | 0.0 / 0.0 | 0.0 / 0.0 |" in text
    for stem in ("rates", "separation", "colreg", "tracking", "cost"):
        assert (out / f"{stem}.png").stat().st_size > 0 and (out / f"{stem}.svg").stat().st_size > 0
    assert main(["report", str(sync.out_dir), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["runs_defined"] == 4 and data["runs_recorded"] == 4 and data["runs_failed"] == 0
    assert data["outcomes"]["completed"] == 4 and "collision" in data["outcomes"]
    assert data["families"]["perturbation"]["per_vessel"]["time_cost_s"]["n"] == 8
    assert main(["report", str(tmp_path / "nothing")]) == 2


def test_a_bad_scheduler_is_refused_before_the_store_is_made(tmp_path):
    spec = load_campaign_spec(write_campaign(tmp_path, runs=1, duration=2.0))
    with pytest.raises(ValueError, match=r"^scheduler: must be 'synchronous', 'local', a distributed.Client or a "
                                         r"scheduler address with its port \(tcp://host:8786\), got 'bogus'$"):
        run_campaign(spec, tmp_path / "out", scheduler="bogus", progress=False)
    with pytest.raises(ValueError, match=r"^workers: only for a local cluster"):  # (0 would ignore the cluster)
        run_campaign(spec, tmp_path / "out", scheduler="tcp://127.0.0.1:8786", workers=0, progress=False)
    assert not (tmp_path / "out").exists()
