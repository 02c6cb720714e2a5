"""The ``mjasc`` command line.

    mjasc run SCENARIO [--out DIR] [--video] [--camera CAM] [--seed N] [--duration S] [--no-progress]
    mjasc list
    mjasc campaign CAMPAIGN [--out DIR] [--workers N] [--scheduler ADDR] [--runs N] [--no-progress]
    mjasc report FOLDER [--json] [--out DIR] [--format png svg pdf]
    mjasc extract FOLDER [RUN ...] [--outcome collision|near_miss|failed] [--out DIR]
    mjasc search CAMPAIGN FAMILY [--method cross_entropy|uniform] [--budget N] [--out DIR]
    mjasc trial speed|turning-circle|zigzag|stopping --vessel NAME [--port F] [--starboard F] [--json]
    mjasc view RUN_DIR|RECORDING [--print]
    mjasc figures [--out DIR] [--format png svg pdf]
    mjasc render DOMAIN TASK [--policy random|baseline|goal_line|cas|cas:METHOD] [--seed N] [--camera CAM] [--out DIR]   (dm_control suite)

SCENARIO and CAMPAIGN are a TOML file's path or the name of a bundled one (``mjasc run demo``,
``mjasc campaign demo_monte_carlo``; ``mjasc list`` shows them), so every command works from any
folder. Paths on the command line, and the default output folders (``runs/<scenario name>``,
``runs/campaigns/<campaign name>``), are relative to the current folder.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import mjasc  # noqa: F401  (chooses the OpenGL backend before mujoco is imported)

NAMED_HELP = "'mjasc list' shows the bundled names"


def _not_found_hint(ref: str, kind: str) -> str:
    """A hint when ``ref`` is neither a file here nor a bundled name, else ''."""
    from mjasc.core.resources import resolve_bundled

    if resolve_bundled(ref, kind) == Path(ref) and not Path(ref).exists():
        return f" (neither a file relative to {Path.cwd()} nor a bundled {kind}: {NAMED_HELP})"
    return ""


def _cmd_run(args) -> int:
    from mjasc.runs.runner import RunFailed, run_scenario
    from mjasc.runs.scenario import ScenarioError, load_scenario

    try:
        scenario = load_scenario(args.scenario).with_overrides(
            seed=args.seed, video=True if args.video or args.camera else None, duration_s=args.duration,
            video_camera=args.camera)
    except ScenarioError as exc:
        print(f"mjasc: invalid scenario: {exc}{_not_found_hint(args.scenario, 'scenario')}", file=sys.stderr)
        return 2
    out = _out_dir(args.out, Path("runs") / scenario.name)
    try:
        result = run_scenario(scenario, out, progress=None if args.progress else False, interruptible=True)
    except RunFailed as exc:
        print(f"mjasc: run failed: {exc}", file=sys.stderr)
        return 130 if exc.summary and exc.summary.get("status") == "interrupted" else 1
    s = result.summary
    print(f"{scenario.name}: {s['status']} — {s['sim_time_s']} s simulated in {s['wall_time_s']} s "
          f"({s['real_time_factor']}× real time), collisions: {len(s['collisions'])}")
    for name, v in s["vessels"].items():
        xte = "" if v["mean_cross_track_m"] is None else \
            f", cross-track mean {v['mean_cross_track_m']} m / max {v['max_cross_track_m']} m"
        print(f"  {name} ({v['type']}): {v['distance_m']} m sailed{xte}, "
              f"closest approach {v['min_clearance_to_any_m']} m")
    for kind, path in result.files.items():
        print(f"  {kind}: {path}")
    if "recording" in result.files:
        print(f"  open the recording with: mjasc view {out}  (or: {viewer_command(result.files['recording'])})")
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


def _cmd_view(args) -> int:
    import subprocess

    target = Path(args.run)
    rrd = target / "recording.rrd" if target.is_dir() else target
    if not rrd.is_file():
        print(f"mjasc: {args.run}: no recording here ({'no recording.rrd in the folder' if target.is_dir() else 'no such file'}"
              f"; a run writes one with [outputs] recording = true)", file=sys.stderr)
        return 2
    exe = viewer_executable()
    if args.print or exe is None:
        print(viewer_command(rrd))
        if exe is None:
            print("mjasc: the Rerun viewer is not installed here (pip install rerun-sdk)", file=sys.stderr)
            return 1
        return 0
    return subprocess.call([exe, str(rrd)])


def _policy_arg(text: str) -> str:
    """A render policy name (checked here so a typo is an argparse error, not a traceback)."""
    if text in ("random", "baseline", "goal_line", "cas"):
        return text
    if text.startswith("cas:"):
        from mjasc.plugins.registry import available

        if text[4:] in available("avoidance"):
            return text
        raise argparse.ArgumentTypeError(f"unknown avoidance method {text[4:]!r} (available: "
                                         f"{', '.join(available('avoidance'))})")
    raise argparse.ArgumentTypeError(f"must be random, baseline, goal_line, cas or cas:METHOD, got {text!r}")


def _cmd_list(args) -> int:
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
                doc = (method_class(stage, name).__doc__ or "").strip().splitlines()[0]
            except ValueError as exc:
                doc = f"INVALID: {exc}"
            print(f"  {stage + ' ' + name:36s} {doc}")
    return 0


def _cmd_trial(args) -> int:
    from mjasc.physics import trials

    try:
        result = trials.run_trial(args.kind, args.vessel, port=args.port, starboard=args.starboard)
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


def _cmd_figures(args) -> int:
    import time

    from mjasc.figures.thesis import make_all_figures

    t0 = time.perf_counter()

    def progress(text: str) -> None:
        print(f"[{time.perf_counter() - t0:5.1f} s] {text}", flush=True)

    paths = make_all_figures(_out_dir(args.out, None), formats=tuple(dict.fromkeys(args.format)), progress=progress)
    print(f"{len(paths)} file(s) in {time.perf_counter() - t0:.1f} s")
    return 0


def _cmd_campaign(args) -> int:
    from mjasc.campaigns.engine import format_aggregate, run_campaign
    from mjasc.campaigns.spec import CampaignError, load_campaign_spec

    try:
        campaign = load_campaign_spec(args.campaign).with_overrides(runs=args.runs)
    except CampaignError as exc:
        print(f"mjasc: invalid campaign: {exc}{_not_found_hint(args.campaign, 'campaign')}", file=sys.stderr)
        return 2
    out = _out_dir(args.out, Path("runs") / "campaigns" / campaign.name)
    try:
        result = run_campaign(campaign, out, scheduler=args.scheduler, workers=args.workers,
                              progress=args.progress and sys.stderr.isatty(), max_attempts=args.max_attempts,
                              time_limit_s=args.time_limit)
    except (ValueError, RuntimeError, OSError) as exc:
        print(f"mjasc: campaign failed: {exc}", file=sys.stderr)
        return 1
    info = result.info
    print(f"{campaign.name}: {info['runs_to_do']} run(s) done now, {info['already_done']} already in the store "
          f"({info['wall_time_s']} s)")
    print(format_aggregate(result.aggregate, campaign.name))
    for kind, path in result.files.items():
        print(f"  {kind}: {path}")
    return 0


def _cmd_report(args) -> int:
    from mjasc.campaigns.report import format_report, report_data, write_report

    try:
        if args.json:
            print(json.dumps(report_data(args.folder), default=str))
            return 0
        if not (Path(args.folder) / "campaign.sqlite").is_file():
            raise FileNotFoundError(f"{args.folder}: no campaign here (no campaign.sqlite)")
        out = write_report(args.folder, _out_dir(args.out, Path(args.folder) / "report"), formats=args.format)
    except FileNotFoundError as exc:
        print(f"mjasc: {exc}", file=sys.stderr)
        return 2
    print(format_report(out["data"]), end="")
    for path in out["files"]:
        print(f"  {path}")
    return 0


def _cmd_extract(args) -> int:
    from mjasc.campaigns.scenario_text import write_scenario
    from mjasc.campaigns.statistics import run_outcome
    from mjasc.campaigns.store import CampaignStore

    try:
        store = CampaignStore.open_existing(args.folder)
    except FileNotFoundError as exc:
        print(f"mjasc: {exc}", file=sys.stderr)
        return 2
    with store:
        runs = {(r.index, r.method): r for r in store.runs()}  # method "" unless the campaign compares methods
    indices = {k for k, _ in runs}
    wanted_idx = set(args.runs or [])
    missing = sorted(wanted_idx - indices)
    if missing:
        print(f"mjasc: {args.folder}: no stored run {', '.join(map(str, missing))} (stored: {len(indices)} runs)",
              file=sys.stderr)
        return 2
    wanted = {key for key in runs if key[0] in wanted_idx}  # an index: its run with every method
    if args.outcome:
        for key, r in runs.items():
            o = run_outcome(r.metrics)
            if (args.outcome == "failed" and r.status != "completed") or \
                    (args.outcome in ("collision", "near_miss") and r.status == "completed" and o[args.outcome]):
                wanted.add(key)
    if not wanted:
        print("mjasc: no run selected (give run indices or --outcome)" if not args.outcome else
              f"no stored run with outcome {args.outcome}", file=sys.stderr)
        return 2 if not args.outcome else 0
    out = _out_dir(args.out, Path(args.folder) / "scenarios")
    paths = {}
    for k, m in sorted(wanted):
        r = runs[(k, m)]
        paths[(k, m)] = path = write_scenario(r.scenario, out / (f"run_{k}_{m}.toml" if m else f"run_{k}.toml"))
        print(f"run {k}{f' ({m})' if m else ''} ({r.family}, seed {r.seed}, {r.status}): {path}")
    print(f"replay one with: mjasc run {paths[min(wanted)]}")
    return 0


def _cmd_search(args) -> int:
    from mjasc.campaigns.search import SearchConfig, search_failures
    from mjasc.campaigns.spec import CampaignError, load_campaign_spec
    from mjasc.core.config_tables import ConfigError

    try:
        campaign = load_campaign_spec(args.campaign)
        config = SearchConfig(method=args.method, budget=args.budget, batch=args.batch,
                              failure_separation_m=args.failure_separation, seed=args.seed)
    except (CampaignError, ConfigError) as exc:
        print(f"mjasc: invalid search: {exc}", file=sys.stderr)
        return 2
    out = _out_dir(args.out, Path("runs") / "search" / f"{campaign.name}_{args.family}_{args.method}")
    try:
        res = search_failures(campaign, args.family, out, config, scheduler=args.scheduler, workers=args.workers,
                              progress=sys.stderr.isatty())
    except (ValueError, RuntimeError, OSError) as exc:
        print(f"mjasc: search failed: {exc}", file=sys.stderr)
        return 1
    t = res.table()
    print(f"{campaign.name} / {args.family} ({args.method}): {t['runs']} runs, {t['failures']} failure(s), "
          f"minimum separation {t['min_separation_m']} m, median {t['median_separation_m']} m")
    for path in res.failures:
        print(f"  failure: {path}  (replay: mjasc run {path})")
    return 0


def _cmd_render(args) -> int:
    import time

    from mjasc.runs.scenario import camera_problem
    from mjasc.suite import TASKS_BY_DOMAIN
    from mjasc.suite.render import render_episode

    tasks = TASKS_BY_DOMAIN.get(args.domain)
    if camera_problem(args.camera):
        print(f"mjasc: render --camera: {camera_problem(args.camera)}", file=sys.stderr)
        return 2
    if tasks is None or args.task not in tasks:  # checked before the output folder is made
        what = f"domain {args.domain!r}" if tasks is None else f"task {args.task!r} of domain {args.domain!r}"
        print(f"mjasc: render: no {what} (known: {_suite_tasks(TASKS_BY_DOMAIN)})", file=sys.stderr)
        return 2
    out = _out_dir(args.out, None)
    print(f"rendering {args.domain} {args.task} ({args.policy} policy, seed {args.seed}) into {out} ...", flush=True)
    t0 = time.perf_counter()
    try:
        result = render_episode(args.domain, args.task, policy=args.policy, out_dir=out, seed=args.seed,
                                camera=args.camera,
                                progress=lambda done, limit: print(f"  {100 * done // limit:3d} % ({done} of {limit} "
                                                                   f"control steps, {time.perf_counter() - t0:.0f} s)",
                                                                   flush=True))
    except ValueError as exc:
        print(f"mjasc: {exc}", file=sys.stderr)
        return 2
    end = "ended by the task (a collision)" if result.terminated else "ran to its time limit"
    print(f"{args.domain} {args.task}: {result.steps} control steps, return {result.episode_return:.3f} "
          f"(sum of rewards, each in [0, 1]); the episode {end}; {time.perf_counter() - t0:.1f} s")
    for kind, path in (("video", result.video_path), ("recording", result.rerun_path)):
        if path is not None:
            print(f"  {kind}: {path}")
    if result.rerun_path is not None:
        print(f"  open the recording with: mjasc view {result.rerun_path}")
    return 0


def _suite_tasks(by_domain) -> str:
    return "; ".join(f"{d}: {', '.join(t)}" for d, t in by_domain.items())


def _plain(text: str) -> str:
    """Docstring text as plain help text: reStructuredText literals ``x`` shown as 'x'."""
    return text.replace("``", "'")


def build_parser(argv: list[str] | None = None) -> argparse.ArgumentParser:
    """The parser. The render command's help lists the suite's domains and tasks, read (importing
    dm_control, ~2 s) only when ``argv`` is a render command."""
    argv = sys.argv[1:] if argv is None else argv
    p = argparse.ArgumentParser(prog="mjasc", description="mjasc: autonomous surface craft in MuJoCo. Commands:\n\n"
                                + "\n".join(line.strip() for line in __doc__.split("\n\n")[1].splitlines()),
                                epilog=_plain(__doc__.split("\n\n")[2]),
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run", help="run a scenario (a file or a bundled name): recording, summary and "
                                   "(with --video) an MP4")
    r.add_argument("scenario", help="a scenario TOML file's path (relative to the current folder; format in "
                                    f"tasks/README.md) or a bundled scenario's name such as 'demo' ({NAMED_HELP})")
    r.add_argument("--out", help="output folder (default: runs/<scenario name> in the current folder)")
    r.add_argument("--video", action="store_true", help="render an MP4 offscreen (OSMesa)")
    r.add_argument("--camera", help="the video's camera (implies --video): top_down, overview, chase:VESSEL, "
                                    "split (overview beside the first vessel's chase view) or split:VESSEL "
                                    "(default: the scenario's [outputs] video_camera, else top_down)")
    r.add_argument("--seed", type=int, help="override the scenario's seed")
    r.add_argument("--duration", type=float, help="override the scenario's duration [s]")
    r.add_argument("--no-progress", dest="progress", action="store_false", help="no progress bar")
    r.set_defaults(func=_cmd_run)
    ls = sub.add_parser("list", help="list the vessels, the bundled scenarios and campaigns, and the stage methods")
    ls.set_defaults(func=_cmd_list)
    t = sub.add_parser("trial", help="standard manoeuvring trial of one hull (results in SI units)")
    t.add_argument("kind", choices=["speed", "turning-circle", "zigzag", "stopping"],
                   help="speed: steady surge speed at constant commands; turning-circle: steady turn "
                        "(diameter, yaw rate); zigzag: heading overshoots; stopping: distance and time to stop")
    t.add_argument("--vessel", required=True, help="a vessel type ('mjasc list' shows them), e.g. otter")
    t.add_argument("--port", type=float, default=None, help="constant port propeller command in [-1, 1] "
                                                             "(default: the trial's own)")
    t.add_argument("--starboard", type=float, default=None, help="constant starboard propeller command in "
                                                                  "[-1, 1] (default: the trial's own)")
    t.add_argument("--json", action="store_true", help="print one JSON object")
    t.set_defaults(func=_cmd_trial)
    f = sub.add_parser("figures", help="make the thesis-style figures (tracking, potential fields, collision "
                                       "avoidance; runs simulations, ~30 s)")
    f.add_argument("--out", default="runs/figures",
                   help="output folder (default: runs/figures in the current folder)")
    f.add_argument("--format", nargs="+", default=["png"], choices=["png", "svg", "pdf"],
                   help="file formats, one file per figure and format (default: png)")
    f.set_defaults(func=_cmd_figures)
    v = sub.add_parser("view", help="open a run's recording in the Rerun viewer installed with mjasc")
    v.add_argument("run", help="a run's output folder (it holds recording.rrd) or an .rrd file")
    v.add_argument("--print", action="store_true", help="print the command that opens it, do not open it")
    v.set_defaults(func=_cmd_view)
    c = sub.add_parser("campaign", help="a campaign of encounter runs on Dask, resumable (docs/campaigns.md)")
    c.add_argument("campaign", help="a campaign TOML file's path (relative to the current folder; format in "
                                    "docs/campaigns.md) or a bundled campaign's name such as 'demo_monte_carlo' "
                                    f"({NAMED_HELP})")
    c.add_argument("--out", help="output folder (default: runs/campaigns/<campaign name> in the current folder)")
    c.add_argument("--workers", type=int, help="local worker processes (default: CPU count; 0: in this process)")
    c.add_argument("--scheduler", help="address of an existing Dask scheduler (tcp://host:8786), or 'synchronous'")
    c.add_argument("--runs", type=int, help="only the campaign's first N runs (the rest can follow later: "
                                            "a rerun into the same folder computes only what is missing)")
    c.add_argument("--max-attempts", type=int, default=2, help="tries per run for errors, timeouts and crashes "
                                                               "(default: 2)")
    c.add_argument("--time-limit", type=float, default=3600.0, help="per-run time limit [s] (default: 3600)")
    c.add_argument("--no-progress", dest="progress", action="store_false", help="no progress bar")
    c.set_defaults(func=_cmd_campaign)
    rp = sub.add_parser("report", help="a campaign's results: table, plots (PNG/SVG/PDF), or --json; works on a "
                                       "campaign that is still running or was killed")
    rp.add_argument("folder", help="the campaign's output folder (it holds campaign.sqlite)")
    rp.add_argument("--json", action="store_true", help="print one JSON object (runs_defined, runs_recorded, "
                                                         "runs_failed, outcomes, families) and write nothing")
    rp.add_argument("--out", help="folder for report.md and the figures (default: FOLDER/report)")
    rp.add_argument("--format", nargs="+", default=["png", "svg"], choices=["png", "svg", "pdf"],
                    help="figure formats (default: png svg)")
    rp.set_defaults(func=_cmd_report)
    ex = sub.add_parser("extract", help="write stored campaign runs as scenario files that 'mjasc run' replays "
                                        "exactly")
    ex.add_argument("folder", help="the campaign's output folder (it holds campaign.sqlite)")
    ex.add_argument("runs", nargs="*", type=int, help="run indices (as in the report and the exports)")
    ex.add_argument("--outcome", choices=["collision", "near_miss", "failed"],
                    help="also every run with this outcome (failed: error, timeout or divergence)")
    ex.add_argument("--out", help="folder for the files (default: FOLDER/scenarios)")
    ex.set_defaults(func=_cmd_extract)
    se = sub.add_parser("search", help="search an encounter family for failures of the collision avoidance "
                                       "(cross-entropy method, or uniform sampling as the baseline)")
    se.add_argument("campaign", help=f"a campaign file's path or a bundled campaign's name ({NAMED_HELP})")
    se.add_argument("family", help="the name of one of its encounter families")
    se.add_argument("--method", default="cross_entropy", choices=["cross_entropy", "uniform"],
                    help="cross_entropy: adapt the sampling towards failures; uniform: the baseline "
                         "(default: cross_entropy)")
    se.add_argument("--budget", type=int, default=48, help="runs in all (default: 48)")
    se.add_argument("--batch", type=int, default=12, help="runs per iteration (default: 12)")
    se.add_argument("--failure-separation", type=float, default=0.0,
                    help="a run whose minimum separation [m] is below this is a failure (default: 0)")
    se.add_argument("--seed", type=int, default=0, help="seed of the search's sampling (default: 0)")
    se.add_argument("--workers", type=int, help="local worker processes (default: CPU count; 0: in this process)")
    se.add_argument("--scheduler", help="address of an existing Dask scheduler")
    se.add_argument("--out", help="output folder (default: runs/search/<campaign>_<family>_<method>)")
    se.set_defaults(func=_cmd_search)
    tasks = ""
    if argv[:1] == ["render"]:
        from mjasc.suite import TASKS_BY_DOMAIN

        tasks = f"Domains and their tasks: {_suite_tasks(TASKS_BY_DOMAIN)}."
    rd = sub.add_parser("render", help="render one episode of a dm_control suite task to MP4 + Rerun", epilog=tasks)
    rd.add_argument("domain", help="a suite domain: otter, delfim or otter_team")
    rd.add_argument("task", help="one of the domain's tasks, e.g. path_following, collision_avoidance, formation")
    rd.add_argument("--policy", default="random", type=_policy_arg,
                    help="random (random actions), baseline (the testbed's own guidance and avoidance), goal_line "
                         "(collision_avoidance: the line to the goal, no avoidance), cas (the vessel's own pipeline "
                         "with the thesis CAS) or cas:METHOD (with any avoidance method of 'mjasc list'); "
                         "default: random")
    rd.add_argument("--seed", type=int, default=0, help="episode seed (default: 0)")
    rd.add_argument("--camera", default="top_down",
                    help="top_down, overview, chase:VESSEL (e.g. chase:otter), split (overview beside the first "
                         "vessel's chase view) or split:VESSEL (default: top_down)")
    rd.add_argument("--out", default="runs/render", help="output folder (default: runs/render)")
    rd.set_defaults(func=_cmd_render)
    return p


def _out_dir(given: str | None, default: Path | None) -> Path:
    """The output folder (``--out`` or the default), made and proven writable before anything runs
    (:func:`mjasc.runs.outputs.check_out_dir`; raises OutputError, which :func:`main` reports)."""
    from mjasc.runs.outputs import check_out_dir

    return check_out_dir(given if given is not None else default, "--out" if given is not None else "output folder")


#: The command-line arguments that name an input file or folder (checked before a command runs).
_INPUTS = ("scenario", "campaign", "folder", "run")


def main(argv: list[str] | None = None) -> int:
    """Run one command. Exit status: 0 done, 1 a run or campaign failed, 2 bad input (a scenario,
    campaign, argument or output folder: one line on stderr, no traceback), 130 interrupted.
    An unexpected error (a bug) is one line too; ``MJASC_TRACEBACK=1`` shows its traceback."""
    import os

    from mjasc.core.config_tables import ConfigError, path_problem, show_path

    args = build_parser(argv).parse_args(argv)
    for name in _INPUTS:
        value = getattr(args, name, None)
        if isinstance(value, str) and path_problem(value):
            print(f"mjasc: {name} {show_path(value)}: not a usable file name ({path_problem(value)})", file=sys.stderr)
            return 2
    try:
        return args.func(args)
    except KeyboardInterrupt:
        print("mjasc: interrupted", file=sys.stderr)
        return 130
    except ConfigError as exc:  # includes ScenarioError and OutputError
        print(f"mjasc: {exc}", file=sys.stderr)
        return 2
    except Exception as exc:  # noqa: BLE001 - the last line of defence: one line, not a traceback
        from mjasc.campaigns.perturbation import CampaignError

        if isinstance(exc, CampaignError):
            print(f"mjasc: invalid campaign: {exc}", file=sys.stderr)
            return 2
        if os.environ.get("MJASC_TRACEBACK"):
            raise
        text = str(exc).replace("\n", " ")
        print(f"mjasc: internal error: {type(exc).__name__}: {text[:500]} (MJASC_TRACEBACK=1 shows where)",
              file=sys.stderr)
        return 1
