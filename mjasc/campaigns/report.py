"""``mjasc report DIR``: what a campaign found, from its store — a table, plots and a JSON object.

Works on any campaign folder, finished, killed or still running (SQLite in WAL mode lets a reader
in while the driver writes). :func:`report_data` computes everything from the stored runs
(:mod:`mjasc.campaigns.statistics`); :func:`write_report` writes ``report.md`` and the figures
(PNG and SVG by default) into ``DIR/report/``:

* ``rates`` — collision and near-miss rates per encounter family with their Wilson 95 % intervals;
* ``separation`` — the distribution of each run's minimum separation per family;
* ``outcomes_<family>`` — an outcome map over the family's two leading varied encounter parameters
  (geometry first: relative bearing or aspect × DCPA), each run coloured by its minimum separation,
  collisions marked;
* ``colreg`` — the share of encounters where the own vessel acted as its COLREG role asks, per role;
* ``tracking`` — mean GOSPA per run, per family;
* ``cost`` — per vessel, the path-length and time cost against the same mission without traffic,
  per family.

The Markdown names, per family, the hulls its own vessels sailed (a built-in name, or a vessel
folder's name, path and content fingerprint: :mod:`mjasc.campaigns.hull_records`; "unknown" from a
store written before they were recorded; the JSON's ``hulls``, ``{family: records or None}``), and
the figures' family labels carry a short tag of them when a family sails a folder. It has two tables
per family: outcomes (rates, separation, compliance, actions) and per
vessel (median / p95 over every vessel of every completed run, :mod:`mjasc.campaigns.statistics`):
path cost (extra distance for the same progress), time cost, mean and max cross-track error,
formation error (mean |lead| over the neighbours, metres of path).

**Comparing methods.** A campaign with ``methods`` (:mod:`mjasc.campaigns.methods`) reports its
methods side by side: one table with a row per (family, method) and per method over all families
(runs, collision and near-miss rates with Wilson 95 % intervals, minimum separation min / p5 /
median, COLREG compliance, median path and time cost, actions), the per-vessel table likewise, and
each method against the first on the same runs (``paired``: collisions only with one of them,
separation larger or smaller). The JSON has ``methods`` (per label: the statistics overall and per
family) and ``paired``. The figures draw the methods side by side (grouped bars and boxes, one
colour per method) and an outcome map per family and method (``outcomes_<family>_<method>``).
"""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import numpy as np

from mjasc.campaigns.hull_records import family_ticks, family_title, hull_table
from mjasc.campaigns.statistics import BEHIND_M, aggregate, before_cpa_note, family_order, run_outcome, wilson_interval
from mjasc.campaigns.report_figures import comparison_figures, numeric_params, outcome_map, save
from mjasc.campaigns.store import CampaignStore
from mjasc.campaigns.stored_file import file_compared_tables, file_gospa, file_methods

__all__ = ["report_data", "write_report", "format_report"]


def report_data(folder: str | Path) -> dict:
    """Everything the report shows, as one JSON-ready object: ``runs_defined``, ``runs_recorded``
    (distinct runs with a result), ``runs_failed``, ``outcomes`` (counts per status and of
    collisions and near misses), ``families`` and overall statistics, ``campaign`` (name, digest),
    ``hulls`` (per family the hulls its own vessels sailed, None when the store does not say)."""
    with CampaignStore.open_existing(folder) as store:
        info = store.info()
        runs = store.runs()
        text = store.file_text()
        order = file_methods(text)
    agg = aggregate(runs, info.get("runs_defined"), methods=order)
    outcomes = dict(agg["statuses"])
    outcomes["collision"] = agg["collision"]["count"]
    outcomes["near_miss"] = agg["near_miss"]["count"]
    stored = info.get("hulls")
    hulls = {f: stored.get(f) if stored is not None else None for f in agg["families"]}
    return {"campaign": {**{k: info.get(k) for k in ("name", "digest", "source", "campaigns_in_store")},
                         "gospa": file_gospa(text), "compared_tables": file_compared_tables(text)},
            "hulls": hulls, "failed": _failed(runs), "runs_defined": agg["runs_defined"],
            "runs_recorded": agg["runs_recorded"],
            "runs_failed": agg["runs_failed"], "outcomes": outcomes, **{k: v for k, v in agg.items() if k not in (
                "runs_defined", "runs_recorded", "runs_failed")}}


