"""``mjasc campaign --scheduler ADDR`` against a real multi-process Dask cluster (a ``dask scheduler``
and ``dask worker`` started as separate processes, as on a lab's cluster): what happens to the
campaign and its store when the cluster misbehaves."""

import contextlib
import json
import os
import shutil
import signal
import socket
import sqlite3
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

from mjasc.campaigns.cluster import math_digest
from mjasc.core.portable_math import cpu_flags

from tests.test_campaign import write_campaign


def _env(**extra) -> dict:
    return {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path), **extra}


@contextlib.contextmanager
def _port_none_listens_on():
    """A port of this host held, bound but not listening, while the block runs: connecting to it is
    refused, and no other process can take it meanwhile (a port found free and let go can be)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        yield s.getsockname()[1]


def _start(*args, env: dict | None = None, cwd=None) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", *args], env=env or _env(), stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, start_new_session=True, cwd=cwd)


def _stop(proc: subprocess.Popen) -> None:
    """End ``proc``'s session (a worker's nanny, worker and run child): asked first, so that Dask
    removes its scratch folders, then killed."""
    for sig, wait_s in ((signal.SIGTERM, 15), (signal.SIGKILL, 30)):
        try:
            os.killpg(proc.pid, sig)
        except ProcessLookupError:
            break
        try:
            proc.wait(timeout=wait_s)
            break
        except subprocess.TimeoutExpired:
            continue
    proc.wait(timeout=30)


@contextlib.contextmanager
def _cluster(nthreads: int = 1, worker_env: dict | None = None, worker_cwd=None):
    """A scheduler and one worker of ``nthreads`` threads (its environment ``worker_env``, default
    this process's, and folder ``worker_cwd``: ``python -m`` puts it first on the path), each a
    process (session) of its own: (address, scheduler process, worker process)."""
    # The scheduler picks its own port and says where in its file (a port found free beforehand
    # could be taken by another process before the scheduler binds it)
    folder = Path(tempfile.mkdtemp(prefix="mjasc_cluster_"))
    info = folder / "scheduler.json"
    scheduler = _start("distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", "0",
                       "--scheduler-file", str(info), "--dashboard-address", ":0")
    worker = None
    try:
        address, deadline = None, time.time() + 120
        while address is None and time.time() < deadline and scheduler.poll() is None:
            try:  # (the scheduler writes its file in two steps: an empty file first)
                address = json.loads(info.read_text())["address"]
            except (OSError, ValueError, KeyError):
                time.sleep(0.1)
        assert address is not None, f"the Dask scheduler did not start (exit {scheduler.poll()})"
        worker = _start("distributed.cli.dask_worker", address, "--nthreads", str(nthreads), "--nworkers", "1",
                        "--dashboard-address", ":0", env=worker_env, cwd=worker_cwd)
        yield address, scheduler, worker
    finally:
        if worker is not None:
            _stop(worker)
        _stop(scheduler)
        shutil.rmtree(folder, ignore_errors=True)


@pytest.fixture
def cluster():
    with _cluster() as c:
        yield c


def _stored(store) -> int:
    try:
        with sqlite3.connect(f"file:{store}?mode=ro", uri=True, timeout=1) as db:
            return db.execute("SELECT COUNT(*) FROM runs").fetchone()[0]
    except sqlite3.Error:
        return 0


def test_a_lost_scheduler_stops_the_campaign_and_spends_no_run(tmp_path, cluster):
    """The scheduler killed mid-campaign: the driver leaves at once with status 1 and one line saying
    so (it used to record every run still out as ``crashed`` with all its attempts spent, exit 0, and
    the same command then never did them); the store keeps exactly the finished runs and the same
    command does the rest."""
    address, scheduler, _ = cluster
    write_campaign(tmp_path, runs=12, duration=20.0, mission_cost=False)
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "mjasc", "campaign", "c.toml", "--scheduler", address, "--out",
                             str(out), "--no-progress"], env=_env(),
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
    # one line: not the client's log of its reconnection, cut short (a traceback of ~30 lines)
    assert len(err.splitlines()) == 1, err
    assert err.startswith(f"mjasc: campaign failed: lost the Dask scheduler at {address}: "), err
    with sqlite3.connect(out / "campaign.sqlite") as db:
        rows = db.execute("SELECT idx, status, attempts FROM runs").fetchall()
    assert rows and len(rows) < 12 and all(s == "completed" and a == 1 for _, s, a in rows), rows
    again = subprocess.run([sys.executable, "-m", "mjasc", "campaign", "c.toml", "--workers", "0", "--out", str(out),
                            "--no-progress"], env=_env(), cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert again.returncode == 0, again.stderr
    assert f"{12 - len(rows)} run(s) done now, {len(rows)} already in the store" in again.stdout
    assert "12 completed, 0 failed" in again.stdout


def _summaries(store) -> dict:
    from mjasc.campaigns.engine import without_timing

    with sqlite3.connect(store) as db:
        return {i: (st, without_timing(json.loads(m) if m else None))
                for i, st, m in db.execute("SELECT idx, status, metrics FROM runs")}


def test_a_worker_of_two_threads_gives_each_run_its_own_result(tmp_path):
    """``dask worker --nthreads 2`` (the docs ask for one thread, dask's default is one per core):
    two runs at once on one worker used to share the worker's one run child, so that each read the
    other's result, one run was lost and the campaign hung; each thread now has a child of its own,
    and the stored summaries are those of the same campaign in one process."""
    write_campaign(tmp_path, runs=8, duration=20.0, mission_cost=False)
    with _cluster(nthreads=2) as (address, _, _):
        proc = subprocess.Popen([sys.executable, "-m", "mjasc", "campaign", "c.toml", "--scheduler", address,
                                 "--out", str(tmp_path / "dask"), "--no-progress"], env=_env(), cwd=tmp_path,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
        try:
            _, err = proc.communicate(timeout=600)
        finally:
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 0, err
    here = subprocess.run([sys.executable, "-m", "mjasc", "campaign", "c.toml", "--workers", "0", "--out",
                           str(tmp_path / "here"), "--no-progress"], env=_env(), cwd=tmp_path, capture_output=True,
                          text=True, timeout=600)
    assert here.returncode == 0, here.stderr
    dask, ref = _summaries(tmp_path / "dask" / "campaign.sqlite"), _summaries(tmp_path / "here" / "campaign.sqlite")
    assert sorted(dask) == list(range(8)) and dask == ref


_PARENT = """
import json, sys, threading, time
from mjasc.campaigns.executor import IsolatedExecutor
from mjasc.campaigns.forked import ForkedExecutor
from mjasc.core.resources import bundled_scenarios

forked = sys.argv[1] == "forked"
ex = ForkedExecutor() if forked else IsolatedExecutor()
assert ex.wait_ready(300)
text = "\\n".join("duration_s = 2400.0" if ln.startswith("duration_s") else ln
                  for ln in bundled_scenarios()["demo"].read_text().splitlines())
request = {"index": 0, "scenario_toml": text, "run_dir": None, "evaluate": False}
threading.Thread(target=ex.run, args=(request,), daemon=True).start()
print(ex.pid if forked else ex._proc.pid, flush=True)
time.sleep(600)
"""


def _running(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"  # (a zombie nobody reaps has gone)
    except FileNotFoundError:
        return False


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize("kind", ["interpreter", "forked"])
def test_a_run_child_leaves_when_its_worker_is_killed(tmp_path, kind):
    """A worker (or driver) killed with SIGKILL in the middle of a run: its run child used to go
    on with the run nobody would read (minutes; a hung run for ever) — a stray process on the
    cluster's node; it now leaves within about a second (the run is done again elsewhere)."""
    parent = subprocess.Popen([sys.executable, "-c", _PARENT, kind], env=_env(), cwd=tmp_path,
                              stdout=subprocess.PIPE, text=True)
    child = None
    try:
        child = int(parent.stdout.readline())
        time.sleep(1.0)  # (the run under way)
        assert _running(child)
        parent.kill()
        parent.wait(timeout=30)
        t0 = time.time()
        while _running(child) and time.time() - t0 < 10:
            time.sleep(0.1)
        assert not _running(child), f"the run child {child} outlived its parent by 10 s"
    finally:
        if parent.poll() is None:
            parent.kill()
        if child is not None and _running(child):
            os.kill(child, signal.SIGKILL)


def test_a_scheduler_address_where_none_listens_leaves_no_store(tmp_path):
    """A mistyped ``--scheduler`` address: one line, status 1 — and no store without runs left in
    ``--out`` (it used to be made before the scheduler was reached; the command still makes the
    folder first, proving it writable, and removes it again when it made it and stored nothing: a
    reviewer's Ctrl-C before the first result left an empty folder); an existing folder keeps what
    it held."""
    write_campaign(tmp_path, runs=6, duration=2.0, mission_cost=False)
    kept = tmp_path / "kept"
    kept.mkdir()
    (kept / "notes.txt").write_text("mine\n")
    with _port_none_listens_on() as port:
        for out in (tmp_path / "new", kept):
            _campaign_without_a_scheduler(tmp_path, f"tcp://127.0.0.1:{port}", out)
    assert not (tmp_path / "new").exists()
    assert sorted(p.name for p in kept.iterdir()) == ["notes.txt"]


def _campaign_without_a_scheduler(tmp_path, address, out):
    proc = subprocess.run([sys.executable, "-m", "mjasc", "campaign", "c.toml", "--scheduler", address, "--out",
                           str(out), "--no-progress"], env=_env(DASK_DISTRIBUTED__COMM__TIMEOUTS__CONNECT="2s"),
                          cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 1, proc.stderr
    assert proc.stderr.startswith("mjasc: campaign failed: ") and len(proc.stderr.splitlines()) == 1, proc.stderr


def test_a_worker_on_other_mjasc_code_stops_the_campaign_before_any_run(tmp_path):
    """A worker started on another checkout (here a copy of mjasc with one comment added, first on
    its PYTHONPATH) reports the same version but other code: the campaign refuses it before any
    run, status 1, one line naming the worker and both code digests (its results would differ)."""
    import shutil

    import mjasc

    other = tmp_path / "other"
    shutil.copytree(os.path.dirname(mjasc.__file__), other / "mjasc",
                    ignore=shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc"))
    with open(other / "mjasc" / "__init__.py", "a") as f:
        f.write("# another checkout\n")
    error = _refused_before_any_run(tmp_path, _env(PYTHONPATH=os.pathsep.join([str(other), *sys.path])), other)
    assert "1 of 1 Dask worker(s) run other mjasc code than this process" in error, error


def _refused_before_any_run(tmp_path, worker_env: dict, worker_cwd=None) -> str:
    """A 4-run campaign on a cluster whose one worker has ``worker_env``: it must stop before any
    run, status 1, one line, no store; that line."""
    write_campaign(tmp_path, runs=4, duration=5.0, mission_cost=False)
    with _cluster(worker_env=worker_env, worker_cwd=worker_cwd) as (address, _, _):
        got = subprocess.run([sys.executable, "-m", "mjasc", "campaign", "c.toml", "--scheduler", address, "--out",
                              str(tmp_path / "out"), "--no-progress"], env=_env(), cwd=tmp_path,
                             capture_output=True, text=True, timeout=300)
    assert got.returncode == 1, got.stderr
    assert len(got.stderr.splitlines()) == 1 and "no run was done" in got.stderr, got.stderr
    assert not (tmp_path / "out" / "campaign.sqlite").exists()
    return got.stderr


@pytest.mark.skipif(not {"avx2", "fma"} <= cpu_flags(), reason="OpenBLAS's Haswell kernels (the pin) need AVX2 and FMA")
def test_a_worker_whose_runs_compute_other_bits_stops_the_campaign_before_any_run(tmp_path):
    """A worker machine whose run children would compute other floating-point bits — here the
    same machine with OpenBLAS's SSE3 kernels forced in the worker's environment (a user's own
    OPENBLAS_CORETYPE: the pin never overrides it), as a node of another CPU kind would — reports
    another math digest: the campaign refuses it before any run, one line naming the worker and
    both digests (its runs would not replay on the driver's machine)."""
    error = _refused_before_any_run(tmp_path, _env(OPENBLAS_CORETYPE="Prescott"))
    assert "1 of 1 Dask worker(s) compute other floating-point bits than this machine" in error, error
    assert f"here {math_digest(True)}" in error
