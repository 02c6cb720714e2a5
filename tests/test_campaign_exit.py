"""``python -m mjasc campaign`` leaves without the interpreter's final clean-up (mjasc/__main__.py):
its exit status, what it printed and every file it wrote are those of the usual exit."""

import json
import os
import subprocess
import sys

import pyarrow.parquet as pq
import pytest

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


@pytest.mark.parametrize("how", ["ctrl-c", "sigterm"])
def test_ctrl_c_on_a_campaign_on_two_workers_leaves_at_once_with_one_line(tmp_path, how):
    """Ctrl-C (SIGINT to the terminal's process group) on ``mjasc campaign --workers 2``, or SIGTERM
    to the command alone (``kill``, a batch system's stop): the queued runs are cancelled and the
    running ones' children closed, so the command leaves within seconds with status 130 and one
    line — no Dask error log of the runs it cut short, no new child started for a queued run while
    the cluster closes — and the store keeps exactly the finished runs, which the same command then
    does not run again. (SIGTERM used to end the command at once with status 143 and no line.)"""
    import signal
    import sqlite3
    import time

    write_campaign(tmp_path, runs=12, duration=20.0, mission_cost=False)
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    proc = subprocess.Popen([sys.executable, "-m", "mjasc", "campaign", "c.toml", "--workers", "2", "--out", str(out),
                             "--no-progress"], env=env, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True)
    store = out / "campaign.sqlite"
    t0 = time.time()
    stored = 0
    while stored < 2 and time.time() - t0 < 300 and proc.poll() is None:
        time.sleep(0.2)
        try:
            with sqlite3.connect(store) as db:
                stored = db.execute("SELECT COUNT(*) FROM runs").fetchone()[0]
        except sqlite3.Error:
            stored = 0
    assert stored >= 2 and proc.poll() is None, "the campaign ended before it could be interrupted"
    t_int = time.time()
    if how == "ctrl-c":
        os.killpg(proc.pid, signal.SIGINT)
    else:
        proc.send_signal(signal.SIGTERM)
    try:
        _, err = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        raise
    assert proc.returncode == 130, err
    assert time.time() - t_int < 20.0
    assert err == "mjasc: interrupted\n", err
    with sqlite3.connect(store) as db:
        assert db.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
        rows = db.execute("SELECT idx, status, attempts FROM runs").fetchall()
    assert rows and all(status == "completed" and attempts == 1 for _, status, attempts in rows)
    # the next command does only what is missing of the first runs up to the highest stored one and one
    # more (two workers can finish run k + 1 before run k: the stored rows need not be the first ones)
    upto = max(idx for idx, _, _ in rows) + 2
    again = _command(tmp_path, "c.toml", "--workers", "0", "--out", str(out), "--no-progress", "--runs", str(upto))
    assert again.returncode == 0 and \
        f"{upto - len(rows)} run(s) done now, {len(rows)} already in the store" in again.stdout


def test_a_second_command_into_a_folder_in_use_is_refused(tmp_path):
    """Two commands into one ``--out`` at once (the same command started again in another terminal,
    a batch job submitted twice): the second used to do every run a second time (each printed "12
    run(s) done now"); it is now refused at once, in one line, and writes nothing; once the first has
    ended the same command runs."""
    import fcntl

    write_campaign(tmp_path, runs=2, duration=2.0, mission_cost=False)
    out = tmp_path / "out"
    out.mkdir()
    fd = os.open(out, os.O_RDONLY)  # (what a running campaign command holds)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        busy = _command(tmp_path, "c.toml", "--workers", "0", "--out", str(out), "--no-progress")
    finally:
        os.close(fd)
    assert busy.returncode == 1, busy.stdout + busy.stderr
    assert busy.stderr == (f"mjasc: campaign failed: {out}: another campaign command is running into this folder; "
                           f"wait for it to end (then the same command does what is left) or give another --out\n")
    assert list(out.iterdir()) == []
    after = _command(tmp_path, "c.toml", "--workers", "0", "--out", str(out), "--no-progress")
    assert after.returncode == 0 and "2 run(s) done now, 0 already in the store" in after.stdout
