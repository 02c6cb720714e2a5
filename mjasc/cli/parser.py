"""The ``mjasc`` command line's parser: every command, its arguments and its help.

    mjasc run SCENARIO [--out DIR] [--video] [--camera CAM] [--seed N] [--duration S] [--evaluate] [--no-progress]
    mjasc list
    mjasc campaign CAMPAIGN [--out DIR] [--workers N] [--scheduler ADDR] [--runs N] [--max-attempts N] [--time-limit S] [--no-progress]
    mjasc report FOLDER [--json] [--out DIR] [--format png svg pdf]
    mjasc extract FOLDER [RUN ...] [--outcome collision|near_miss|failed] [--out DIR]
    mjasc search CAMPAIGN FAMILY [--method cross_entropy|uniform] [--budget N] [--batch N] [--failure-separation M] [--seed N] [--workers N] [--scheduler ADDR] [--out DIR]
    mjasc trial speed|turning-circle|zigzag|stopping|tightest-turn --vessel NAME|PATH [--port F] [--starboard F] [--speed M_S] [--json]
    mjasc view RUN_DIR|RECORDING [--print]
    mjasc figures [--out DIR] [--format png svg pdf]
    mjasc render DOMAIN TASK [--policy random|baseline|goal_line|cas|cas:METHOD] [--seed N] [--vessel NAME|PATH] [--camera CAM] [--no-hud] [--out DIR]   (dm_control suite)

SCENARIO and CAMPAIGN are a TOML file's path or the name of a bundled one (``mjasc run demo``,
``mjasc campaign demo_monte_carlo``; ``mjasc list`` shows them), so every command works from any
folder. Paths on the command line, and the default output folders (``runs/<scenario name>``,
``runs/campaigns/<campaign name>``), are relative to the current folder.
"""

from __future__ import annotations

import argparse
import sys

from mjasc.cli.arguments import NAMED_HELP, suite_tasks
from mjasc.cli.campaign_commands import cmd_campaign, cmd_extract, cmd_report, cmd_search
from mjasc.cli.run_commands import cmd_figures, cmd_list, cmd_render, cmd_run, cmd_trial, cmd_view


def policy_arg(text: str) -> str:
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


class _Parser(argparse.ArgumentParser):
    """argparse's parser whose usage errors are one line on stderr (exit status 2), as every other
    bad input of the command line: the command, the problem and where the usage is."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: {message} ('{self.prog} --help' shows the usage)\n")


def count_arg(minimum: int):
    """An argparse type: an integer ≥ ``minimum`` (checked before any folder is made)."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be an integer, got {text!r}") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be ≥ {minimum}, got {value}")
        return value
    parse.__name__ = "integer"
    return parse


def seed_arg(text: str) -> int:
    """An argparse type: a seed, an integer in [0, MAX_SEED] (2**32 − 1: what numpy's and
    dm_control's generators take; the scenario file's ``seed`` has the same bound,
    :data:`mjasc.runs.scenario_values.MAX_SEED`)."""
    from mjasc.runs.scenario_values import MAX_SEED

    value = count_arg(0)(text)
    if value > MAX_SEED:
        raise argparse.ArgumentTypeError(f"must be ≤ {MAX_SEED} (2**32 − 1), got {value}")
    return value


def seconds_arg(text: str) -> float:
    """An argparse type: a finite positive duration [s]."""
    import math

    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number of seconds, got {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text}")
    return value


def scheduler_arg(text: str) -> str:
    """An argparse type: 'synchronous', 'local' or a Dask scheduler's address with its port
    (``tcp://host:8786``, ``host:8786``)."""
    from mjasc.campaigns.cluster import scheduler_problem

    if problem := scheduler_problem(text):
        raise argparse.ArgumentTypeError(problem.replace(", a distributed.Client", ""))
    return text


seed_arg.__name__, seconds_arg.__name__, scheduler_arg.__name__ = "seed", "seconds", "scheduler"


def _plain(text: str) -> str:
    """Docstring text as plain help text: reStructuredText literals ``x`` shown as 'x'."""
    return text.replace("``", "'")


