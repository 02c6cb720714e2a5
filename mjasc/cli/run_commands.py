"""The commands about single runs: ``mjasc run``, ``view`` (and the Rerun viewer it opens),
``list``, ``trial``, ``figures`` and ``render`` (a dm_control suite episode)."""

from __future__ import annotations

import json
import os
import shlex
import sys
from pathlib import Path

from mjasc.cli.arguments import not_found_hint, out_dir, suite_tasks
from mjasc.runs.early_interrupts import EXIT_INTERRUPTED


def cmd_run(args) -> int:
    from mjasc.core.resources import resolve_bundled
    from mjasc.runs.outputs import FolderInUse
    from mjasc.runs.runner import RunFailed, Runner
    from mjasc.runs.scenario import ScenarioError, load_scenario

    overrides = {k: v for k, v in (("seed", args.seed), ("duration_s", args.duration)) if v is not None}
    try:  # (the file as if it said --seed/--duration: checked with those values only)
        scenario = load_scenario(args.scenario, **overrides)
    except ScenarioError as exc:
        own = None
        if overrides:
            try:
                load_scenario(args.scenario)
            except ScenarioError as err:
                own = err  # (the file is bad on its own: its own error)
            else:  # (the options' values made it bad: say so)
                flags = " ".join(f"{flag} {value}" for flag, value in (("--seed", args.seed),
                                                                        ("--duration", args.duration))
                                 if value is not None)
                msg = str(exc).removeprefix(f"{resolve_bundled(args.scenario, 'scenario')}: ")
                print(f"mjasc: invalid scenario: {args.scenario} with {flags}: {msg}", file=sys.stderr)
                return 2
        print(f"mjasc: invalid scenario: {own or exc}{not_found_hint(args.scenario, 'scenario')}", file=sys.stderr)
        return 2
    if args.camera is not None:
        try:
            scenario = scenario.with_overrides(video_camera=args.camera)
        except ScenarioError as exc:  # (the message names the field the option sets: name the option)
            print(f"mjasc: --camera: {str(exc).removeprefix('outputs.video_camera: ')}", file=sys.stderr)
            return 2
    if args.video or args.camera:
        scenario = scenario.with_overrides(video=True)
    out = out_dir(args.out, Path("runs") / scenario.name)
    try:
        runner = Runner(scenario, out, None if args.progress else False)
        if args.evaluate:  # (scored against the truth as a campaign's runs are: summary.json's evaluation)
            from mjasc.evaluation.run_evaluation import RunEvaluator

            evaluator = RunEvaluator(runner)
            runner.observe("record", evaluator)
            runner.add_summary("evaluation", evaluator.summary)
        result = runner.run(interruptible=True)
    except RunFailed as exc:
        print(f"mjasc: run failed: {exc}", file=sys.stderr)
        return EXIT_INTERRUPTED if exc.summary and exc.summary.get("status") == "interrupted" else 1
    except FolderInUse as exc:  # (another run writes into --out: as a campaign's folder, refused)
        print(f"mjasc: {exc}", file=sys.stderr)
        return 1
    s = result.summary
    print(f"{scenario.name}: {s['status']} — {s['sim_time_s']} s simulated in {s['wall_time_s']} s "
          f"({s['real_time_factor']}× real time), collisions: {len(s['collisions'])}")
    for name, v in s["vessels"].items():
        xte = "" if v["mean_cross_track_m"] is None else \
            f", cross-track mean {v['mean_cross_track_m']} m / max {v['max_cross_track_m']} m"
        offset = v.get("max_mission_offset_m")
        off = "" if offset is None else f", off the mission path max {offset} m"
        near = "" if v["min_clearance_to_any_m"] is None else f", closest approach {v['min_clearance_to_any_m']} m"
        print(f"  {name} ({v['type']}): {v['distance_m']} m sailed{xte}{off}{near}")
    for kind, path in result.files.items():
        print(f"  {kind}: {path}")
    if "recording" in result.files:
        print(f"  open the recording with: {shlex.join(['mjasc', 'view', str(out)])}  "
              f"(or: {viewer_command(result.files['recording'])})")
    return 0


def viewer_executable() -> str | None:
    """The Rerun viewer installed with this package: the ``rerun`` executable next to the running
    Python (the same virtual environment, whether or not it is on PATH), else the one on PATH."""
    import shutil

    here = Path(sys.executable).parent
    for name in ("rerun", "rerun.exe"):
        if (here / name).is_file():
            return str(here / name)
    return shutil.which("rerun")


def viewer_command(recording: str | Path) -> str:
    """The exact shell command that opens ``recording`` in :func:`viewer_executable`."""
    import shlex

    return shlex.join([viewer_executable() or "rerun", str(recording)])


