"""Monte Carlo campaigns on Dask: the same campaign gives the same per-run results in this process
and on a LocalCluster of 2 worker processes (whatever the completion order); a failed or diverged
run is a failed row, not a crashed campaign; the aggregate's Wilson interval and quantiles match
their closed forms; outputs (campaign.json, runs.csv, per-run recordings) and the CLI."""

import csv
import json
import pickle
from pathlib import Path

import numpy as np
import pytest

from mjasc.campaigns.engine import aggregate_rows, run_campaign, wilson_interval, without_timing
from mjasc.campaigns.perturbation import load_campaign, parse_campaign, randomized_scenario
from mjasc.cli import main
from mjasc.runs.runner import RunFailed, run_scenario
from mjasc.runs.scenario import load_scenario

TASKS = Path(__file__).resolve().parent.parent / "tasks"
SIGMAS = dict(vessel_position_sigma_m=2.0, vessel_heading_sigma_deg=5.0, current_velocity_sigma_m_s=0.05,
              traffic_heading_sigma_deg=10.0, traffic_speed_sigma_m_s=0.1)


#: An eddy of 10⁹ m/s beside the start: the hydrodynamic forces overflow within a few steps.
WILD = """
duration_s = 3.0
[current]
type = "vortex"
centre_m = [5.0, 0.0]
core_radius_m = 1.0
max_speed_m_s = 1e9
[[vessels]]
name = "alpha"
type = "otter"
speed_m_s = 1.0
controller = { type = "path_following", waypoints = [[0.0, 0.0], [100.0, 0.0]] }
"""


#: The test scenario (independent of the shipped files): two Otters in a cross current, one with a
#: noisy range sensor and an IMM tracker (its own random streams), a ferry crossing ahead.
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


@pytest.fixture(scope="module")
def short_scenario(tmp_path_factory):
    path = tmp_path_factory.mktemp("scenario") / "short.toml"
    path.write_text(SHORT)
    return path


def short_campaign(scenario_path, runs=4, duration_s=8.0, **kw):
    d = {"name": "short", "scenario": str(scenario_path), "runs": runs, "base_seed": 5,
         "duration_s": duration_s, "randomize": dict(SIGMAS)}
    d.update(kw)
    return parse_campaign(d)


def statuses(result):
    """Each row's status, with the error of any run that did not complete (for the assertion message)."""
    return [r["status"] if r["status"] == "completed" else f"{r['status']}: {r['error']}" for r in result.rows]


@pytest.fixture(scope="module")
def cluster():
    """One LocalCluster of 2 single-threaded worker processes for the module (start-up ≈ 2-3 s)."""
    from distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0") as c:
        yield c


@pytest.fixture(scope="module")
def synchronous_result(tmp_path_factory, short_scenario):
    return run_campaign(short_campaign(short_scenario), tmp_path_factory.mktemp("sync"), scheduler="synchronous",
                        progress=False)


# ---------------------------------------------------------------------- statistics in closed form
def test_wilson_interval_solves_the_score_equation():
    """The Wilson bounds are the two roots p of (p̂ − p)² = z² p(1 − p)/n."""
    z = 1.959963984540054
    for c, n in [(0, 20), (5, 20), (20, 20), (37, 1000), (1, 3)]:
        lo, hi = wilson_interval(c, n)
        p_hat = c / n
        for p in (lo, hi):
            assert (p_hat - p) ** 2 == pytest.approx(z * z * p * (1 - p) / n, abs=1e-12)
        assert lo <= p_hat <= hi
        lo2, hi2 = wilson_interval(n - c, n)
        assert (lo2, hi2) == pytest.approx((1 - hi, 1 - lo), abs=1e-12)
    assert wilson_interval(0, 20) == pytest.approx((0.0, 0.16113), abs=1e-5)  # the "rule of three" regime
    assert wilson_interval(0, 400)[0] == 0.0 and wilson_interval(0, 400)[1] == pytest.approx(z * z / (400 + z * z))
    assert wilson_interval(0, 0) is None
    with pytest.raises(ValueError, match="successes"):
        wilson_interval(5, 4)


def _row(k, clear, xte_mean, xte_max, collided, status="completed"):
    if status != "completed":
        return {"k": k, "seed": k, "status": status, "error": "boom", "summary": None, "wall_time_s": 1.0}
    v = {"a": {"min_clearance_to_any_m": clear, "mean_cross_track_m": xte_mean, "max_cross_track_m": xte_max,
               "collisions": [{"time_s": 1.0, "between": ["a", "x"]}] if collided else []}}
    return {"k": k, "seed": k, "status": status, "error": None, "wall_time_s": 2.0,
            "summary": {"vessels": v, "collisions": v["a"]["collisions"], "any_collision": collided,
                        "sim_time_s": 10.0}}


