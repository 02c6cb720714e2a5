"""A run's folder under stress: one run at a time into it, nothing of a killed or interrupted run
left looking like a completed one, a second interrupt while it closes costs no summary, a full
disk is one line and a summary, an empty --out is refused, interrupts during the set-up are one
line (README: exit codes and signals)."""

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from mjasc.cli import main
from mjasc.runs.outputs import FolderInUse, lock_folder, unlock_folder
from mjasc.runs.runner import Runner
from mjasc.runs.scenario import load_scenario

ROOT = Path(__file__).resolve().parent.parent


def _scenario(seconds=1.0):
    return load_scenario("demo", duration_s=seconds)


def test_an_empty_out_is_refused_in_one_line(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["run", "demo", "--out", ""]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--out: an empty name" in err and not list(tmp_path.iterdir())


def test_a_second_run_into_a_folder_in_use_is_refused(tmp_path, capsys):
    out = tmp_path / "run"
    out.mkdir()
    held = lock_folder(out, "run")  # (as another process's run would hold it)
    try:
        assert main(["run", "demo", "--duration", "0.5", "--out", str(out), "--no-progress"]) == 1
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "another run is writing into this folder" in err
        with pytest.raises(FolderInUse):
            Runner(_scenario(), out, False).run()
    finally:
        unlock_folder(held)
    assert not list(out.iterdir())


def test_a_run_clears_stale_temporary_files_and_the_earlier_run_first(tmp_path, capsys):
    out = tmp_path / "sp ace"
    out.mkdir()
    for name in (".video.part.mp4", ".recording.part.rrd", ".summary.part.json", ".recording.part.rrd.canonical"):
        (out / name).write_bytes(b"stale")
    (out / "summary.json").write_text('{"status": "completed"}')
    (out / "video.mp4").write_bytes(b"an earlier run's")
    assert main(["run", "demo", "--duration", "0.5", "--out", str(out), "--no-progress"]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["recording.rrd", "summary.json"]
    assert f"mjasc view '{out}'" in capsys.readouterr().out  # (shell-quoted, as the rerun hint)


def test_an_interrupt_while_the_outputs_open_leaves_no_temporary_file_nor_the_earlier_summary(tmp_path, monkeypatch):
    out = tmp_path / "run"
    out.mkdir()
    (out / "summary.json").write_text('{"status": "completed"}')
    opened = Runner._open_outputs

    def interrupted(self, files):
        opened(self, files)
        raise KeyboardInterrupt

    monkeypatch.setattr(Runner, "_open_outputs", interrupted)
    with pytest.raises(KeyboardInterrupt):
        Runner(_scenario(), out, False).run(interruptible=True)
    assert not list(out.iterdir())  # (not the earlier run's summary beside a run that never ran)


def test_a_second_interrupt_while_the_run_closes_waits_for_its_summary(tmp_path, monkeypatch):
    from mjasc.runs.recording import Recorder

    out = tmp_path / "run"
    close = Recorder.close

    def pressed_while_closing(self):
        os.kill(os.getpid(), signal.SIGINT)  # (Ctrl-C while the recording is written)
        os.kill(os.getpid(), signal.SIGTERM)
        close(self)

    monkeypatch.setattr(Recorder, "close", pressed_while_closing)
    with pytest.raises(KeyboardInterrupt):  # (the command stops as asked, once its outputs are whole)
        Runner(_scenario(), out, False).run(interruptible=True)
    assert json.loads((out / "summary.json").read_text())["status"] == "completed"
    assert (out / "recording.rrd").exists() and not list(out.glob(".*part*"))


def test_a_full_disk_is_one_line_and_a_summary_saying_error(tmp_path, monkeypatch, capsys):
    import mjasc.runs.recording as recording

    monkeypatch.setattr(recording, "no_room", lambda folder: True)
    out = tmp_path / "run"
    assert main(["run", "demo", "--duration", "0.5", "--out", str(out), "--no-progress"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "recording.rrd: no space left on device" in err, err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "error" and "no space left on device" in summary["error"]
    assert sorted(p.name for p in out.iterdir()) == ["summary.json"]


def test_an_interrupt_before_the_command_runs_is_one_line(capsys, monkeypatch):
    import mjasc.cli as cli

    def interrupted(argv=None):
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "build_parser", interrupted)
    assert cli.main(["list"]) == 130
    assert capsys.readouterr().err == "mjasc: interrupted\n"


_TERM_IN_SETUP = """
import os, signal, sys, runpy
from mjasc.runs.runner import Runner
def built(self, *a, **k):
    os.kill(os.getpid(), signal.SIGTERM)  # (a batch system's stop while the world is built)
Runner.__init__ = built
sys.argv[0] = "mjasc"
runpy.run_module("mjasc", run_name="__main__", alter_sys=True)
"""


def test_sigterm_during_the_set_up_is_an_interrupt(tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run([sys.executable, "-c", _TERM_IN_SETUP, "run", "demo", "--out", str(tmp_path / "r"),
                           "--no-progress"], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert (proc.returncode, proc.stderr) == (130, "mjasc: interrupted\n")