def cmd_view(args) -> int:
    import subprocess

    target = Path(args.run)
    rrd = target / "recording.rrd" if target.is_dir() else target
    if not rrd.is_file():
        if (target / "campaign.sqlite").is_file():  # a campaign folder: its runs' recordings lie below it
            found = sorted((p.parent for p in target.glob("runs/**/recording.rrd")),  # (run 3 before run 12)
                           key=lambda p: [(0, int(x), "") if x.isdigit() else (1, 0, x) for x in p.parts])
            where = (f"its runs' recordings are in runs/: mjasc view {found[0]}" if found else
                     "it keeps run recordings (runs/<k>/) only with [outputs] recordings = true in the campaign file")
            print(f"mjasc: {args.run}: a campaign folder, not a run; {where}", file=sys.stderr)
            return 2
        print(f"mjasc: {args.run}: no recording here ({'no recording.rrd in the folder' if target.is_dir() else 'no such file'}"
              f"; a run writes one with [outputs] recording = true)", file=sys.stderr)
        return 2
    try:
        with open(rrd, "rb") as f:
            magic = f.read(4)
    except OSError as exc:
        print(f"mjasc: {rrd}: cannot read: {exc.strerror or exc}", file=sys.stderr)
        return 2
    if magic != b"RRF2":  # (every Rerun recording file starts so)
        print(f"mjasc: {rrd}: not a Rerun recording (a run's recording.rrd, or its folder)", file=sys.stderr)
        return 2
    exe = viewer_executable()
    if args.print or exe is None:
        print(viewer_command(rrd))
        if exe is None:
            print("mjasc: the Rerun viewer is not installed here (pip install rerun-sdk)", file=sys.stderr)
            return 1
        return 0
    if not has_display():  # the native viewer would fail with winit's "neither WAYLAND_DISPLAY nor ..." panic
        print(f"mjasc: {rrd}: no display here (DISPLAY and WAYLAND_DISPLAY are unset), so the Rerun viewer cannot "
              f"open; copy the recording to a machine with a display, or see the README's 'Viewing recordings "
              f"headless' ('mjasc view --print' gives the viewer's command)", file=sys.stderr)
        return 1
    return subprocess.call([exe, str(rrd)])


def has_display() -> bool:
    """Whether the native Rerun viewer has a display to open a window on: always on macOS and Windows;
    on Linux and the BSDs an X11 (``DISPLAY``) or Wayland (``WAYLAND_DISPLAY``, ``WAYLAND_SOCKET``) one."""
    if sys.platform in ("darwin", "win32", "cygwin"):
        return True
    return any(os.environ.get(name) for name in ("DISPLAY", "WAYLAND_DISPLAY", "WAYLAND_SOCKET"))


def method_summary(doc: str | None) -> str:
    """A method's one-line description for ``mjasc list``: the first sentence of its docstring's
    first paragraph (its lines joined, not the first line cut mid-sentence), without reST markup
    and without pointers into the source ("(module docstring)")."""
    import re

    paragraph = " ".join((doc or "").strip().split("\n\n", 1)[0].split())
    text = re.sub(r":[a-z]+:`~?([^`]+)`", r"\1", paragraph).replace("``", "")
    text = re.sub(r"\s*\((?:see )?(?:the )?module docstring\)", "", text)
    m = re.search(r"[.;](\s|$)", text)
    return (text[:m.start()] + ".") if m else text


def cmd_list(args) -> int:
    from mjasc.campaigns.spec import CampaignError, load_campaign_spec as load_campaign
    from mjasc.core.resources import bundled_campaigns, bundled_scenarios
    from mjasc.physics.vessels import available_vessels, load_vessel_type
    from mjasc.runs.scenario import ScenarioError, load_scenario

    print("vessels:")
    for name in available_vessels():
        v = load_vessel_type(name)
        print(f"  {name:10s} {v.length_m:.2f} m × {v.beam_m:.2f} m, cruise {v.cruise_speed_m_s} m/s, "
              f"top {v.top_speed_m_s} m/s — {v.description}")
    print("scenarios:")
    for name, path in bundled_scenarios().items():
        try:
            sc = load_scenario(path)
            print(f"  {name:36s} {sc.duration_s:7.0f} s, {len(sc.vessels)} vessel(s) — {sc.description}")
        except ScenarioError as exc:
            print(f"  {name:36s} INVALID: {exc}")
    print("campaigns:")
    for name, path in bundled_campaigns().items():
        short = name.removeprefix("campaigns/")  # what `mjasc campaign` takes
        try:
            c = load_campaign(path)
            print(f"  {short:36s} {c.description}")
        except CampaignError as exc:
            print(f"  {short:36s} INVALID: {exc}")
    from mjasc.plugins.registry import STAGES, available, method_class

    print("methods (select with method = \"NAME\" in the stage's table; docs/plugins.md):")
    for stage in STAGES:
        for name in available(stage):
            try:
                doc = method_summary(method_class(stage, name).__doc__)
            except ValueError as exc:
                doc = f"INVALID: {exc}"
            print(f"  {stage + ' ' + name:36s} {doc}")
    return 0


