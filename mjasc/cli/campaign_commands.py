"""The campaign commands: ``mjasc campaign`` (run one on Dask), ``report``, ``extract`` (stored runs
as replayable scenario files) and ``search`` (failure search in an encounter family)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from mjasc.cli.arguments import not_found_hint, out_dir
from mjasc.runs.interrupts import catch_sigterm, restore_sigterm


def _scheduler_problem(args) -> str:
    """The line to print when --scheduler and --workers do not go together ('' if they do:
    :func:`mjasc.campaigns.cluster.workers_problem`, checked here before anything starts)."""
    from mjasc.campaigns.cluster import workers_problem

    problem = workers_problem(args.scheduler, args.workers)
    return f"mjasc: --workers {args.workers}: {problem}" if problem else ""


def cmd_campaign(args) -> int:
    from mjasc.campaigns.executor import close_prestarted, prestart_isolated

    if problem := _scheduler_problem(args):
        print(problem, file=sys.stderr)
        return 2

    if args.scheduler in (None, "local") and args.workers != 0:
        prestart_isolated(args.workers)  # the runs' children import while the campaign is read
    previous = catch_sigterm()  # (SIGTERM — a batch system's stop, scancel — ends it as Ctrl-C does: 130)
    try:
        status = _campaign(args)
    finally:
        late = restore_sigterm(previous)
        close_prestarted()  # (any the campaign did not take: an invalid file, nothing to run)
    if late is not None:  # (an interrupt kept after the campaign's last look: the command stops as asked)
        raise late
    return status


def _campaign(args) -> int:
    from mjasc.campaigns.engine import format_aggregate, run_campaign
    from mjasc.campaigns.spec import CampaignError, load_campaign_spec
    from mjasc.campaigns.store import StoreError

    try:
        campaign = load_campaign_spec(args.campaign).with_overrides(runs=args.runs)
    except CampaignError as exc:
        print(f"mjasc: invalid campaign: {exc}{not_found_hint(args.campaign, 'campaign')}", file=sys.stderr)
        return 2
    target = Path(args.out) if args.out is not None else Path("runs") / "campaigns" / campaign.name
    existed = target.is_dir()
    out = out_dir(args.out, Path("runs") / "campaigns" / campaign.name)
    result = None
    try:
        result = run_campaign(campaign, out, scheduler=args.scheduler, workers=args.workers,
                              progress=args.progress and sys.stderr.isatty(), max_attempts=args.max_attempts,
                              time_limit_s=args.time_limit)
    except CampaignError as exc:  # (found when its runs are drawn: a grid point no draw can make, ...)
        print(f"mjasc: invalid campaign: {_in_file(exc, campaign.source)}", file=sys.stderr)
        return 2
    except StoreError as exc:  # (--out holds a campaign.sqlite that is not a store)
        print(f"mjasc: {exc}", file=sys.stderr)
        return 2
    except (ValueError, RuntimeError, OSError) as exc:
        print(f"mjasc: campaign failed: {exc}", file=sys.stderr)
        return 1
    finally:
        if result is None and not existed:  # (stopped before its first result: the folder it made goes, if empty)
            try:
                out.rmdir()
            except OSError:
                pass
    info = result.info
    if "workers_asked" in info:
        print(f"note: --workers {info['workers_asked']} capped at {info.get('workers')}, the runs to do",
              file=sys.stderr)
    print(f"{campaign.name}: {info['runs_to_do']} run(s) done now, {info['already_done']} already in the store "
          f"({info['wall_time_s']} s)")
    print(format_aggregate(result.aggregate, campaign.name))
    hint = retry_hint(result.aggregate, args.max_attempts)
    if hint:
        print(hint)
    for kind, path in result.files.items():
        print(f"  {kind}: {path}")
    return 0


def retry_hint(aggregate: dict, max_attempts: int) -> str | None:
    """What to do about the stored runs that failed in a way another attempt may not
    (``RETRY_STATUSES``: an error, a timeout, a crash; not ``diverged``, a final outcome): they are
    tried ``--max-attempts`` times in all, so a command run again does not retry them unless it is
    given more. None when there are none."""
    from mjasc.campaigns.store import RETRY_STATUSES

    k = sum(n for status, n in aggregate.get("statuses", {}).items() if status in RETRY_STATUSES)
    if not k:
        return None
    return (f"note: {k} run(s) failed (an error or a time limit) and are retried up to --max-attempts times in all "
            f"({max_attempts} now): run the command again with a larger --max-attempts (and --time-limit, for "
            f"timeouts) to retry them")


def _in_file(exc: Exception, source) -> str:
    """``exc``'s message prefixed with the campaign file ``source`` unless it names it already."""
    text, source = str(exc), str(source or "")
    return text if not source or text.startswith(source) else f"{source}: {text}"


