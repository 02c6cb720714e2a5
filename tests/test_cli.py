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


def test_list_describes_each_method_in_one_whole_sentence(tmp_path, monkeypatch, capsys):
    """Each method's line is a whole sentence without reST markup (it was the docstring's first
    line, cut mid-sentence: "… registered as the", "… manoeuvre detector, static")."""
    monkeypatch.chdir(tmp_path)
    assert main(["list"]) == 0
    out = capsys.readouterr().out.split("methods (", 1)[1].splitlines()[1:]
    assert len(out) >= 6
    for line in out:
        assert line.rstrip().endswith(".") and "``" not in line and ":class:" not in line, line
        assert "module docstring" not in line, line


def test_the_overview_names_every_option_of_every_command(capsys):
    """``mjasc --help``'s one line per command lists all of that command's options (campaign's
    --max-attempts/--time-limit and five of search's were missing)."""
    import argparse

    from mjasc.cli import build_parser

    parser = build_parser()
    with pytest.raises(SystemExit):
        main(["--help"])
    overview = capsys.readouterr().out
    commands = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices
    missing = []
    for name, sub in commands.items():
        line = next(ln for ln in overview.splitlines() if ln.split()[:2] == ["mjasc", name])
        missing += [f"{name} {opt}" for action in sub._actions for opt in action.option_strings[-1:]
                    if opt.startswith("--") and opt != "--help" and opt not in line]
    assert missing == []


def test_help_says_a_scenario_is_a_path_or_a_bundled_name(capsys):
    for argv in (["run", "--help"], ["campaign", "--help"]):
        with pytest.raises(SystemExit):
            main(argv)
        text = " ".join(capsys.readouterr().out.split())
        assert "bundled" in text and "relative to the current folder" in text


_IMPOSSIBLE = """name = "impossible"
base_seed = 5
[[families]]
kind = "head_on"
runs_per_point = 1
duration_s = 10.0
[families.parameters]
dcpa_m = { grid = [0.0, 90.0] }
"""


def test_a_campaign_point_no_draw_can_make_is_bad_input_naming_the_file(tmp_path, capsys):
    """A head-on family asked for a 90 m passing distance (a crossing, not a head-on encounter) is
    found when the runs are drawn, before any runs: bad input (status 2), one line naming the file
    and the family, nothing stored."""
    bad = tmp_path / "impossible.toml"
    bad.write_text(_IMPOSSIBLE)
    out = tmp_path / "out"
    assert main(["campaign", str(bad), "--workers", "0", "--out", str(out), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"mjasc: invalid campaign: {bad}: families[0] (head_on) run 1:") and err.count("\n") == 1
    assert not out.exists()  # (the runs are drawn before anything is written; the folder it made is gone)


def test_a_search_of_an_unknown_family_is_bad_input(tmp_path, capsys):
    good = tmp_path / "c.toml"
    good.write_text(_IMPOSSIBLE.replace("grid = [0.0, 90.0]", "uniform = [-4.0, 4.0]"))
    assert main(["search", str(good), "nofam", "--budget", "4", "--workers", "0", "--out", str(tmp_path / "s")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"mjasc: invalid search: {good}: family: no encounter family 'nofam'")
    assert err.count("\n") == 1
    assert not (tmp_path / "s").exists()  # (bad input: no output folder; it was left behind, empty)


def test_a_search_of_a_family_without_laws_makes_no_default_folder(tmp_path, monkeypatch, capsys):
    """mjasc search demo_monte_carlo perturbation: bad input before runs/search/<...> is made."""
    monkeypatch.chdir(tmp_path)
    assert main(["search", "demo_monte_carlo", "perturbation", "--budget", "2", "--workers", "0"]) == 2
    assert "which has no parameter laws to search" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_run_evaluate_writes_the_evaluation_into_the_summary(tmp_path):
    """``mjasc run --evaluate``: the run scored against the truth as a campaign's runs are (summary.json's
    evaluation: tracking GOSPA and position RMSE per vessel with a tracker), absent without the option."""
    import json

    assert main(["run", "thesis_6_1_tracking", "--duration", "20", "--evaluate", "--out", str(tmp_path / "e"),
                 "--no-progress"]) == 0
    ev = json.loads((tmp_path / "e" / "summary.json").read_text())["evaluation"]
    track = ev["tracking"]["asc"]
    assert track["evaluations"] > 150 and 0.0 < track["position_rmse_m"] < 0.3 and track["id_switches"] == 0
    assert main(["run", "thesis_6_1_tracking", "--duration", "5", "--out", str(tmp_path / "p"), "--no-progress"]) == 0
    assert "evaluation" not in json.loads((tmp_path / "p" / "summary.json").read_text())
