"""``mjasc campaign --scheduler ADDR`` against a real multi-process Dask cluster (a ``dask scheduler``
and ``dask worker`` started as separate processes, as on a lab's cluster): what happens to the
campaign and its store when the cluster misbehaves."""

import os
import signal
import socket
import sqlite3
import subprocess
import sys
import time

import pytest

from tests.test_campaign import write_campaign


def _env(**extra) -> dict:
    return {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path), **extra}


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _start(*args) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", *args], env=_env(), stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, start_new_session=True)


def _stop(proc: subprocess.Popen) -> None:
    try:
        os.killpg(proc.pid, signal.SIGKILL)  # (its session: a worker's nanny, worker and run child)
    except ProcessLookupError:
        pass
    proc.wait(timeout=30)


@pytest.fixture
def cluster():
    """A scheduler and one single-threaded worker, each a process (session) of its own:
    (address, scheduler process, worker process)."""
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    scheduler = _start("distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", str(port),
                       "--dashboard-address", ":0")
    worker = _start("distributed.cli.dask_worker", address, "--nthreads", "1", "--nworkers", "1",
                    "--dashboard-address", ":0")
    try:
        yield address, scheduler, worker
    finally:
        _stop(worker)
        _stop(scheduler)


def _stored(store) -> int:
    try:
        with sqlite3.connect(f"file:{store}?mode=ro", uri=True, timeout=1) as db:
            return db.execute("SELECT COUNT(*) FROM runs").fetchone()[0]
    except sqlite3.Error:
        return 0


def test_a_lost_scheduler_stops_the_campaign_and_spends_no_run(tmp_path, cluster):
    """The scheduler killed mid-campaign: the driver leaves with status 1 and one line saying so
    (it used to record every run still out as ``crashed`` with all its attempts spent, exit 0, and
    the same command then never did them); the store keeps exactly the finished runs and the same
    command does the rest."""
    address, scheduler, _ = cluster
    write_campaign(tmp_path, runs=12, duration=20.0, mission_cost=False)
    out = tmp_path / "out"
    # (the client's reconnection attempt: 30 s by default)
    proc = subprocess.Popen([sys.executable, "-m", "mjasc", "campaign", "c.toml", "--scheduler", address, "--out",
                             str(out), "--no-progress"], env=_env(DASK_DISTRIBUTED__COMM__TIMEOUTS__CONNECT="3s"),
                            cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    try:
        t0 = time.time()
        while _stored(out / "campaign.sqlite") < 1 and time.time() - t0 < 300 and proc.poll() is None:
            time.sleep(0.05)
        assert proc.poll() is None, "the campaign ended before its scheduler could be killed"
        scheduler.kill()
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 1, err
    last = err.strip().splitlines()[-1]
    assert last.startswith(f"mjasc: campaign failed: lost the Dask scheduler at {address}: "), err
    with sqlite3.connect(out / "campaign.sqlite") as db:
        rows = db.execute("SELECT idx, status, attempts FROM runs").fetchall()
    assert rows and len(rows) < 12 and all(s == "completed" and a == 1 for _, s, a in rows), rows
    again = subprocess.run([sys.executable, "-m", "mjasc", "campaign", "c.toml", "--workers", "0", "--out", str(out),
                            "--no-progress"], env=_env(), cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert again.returncode == 0, again.stderr
    assert f"{12 - len(rows)} run(s) done now, {len(rows)} already in the store" in again.stdout
    assert "12 completed, 0 failed" in again.stdout