def gospa_label(data: dict) -> str:
    """``c = 10 m, p = 2`` for the campaign of ``data`` (:func:`report_data`)."""
    g = (data.get("campaign") or {}).get("gospa") or {"cutoff_m": 10.0, "order": 2.0}
    return f"c = {g['cutoff_m']:g} m, p = {g['order']:g}"


#: At most this many failed runs are listed in the report (the rest: runs.csv's ``error`` column).
MAX_FAILED_LISTED = 20


def _failed(runs) -> list[dict]:
    """The runs that did not complete, in index order: index, method label, family, status, attempts
    and the error's first line (shortened), for the report to say why."""
    bad = sorted((r for r in runs if r.status != "completed"), key=lambda r: (r.index, r.method))
    return [{"index": r.index, "method": r.method, "family": r.family, "status": r.status, "attempts": r.attempts,
             "error": ((r.error or "").splitlines() or [""])[0][:200]} for r in bad]


def _failed_lines(data: dict) -> list[str]:
    """The report's list of failed runs (none: no lines)."""
    failed = data.get("failed") or []
    if not failed:
        return []
    lines = ["", f"Failed runs ({len(failed)}; replay one with `mjasc extract DIR INDEX`, then `mjasc run` the file):",
             "", "| run | method | family | status | attempts | error |", "|---:|---|---|---|---:|---|"]
    for f in failed[:MAX_FAILED_LISTED]:
        error = f["error"].replace("|", "\\|") or "—"
        lines.append(f"| {f['index']} | {f['method'] or '—'} | {f['family']} | {f['status']} | {f['attempts']} "
                     f"| {error} |")
    if len(failed) > MAX_FAILED_LISTED:
        lines.append(f"\n{len(failed) - MAX_FAILED_LISTED} more in runs.csv (its `error` column).")
    return lines


def _pct(r: dict) -> str:
    if r["rate"] is None:
        return "—"
    lo, hi = r["wilson95"]
    return f"{r['count']}/{r['n']} = {100 * r['rate']:.1f} % [{100 * lo:.1f}, {100 * hi:.1f}]"


def _title(c: dict) -> list[str]:
    """The report's heading lines for ``data["campaign"]``, saying which campaign it is when the
    folder's store holds several (an edited file is a new campaign in the same folder)."""
    lines = [f"# Campaign {c.get('name')} (digest {str(c.get('digest'))[:12]})", ""]
    n = c.get("campaigns_in_store") or 1
    if n > 1:
        lines += [f"This folder's store holds {n} campaigns (an edited file is a new one); this report is of the "
                  f"one run last.", ""]
    return lines


def _known(x) -> str:
    """A count, or "—" when unknown (None: a store made before the value existed)."""
    return "—" if x is None else str(x)


def _vessels(pv: dict) -> int:
    """How many vessels a family's per-vessel quantiles rest on (the largest n of its values)."""
    return max((q["n"] for q in pv.values() if isinstance(q, dict)), default=0)


def _before_cpa(data: dict) -> list[str]:
    """The report's warning about runs cut before their encounter (none when there are none)."""
    note = before_cpa_note(data)
    return ["", f"**{note[0].upper()}{note[1:]}**"] if note else []


def _statuses(data: dict) -> str:
    """``statuses: completed 3, error 1`` — or, for a store without a run yet, that it holds none."""
    if not data["statuses"]:
        return "no run stored yet: the campaign command stores each run as it finishes"
    return f"statuses: {', '.join(f'{k} {v}' for k, v in sorted(data['statuses'].items()))}"


