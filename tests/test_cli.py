"""The command line from any folder: bundled names, paths relative to the current folder, default
output folders under the current folder, and a helpful error for an unknown name."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from mjasc.cli import main
from mjasc.core.resources import bundled_scenarios

ROOT = Path(__file__).resolve().parent.parent


def test_run_a_bundled_scenario_by_name_into_the_default_folder(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["run", "demo", "--duration", "1", "--no-progress"]) == 0
    summary = json.loads((tmp_path / "runs" / "demo" / "summary.json").read_text())
    assert summary["status"] == "completed" and summary["sim_time_s"] == pytest.approx(1.0)
    assert "runs/demo/summary.json" in capsys.readouterr().out


def test_paths_on_the_command_line_are_relative_to_the_current_folder(tmp_path, monkeypatch):
    (tmp_path / "mine").mkdir()
    shutil.copy(bundled_scenarios()["thesis_6_1_static"], tmp_path / "mine" / "static.toml")
    monkeypatch.chdir(tmp_path)
    assert main(["run", "mine/static.toml", "--duration", "1", "--out", "out/static", "--no-progress"]) == 0
    assert json.loads((tmp_path / "out" / "static" / "summary.json").read_text())["status"] == "completed"


def test_a_file_in_the_current_folder_wins_over_a_bundled_name(tmp_path, monkeypatch):
    text = bundled_scenarios()["thesis_6_1_static"].read_text()
    (tmp_path / "demo").write_text(text)  # a file named like a bundled scenario
    monkeypatch.chdir(tmp_path)
    assert main(["run", "demo", "--duration", "0.5", "--out", "o", "--no-progress"]) == 0
    assert json.loads((tmp_path / "o" / "summary.json").read_text())["scenario"] == "thesis_6_1_static"


@pytest.mark.parametrize("command", ["run", "campaign"])
def test_an_unknown_name_says_where_to_look(command, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main([command, "no_such_thing"]) == 2
    err = capsys.readouterr().err
    assert "no_such_thing" in err and "mjasc list" in err and str(tmp_path) in err


def test_list_shows_bundled_scenarios_and_campaigns(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    for name in bundled_scenarios():
        assert f"  {name} " in out
    assert "  demo_monte_carlo " in out and "INVALID" not in out


def test_help_says_a_scenario_is_a_path_or_a_bundled_name(capsys):
    for argv in (["run", "--help"], ["campaign", "--help"]):
        with pytest.raises(SystemExit):
            main(argv)
        text = " ".join(capsys.readouterr().out.split())
        assert "bundled" in text and "relative to the current folder" in text
