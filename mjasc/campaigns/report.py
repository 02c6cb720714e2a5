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

The Markdown has two tables per family: outcomes (rates, separation, compliance, actions) and per
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

from mjasc.campaigns.statistics import aggregate, run_outcome, wilson_interval
from mjasc.campaigns.store import CampaignStore

__all__ = ["report_data", "write_report", "format_report"]


def report_data(folder: str | Path) -> dict:
    """Everything the report shows, as one JSON-ready object: ``runs_defined``, ``runs_recorded``
    (distinct runs with a result), ``runs_failed``, ``outcomes`` (counts per status and of
    collisions and near misses), ``families`` and overall statistics, ``campaign`` (name, digest)."""
    with CampaignStore.open_existing(folder) as store:
        info = store.info()
        runs = store.runs()
        order = _file_methods(store.file_text())
    agg = aggregate(runs, info.get("runs_defined"), methods=order)
    outcomes = dict(agg["statuses"])
    outcomes["collision"] = agg["collision"]["count"]
    outcomes["near_miss"] = agg["near_miss"]["count"]
    return {"campaign": {k: info.get(k) for k in ("name", "digest", "source")},
            "runs_defined": agg["runs_defined"], "runs_recorded": agg["runs_recorded"],
            "runs_failed": agg["runs_failed"], "outcomes": outcomes, **{k: v for k, v in agg.items() if k not in (
                "runs_defined", "runs_recorded", "runs_failed")}}


def _file_methods(text: str) -> list[str]:
    """The method labels in the campaign file's order (from the stored file), or []."""
    import json

    try:
        entries = json.loads(text).get("methods") or []
    except (ValueError, AttributeError):
        return []
    out = []
    for e in entries if isinstance(entries, list) else []:
        label = e if isinstance(e, str) else (e.get("label", e.get("name")) if isinstance(e, dict) else None)
        if isinstance(label, str):
            out.append(label)
    return out


def _pct(r: dict) -> str:
    if r["rate"] is None:
        return "—"
    lo, hi = r["wilson95"]
    return f"{r['count']}/{r['n']} = {100 * r['rate']:.1f} % [{100 * lo:.1f}, {100 * hi:.1f}]"