def test_aggregate_counts_quantiles_and_throughput():
    rows = [_row(k, float(k), 0.1 * k, 0.2 * k, k % 4 == 0) for k in range(20)] + [_row(20, 0, 0, 0, False, "diverged")]
    agg = aggregate_rows(rows, wall_time_s=36.0)
    assert (agg["runs"], agg["completed"], agg["failed"]) == (21, 20, 1)
    assert agg["failed_runs"] == [{"k": 20, "status": "diverged", "error": "boom"}]
    assert agg["collision"]["runs_with_collision"] == 5 and agg["collision"]["rate"] == 0.25
    assert agg["collision"]["wilson95"] == pytest.approx(wilson_interval(5, 20), abs=1e-4)
    clear = np.arange(20.0)
    assert agg["min_clearance_m"]["p50"] == pytest.approx(np.median(clear))
    assert agg["min_clearance_m"]["p5"] == pytest.approx(np.quantile(clear, 0.05))
    assert agg["min_clearance_m"]["std"] == pytest.approx(np.std(clear, ddof=1), abs=1e-4)
    assert agg["max_cross_track_m"]["p100"] == pytest.approx(3.8)
    assert agg["throughput_runs_per_hour"] == pytest.approx(3600 * 21 / 36.0)
    assert agg["real_time_factor"] == pytest.approx(200.0 / 36.0, abs=0.01)
    assert agg["per_vessel"]["a"]["collisions"] == 5


# ---------------------------------------------------------------------- determinism across schedulers
def test_local_cluster_of_two_workers_gives_the_synchronous_results(synchronous_result, short_scenario, tmp_path):
    dist = run_campaign(short_campaign(short_scenario), tmp_path, workers=2, progress=False)
    sync = synchronous_result
    assert [r["k"] for r in dist.rows] == [0, 1, 2, 3]
    assert statuses(dist) == statuses(sync) == ["completed"] * 4
    assert without_timing(dist.rows) == without_timing(sync.rows)
    assert len({r["worker"] for r in dist.rows}) <= 2
    doc = json.loads((tmp_path / "campaign.json").read_text())
    assert doc["campaign"]["workers"] == 2 and doc["campaign"]["scheduler"] == "local"
    assert without_timing(doc["aggregate"]) == without_timing(sync.aggregate)


def test_run_k_is_the_randomized_scenario_run_directly(synchronous_result, short_scenario):
    c = short_campaign(short_scenario)
    sc = randomized_scenario(c.scenario, c, 2)
    from dataclasses import replace

    direct = run_scenario(replace(sc, outputs=replace(sc.outputs, recording=False)), None, progress=False).summary
    row = synchronous_result.rows[2]
    assert row["seed"] == 7 == direct["seed"]
    assert without_timing(row["summary"]) == without_timing(json.loads(json.dumps(direct)))
    # Runs differ from each other (the perturbations act).
    xte = [r["summary"]["vessels"]["alpha"]["mean_cross_track_m"] for r in synchronous_result.rows]
    assert len(set(xte)) == 4
    assert row["summary"]["vessels"]["alpha"]["perception"]  # the sensor and tracker ran


def test_outputs_on_disk(synchronous_result):
    out = synchronous_result.out_dir
    doc = json.loads((out / "campaign.json").read_text())
    assert [r["k"] for r in doc["runs"]] == [0, 1, 2, 3] and doc["campaign"]["base_seed"] == 5
    assert doc["campaign"]["randomize"] == SIGMAS and doc["aggregate"]["completed"] == 4
    with open(out / "runs.csv") as f:
        lines = list(csv.DictReader(f))
    assert [int(r["k"]) for r in lines] == [0, 1, 2, 3] and [int(r["seed"]) for r in lines] == [5, 6, 7, 8]
    r1 = synchronous_result.rows[1]
    assert float(lines[1]["alpha.mean_cross_track_m"]) == r1["summary"]["vessels"]["alpha"]["mean_cross_track_m"]
    assert float(lines[1]["draw.alpha.dx_m"]) == r1["draws"]["vessels"]["alpha"]["dx_m"]
    assert float(lines[1]["draw.ferry.dspeed_m_s"]) == r1["draws"]["traffic"]["ferry"]["dspeed_m_s"]
    assert not (out / "runs").exists()  # summaries only unless recordings are asked for


