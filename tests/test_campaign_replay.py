"""A campaign run is a normal scenario: its text written to a file and run with ``mjasc run`` gives
the same summary.json (timing fields aside) as running the RunSpec's parsed scenario."""

import json

import pytest

from mjasc.campaigns.engine import without_timing
from mjasc.campaigns.spec import parse_campaign_spec, write_scenario
from mjasc.cli import main
from mjasc.runs.runner import run_scenario

SHORT = """
name = "short"
duration_s = 3.0
[current]
type = "gauss_markov"
mean_velocity_m_s = [0.1, 0.0]
sigma_m_s = 0.05
time_constant_s = 20.0
[[vessels]]
name = "alpha"
type = "otter"
speed_m_s = 1.0
controller = { type = "path_following", waypoints = [[0.0, 0.0], [200.0, 0.0]], speed_m_s = 1.5 }
[vessels.sensor]
[vessels.tracking]
[[moving_obstacles]]
name = "ferry"
radius_m = 3.0
position_m = [30.0, 25.0]
heading_deg = -90.0
speed_m_s = 1.2
"""


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    folder = tmp_path_factory.mktemp("campaign")
    (folder / "short.toml").write_text(SHORT)
    return parse_campaign_spec({
        "name": "replay", "base_seed": 11,
        "families": [
            {"kind": "perturbation", "scenario": "short.toml", "runs_per_point": 2,
             "randomize": {"vessel_position_sigma_m": 1.0, "current_velocity_sigma_m_s": 0.05,
                           "traffic_heading_sigma_deg": 5.0}},
            {"kind": "team_vs_traffic", "duration_s": 3.0, "runs_per_point": 1,
             "parameters": {"team_size": 2, "comms_loss": 0.3, "current_m_s": 0.15, "dcpa_m": {"uniform": [-5, 5]},
                            "sensor_dropout": 0.1}},
        ]}, "replay.toml", folder)


@pytest.mark.parametrize("index", [1, 2])
def test_mjasc_run_on_the_written_file_replays_the_run(campaign, index, tmp_path, monkeypatch):
    run = campaign.run(index)
    path = write_scenario(run, tmp_path / "scenario" / f"run_{index}.toml")
    assert path.read_text() == run.scenario_toml
    monkeypatch.chdir(tmp_path)
    assert main(["run", str(path), "--out", str(tmp_path / "cli"), "--no-progress"]) == 0
    direct = run_scenario(run.scenario(), tmp_path / "direct", progress=False)
    replayed = json.loads((tmp_path / "cli" / "summary.json").read_text())
    stored = json.loads((tmp_path / "direct" / "summary.json").read_text())
    assert replayed["seed"] == run.seed == campaign.base_seed + index
    assert without_timing(replayed) == without_timing(stored) == without_timing(json.loads(json.dumps(direct.summary)))
    assert replayed["vessels"]  # something ran


def test_mjasc_extract_writes_a_stored_run_that_replays_exactly(campaign, tmp_path, monkeypatch, capsys):
    """The store → `mjasc extract` → `mjasc run` gives the stored run's summary (the evaluation
    aside: the campaign adds it, a plain run does not)."""
    from mjasc.campaigns.engine import run_campaign

    res = run_campaign(campaign.with_overrides(runs=3), tmp_path / "out", workers=0, progress=False)
    stored = {r.index: r for r in res.runs}
    monkeypatch.chdir(tmp_path)
    assert main(["extract", str(tmp_path / "out"), "2", "--out", str(tmp_path / "files")]) == 0
    path = tmp_path / "files" / "run_2.toml"
    assert path.read_text() == campaign.run(2).scenario_toml and "mjasc run" in capsys.readouterr().out
    assert main(["run", str(path), "--out", str(tmp_path / "replay"), "--no-progress"]) == 0
    replayed = json.loads((tmp_path / "replay" / "summary.json").read_text())
    metrics = {k: v for k, v in stored[2].metrics.items() if k != "evaluation"}
    assert without_timing(replayed) == without_timing(metrics)
    assert main(["extract", str(tmp_path / "out"), "7"]) == 2  # not stored: a clear error
    assert "no stored run 7" in capsys.readouterr().err
