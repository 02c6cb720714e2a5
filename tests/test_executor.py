"""Isolated execution of campaign runs: results, a bad scenario, a time limit, a child that dies."""

import os
import signal
import threading

import pytest

from mjasc.campaigns.executor import IsolatedExecutor, execute_in_process
from mjasc.campaigns.forked import ForkedExecutor

SCENARIO = """
name = "tiny"
duration_s = {duration}
seed = 5
[outputs]
recording = false
[[vessels]]
name = "a"
type = "otter"
position_m = [0.0, 0.0]
speed_m_s = 1.0
controller = {{ type = "path_following", waypoints = [[0.0, 0.0], [400.0, 0.0]], speed_m_s = 1.5 }}
"""


#: A run that cannot end before the tests kill it (2–4 s): a day of simulated time (the format's
#: maximum), hours of wall time. (A 3000-s run once served; the stack got fast enough to finish it.)
SLOW_S = 86400.0


def _req(duration=3.0, k=0):
    return {"index": k, "scenario_toml": SCENARIO.format(duration=duration), "run_dir": None, "evaluate": True}


def test_in_process_and_isolated_give_the_same_result():
    a = execute_in_process(_req())
    ex = IsolatedExecutor()
    try:
        b = ex.run(_req(), time_limit_s=120)
        c = ex.run(_req(k=1), time_limit_s=120)  # the same child serves the next run
    finally:
        ex.close()
    assert a["status"] == b["status"] == "completed"
    for key in ("distance_m", "mean_cross_track_m"):
        assert a["summary"]["vessels"]["a"][key] == b["summary"]["vessels"]["a"][key]
    assert b["worker"] == c["worker"] and "evaluation" in b["summary"]


def test_a_bad_scenario_is_an_error_row_not_an_exception():
    out = execute_in_process({"index": 3, "scenario_toml": "duration_s = -1\n", "run_dir": None})
    assert out["status"] == "error" and "duration_s" in out["error"]


@pytest.mark.parametrize("executor", [IsolatedExecutor, ForkedExecutor], ids=["new_interpreter", "forked"])
def test_a_run_over_its_time_limit_is_killed_and_the_next_run_works(executor):
    ex = executor()
    try:
        slow = ex.run(_req(duration=SLOW_S), time_limit_s=4.0)
        assert slow["status"] == "timeout" and "time limit" in slow["error"]
        assert ex.run(_req(), time_limit_s=120)["status"] == "completed"
    finally:
        ex.close()


def test_a_dying_child_costs_only_its_run():
    ex = IsolatedExecutor()
    try:
        ex.run(_req(), time_limit_s=120)  # the child is up
        pid = ex._proc.pid
        threading.Timer(2.0, lambda: os.kill(pid, signal.SIGKILL)).start()
        dead = ex.run(_req(duration=SLOW_S), time_limit_s=120)
        assert dead["status"] == "crashed" and "signal 9" in dead["error"]
        assert ex.run(_req(), time_limit_s=120)["status"] == "completed"
    finally:
        ex.close()


def test_wait_ready_then_runs_and_a_closed_child_leaves():
    ex = IsolatedExecutor()
    try:
        assert ex.wait_ready(120)  # imports done: the "ready" line is read here, not by the run
        pid = ex._proc.pid
        assert ex.run(_req(), time_limit_s=120)["status"] == "completed"
        assert ex.wait_ready(1) and ex._proc.pid == pid  # no new child
        proc = ex._proc
    finally:
        ex.close()
    assert proc.returncode == 0
    ex = IsolatedExecutor()
    try:  # a run on a child started but not waited for reads the ready line first
        ex.start()
        a, b = ex.run(_req(), time_limit_s=120), ex.run(_req(k=1), time_limit_s=120)
        assert a["status"] == b["status"] == "completed" and a["worker"] == b["worker"]
    finally:
        ex.close()


