"""``python -m mjasc campaign`` leaves without the interpreter's final clean-up (mjasc/__main__.py):
its exit status, what it printed and every file it wrote are those of the usual exit."""

import json
import os
import subprocess
import sys

import pyarrow.parquet as pq

from tests.test_campaign import write_campaign


def _command(tmp_path, *args):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    return subprocess.run([sys.executable, "-m", "mjasc", "campaign", *args], env=env, capture_output=True, text=True,
                          cwd=tmp_path, timeout=600)


def test_campaign_command_leaves_with_its_outputs_complete(tmp_path):
    write_campaign(tmp_path, runs=3, duration=2.0, mission_cost=False)  # (the c.toml of tests/test_campaign.py)
    out = tmp_path / "out"
    proc = _command(tmp_path, "c.toml", "--workers", "2", "--out", str(out), "--no-progress")
    assert proc.returncode == 0, proc.stderr
    # stdout is a pipe (block-buffered): everything printed reached it
    assert "short: 3 run(s) done now, 0 already in the store" in proc.stdout
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