def format_report(data: dict) -> str:
    """The report's table as Markdown (also printed by ``mjasc report``)."""
    if data.get("methods"):
        return _format_comparison(data)
    lines = [*_title(data["campaign"]),
             f"{data['runs_recorded']} of {data['runs_defined']} runs recorded, {data['runs_failed']} failed "
             f"({_statuses(data)}).",
             *_before_cpa(data), "",
             *hull_table(data.get("hulls"), list(data["families"])),
             "| family | runs | collision [Wilson 95 %] | near miss [Wilson 95 %] | min separation: min / median [m] "
             "| COLREG compliant (encounters with a role) | actions |", "|---|---:|---|---|---|---|---|"]
    for fam, g in list(data["families"].items()) + [("**all**", data)]:
        q = g["min_separation_m"]
        sep = "—" if not q else f"{q['p0']:.2f} / {q['p50']:.2f}"
        acts = ", ".join(f"{k} {v}" for k, v in sorted(g["actions"].items()) if v) or "—"
        lines.append(f"| {fam} | {g['completed']} | {_pct(g['collision'])} | {_pct(g['near_miss'])} | {sep} | "
                     f"{_pct(g['colreg']['compliant'])} | {acts} |")
    lines += ["", "Per vessel, median / p95 over the vessels of the completed runs; cost against the same mission "
                  "without traffic (path: extra distance for the same progress; time: later than without traffic "
                  "by; *lost*: how much less progress than without traffic by the run's end, and *behind*: vessels "
                  f"more than {BEHIND_M:g} m behind — a vessel that stopped or was pushed back made its little "
                  "progress at no path or time cost; *short*: vessels whose reference never got as far, no time "
                  "cost; *off mission*: the largest distance from the mission path, detours included):", "",
              "| family | vessels | path cost [%] | time cost [s] | progress lost [m] | behind | off mission [m] "
              "| mean cross-track [m] | max cross-track [m] | formation error [m] | short |",
              "|---|---:|---|---|---|---:|---|---|---|---|---:|"]
    for fam, g in list(data["families"].items()) + [("**all**", data)]:
        pv = g["per_vessel"]
        lines.append(f"| {fam} | {_vessels(pv)} | {_q(pv['path_cost'], 100, 1)} | {_q(pv['time_cost_s'], 1, 1)} | "
                     f"{_q(pv.get('progress_lost_m'), 1, 1)} | {_known(pv.get('behind'))} | "
                     f"{_q(pv.get('max_mission_offset_m'), 1, 2)} | "
                     f"{_q(pv['mean_cross_track_m'], 1, 2)} | {_q(pv['max_cross_track_m'], 1, 2)} | "
                     f"{_q(pv['formation_error_m'], 1, 2)} | {pv['reference_short']} |")
    if data.get("mission"):  # chained missions (docs/missions.md)
        lines += ["", "Missions (median / p95 / max over the completed runs; arrival: go-to-formation, over the runs "
                  "where every vessel arrived: how many when not all):", "",
                  "| family | mission completed [Wilson 95 %] | arrival spread [s] | arrival position error [m] |",
                  "|---|---|---|---|"]
        for fam, g in list(data["families"].items()) + [("**all**", data)]:
            m = g.get("mission")
            if m:
                runs = m["completed"]["n"]
                lines.append(f"| {fam} | {_pct(m['completed'])} | {_q3(m['arrival_spread_s'], runs)} | "
                             f"{_q3(m['arrival_position_error_m'], runs)} |")
    lines += _tracking_lines([(fam, None, g) for fam, g in list(data["families"].items()) + [("**all**", data)]],
                             gospa_label(data))
    return "\n".join(lines + _failed_lines(data)) + "\n"


def _tracking_lines(rows, label: str) -> list[str]:
    """The tracking table — per (family, method or None, statistics): the runs' mean GOSPA and
    position RMSE (median / p95 / max over the runs) and the identity switches — or nothing when no
    run was scored (no vessel with perception)."""
    rows = [r for r in rows if r[2].get("gospa_mean_m")]
    if not rows:
        return []
    with_m = any(m is not None for _, m, _ in rows)
    head = "| family | method | runs scored " if with_m else "| family | runs scored "
    lines = ["", f"Tracking against the truth (each run's mean GOSPA over its vessels and record ticks, {label}, "
                 "and its position RMSE over the assigned pairs: median / p95 / max over the runs; "
                 "identity switches summed; docs/campaigns.md, \"Outputs and metrics\"):", "",
             head + "| mean GOSPA per run [m] | position RMSE per run [m] | identity switches |",
             "|---|---|---:|---|---|---:|" if with_m else "|---|---:|---|---|---:|"]

    def three(q):
        return "—" if not q else f"{q['p50']:.3f} / {q['p95']:.3f} / {q['p100']:.3f}"

    for fam, m, g in rows:
        q = g["gospa_mean_m"]
        lines.append(f"| {fam} | " + (f"{m} | " if with_m else "") + f"{q['n']} | {three(q)} | "
                     f"{three(g.get('position_rmse_m'))} | {g['id_switches']} |")
    return lines