def cmd_report(args) -> int:
    from mjasc.campaigns.report import format_report, report_data, write_report

    try:
        if args.json:
            print(json.dumps(report_data(args.folder), default=str))
            return 0
        if not (Path(args.folder) / "campaign.sqlite").is_file():
            raise FileNotFoundError(f"{args.folder}: no campaign here (no campaign.sqlite)")
        from mjasc.campaigns.store import CampaignStore

        CampaignStore.open_existing(args.folder).close()  # (a store that opens: only then a report folder)
        out = write_report(args.folder, out_dir(args.out, Path(args.folder) / "report"), formats=args.format)
    except FileNotFoundError as exc:
        print(f"mjasc: {exc}", file=sys.stderr)
        return 2
    print(format_report(out["data"]), end="")
    for path in out["files"]:
        print(f"  {path}")
    return 0


def cmd_extract(args) -> int:
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
    out = out_dir(args.out, Path(args.folder) / "scenarios")
    paths = {}
    for k, m in sorted(wanted):
        r = runs[(k, m)]
        paths[(k, m)] = path = write_scenario(r.scenario, out / (f"run_{k}_{m}.toml" if m else f"run_{k}.toml"))
        print(f"run {k}{f' ({m})' if m else ''} ({r.family}, seed {r.seed}, {r.status}): {path}")
    print(f"replay one with: mjasc run {paths[min(wanted)]}")
    return 0


def cmd_search(args) -> int:
    from mjasc.campaigns.search import SearchConfig, search_failures, searchable_family
    from mjasc.campaigns.spec import CampaignError, load_campaign_spec
    from mjasc.core.config_tables import ConfigError

    if problem := _scheduler_problem(args):
        print(problem, file=sys.stderr)
        return 2
    try:
        campaign = load_campaign_spec(args.campaign)
        config = SearchConfig(method=args.method, budget=args.budget, batch=args.batch,
                              failure_separation_m=args.failure_separation, seed=args.seed)
    except (CampaignError, ConfigError) as exc:
        print(f"mjasc: invalid search: {exc}{not_found_hint(args.campaign, 'campaign')}", file=sys.stderr)
        return 2
    try:  # (a family that cannot be searched is bad input before the output folder is made)
        searchable_family(campaign, args.family)
    except CampaignError as exc:
        print(f"mjasc: invalid search: {_in_file(exc, campaign.source)}", file=sys.stderr)
        return 2
    out = out_dir(args.out, Path("runs") / "search" / f"{campaign.name}_{args.family}_{args.method}")
    previous = catch_sigterm()  # (SIGTERM ends it as Ctrl-C does: 130)
    try:
        res = search_failures(campaign, args.family, out, config, scheduler=args.scheduler, workers=args.workers,
                              progress=sys.stderr.isatty())
    except CampaignError as exc:  # (an unknown family, one with nothing to search, a draw no run can make)
        print(f"mjasc: invalid search: {_in_file(exc, campaign.source)}", file=sys.stderr)
        return 2
    except (ValueError, RuntimeError, OSError) as exc:
        print(f"mjasc: search failed: {exc}", file=sys.stderr)
        return 1
    finally:
        late = restore_sigterm(previous)
    t = res.table()
    print(f"{campaign.name} / {args.family} ({args.method}): {t['runs']} runs, {t['failures']} failure(s), "
          f"minimum separation {t['min_separation_m']} m, median {t['median_separation_m']} m")
    for path in res.failures:
        print(f"  failure: {path}  (replay: mjasc run {path})")
    if late is not None:  # (an interrupt kept after the search's last look: its table said, it stops as asked)
        raise late
    return 0