def format_report(data: dict) -> str:
    """The report's table as Markdown (also printed by ``mjasc report``)."""
    if data.get("methods"):
        return _format_comparison(data)
    c = data["campaign"]
    lines = [f"# Campaign {c.get('name')} (digest {str(c.get('digest'))[:12]})", "",
             f"{data['runs_recorded']} of {data['runs_defined']} runs recorded, {data['runs_failed']} failed "
             f"(statuses: {', '.join(f'{k} {v}' for k, v in sorted(data['statuses'].items()))}).", "",
             "| family | runs | collision [Wilson 95 %] | near miss [Wilson 95 %] | min separation: min / median [m] "
             "| COLREG compliant | actions |", "|---|---:|---|---|---|---|---|"]
    for fam, g in list(data["families"].items()) + [("**all**", data)]:
        q = g["min_separation_m"]
        sep = "—" if not q else f"{q['p0']:.2f} / {q['p50']:.2f}"
        acts = ", ".join(f"{k} {v}" for k, v in sorted(g["actions"].items()) if v) or "—"
        lines.append(f"| {fam} | {g['completed']} | {_pct(g['collision'])} | {_pct(g['near_miss'])} | {sep} | "
                     f"{_pct(g['colreg']['compliant'])} | {acts} |")
    lines += ["", "Per vessel, median / p95 over the vessels of the completed runs; cost against the same mission "
                  "without traffic (path: extra distance for the same progress; time: later than without traffic "
                  "by; *short*: vessels whose reference never got as far, no time cost):", "",
              "| family | vessels | path cost [%] | time cost [s] | mean cross-track [m] | max cross-track [m] "
              "| formation error [m] | short |", "|---|---:|---|---|---|---|---|---:|"]
    for fam, g in list(data["families"].items()) + [("**all**", data)]:
        pv = g["per_vessel"]
        n = max((q["n"] for k, q in pv.items() if k != "reference_short" and q), default=0)
        lines.append(f"| {fam} | {n} | {_q(pv['path_cost'], 100, 1)} | {_q(pv['time_cost_s'], 1, 1)} | "
                     f"{_q(pv['mean_cross_track_m'], 1, 2)} | {_q(pv['max_cross_track_m'], 1, 2)} | "
                     f"{_q(pv['formation_error_m'], 1, 2)} | {pv['reference_short']} |")
    return "\n".join(lines) + "\n"


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
    lines = [f"# Campaign {c.get('name')} (digest {str(c.get('digest'))[:12]})", "",
             f"{data['runs_recorded']} of {data['runs_defined']} runs recorded, {data['runs_failed']} failed "
             f"(statuses: {', '.join(f'{k} {v}' for k, v in sorted(data['statuses'].items()))}). "
             f"Methods compared: {', '.join(methods)} (each generated run once per method, the same scenario but "
             f"for its avoidance tables).", "",
             "| family | method | runs | collision [Wilson 95 %] | near miss [Wilson 95 %] "
             "| min separation: min / p5 / median [m] | COLREG compliant | path cost, median [%] "
             "| time cost, median [s] | actions |", "|---|---|---:|---|---|---|---|---:|---:|---|"]
    for fam, m, g in _comparison_rows(data):
        acts = ", ".join(f"{k} {v}" for k, v in sorted(g["actions"].items()) if v) or "—"
        pv = g["per_vessel"]
        lines.append(f"| {fam} | {m} | {g['completed']} | {_pct(g['collision'])} | {_pct(g['near_miss'])} | "
                     f"{_sep3(g['min_separation_m'])} | {_pct(g['colreg']['compliant'])} | "
                     f"{_med(pv['path_cost'], 100, 1, True)} | {_med(pv['time_cost_s'], 1, 1, True)} | {acts} |")
    lines += ["", "Per vessel, median / p95 over the vessels of the completed runs; cost against the same mission "
                  "without traffic, with the same method (*short*: vessels whose reference never got as far, no "
                  "time cost):", "",
              "| family | method | vessels | path cost [%] | time cost [s] | mean cross-track [m] | max cross-track [m] "
              "| formation error [m] | short |", "|---|---|---:|---|---|---|---|---|---:|"]
    for fam, m, g in _comparison_rows(data):
        pv = g["per_vessel"]
        n = max((q["n"] for k, q in pv.items() if k != "reference_short" and q), default=0)
        lines.append(f"| {fam} | {m} | {n} | {_q(pv['path_cost'], 100, 1)} | {_q(pv['time_cost_s'], 1, 1)} | "
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
    return "\n".join(lines) + "\n"


def _q(q: dict | None, scale: float, digits: int) -> str:
    """``median / p95`` of a quantiles dict, scaled; — when there are none."""
    return "—" if not q else f"{scale * q['p50']:.{digits}f} / {scale * q['p95']:.{digits}f}"


# ---------------------------------------------------------------------- figures
def _numeric_params(runs) -> list[str]:
    """The family's numeric parameters that vary (among those every run has: an Imazu case with one
    target has no ``t2.dcpa_m``), the encounter's geometry first (bearing or
    aspect, DCPA, TCPA, speed ratio: what an outcome map is read against), then the others, each
    group most varied first (by the number of distinct values)."""
    values: dict[str, set] = defaultdict(set)
    common = set.intersection(*(set(r.parameters) for r in runs)) if runs else set()
    for r in runs:
        for k, v in r.parameters.items():
            if k in common and isinstance(v, (int, float)) and not isinstance(v, bool) and k != "attempts":
                values[k].add(round(float(v), 9))

    def rank(item):
        name, distinct = item
        base = name.rsplit(".", 1)[-1]  # t2.dcpa_m → dcpa_m
        return (_GEOMETRY.index(base) if base in _GEOMETRY else len(_GEOMETRY), -len(distinct))

    ordered = [k for k, s in sorted(values.items(), key=rank) if len(s) > 1]
    # bearing and aspect: one follows from the other (with speed ratio, DCPA, TCPA): map one of them
    angles = [k for k in ordered if k.rsplit(".", 1)[-1] in _GEOMETRY[:2]]
    return [k for k in ordered if k not in angles[1:]]


#: Encounter parameters an outcome map is drawn over first, in this order.
_GEOMETRY = ("relative_bearing_deg", "relative_course_deg", "dcpa_m", "tcpa_s", "speed_ratio", "case")


def _save(fig, out: Path, stem: str, formats) -> list[Path]:
    paths = []
    for fmt in formats:
        p = out / f"{stem}.{fmt}"
        fig.savefig(p, dpi=120)
        paths.append(p)
    return paths


def write_report(folder: str | Path, out_dir: str | Path | None = None, formats=("png", "svg")) -> dict:
    """Write ``report.md`` and the figures (module docstring); returns ``{"data", "files"}``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    folder = Path(folder)
    out = Path(out_dir) if out_dir is not None else folder / "report"
    out.mkdir(parents=True, exist_ok=True)
    data = report_data(folder)
    files: list[Path] = []
    (out / "report.md").write_text(format_report(data))
    files.append(out / "report.md")
    with CampaignStore.open_existing(folder) as store:
        runs = [r for r in store.runs() if r.status == "completed"]
    fams = sorted({r.family for r in runs})
    if not runs:
        return {"data": data, "files": files}
    if data.get("methods"):
        files += _comparison_figures(plt, data, runs, out, formats)
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
    ax.set_xticks(x, fams, rotation=20, ha="right")
    ax.set_ylabel("runs [%] (bars: Wilson 95 %)")
    ax.set_title("Collision and near-miss rate per encounter family")
    ax.legend()
    fig.tight_layout()
    files += _save(fig, out, "rates", formats)
    plt.close(fig)
    # separation distributions
    fig, ax = plt.subplots(figsize=(max(5, 1.4 * len(fams) + 2), 4))
    seps = [[run_outcome(r.metrics)["min_separation_m"] for r in runs if r.family == f] for f in fams]
    ax.boxplot([[s for s in v if s is not None] or [np.nan] for v in seps], showfliers=True)
    ax.set_xticks(np.arange(1, len(fams) + 1), fams, rotation=20, ha="right")
    ax.axhline(0.0, color="tab:red", lw=1, ls="--")
    ax.set_ylabel("minimum separation [m]\n(< 0: hull circles overlap)")
    ax.set_title("Minimum separation per run")
    fig.tight_layout()
    files += _save(fig, out, "separation", formats)
    plt.close(fig)
    # outcome maps
    for f in fams:
        fr = [r for r in runs if r.family == f]
        params = _numeric_params(fr)
        if len(params) < 2:
            continue
        px, py = params[0], params[1]
        xs = np.array([r.parameters[px] for r in fr], dtype=float)
        ys = np.array([r.parameters[py] for r in fr], dtype=float)
        sep = np.array([run_outcome(r.metrics)["min_separation_m"] or np.nan for r in fr], dtype=float)
        coll = np.array([run_outcome(r.metrics)["collision"] for r in fr])
        fig, ax = plt.subplots(figsize=(6, 4.5))
        sc = ax.scatter(xs, ys, c=sep, cmap="viridis", s=30)
        if coll.any():
            ax.scatter(xs[coll], ys[coll], marker="x", color="tab:red", s=60, label="collision")
            ax.legend()
        fig.colorbar(sc, ax=ax, label="minimum separation [m]")
        ax.set_xlabel(px)
        ax.set_ylabel(py)
        ax.set_title(f"{f}: outcome over {px} × {py}")
        fig.tight_layout()
        files += _save(fig, out, f"outcomes_{f}", formats)
        plt.close(fig)
    # COLREG compliance per role
    per_role: dict[str, list[int]] = defaultdict(lambda: [0, 0])
    for r in runs:
        for e in (r.metrics or {}).get("evaluation", {}).get("encounters", []):
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
        files += _save(fig, out, "colreg", formats)
        plt.close(fig)
    # tracking
    gospa = [[run_outcome(r.metrics)["gospa_mean_m"] for r in runs if r.family == f] for f in fams]
    if any(v is not None for g in gospa for v in g):
        fig, ax = plt.subplots(figsize=(max(5, 1.4 * len(fams) + 2), 4))
        ax.boxplot([[v for v in g if v is not None] or [np.nan] for g in gospa])
        ax.set_xticks(np.arange(1, len(fams) + 1), fams, rotation=20, ha="right")
        ax.set_ylabel("mean GOSPA per run [m] (c = 10 m, p = 2)")
        ax.set_title("Tracking accuracy against the truth")
        fig.tight_layout()
        files += _save(fig, out, "tracking", formats)
        plt.close(fig)
    # mission cost per vessel
    samples = {f: [run_outcome(r.metrics)["per_vessel"] for r in runs if r.family == f] for f in fams}
    if any(o["path_cost"] for f in fams for o in samples[f]):
        fig, axes = plt.subplots(1, 2, figsize=(max(8, 2.4 * len(fams) + 3), 4))
        for ax, key, scale, label in ((axes[0], "path_cost", 100.0, "extra distance for the same progress [%]"),
                                      (axes[1], "time_cost_s", 1.0, "later than without traffic [s]")):
            ax.boxplot([[scale * x for o in samples[f] for x in o[key]] or [np.nan] for f in fams])
            ax.set_xticks(np.arange(1, len(fams) + 1), fams, rotation=20, ha="right")
            ax.axhline(0.0, color="grey", lw=1, ls="--")
            ax.set_ylabel(label)
        fig.suptitle("Mission cost per vessel against the same mission without traffic")
        fig.tight_layout()
        files += _save(fig, out, "cost", formats)
        plt.close(fig)
    return {"data": data, "files": files}


# ---------------------------------------------------------------------- figures of a comparison
def _grouped_bars(ax, cats: list[str], series: dict) -> None:
    """Bars per category, one per series side by side: ``series[label] = (values, lo, hi)``
    (values in %, lo/hi the interval's ends, or None for no error bar)."""
    k = max(1, len(series))
    width = 0.8 / k
    x = np.arange(len(cats))
    for j, (label, (vals, lo, hi)) in enumerate(series.items()):
        pos = x - 0.4 + width * (j + 0.5)
        ax.bar(pos, vals, width=width * 0.95, color=f"C{j}", label=label)
        if lo is not None:
            ax.errorbar(pos, vals, yerr=[np.subtract(vals, lo), np.subtract(hi, vals)], fmt="none", ecolor="black",
                        capsize=2)
    ax.set_xticks(x, cats, rotation=20, ha="right")


def _grouped_boxes(ax, cats: list[str], series: dict) -> None:
    """Box plots per category, one per series side by side: ``series[label] = [values per category]``."""
    k = max(1, len(series))
    width = 0.8 / k
    x = np.arange(len(cats))
    for j, (label, per_cat) in enumerate(series.items()):
        pos = x - 0.4 + width * (j + 0.5)
        bp = ax.boxplot([[v for v in vals if v is not None] or [np.nan] for vals in per_cat], positions=pos,
                        widths=width * 0.85, patch_artist=True, manage_ticks=False,
                        medianprops={"color": "black"})
        for patch in bp["boxes"]:
            patch.set_facecolor(f"C{j}")
            patch.set_alpha(0.6)
        ax.plot([], [], color=f"C{j}", lw=6, alpha=0.6, label=label)
    ax.set_xticks(x, cats, rotation=20, ha="right")
    ax.set_xlim(-0.6, len(cats) - 0.4)


def _comparison_figures(plt, data: dict, runs, out: Path, formats) -> list[Path]:
    """The figures of a campaign comparing methods (module docstring)."""
    files: list[Path] = []
    methods = list(data["methods"])
    fams = sorted({r.family for r in runs})
    outcome = {(r.index, r.method): run_outcome(r.metrics) for r in runs}

    def of(m, f):
        return [outcome[(r.index, r.method)] for r in runs if r.method == m and r.family == f]

    def rate_series(key):
        series = {}
        for m in methods:
            vals, lo, hi = [], [], []
            for f in fams:
                g = data["methods"][m]["families"].get(f, {}).get(key) or {"rate": None, "wilson95": None}
                vals.append(100 * (g["rate"] or 0.0))
                w = g["wilson95"] or [g["rate"] or 0.0] * 2
                lo.append(100 * w[0])
                hi.append(100 * w[1])
            series[m] = (vals, lo, hi)
        return series

    fig, axes = plt.subplots(1, 2, figsize=(max(9, 2.2 * len(fams) + 3), 4.2))
    for ax, key, title in ((axes[0], "collision", "collision"), (axes[1], "near_miss", "near miss (< 1 m, no contact)")):
        _grouped_bars(ax, fams, rate_series(key))
        ax.set_ylabel("runs [%] (bars: Wilson 95 %)")
        ax.set_title(title)
    axes[0].legend(title="method")
    fig.suptitle("Collision and near-miss rate per encounter family and method")
    fig.tight_layout()
    files += _save(fig, out, "rates", formats)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(max(6, 1.8 * len(fams) + 2), 4.2))
    _grouped_boxes(ax, fams, {m: [[o["min_separation_m"] for o in of(m, f)] for f in fams] for m in methods})
    ax.axhline(0.0, color="tab:red", lw=1, ls="--")
    ax.set_ylabel("minimum separation [m]\n(< 0: hull circles overlap)")
    ax.set_title("Minimum separation per run and method")
    ax.legend(title="method")
    fig.tight_layout()
    files += _save(fig, out, "separation", formats)
    plt.close(fig)

    for f in fams:  # outcome maps per family and method, on shared axes and colour scale
        fr = [r for r in runs if r.family == f]
        params = _numeric_params(fr)
        if len(params) < 2:
            continue
        px, py = params[0], params[1]
        seps = [outcome[(r.index, r.method)]["min_separation_m"] for r in fr]
        seps = [s for s in seps if s is not None]
        vmin, vmax = (min(seps), max(seps)) if seps else (0.0, 1.0)
        for m in methods:
            mr = [r for r in fr if r.method == m]
            if not mr:
                continue
            xs = np.array([r.parameters[px] for r in mr], dtype=float)
            ys = np.array([r.parameters[py] for r in mr], dtype=float)
            sep = np.array([outcome[(r.index, m)]["min_separation_m"] or np.nan for r in mr], dtype=float)
            coll = np.array([outcome[(r.index, m)]["collision"] for r in mr])
            fig, ax = plt.subplots(figsize=(6, 4.5))
            sc = ax.scatter(xs, ys, c=sep, cmap="viridis", s=30, vmin=vmin, vmax=vmax)
            if coll.any():
                ax.scatter(xs[coll], ys[coll], marker="x", color="tab:red", s=60, label="collision")
                ax.legend()
            fig.colorbar(sc, ax=ax, label="minimum separation [m]")
            ax.set_xlabel(px)
            ax.set_ylabel(py)
            ax.set_title(f"{f}, {m}: outcome over {px} × {py}")
            fig.tight_layout()
            files += _save(fig, out, f"outcomes_{f}_{m}", formats)
            plt.close(fig)

    per_role: dict = defaultdict(lambda: [0, 0])
    for r in runs:
        for e in (r.metrics or {}).get("evaluation", {}).get("encounters", []):
            per_role[(e["role"], r.method)][0] += bool(e["compliant"])
            per_role[(e["role"], r.method)][1] += 1
    if per_role:
        roles = sorted({k[0] for k in per_role})
        series = {}
        for m in methods:
            vals, lo, hi = [], [], []
            for role in roles:
                k, n = per_role.get((role, m), [0, 0])
                w = wilson_interval(k, n) or (0.0, 0.0)
                vals.append(100 * k / n if n else 0.0)
                lo.append(100 * w[0])
                hi.append(100 * w[1])
            series[m] = (vals, lo, hi)
        fig, ax = plt.subplots(figsize=(max(6, 1.8 * len(roles) + 2), 4.2))
        _grouped_bars(ax, roles, series)
        ax.set_xticks(np.arange(len(roles)), [f"{role}\n(n = {' / '.join(str(per_role.get((role, m), [0, 0])[1]) for m in methods)})"
                                              for role in roles], rotation=0, ha="center", fontsize=8)
        ax.set_ylabel("compliant encounters [%]")
        ax.set_ylim(0, 105)
        ax.set_title("COLREG compliance per role of the own vessel and method")
        ax.legend(title="method")
        fig.tight_layout()
        files += _save(fig, out, "colreg", formats)
        plt.close(fig)

    gospa = {m: [[o["gospa_mean_m"] for o in of(m, f)] for f in fams] for m in methods}
    if any(v is not None for g in gospa.values() for vals in g for v in vals):
        fig, ax = plt.subplots(figsize=(max(6, 1.8 * len(fams) + 2), 4.2))
        _grouped_boxes(ax, fams, gospa)
        ax.set_ylabel("mean GOSPA per run [m] (c = 10 m, p = 2)")
        ax.set_title("Tracking accuracy against the truth, per method")
        ax.legend(title="method")
        fig.tight_layout()
        files += _save(fig, out, "tracking", formats)
        plt.close(fig)

    if any(o["per_vessel"]["path_cost"] for o in outcome.values()):
        fig, axes = plt.subplots(1, 2, figsize=(max(10, 3.2 * len(fams) + 3), 4.2))
        for ax, key, scale, label in ((axes[0], "path_cost", 100.0, "extra distance for the same progress [%]"),
                                      (axes[1], "time_cost_s", 1.0, "later than without traffic [s]")):
            _grouped_boxes(ax, fams, {m: [[scale * x for o in of(m, f) for x in o["per_vessel"][key]] for f in fams]
                                      for m in methods})
            ax.axhline(0.0, color="grey", lw=1, ls="--")
            ax.set_ylabel(label)
        axes[0].legend(title="method")
        fig.suptitle("Mission cost per vessel against the same mission without traffic, per method")
        fig.tight_layout()
        files += _save(fig, out, "cost", formats)
        plt.close(fig)
    return files