def _q3(q: dict | None, runs: int | None = None) -> str:
    """median / p95 / max; with ``runs``, how many of them the figures rest on when not all (a run
    whose team never reached its formation poses has no arrival spread)."""
    if not q:
        return "—" if not runs else f"— (0 of {runs} runs)"
    out = f"{q['p50']:.2f} / {q['p95']:.2f} / {q['p100']:.2f}"
    return out if runs is None or q["n"] >= runs else f"{out} ({q['n']} of {runs} runs)"


def _sep3(q: dict | None) -> str:
    return "—" if not q else f"{q['p0']:.2f} / {q['p5']:.2f} / {q['p50']:.2f}"


def _med(q: dict | None, scale: float, digits: int, sign: bool = False) -> str:
    return "—" if not q else f"{scale * q['p50']:{'+' if sign else ''}.{digits}f}"


def _comparison_rows(data: dict):
    """``(family, method, group)`` per family and method, then ``**all**`` per method."""
    for fam in data["families"]:
        for m, gm in data["methods"].items():
            if fam in gm["families"]:
                yield fam, m, gm["families"][fam]
    for m, gm in data["methods"].items():
        yield "**all**", m, gm


def _format_comparison(data: dict) -> str:
    """The Markdown of a campaign comparing methods (module docstring)."""
    c = data["campaign"]
    methods = list(data["methods"])
    lines = [*_title(c),
             f"{data['runs_recorded']} of {data['runs_defined']} runs recorded, {data['runs_failed']} failed "
             f"({_statuses(data)}). "
             f"Methods compared: {', '.join(methods)} (each generated run once per method, the same scenario but "
             f"for its {c.get('compared_tables', 'avoidance')} tables).", *_before_cpa(data), "",
             *hull_table(data.get("hulls"), list(data["families"])),
             "| family | method | runs | collision [Wilson 95 %] | near miss [Wilson 95 %] "
             "| min separation: min / p5 / median [m] | COLREG compliant (encounters with a role) "
             "| path cost, median [%] "
             "| time cost, median [s] | actions |", "|---|---|---:|---|---|---|---|---:|---:|---|"]
    for fam, m, g in _comparison_rows(data):
        acts = ", ".join(f"{k} {v}" for k, v in sorted(g["actions"].items()) if v) or "—"
        pv = g["per_vessel"]
        lines.append(f"| {fam} | {m} | {g['completed']} | {_pct(g['collision'])} | {_pct(g['near_miss'])} | "
                     f"{_sep3(g['min_separation_m'])} | {_pct(g['colreg']['compliant'])} | "
                     f"{_med(pv['path_cost'], 100, 1, True)} | {_med(pv['time_cost_s'], 1, 1, True)} | {acts} |")
    lines += ["", "Per vessel, median / p95 over the vessels of the completed runs; cost against the same mission "
                  "without traffic, with the same method (*lost* / *behind*: how much less progress than without "
                  f"traffic by the run's end, and the vessels more than {BEHIND_M:g} m behind; *off mission*: the "
                  "largest distance from the mission path, detours included — the same measure for every method; "
                  "*short*: vessels whose reference never got as far, no time cost):", "",
              "| family | method | vessels | path cost [%] | time cost [s] | progress lost [m] | behind "
              "| off mission [m] | mean cross-track [m] | max cross-track [m] | formation error [m] | short |",
              "|---|---|---:|---|---|---|---:|---|---|---|---|---:|"]
    for fam, m, g in _comparison_rows(data):
        pv = g["per_vessel"]
        lines.append(f"| {fam} | {m} | {_vessels(pv)} | {_q(pv['path_cost'], 100, 1)} | "
                     f"{_q(pv['time_cost_s'], 1, 1)} | {_q(pv.get('progress_lost_m'), 1, 1)} | "
                     f"{_known(pv.get('behind'))} | {_q(pv.get('max_mission_offset_m'), 1, 2)} | "
                     f"{_q(pv['mean_cross_track_m'], 1, 2)} | {_q(pv['max_cross_track_m'], 1, 2)} | "
                     f"{_q(pv['formation_error_m'], 1, 2)} | {pv['reference_short']} |")
    for m, p in (data.get("paired") or {}).items():
        base = p["baseline"]
        lines += ["", f"{m} against {base} on the same runs (both completed): collisions with only one of them, "
                      f"and how often {m}'s minimum separation was larger or smaller than {base}'s:", "",
                  f"| family | pairs | collision only {base} | collision only {m} | both collide "
                  f"| separation larger | separation smaller |", "|---|---:|---:|---:|---:|---:|---:|"]
        for fam, cnt in p.items():
            if fam == "baseline":
                continue
            lines.append(f"| {'**all**' if fam == 'all' else fam} | {cnt['pairs']} | {cnt['collision_only_' + base]} | "
                         f"{cnt['collision_only_' + m]} | {cnt['collision_both']} | {cnt['separation_larger']} | "
                         f"{cnt['separation_smaller']} |")
    lines += _tracking_lines(list(_comparison_rows(data)), gospa_label(data))
    return "\n".join(lines + _failed_lines(data)) + "\n"