def cmd_trial(args) -> int:
    from mjasc.physics import trials

    try:
        result = trials.run_trial(args.kind, args.vessel, port=args.port, starboard=args.starboard,
                                  speed_m_s=args.speed)
    except ValueError as exc:
        print(f"mjasc: {exc}", file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(result, sort_keys=True))
    else:
        for k, v in result.items():
            unit = trials.UNITS.get(k, "")
            print(f"{k:24s} {v}{' ' + unit if unit else ''}")
    return 0


def cmd_figures(args) -> int:
    import time

    from mjasc.figures.thesis import make_all_figures

    t0 = time.perf_counter()

    def progress(text: str) -> None:
        print(f"[{time.perf_counter() - t0:5.1f} s] {text}", flush=True)

    paths = make_all_figures(out_dir(args.out, None), formats=tuple(dict.fromkeys(args.format)), progress=progress)
    print(f"{len(paths)} file(s) in {time.perf_counter() - t0:.1f} s")
    return 0


def cmd_render(args) -> int:
    import time

    from mjasc.runs.scenario import camera_problem
    from mjasc.suite import TASKS_BY_DOMAIN
    from mjasc.suite.render import render_episode

    tasks = TASKS_BY_DOMAIN.get(args.domain)
    camera = args.camera  # the suite's own cameras too (docs/suite.md, "Pixel observations"), as render_episode
    kind, _, vessel = camera.partition(":")
    if kind in ("follow", "heading_up") and vessel:
        camera = f"{vessel}/{kind}"
    elif camera != "basin" and camera_problem(camera):
        print(f"mjasc: render --camera: {camera_problem(camera)} (or the suite's basin, follow:<vessel>, "
              f"heading_up:<vessel>)", file=sys.stderr)
        return 2
    if tasks is None or args.task not in tasks:  # checked before the output folder is made
        what = f"domain {args.domain!r}" if tasks is None else f"task {args.task!r} of domain {args.domain!r}"
        print(f"mjasc: render: no {what} (known: {suite_tasks(TASKS_BY_DOMAIN)})", file=sys.stderr)
        return 2
    if (args.policy in ("goal_line", "cas") or args.policy.startswith("cas:")) and \
            not args.task.startswith("collision_avoidance"):
        print(f"mjasc: render --policy {args.policy}: a policy of the collision_avoidance tasks only, not "
              f"{args.domain} {args.task} (its policies: random, baseline)", file=sys.stderr)
        return 2
    task_kwargs = {}
    if getattr(args, "vessel", None) is not None:
        from mjasc.physics.vessels import resolve_vessel_type

        try:  # (relative to the current folder, as trial's --vessel; before the output folder is made)
            task_kwargs["vessel"] = resolve_vessel_type(args.vessel)
        except ValueError as exc:
            print(f"mjasc: render --vessel: {exc}", file=sys.stderr)
            return 2
    existed = Path(args.out).is_dir()
    out = out_dir(args.out, None)
    hull = f", vessel {args.vessel}" if task_kwargs else ""
    print(f"rendering {args.domain} {args.task} ({args.policy} policy, seed {args.seed}{hull}) into {out} ...",
          flush=True)
    t0 = time.perf_counter()
    try:
        result = render_episode(args.domain, args.task, policy=args.policy, out_dir=out, seed=args.seed,
                                task_kwargs=task_kwargs, camera=camera, hud=getattr(args, "hud", True),
                                progress=lambda done, limit: print(f"  {100 * done // limit:3d} % ({done} of {limit} "
                                                                   f"control steps, {time.perf_counter() - t0:.0f} s)",
                                                                   flush=True))
    except ValueError as exc:  # (bad input found in the task: a chase camera on no vessel of it, ...)
        print(f"mjasc: {exc}", file=sys.stderr)
        if not existed and out.is_dir() and not any(out.iterdir()):
            out.rmdir()  # (the folder made for it, left empty: nothing was written)
        return 2
    end = "ended by the task (a collision)" if result.terminated else "ran to its time limit"
    print(f"{args.domain} {args.task}: {result.steps} control steps, return {result.episode_return:.3f} "
          f"(sum of rewards, each in [0, 1]); the episode {end}; {time.perf_counter() - t0:.1f} s")
    for kind, path in (("video", result.video_path), ("recording", result.rerun_path)):
        if path is not None:
            print(f"  {kind}: {path}")
    if result.rerun_path is not None:
        print(f"  open the recording with: {shlex.join(['mjasc', 'view', str(result.rerun_path)])}")
    return 0
