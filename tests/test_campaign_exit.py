"""``python -m mjasc campaign`` leaves without the interpreter's final clean-up (mjasc/__main__.py):
its exit status, what it printed and every file it wrote are those of the usual exit."""

import json
import os
import subprocess
import sys

import pyarrow.parquet as pq

SCENARIO = """
name = "exit"
duration_s = 2.0
seed = 0
[[vessels]]
name = "alpha"
type = "otter"
speed_m_s = 1.0
controller = { type = "path_following", waypoints = [[0.0, 0.0], [200.0, 0.0]], speed_m_s = 1.5 }
[vessels.sensor]
[vessels.tracking]
[[moving_obstacles]]
name = "ferry"
radius_m = 4.0
position_m = [30.0, 25.0]
heading_deg = -90.0
speed_m_s = 1.2
"""

CAMPAIGN = """
name = "exit"
scenario = "exit.toml"
runs = 3
base_seed = 1
[randomize]
vessel_position_sigma_m = 2.0
[outputs]
recordings = false
[evaluation]
mission_cost = false
"""


def _command(tmp_path, *args):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    return subprocess.run([sys.executable, "-m", "mjasc", "campaign", *args], env=env, capture_output=True, text=True,
                          cwd=tmp_path, timeout=600)


def test_campaign_command_leaves_with_its_outputs_complete(tmp_path):
    (tmp_path / "exit.toml").write_text(SCENARIO)
    (tmp_path / "c.toml").write_text(CAMPAIGN)
    out = tmp_path / "out"
    proc = _command(tmp_path, "c.toml", "--workers", "2", "--out", str(out), "--no-progress")
    assert proc.returncode == 0, proc.stderr
    # stdout is a pipe (block-buffered): everything printed reached it
    assert "exit: 3 run(s) done now, 0 already in the store" in proc.stdout
    assert f"campaign: {out / 'campaign.json'}" in proc.stdout and proc.stdout.endswith("\n")
    doc = json.loads((out / "campaign.json").read_text())
    assert doc["campaign"]["runs_to_do"] == 3 and doc["aggregate"]
    assert pq.read_table(out / "runs.parquet").num_rows == 3
    assert len((out / "runs.csv").read_text().strip().splitlines()) == 4
    # the store is whole: the same command finds every run done
    again = _command(tmp_path, "c.toml", "--workers", "2", "--out", str(out), "--no-progress")
    assert again.returncode == 0 and "0 run(s) done now, 3 already in the store" in again.stdout


def test_campaign_command_failure_keeps_its_status_and_message(tmp_path):
    (tmp_path / "bad.toml").write_text('name = "bad"\nscenario = "missing.toml"\nruns = 2\n')
    proc = _command(tmp_path, "bad.toml", "--workers", "0", "--out", str(tmp_path / "out"))
    assert proc.returncode == 2
    assert proc.stderr.startswith("mjasc: invalid campaign:")
