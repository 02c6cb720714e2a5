"""The campaign report's figures: outcome maps over a family's encounter parameters, grouped bars
and boxes for methods side by side, and the figures of a campaign comparing methods
(:mod:`mjasc.campaigns.report` lists them)."""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import numpy as np

from mjasc.campaigns.hull_records import family_ticks, family_title
from mjasc.campaigns.statistics import family_order, run_outcome, wilson_interval

__all__ = ["numeric_params", "outcome_map", "save", "comparison_figures"]


def numeric_params(runs) -> list[str]:
    """The family's numeric parameters that vary (among those every run has: an Imazu case with one
    target has no ``t2.dcpa_m``), the encounter's geometry first (bearing or
    aspect, DCPA, TCPA, speed ratio: what an outcome map is read against), then the others, each
    group most varied first (by the number of distinct values)."""
    values: dict[str, set] = defaultdict(set)
    common = set.intersection(*(set(r.parameters) for r in runs)) if runs else set()
    for r in runs:
        for k, v in r.parameters.items():
            if k in common and isinstance(v, (int, float)) and not isinstance(v, bool) and \
                    k not in ("draws", "attempts"):  # (how many draws a run took: "attempts" in older stores)
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


def outcome_map(plt, runs, outcomes, px: str, py: str, title: str, out: Path, stem: str, formats,
                 limits=(None, None)) -> list[Path]:
    """One family's runs over two of its parameters, coloured by minimum separation [m] (``limits``:
    the colour scale's ends, None: the data's), collisions marked."""
    xs = np.array([r.parameters[px] for r in runs], dtype=float)
    ys = np.array([r.parameters[py] for r in runs], dtype=float)
    sep = np.array([o["min_separation_m"] or np.nan for o in outcomes], dtype=float)
    coll = np.array([o["collision"] for o in outcomes])
    fig, ax = plt.subplots(figsize=(6, 4.5))
    sc = ax.scatter(xs, ys, c=sep, cmap="viridis", s=30, vmin=limits[0], vmax=limits[1])
    if coll.any():
        ax.scatter(xs[coll], ys[coll], marker="x", color="tab:red", s=60, label="collision")
        ax.legend()
    fig.colorbar(sc, ax=ax, label="minimum separation [m]")
    ax.set_xlabel(px)
    ax.set_ylabel(py)
    text = f"{title}: outcome over {px} × {py}"
    ax.set_title(text if len(text) <= 55 else f"{title}\noutcome over {px} × {py}")  # (within the figure's width)
    fig.tight_layout()
    paths = save(fig, out, stem, formats)
    plt.close(fig)
    return paths


def save(fig, out: Path, stem: str, formats) -> list[Path]:
    paths = []
    for fmt in formats:
        p = out / f"{stem}.{fmt}"
        fig.savefig(p, dpi=120)
        paths.append(p)
    return paths


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


def comparison_figures(plt, data: dict, runs, out: Path, formats) -> list[Path]:
    """The figures of a campaign comparing methods (module docstring)."""
    files: list[Path] = []
    methods = list(data["methods"])
    fams = family_order(runs)
    ticks = family_ticks(data.get("hulls"), fams)  # (a family's hulls under its name when one is a folder)
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
        _grouped_bars(ax, ticks, rate_series(key))
        ax.set_ylabel("runs [%] (bars: Wilson 95 %)")
        ax.set_title(title)
    axes[0].legend(title="method")
    fig.suptitle("Collision and near-miss rate per encounter family and method")
    fig.tight_layout()
    files += save(fig, out, "rates", formats)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(max(6, 1.8 * len(fams) + 2), 4.2))
    _grouped_boxes(ax, ticks, {m: [[o["min_separation_m"] for o in of(m, f)] for f in fams] for m in methods})
    ax.axhline(0.0, color="tab:red", lw=1, ls="--")
    ax.set_ylabel("minimum separation [m]\n(< 0: hull circles overlap)")
    ax.set_title("Minimum separation per run and method")
    ax.legend(title="method")
    fig.tight_layout()
    files += save(fig, out, "separation", formats)
    plt.close(fig)

    for f in fams:  # outcome maps per family and method, on shared axes and colour scale
        fr = [r for r in runs if r.family == f]
        params = numeric_params(fr)
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
            title = family_title(data.get("hulls"), f)
            files += outcome_map(plt, mr, [outcome[(r.index, m)] for r in mr], px, py, f"{title}, {m}", out,
                                  f"outcomes_{f}_{m}", formats, (vmin, vmax))

    per_role: dict = defaultdict(lambda: [0, 0])
    for r in runs:
        for e in (r.metrics or {}).get("evaluation", {}).get("encounters", []):
            if e["role"] == "none":  # no risk of collision: nothing asked, not judged
                continue
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
        files += save(fig, out, "colreg", formats)
        plt.close(fig)

    gospa = {m: [[o["gospa_mean_m"] for o in of(m, f)] for f in fams] for m in methods}
    if any(v is not None for g in gospa.values() for vals in g for v in vals):
        fig, ax = plt.subplots(figsize=(max(6, 1.8 * len(fams) + 2), 4.2))
        _grouped_boxes(ax, ticks, gospa)
        from mjasc.campaigns.report import gospa_label

        ax.set_ylabel(f"mean GOSPA per run [m] ({gospa_label(data)})")
        ax.set_title("Tracking accuracy against the truth, per method")
        ax.legend(title="method")
        fig.tight_layout()
        files += save(fig, out, "tracking", formats)
        plt.close(fig)

    if any(o["per_vessel"]["path_cost"] for o in outcome.values()):
        fig, axes = plt.subplots(1, 2, figsize=(max(10, 3.2 * len(fams) + 3), 4.2))
        for ax, key, scale, label in ((axes[0], "path_cost", 100.0, "extra distance for the same progress [%]"),
                                      (axes[1], "time_cost_s", 1.0, "later than without traffic [s]")):
            _grouped_boxes(ax, ticks, {m: [[scale * x for o in of(m, f) for x in o["per_vessel"][key]] for f in fams]
                                      for m in methods})
            ax.axhline(0.0, color="grey", lw=1, ls="--")
            ax.set_ylabel(label)
        axes[0].legend(title="method")
        fig.suptitle("Mission cost per vessel against the same mission without traffic, per method")
        fig.tight_layout()
        files += save(fig, out, "cost", formats)
        plt.close(fig)
    return files