def _q(q: dict | None, scale: float, digits: int) -> str:
    """``median / p95`` of a quantiles dict, scaled; — when there are none."""
    return "—" if not q else f"{scale * q['p50']:.{digits}f} / {scale * q['p95']:.{digits}f}"


# ---------------------------------------------------------------------- figures
def write_report(folder: str | Path, out_dir: str | Path | None = None, formats=("png", "svg")) -> dict:
    """Write ``report.md`` and the figures (module docstring); returns ``{"data", "files"}``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    folder = Path(folder)
    out = Path(out_dir) if out_dir is not None else folder / "report"
    data = report_data(folder)  # (first: a folder without a store gets no report folder)
    out.mkdir(parents=True, exist_ok=True)
    files: list[Path] = []
    (out / "report.md").write_text(format_report(data))
    files.append(out / "report.md")
    with CampaignStore.open_existing(folder) as store:
        runs = [r for r in store.runs() if r.status == "completed"]
    fams = family_order(runs)
    ticks = family_ticks(data.get("hulls"), fams)  # (a family's hulls under its name when one is a folder)
    if not runs:
        return {"data": data, "files": files}
    if data.get("methods"):
        files += comparison_figures(plt, data, runs, out, formats)
        return {"data": data, "files": files}
    # rates with Wilson intervals
    fig, ax = plt.subplots(figsize=(max(5, 1.4 * len(fams) + 2), 4))
    x = np.arange(len(fams))
    for off, key, col in ((-0.18, "collision", "tab:red"), (0.18, "near_miss", "tab:orange")):
        rates, lo, hi = [], [], []
        for f in fams:
            g = data["families"][f][key]
            rates.append(100 * (g["rate"] or 0.0))
            w = g["wilson95"] or [0, 0]
            lo.append(100 * (g["rate"] or 0.0) - 100 * w[0])
            hi.append(100 * w[1] - 100 * (g["rate"] or 0.0))
        ax.bar(x + off, rates, width=0.36, color=col, label=key.replace("_", " "))
        ax.errorbar(x + off, rates, yerr=[lo, hi], fmt="none", ecolor="black", capsize=3)
    ax.set_xticks(x, ticks, rotation=20, ha="right")
    ax.set_ylabel("runs [%] (bars: Wilson 95 %)")
    ax.set_title("Collision and near-miss rate per encounter family")
    ax.legend()
    fig.tight_layout()
    files += save(fig, out, "rates", formats)
    plt.close(fig)
    # separation distributions
    fig, ax = plt.subplots(figsize=(max(5, 1.4 * len(fams) + 2), 4))
    seps = [[run_outcome(r.metrics)["min_separation_m"] for r in runs if r.family == f] for f in fams]
    ax.boxplot([[s for s in v if s is not None] or [np.nan] for v in seps], showfliers=True)
    ax.set_xticks(np.arange(1, len(fams) + 1), ticks, rotation=20, ha="right")
    ax.axhline(0.0, color="tab:red", lw=1, ls="--")
    ax.set_ylabel("minimum separation [m]\n(< 0: hull circles overlap)")
    ax.set_title("Minimum separation per run")
    fig.tight_layout()
    files += save(fig, out, "separation", formats)
    plt.close(fig)
    # outcome maps
    for f in fams:
        fr = [r for r in runs if r.family == f]
        params = numeric_params(fr)
        if len(params) < 2:
            continue
        outcomes = [run_outcome(r.metrics) for r in fr]
        title = family_title(data.get("hulls"), f)
        files += outcome_map(plt, fr, outcomes, params[0], params[1], title, out, f"outcomes_{f}", formats)
    # COLREG compliance per role
    per_role: dict[str, list[int]] = defaultdict(lambda: [0, 0])
    for r in runs:
        for e in (r.metrics or {}).get("evaluation", {}).get("encounters", []):
            if e["role"] == "none":  # no risk of collision: nothing asked, not judged
                continue
            per_role[e["role"]][0] += bool(e["compliant"])
            per_role[e["role"]][1] += 1
    if per_role:
        roles = sorted(per_role)
        fig, ax = plt.subplots(figsize=(max(5, 1.3 * len(roles) + 2), 4))
        rate = [100 * per_role[k][0] / per_role[k][1] for k in roles]
        w = [wilson_interval(*per_role[k]) for k in roles]
        ax.bar(np.arange(len(roles)), rate, color="tab:blue")
        ax.errorbar(np.arange(len(roles)), rate, yerr=[[r - 100 * a for r, (a, b) in zip(rate, w)],
                                                       [100 * b - r for r, (a, b) in zip(rate, w)]],
                    fmt="none", ecolor="black", capsize=3)
        ax.set_xticks(np.arange(len(roles)), [f"{k}\n(n = {per_role[k][1]})" for k in roles], fontsize=8)
        ax.set_ylabel("compliant encounters [%]")
        ax.set_ylim(0, 105)
        ax.set_title("COLREG compliance per role of the own vessel")
        fig.tight_layout()
        files += save(fig, out, "colreg", formats)
        plt.close(fig)
    # tracking
    gospa = [[run_outcome(r.metrics)["gospa_mean_m"] for r in runs if r.family == f] for f in fams]
    if any(v is not None for g in gospa for v in g):
        fig, ax = plt.subplots(figsize=(max(5, 1.4 * len(fams) + 2), 4))
        ax.boxplot([[v for v in g if v is not None] or [np.nan] for g in gospa])
        ax.set_xticks(np.arange(1, len(fams) + 1), ticks, rotation=20, ha="right")
        ax.set_ylabel(f"mean GOSPA per run [m] ({gospa_label(data)})")
        ax.set_title("Tracking accuracy against the truth")
        fig.tight_layout()
        files += save(fig, out, "tracking", formats)
        plt.close(fig)
    # mission cost per vessel
    samples = {f: [run_outcome(r.metrics)["per_vessel"] for r in runs if r.family == f] for f in fams}
    if any(o["path_cost"] for f in fams for o in samples[f]):
        fig, axes = plt.subplots(1, 2, figsize=(max(8, 2.4 * len(fams) + 3), 4))
        for ax, key, scale, label in ((axes[0], "path_cost", 100.0, "extra distance for the same progress [%]"),
                                      (axes[1], "time_cost_s", 1.0, "later than without traffic [s]")):
            ax.boxplot([[scale * x for o in samples[f] for x in o[key]] or [np.nan] for f in fams])
            ax.set_xticks(np.arange(1, len(fams) + 1), ticks, rotation=20, ha="right")
            ax.axhline(0.0, color="grey", lw=1, ls="--")
            ax.set_ylabel(label)
        fig.suptitle("Mission cost per vessel against the same mission without traffic")
        fig.tight_layout()
        files += save(fig, out, "cost", formats)
        plt.close(fig)
    return {"data": data, "files": files}


# ---------------------------------------------------------------------- figures of a comparison