# ---------------------------------------------------------------------- failures
def test_failed_runs_are_rows_and_the_others_go_on(cluster, short_scenario, tmp_path):
    def flaky(scenario, out_dir, progress):  # defined here so Dask pickles it by value
        if scenario.seed == 6:
            raise RunFailed("physics diverged at t = 1.000 s: injected")
        if scenario.seed == 7:
            raise ValueError("injected bug")
        return run_scenario(scenario, out_dir, progress)

    c = short_campaign(short_scenario, duration_s=4.0)
    dist = run_campaign(c, tmp_path / "dist", scheduler=cluster.scheduler_address, progress=False, run_fn=flaky)
    sync = run_campaign(c, tmp_path / "sync", workers=0, progress=False, run_fn=flaky)
    for res in (dist, sync):
        assert [r["status"] for r in res.rows] == ["completed", "diverged", "failed", "completed"], statuses(res)
        assert res.rows[1]["error"].startswith("RunFailed: physics diverged") and res.rows[1]["summary"] is None
        assert res.rows[2]["error"] == "ValueError: injected bug"
        assert res.aggregate["failed"] == 2 and res.aggregate["completed"] == 2
        assert res.aggregate["min_clearance_m"]["n"] == 2
    assert without_timing(dist.rows) == without_timing(sync.rows)
    assert json.loads((tmp_path / "dist" / "campaign.json").read_text())["campaign"]["scheduler"].startswith("tcp://")


@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # the overflow that makes it diverge
def test_a_run_whose_physics_diverges_is_reported_as_diverged(tmp_path):
    (tmp_path / "wild.toml").write_text(WILD)
    (tmp_path / "c.toml").write_text('scenario = "wild.toml"\nruns = 2\n')
    res = run_campaign(load_campaign(tmp_path / "c.toml"), tmp_path / "out", scheduler="synchronous", progress=False)
    assert [r["status"] for r in res.rows] == ["diverged", "diverged"]
    assert "physics diverged" in res.rows[0]["error"]
    assert res.aggregate["collision"]["rate"] is None and res.aggregate["min_clearance_m"] is None


# ---------------------------------------------------------------------- recordings, arguments, CLI
def test_recordings_are_kept_per_run_when_asked(short_scenario, tmp_path):
    c = short_campaign(short_scenario, runs=2, duration_s=2.0, outputs={"recordings": True})
    res = run_campaign(c, tmp_path, scheduler="synchronous", progress=False)
    for k in (0, 1):
        assert (tmp_path / "runs" / str(k) / "recording.rrd").stat().st_size > 0
        s = json.loads((tmp_path / "runs" / str(k) / "summary.json").read_text())
        assert s["seed"] == 5 + k and without_timing(s) == without_timing(res.rows[k]["summary"])


def test_bad_scheduler_arguments_name_the_field(short_scenario, tmp_path):
    c = short_campaign(short_scenario, runs=1)
    with pytest.raises(ValueError, match="^workers: must be ≥ 0, got -1$"):
        run_campaign(c, tmp_path, workers=-1, progress=False)
    with pytest.raises(ValueError, match="^workers: must be an integer, got 2.5$"):
        run_campaign(c, tmp_path, workers=2.5, progress=False)
    with pytest.raises(ValueError, match="workers: only for a local cluster"):
        run_campaign(c, tmp_path, scheduler="tcp://127.0.0.1:1", workers=2, progress=False)


@pytest.mark.parametrize("path", [TASKS / "demo.toml", *sorted(TASKS.glob("thesis_*.toml"))], ids=lambda p: p.name)
def test_scenarios_pickle_for_the_workers(path):
    sc = load_scenario(path)
    back = pickle.loads(pickle.dumps(sc))
    assert back.seed == sc.seed and [v.name for v in back.vessels] == [v.name for v in sc.vessels]
    origin = np.zeros((1, 2))
    np.testing.assert_array_equal(back.current.velocity(origin, 1.0), sc.current.velocity(origin, 1.0))


def test_cli_campaign_prints_the_aggregate(short_scenario, tmp_path, capsys):
    (tmp_path / "c.toml").write_text(f'scenario = "{short_scenario}"\nruns = 5\nduration_s = 2.0\n'
                                     '[randomize]\nvessel_position_sigma_m = 1.0\n')
    assert main(["campaign", str(tmp_path / "c.toml"), "--workers", "0", "--runs", "2", "--out",
                 str(tmp_path / "out"), "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "c: 2 run(s), 2 completed, 0 failed" in out and "collision rate" in out and "min clearance" in out
    assert len(json.loads((tmp_path / "out" / "campaign.json").read_text())["runs"]) == 2
    (tmp_path / "bad.toml").write_text('scenario = "x.toml"\nruns = -1\n')
    assert main(["campaign", str(tmp_path / "bad.toml")]) == 2
    assert "runs: must be ≥ 1" in capsys.readouterr().err