def build_parser(argv: list[str] | None = None) -> argparse.ArgumentParser:
    """The parser. The render command's help lists the suite's domains and tasks, read (importing
    dm_control, ~2 s) only when ``argv`` is a render command."""
    argv = sys.argv[1:] if argv is None else argv
    p = _Parser(prog="mjasc", description="mjasc: autonomous surface craft in MuJoCo. Commands:\n\n"
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
    r.add_argument("--seed", type=seed_arg, help="override the scenario's seed")
    r.add_argument("--duration", type=seconds_arg, help="override the scenario's duration [s]")
    r.add_argument("--evaluate", action="store_true",
                   help="score the run against the truth as a campaign's runs are (tracking GOSPA and position "
                        "RMSE, COLREG roles, encounters): summary.json's evaluation")
    r.add_argument("--no-progress", dest="progress", action="store_false", help="no progress bar")
    r.set_defaults(func=cmd_run)
    ls = sub.add_parser("list", help="list the vessels, the bundled scenarios and campaigns, and the stage methods")
    ls.set_defaults(func=cmd_list)
    t = sub.add_parser("trial", help="standard manoeuvring trial of one hull (results in SI units)")
    t.add_argument("kind", choices=["speed", "turning-circle", "zigzag", "stopping", "tightest-turn"],
                   help="speed: steady surge speed at constant commands; turning-circle: steady turn "
                        "(diameter, yaw rate); zigzag: heading overshoots; stopping: distance and time to stop; "
                        "tightest-turn: the tightest steady turn at a speed (go-to-formation's smallest "
                        "turn_radius_m is half its diameter)")
    t.add_argument("--vessel", required=True,
                   help="a built-in vessel type ('mjasc list' shows them), e.g. otter, or a vessel folder's path "
                        "(a folder holding <folder name>.xml and hydrodynamics.toml: assets/README.md, "
                        "\"Your own hull\"), e.g. examples/my_hull/hulls/otter_payload")
    t.add_argument("--port", type=float, default=None, help="constant port propeller command in [-1, 1] "
                                                             "(default: the trial's own)")
    t.add_argument("--starboard", type=float, default=None, help="constant starboard propeller command in "
                                                                  "[-1, 1] (default: the trial's own)")
    t.add_argument("--speed", type=float, default=None, help="tightest-turn only: the speed [m/s] of the turn "
                                                              "(default: the hull's cruise speed)")
    t.add_argument("--json", action="store_true", help="print one JSON object")
    t.set_defaults(func=cmd_trial)
    f = sub.add_parser("figures", help="make the thesis-style figures (tracking, potential fields, collision "
                                       "avoidance; runs simulations, ~30 s)")
    f.add_argument("--out", default="runs/figures",
                   help="output folder (default: runs/figures in the current folder)")
    f.add_argument("--format", nargs="+", default=["png"], choices=["png", "svg", "pdf"],
                   help="file formats, one file per figure and format (default: png)")
    f.set_defaults(func=cmd_figures)
    v = sub.add_parser("view", help="open a run's recording in the Rerun viewer installed with mjasc")
    v.add_argument("run", help="a run's output folder (it holds recording.rrd) or an .rrd file")
    v.add_argument("--print", action="store_true", help="print the command that opens it, do not open it")
    v.set_defaults(func=cmd_view)
    c = sub.add_parser("campaign", help="a campaign of encounter runs on Dask, resumable (docs/campaigns.md)")
    c.add_argument("campaign", help="a campaign TOML file's path (relative to the current folder; format in "
                                    "docs/campaigns.md) or a bundled campaign's name such as 'demo_monte_carlo' "
                                    f"({NAMED_HELP})")
    c.add_argument("--out", help="output folder (default: runs/campaigns/<campaign name> in the current folder)")
    c.add_argument("--workers", type=count_arg(0), help="local worker processes (default: CPU count; 0: in this "
                                                        "process)")
    c.add_argument("--scheduler", type=scheduler_arg,
                   help="address of an existing Dask scheduler (tcp://host:8786), or 'synchronous'")
    c.add_argument("--runs", type=count_arg(1), help="only the campaign's first N runs (the rest can follow "
                                                     "later: a rerun into the same folder computes only what is "
                                                     "missing)")
    c.add_argument("--max-attempts", type=count_arg(1), default=2,
                   help="tries per run for errors, timeouts and crashes (default: 2)")
    c.add_argument("--time-limit", type=seconds_arg, default=3600.0, help="per-run time limit [s] (default: 3600)")
    c.add_argument("--no-progress", dest="progress", action="store_false", help="no progress bar")
    c.set_defaults(func=cmd_campaign)
    rp = sub.add_parser("report", help="a campaign's results: table, plots (PNG/SVG/PDF), or --json; works on a "
                                       "campaign that is still running or was killed")
    rp.add_argument("folder", help="the campaign's output folder (it holds campaign.sqlite)")
    rp.add_argument("--json", action="store_true", help="print one JSON object (runs_defined, runs_recorded, "
                                                         "runs_failed, outcomes, families) and write nothing")
    rp.add_argument("--out", help="folder for report.md and the figures (default: FOLDER/report)")
    rp.add_argument("--format", nargs="+", default=["png", "svg"], choices=["png", "svg", "pdf"],
                    help="figure formats (default: png svg)")
    rp.set_defaults(func=cmd_report)
    ex = sub.add_parser("extract", help="write stored campaign runs as scenario files that 'mjasc run' replays "
                                        "exactly")
    ex.add_argument("folder", help="the campaign's output folder (it holds campaign.sqlite)")
    ex.add_argument("runs", nargs="*", type=count_arg(0), help="run indices (as in the report and the exports)")
    ex.add_argument("--outcome", choices=["collision", "near_miss", "failed"],
                    help="also every run with this outcome (failed: error, timeout or divergence)")
    ex.add_argument("--out", help="folder for the files (default: FOLDER/scenarios)")
    ex.set_defaults(func=cmd_extract)
    se = sub.add_parser("search", help="search an encounter family for failures of the collision avoidance "
                                       "(cross-entropy method, or uniform sampling as the baseline)")
    se.add_argument("campaign", help=f"a campaign file's path or a bundled campaign's name ({NAMED_HELP})")
    se.add_argument("family", help="the name of one of its encounter families")
    se.add_argument("--method", default="cross_entropy", choices=["cross_entropy", "uniform"],
                    help="cross_entropy: adapt the sampling towards failures; uniform: the baseline "
                         "(default: cross_entropy)")
    se.add_argument("--budget", type=count_arg(1), default=48, help="runs in all (default: 48)")
    se.add_argument("--batch", type=count_arg(1), default=12, help="runs per iteration (default: 12)")
    se.add_argument("--failure-separation", type=float, default=0.0,
                    help="a run whose minimum separation [m] is below this is a failure (default: 0)")
    se.add_argument("--seed", type=seed_arg, default=0, help="seed of the search's sampling (default: 0)")
    se.add_argument("--workers", type=count_arg(0),
                    help="local worker processes (default: CPU count; 0: in this process)")
    se.add_argument("--scheduler", type=scheduler_arg, help="address of an existing Dask scheduler")
    se.add_argument("--out", help="output folder (default: runs/search/<campaign>_<family>_<method>)")
    se.set_defaults(func=cmd_search)
    tasks = ""
    if argv[:1] == ["render"]:
        from mjasc.suite import TASKS_BY_DOMAIN

        tasks = f"Domains and their tasks: {suite_tasks(TASKS_BY_DOMAIN)}."
    rd = sub.add_parser("render", help="render one episode of a dm_control suite task to MP4 + Rerun", epilog=tasks)
    rd.add_argument("domain", help="a suite domain: otter, delfim or otter_team")
    rd.add_argument("task", help="one of the domain's tasks, e.g. path_following, collision_avoidance, formation")
    rd.add_argument("--policy", default="random", type=policy_arg,
                    help="random (random actions), baseline (the testbed's own guidance and avoidance), goal_line "
                         "(collision_avoidance: the line to the goal, no avoidance), cas (the vessel's own pipeline "
                         "with the thesis CAS) or cas:METHOD (with any avoidance method of 'mjasc list'); "
                         "default: random")
    rd.add_argument("--seed", type=seed_arg, default=0, help="episode seed (default: 0)")
    rd.add_argument("--vessel", help="the hull to sail instead of the domain's own (every vessel of otter_team): a "
                                     "built-in vessel type ('mjasc list') or a vessel folder's path, relative to the "
                                     "current folder (assets/README.md, \"Your own hull\"), e.g. "
                                     "examples/my_hull/hulls/otter_payload (default: the domain's)")
    rd.add_argument("--camera", default="top_down",
                    help="top_down, overview, chase:VESSEL (e.g. chase:otter), split (overview beside the first "
                         "vessel's chase view), split:VESSEL, or a pixel agent's view: basin, follow:VESSEL, "
                         "heading_up:VESSEL (default: top_down)")
    rd.add_argument("--no-hud", dest="hud", action="store_false",
                    help="no heads-up display on the video (task, time, policy, reward, return, names, legend)")
    rd.add_argument("--out", default="runs/render", help="output folder (default: runs/render)")
    rd.set_defaults(func=cmd_render)
    return p
