"""What the command line shows a user: plain help, the viewer's exact path, units, progress,
figure formats, and no output folder for a bad render request."""

from __future__ import annotations

import os
import shlex
import sys
from pathlib import Path

import pytest

from mjasc.cli import build_parser, main, viewer_executable

SUBCOMMANDS = ("run", "list", "trial", "figures", "view", "campaign", "report", "extract", "search", "render")


@pytest.mark.parametrize("argv", [["--help"], *[[c, "--help"] for c in SUBCOMMANDS]])
def test_help_has_no_restructuredtext_markup(argv, capsys):
    with pytest.raises(SystemExit):
        main(argv)
    text = capsys.readouterr().out
    assert text.strip()
    for markup in ("``", ":func:", ":class:", ":mod:", ":data:", ":meth:", "`mjasc"):
        assert markup not in text, markup


def test_render_help_lists_every_domain_and_task(capsys):
    from mjasc.suite import TASKS_BY_DOMAIN

    with pytest.raises(SystemExit):
        main(["render", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for domain, tasks in TASKS_BY_DOMAIN.items():
        assert f"{domain}: {', '.join(tasks)}" in text


def test_view_uses_the_viewer_installed_next_to_this_python(tmp_path, capsys):
    (tmp_path / "recording.rrd").write_bytes(b"RRF2")  # (a Rerun file's magic: view checks it)
    assert main(["view", str(tmp_path), "--print"]) == 0
    exe = viewer_executable()
    assert exe is not None and Path(exe).parent == Path(sys.executable).parent  # the venv's, not PATH's
    assert capsys.readouterr().out.strip() == shlex.join([exe, str(tmp_path / "recording.rrd")])


def test_view_without_a_display_says_so_in_one_line_and_starts_no_viewer(tmp_path, capsys, monkeypatch):
    """On a headless Linux machine the native viewer panics (winit: "neither WAYLAND_DISPLAY nor
    WAYLAND_SOCKET nor DISPLAY is set") after its telemetry lines; mjasc says why before starting it."""
    import subprocess

    (tmp_path / "recording.rrd").write_bytes(b"RRF2")
    monkeypatch.setattr(sys, "platform", "linux")
    for name in ("DISPLAY", "WAYLAND_DISPLAY", "WAYLAND_SOCKET"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setattr(subprocess, "call", lambda *a, **k: pytest.fail("the viewer was started"))
    assert main(["view", str(tmp_path)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no display here" in err and "Viewing recordings headless" in err
    assert main(["view", str(tmp_path), "--print"]) == 0  # (the command itself is still given)
    started = []
    monkeypatch.setattr(subprocess, "call", lambda argv, **k: started.append(argv) or 0)
    monkeypatch.setenv("DISPLAY", ":99")
    assert main(["view", str(tmp_path)]) == 0 and started[0][-1] == str(tmp_path / "recording.rrd")


def test_view_of_a_file_that_is_not_a_recording_is_bad_input(tmp_path, capsys):
    (tmp_path / "demo.toml").write_text('name = "demo"\n')
    assert main(["view", str(tmp_path / "demo.toml"), "--print"]) == 2
    err = capsys.readouterr().err
    assert err == f"mjasc: {tmp_path / 'demo.toml'}: not a Rerun recording (a run's recording.rrd, or its folder)\n"


def test_usage_errors_and_bad_option_values_are_one_line_naming_the_option(tmp_path, capsys):
    """argparse's own errors (an unknown option, a value of the wrong type) and the numeric options'
    bounds are one line naming the option, status 2, before any folder is made."""
    cases = [(["run", "demo", "--bogus"], "unrecognized arguments: --bogus"),
             (["run", "demo", "--seed", "abc"], "argument --seed: must be an integer, got 'abc'"),
             (["run", "demo", "--seed", "-3"], "argument --seed: must be ≥ 0, got -3"),
             (["run", "demo", "--duration", "nan"], "argument --duration: must be a finite number > 0, got nan"),
             (["campaign", "demo_monte_carlo", "--workers", "-1", "--out", str(tmp_path / "c")],
              "argument --workers: must be ≥ 0, got -1"),
             (["campaign", "demo_monte_carlo", "--max-attempts", "0", "--out", str(tmp_path / "c")],
              "argument --max-attempts: must be ≥ 1, got 0"),
             (["campaign", "demo_monte_carlo", "--time-limit", "0", "--out", str(tmp_path / "c")],
              "argument --time-limit: must be a finite number > 0, got 0"),
             (["search", "demo_monte_carlo", "head_on", "--workers", "-2", "--out", str(tmp_path / "s")],
              "argument --workers: must be ≥ 0, got -2"),
             (["render", "otter", "path_following", "--seed", "-1", "--out", str(tmp_path / "r")],
              "argument --seed: must be ≥ 0, got -1"),
             (["campaign", "demo_monte_carlo", "--scheduler", "bogus", "--out", str(tmp_path / "c")],
              "argument --scheduler: must be 'synchronous', 'local' or a scheduler address with its port")]
    for argv, message in cases:
        with pytest.raises(SystemExit) as stop:
            main(argv)
        assert stop.value.code == 2, argv
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and message in err, (argv, err)
    assert not any(tmp_path.iterdir())  # (no output folder made)
    for command in ("campaign", "search"):  # (an existing cluster has its own workers: 0 would ignore it)
        argv = [command, "demo_monte_carlo", *(["head_on"] if command == "search" else []), "--scheduler",
                "tcp://127.0.0.1:8786", "--workers", "0", "--out", str(tmp_path / "c")]
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert err.startswith("mjasc: --workers 0: only for a local cluster") and err.count("\n") == 1
    # the synchronous scheduler runs in this process: --workers 2 was ignored silently (workers 0 recorded)
    assert main(["campaign", "demo_monte_carlo", "--scheduler", "synchronous", "--workers", "2", "--out",
                 str(tmp_path / "c")]) == 2
    err = capsys.readouterr().err
    assert err == ("mjasc: --workers 2: only for a local cluster; the synchronous scheduler runs every run in this "
                   "process\n"), err
    assert not any(tmp_path.iterdir())


def test_a_closed_pipe_is_not_an_error(monkeypatch, capsys):
    """``mjasc list | head -1``: the reader leaves; the command stops quietly with SIGPIPE's status
    (141: no traceback, no 'internal error'), as a Unix tool does — also when what it wrote was
    still buffered (written at the command's end)."""
    import io

    r, w = os.pipe()
    os.close(r)  # (the reader has left: a write raises BrokenPipeError)
    out = io.TextIOWrapper(os.fdopen(w, "wb"), encoding="utf-8")
    monkeypatch.setattr(sys, "stdout", out)
    assert main(["list"]) == 141
    assert capsys.readouterr().err == ""
    out.write("more\n")
    out.flush()  # (stdout now goes nowhere: the interpreter's last flush raises nothing)


def test_view_without_a_recording_is_bad_input(tmp_path, capsys):
    assert main(["view", str(tmp_path), "--print"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no recording.rrd" in err


def test_view_of_a_campaign_folder_points_at_its_runs_recordings(tmp_path, capsys):
    # It said "no recording.rrd in the folder; a run writes one with [outputs] recording = true",
    # though the campaign kept every run's recording under runs/<k>/ ([outputs] recordings = true).
    (tmp_path / "campaign.sqlite").write_bytes(b"")
    assert main(["view", str(tmp_path), "--print"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "a campaign folder" in err and "recordings = true" in err
    for k in (3, 12):
        (tmp_path / "runs" / str(k)).mkdir(parents=True)
        (tmp_path / "runs" / str(k) / "recording.rrd").write_bytes(b"RRF2")
    assert main(["view", str(tmp_path), "--print"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"mjasc view {tmp_path / 'runs' / '3'}" in err


@pytest.mark.parametrize("domain, task", [("nope", "path_following"), ("otter", "nope")])
def test_render_with_an_unknown_domain_or_task_creates_nothing(domain, task, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["render", domain, task]) == 2
    assert list(tmp_path.iterdir()) == []
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "otter: path_following" in err


@pytest.mark.parametrize("argv, field", [(["render", "otter", "path_following", "--camera", "sideways"],
                                          "render --camera"),
                                         (["run", "demo", "--camera", "split:zulu"], "--camera: no vessel named")])
def test_a_bad_camera_is_one_line_naming_the_field_and_creates_nothing(argv, field, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    assert list(tmp_path.iterdir()) == []
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and field in err


def test_trial_prints_units(capsys):
    assert main(["trial", "speed", "--vessel", "otter"]) == 0
    rows = dict(line.split(None, 1) for line in capsys.readouterr().out.splitlines())
    assert rows["steady_speed"].endswith(" m/s") and rows["t63"].endswith(" s")
    assert rows["steady_yaw_rate"].endswith(" rad/s") and rows["timestep_s"].endswith(" s")


def test_figures_prints_progress_and_writes_every_format(tmp_path, monkeypatch, capsys):
    """The figure makers are replaced by one quick figure each: what is checked is the command's
    progress and formats, not the figures (tests/test_figures.py)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    import mjasc.figures.avoidance as avoidance
    import mjasc.figures.missions as missions
    import mjasc.figures.potential_field as potential_field
    import mjasc.figures.tracking as tracking
    from mjasc.figures.thesis import save_figure

    def fake(stem):
        def make(out_dir, formats=("png",)):
            Path(out_dir).mkdir(parents=True, exist_ok=True)
            fig = plt.figure()
            try:
                return save_figure(fig, Path(out_dir) / f"{stem}.png", formats)
            finally:
                plt.close(fig)
        return make

    monkeypatch.setattr(tracking, "make_tracking_figures", fake("t"))
    monkeypatch.setattr(potential_field, "make_figures", fake("p"))
    monkeypatch.setattr(avoidance, "make_avoidance_figures", fake("a"))
    monkeypatch.setattr(missions, "make_mission_figures", fake("m"))
    assert main(["figures", "--out", str(tmp_path), "--format", "png", "svg", "pdf"]) == 0
    out = capsys.readouterr().out
    assert out.count(" ...") == 4 and out.count("wrote") == 12 and "12 file(s)" in out
    magic = {".png": b"\x89PNG", ".svg": b"<?xml", ".pdf": b"%PDF"}
    files = sorted(tmp_path.rglob("*.*"))
    assert len(files) == 12
    for f in files:
        assert f.read_bytes().startswith(magic[f.suffix]), f


def test_figure_formats_are_checked():
    from mjasc.figures.thesis import save_figure

    with pytest.raises(ValueError, match="formats: must be some of png, svg, pdf, got jpg"):
        save_figure(None, "x.png", ("jpg",))
    with pytest.raises(SystemExit):
        build_parser(["figures"]).parse_args(["figures", "--format", "jpg"])


def test_an_option_s_bad_value_names_the_option_not_the_file_field(tmp_path, capsys):
    assert main(["run", "demo", "--camera", "bogus", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("mjasc: --camera: must be top_down") and err.count("\n") == 1
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("domain, task, policy", [("otter_team", "formation", "cas"),
                                                 ("otter", "path_following", "goal_line"),
                                                 ("delfim", "station_keeping_hard", "cas:velocity_obstacle")])
def test_render_with_a_collision_avoidance_policy_on_another_task_is_bad_input_before_anything(
        domain, task, policy, tmp_path, monkeypatch, capsys):
    """The CAS and goal-line policies steer to collision_avoidance's goal: on another task the command
    says so naming the option and the task (it printed "rendering ..." first and then named the task's
    class, "not Formation")."""
    monkeypatch.chdir(tmp_path)
    assert main(["render", domain, task, "--policy", policy]) == 2
    out, err = capsys.readouterr()
    assert out == "" and list(tmp_path.iterdir()) == []
    assert err == (f"mjasc: render --policy {policy}: a policy of the collision_avoidance tasks only, not "
                   f"{domain} {task} (its policies: random, baseline)\n")


def test_render_with_a_chase_camera_on_no_vessel_leaves_no_folder(tmp_path, capsys):
    out = tmp_path / "r"
    assert main(["render", "otter", "path_following", "--camera", "chase:nobody", "--out", str(out)]) == 2
    assert "no camera 'nobody/chase'" in capsys.readouterr().err and not out.exists()


def test_screenshot_script_without_chromium_says_what_to_install_in_one_line(tmp_path):
    """The README's first headless route (scripts/screenshot_recording.py) on a machine without
    Chromium: one line naming what to install, status 2, nothing started (it was a traceback)."""
    import subprocess

    (tmp_path / "recording.rrd").write_bytes(b"RRF2")
    script = Path(__file__).resolve().parent.parent / "scripts" / "screenshot_recording.py"
    done = subprocess.run([sys.executable, str(script), str(tmp_path), str(tmp_path / "v.png"),
                           "--chromium", str(tmp_path / "no-chromium")], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2 and done.stdout == ""
    assert done.stderr == (f"screenshot_recording: Chromium not found ({str(tmp_path / 'no-chromium')!r}): "
                           f"apt-get install chromium, or --chromium PATH\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["recording.rrd"]


@pytest.mark.parametrize("argv, suggestion", [(["run", "imazu_05"], "did you mean 'imazu/imazu_05'?"),
                                              (["run", "thesis_6_2_dok.toml"], "did you mean 'thesis_6_2_dock'?"),
                                              (["campaign", "encounter"], "did you mean 'encounters'?"),
                                              (["search", "encounter", "head_on"], "did you mean 'encounters'?")])
def test_a_bundled_name_without_its_folder_or_misspelt_gets_a_suggestion(argv, suggestion, tmp_path, monkeypatch,
                                                                         capsys):
    """'mjasc list' shows imazu/imazu_05; 'mjasc run imazu_05' said only that no such file exists."""
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.rstrip().endswith(f"{suggestion})")
    assert list(tmp_path.iterdir()) == []


def test_no_suggestion_for_a_name_like_no_bundled_one(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["run", "harbour_crossing"]) == 2
    assert "did you mean" not in capsys.readouterr().err


def test_a_campaign_with_failed_runs_says_how_to_retry_them(tmp_path, capsys):
    """Runs that time out are tried ``--max-attempts`` times in all: the same command run again did
    nothing and said only "0 run(s) done now, 2 already in the store" (a reviewer's find); both
    commands now say how to retry them."""
    spec = tmp_path / "slow.toml"
    spec.write_text('name = "slow"\nbase_seed = 0\n[[families]]\nkind = "head_on"\nruns_per_point = 2\n')
    argv = ["campaign", str(spec), "--workers", "1", "--no-progress", "--out", str(tmp_path / "out"),
            "--time-limit", "0.2", "--max-attempts", "1"]
    for again in (False, True):
        assert main(argv) == 0
        out = capsys.readouterr().out
        assert ("0 run(s) done now, 2 already in the store" in out) is again
        assert "note: 2 run(s) failed (an error or a time limit) and are retried up to --max-attempts times in all " \
               "(1 now): run the command again with a larger --max-attempts" in out
