"""The ``mjasc`` program leaves without the interpreter's final clean-up (mjasc/cli/process_exit.py):
its exit status, what it printed and every file it wrote are those of the usual exit — for a
campaign, a run with its recording, video and summary, the console script's entry point and a
command that fails."""

import json
import os
import subprocess
import sys

import pyarrow.parquet as pq
import pytest

from tests.test_campaign import write_campaign


def _command(tmp_path, *args, command="campaign"):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    return subprocess.run([sys.executable, "-m", "mjasc", command, *args], env=env, capture_output=True, text=True,
                          cwd=tmp_path, timeout=600)


def test_a_run_leaves_with_its_recording_video_and_summary_complete(tmp_path):
    import imageio_ffmpeg

    from mjasc.runs.rrd_canonical import canonicalise

    out = tmp_path / "run"
    proc = _command(tmp_path, "thesis_6_1_static", "--duration", "2", "--video", "--out", str(out), "--no-progress",
                    command="run")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.endswith("\n") and f"summary: {out / 'summary.json'}" in proc.stdout
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "completed" and summary["video_frames"] > 1
    reader = imageio_ffmpeg.read_frames(str(out / "video.mp4"))  # the MP4 is whole: every frame decodes
    next(reader)
    assert sum(1 for _ in reader) == summary["video_frames"]
    # the recording is whole and canonical: re-encoding it again gives the same bytes
    canonicalise(out / "recording.rrd", tmp_path / "again.rrd", *_recording_ids(out / "recording.rrd"))
    assert (tmp_path / "again.rrd").read_bytes() == (out / "recording.rrd").read_bytes()
    assert not list(out.glob("*.part*"))


def _recording_ids(path):
    """The (recording, blueprint) store ids of a canonical recording."""
    from mjasc.runs.rrd_canonical import SdkMessages

    sdk = SdkMessages()
    sdk.feed(path.read_bytes())
    ids = {kind: store for kind, store in sdk.stores}
    return ids[1], ids[2]


def test_the_console_script_s_entry_point_leaves_with_the_command_s_status(tmp_path):
    """``mjasc`` as installed runs :func:`mjasc.cli.command_line` (pyproject's script): its status is
    the command's, bad input one line on stderr; a status that is not one is raised as usual."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    code = "import sys; sys.argv = ['mjasc', *sys.argv[1:]]; from mjasc.cli import command_line; command_line()"
    ok = subprocess.run([sys.executable, "-c", code, "list"], env=env, capture_output=True, text=True, cwd=tmp_path,
                        timeout=600)
    assert ok.returncode == 0 and "thesis_6_4_crossing" in ok.stdout and ok.stdout.endswith("\n")
    bad = subprocess.run([sys.executable, "-c", code, "run", "missing.toml"], env=env, capture_output=True, text=True,
                         cwd=tmp_path, timeout=600)
    assert bad.returncode == 2 and bad.stderr.startswith("mjasc: invalid scenario: missing.toml")
    assert len(bad.stderr.strip().splitlines()) == 1
    from importlib.metadata import entry_points

    assert entry_points(group="console_scripts")["mjasc"].value == "mjasc.cli:command_line"


_PROBE = """
import atexit, sys
{before}
import mjasc.cli
from mjasc.cli import process_exit
print(atexit._ncallbacks(), process_exit.ARMED)
sys.argv = ["mjasc", "list"]
mjasc.cli.command_line()
"""


@pytest.mark.parametrize("before", ["", "atexit.register(lambda: print('earlier handler ran', flush=True))"])
def test_the_quick_exit_is_armed_only_as_the_first_exit_handler(tmp_path, before):
    """Importing mjasc.cli registers the quick exit first (then it runs last, after every other
    handler); a process that registered a handler before — a sitecustomize, a coverage hook —
    keeps the usual exit, so that handler still runs."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    proc = subprocess.run([sys.executable, "-c", _PROBE.format(before=before)], env=env, capture_output=True,
                          text=True, cwd=tmp_path, timeout=600)
    assert proc.returncode == 0, proc.stderr
    first = proc.stdout.splitlines()[0]
    if before:
        assert first == "2 False" and proc.stdout.rstrip().endswith("earlier handler ran")
    else:
        assert first == "1 True" and "thesis_6_4_crossing" in proc.stdout


def test_a_stdout_that_cannot_be_flushed_at_the_exit_ends_with_status_120_as_the_usual_exit(tmp_path):
    """What is still buffered on stdout when the program leaves, on a full device (/dev/full): the
    usual exit ends with status 120, and so does the quick one (a command flushes its own output
    first: there, a full disk is the command's error, status 1 and one line)."""
    if not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full on this system")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}
    env["PYTHONPATH"] = os.pathsep.join(sys.path)
    code = ("import sys; from mjasc.cli import process_exit; print('still in the buffer'); "
            "process_exit.leave_with(0) if sys.argv[1] == 'quick' else None")
    for how in ("usual", "quick"):
        with open("/dev/full", "w") as full:
            proc = subprocess.run([sys.executable, "-c", code, how], env=env, stdout=full, stderr=subprocess.PIPE,
                                  text=True, cwd=tmp_path, timeout=600)
        assert proc.returncode == 120, (how, proc.stderr)


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


def test_the_program_collects_young_objects_as_a_run_s_loop_does_and_main_as_a_function_not(tmp_path, capsys):
    """The program raises the collector's young threshold from its start (a command's imports and
    set-up made ~500 collections, ~0.3 s); :func:`mjasc.cli.main` called as a function does not."""
    import gc

    from mjasc.cli import main
    from mjasc.runs.collector import YOUNG_THRESHOLD

    before = gc.get_threshold()
    assert main(["list"]) == 0 and gc.get_threshold() == before
    capsys.readouterr()
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    code = ("import atexit, gc, sys; import mjasc.cli; "
            "atexit.register(lambda: print(gc.get_threshold()[0], flush=True)); "
            "sys.argv = ['mjasc', 'list']; mjasc.cli.command_line()")
    proc = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, cwd=tmp_path,
                          timeout=600)
    assert proc.returncode == 0 and proc.stdout.splitlines()[-1] == str(max(YOUNG_THRESHOLD, before[0]))


def test_dasks_cancel_race_on_ctrl_c_is_not_logged():
    """Ctrl-C landing before Dask's ``sync`` has made its future: its cancel callback raises
    NameError on the loop's thread and tornado logs the traceback (seen once in CI before the
    command's one line). The campaign's client drops exactly that record; other errors are logged."""
    import logging

    from mjasc.campaigns.cluster import _InterruptedSyncFilter, _quiet_interrupted_sync

    def record(exc, msg):
        try:
            raise exc
        except Exception:
            return logging.LogRecord("tornado.application", logging.ERROR, __file__, 1, msg, (), sys.exc_info())

    race = record(NameError("cannot access free variable 'future'"),
                  "Exception in callback functools.partial(<function sync.<locals>.cancel at 0x7f7>)")
    other = record(NameError("x"), "Exception in callback functools.partial(<function other at 0x7f7>)")
    assert not _InterruptedSyncFilter.filter(race)
    assert _InterruptedSyncFilter.filter(other)
    assert _InterruptedSyncFilter.filter(record(ValueError("v"), race.getMessage()))
    _quiet_interrupted_sync()
    _quiet_interrupted_sync()
    log = logging.getLogger("tornado.application")
    assert sum(isinstance(f, _InterruptedSyncFilter) for f in log.filters) == 1
    assert not log.filter(race) and log.filter(other)