def test_a_run_without_recording_never_imports_rerun():
    """A campaign's child process imports what runs need; Rerun (with pyarrow and PIL, ~0.4 s of
    its start-up) only loads when a run records."""
    import subprocess
    import sys
    from pathlib import Path

    demo = (Path(__file__).resolve().parent.parent / "tasks" / "demo.toml").read_text()
    code = ("import json, sys\n"
            "import mjasc.campaigns.executor as ex\n"
            "import mjasc.avoidance.system, mjasc.evaluation.run_evaluation, mjasc.runs.runner\n"
            "out = ex.execute_in_process(json.loads(sys.stdin.read()))\n"
            "print(out['status'], 'rerun' in sys.modules, 'pyarrow' in sys.modules)\n")
    request = {"index": 0, "scenario_toml": demo.replace("duration_s = 240.0", "duration_s = 1.0"), "run_dir": None,
               "evaluate": True}
    env = dict(os.environ, MUJOCO_GL="disable", PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    import json

    got = subprocess.run([sys.executable, "-c", code], input=json.dumps(request), capture_output=True, text=True,
                         env=env, timeout=300)
    assert got.stdout.split() == ["completed", "False", "False"], got.stderr[-2000:]


def test_children_started_before_the_campaign_is_read_are_the_ones_that_run_it(tmp_path, monkeypatch, capsys):
    """The ``campaign`` command starts the runs' children before it parses the campaign file
    (prestart_isolated); the engine takes them instead of starting its own, and one left untaken
    (a campaign with nothing to do) is killed at exit, not left behind."""
    import mjasc.campaigns.executor as ex_mod
    from mjasc.campaigns.engine import run_campaign
    from mjasc.campaigns.forked import ForkedExecutor
    from mjasc.campaigns.spec import load_campaign_spec
    from tests.test_campaign import write_campaign

    monkeypatch.setattr(os, "cpu_count", lambda: 2)
    assert ex_mod.prestart_isolated(None) == 1  # two cores: the driver parses on one, a child imports on the other
    (child,) = ex_mod._PRESTARTED
    assert isinstance(child, ForkedExecutor)  # (python -m pytest: forking is safe)
    spec = load_campaign_spec(write_campaign(tmp_path, runs=2, duration=2.0))
    res = run_campaign(spec, tmp_path / "out", workers=1, progress=False)
    assert not ex_mod._PRESTARTED and [r.status for r in res.runs] == ["completed", "completed"]
    assert {r.worker for r in res.runs} == {f"{os.uname().nodename}:{child.pid}"}  # both runs in the pre-started child
    assert child._process is None  # the campaign closed it
    assert ex_mod.prestart_isolated(3) == 1  # never more than the idle cores
    taken = ex_mod.take_prestarted(5)
    assert len(taken) == 1 and isinstance(taken[0], ForkedExecutor) and not ex_mod._PRESTARTED
    taken[0].close()
    ex_mod.prestart_isolated(1)
    spare = ex_mod._PRESTARTED[0]
    assert spare.wait_ready(120)
    pid = spare.pid
    ex_mod.close_prestarted()  # (what exit does)
    assert spare._process is None and not ex_mod._PRESTARTED
    assert not _alive(pid)


def test_an_invalid_campaign_leaves_no_prestarted_child(tmp_path, monkeypatch, capsys):
    """The ``campaign`` command started a child before reading its file; the file is invalid, so
    no campaign takes the child: the command kills it before it returns (a process that calls the
    command, a test or a notebook, is not left with a child until it exits)."""
    import mjasc.campaigns.executor as ex_mod
    from mjasc.cli import main

    monkeypatch.setattr(os, "cpu_count", lambda: 2)
    started = []
    prestart = ex_mod.prestart_isolated

    def recording(workers):
        n = prestart(workers)
        for child in ex_mod._PRESTARTED:
            assert child.wait_ready(120)
            started.append((child, child.pid))
        return n

    monkeypatch.setattr(ex_mod, "prestart_isolated", recording)
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "bad"\nscenario = "nowhere.toml"\nruns = 2\n')
    assert main(["campaign", str(bad), "--workers", "1", "--out", str(tmp_path / "out")]) == 2
    assert "invalid campaign" in capsys.readouterr().err
    assert len(started) == 1 and not ex_mod._PRESTARTED  # one started, none left
    (child, pid), = started
    assert child._process is None and not _alive(pid)


def _alive(pid: int) -> bool:
    """Whether process ``pid`` still exists (a killed fork is reaped by its server within moments)."""
    import time

    for _ in range(50):
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return False
        time.sleep(0.1)
    return True


def test_a_warmed_up_child_gives_the_same_results():
    """A pre-started child warms numba's kernels with a second of the demo while it waits for its
    first run (``--warm``); nothing of that run stays: the demo's runs are the same as a cold
    child's, bit for bit (timing fields aside)."""
    from pathlib import Path

    from mjasc.campaigns.engine import without_timing

    demo = (Path(__file__).resolve().parent.parent / "tasks" / "demo.toml").read_text()
    text = "\n".join("duration_s = 6.0" if ln.startswith("duration_s") else ln for ln in demo.splitlines())
    req = {"index": 0, "scenario_toml": text, "run_dir": None, "evaluate": True}
    out = []
    for warm in (False, True):
        ex = IsolatedExecutor(warm=warm)
        try:
            assert ex.wait_ready(120)
            out.append(ex.run(req, time_limit_s=120))
        finally:
            ex.close()
    assert out[0]["status"] == out[1]["status"] == "completed"
    assert without_timing(out[0]["summary"]) == without_timing(out[1]["summary"])


def test_a_released_worker_starts_no_new_child(monkeypatch):
    """A task that reaches a worker after its shutdown released its child (an interrupted campaign)
    fails at once: no new run child is started for it."""
    import mjasc.campaigns.executor as ex_mod

    made = []
    monkeypatch.setattr(ex_mod, "IsolatedExecutor", lambda: made.append(1))
    ex_mod.release_isolated("worker-test-released")
    with pytest.raises(RuntimeError, match="shutting down"):
        ex_mod.run_isolated({}, None, key="worker-test-released")
    assert not made
