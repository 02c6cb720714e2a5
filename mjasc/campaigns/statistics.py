"""Campaign statistics: outcome rates with Wilson score intervals, quantiles, per encounter family.

Per run (from its summary, :func:`run_outcome`): collision (hull contact), near miss (an encounter's
separation below the near-miss distance, and no collision), the minimum separation over the run
(the smallest clearance between a vessel's bounding circle and anything), the mean and max
cross-track error, the CAS actions by kind, the COLREG compliance of its encounters with traffic (over
those with a role: ``none``, no risk of collision, asks nothing), and tracking quality (mean GOSPA,
identity switches). Per vessel of a run (:func:`vessel_samples`, lists over the vessels): the
mission cost against the same mission without traffic (``evaluation.cost``,
:mod:`mjasc.evaluation.mission_cost`: ``path_cost`` relative extra distance,
``time_cost_s``), the mean and max |cross-track error| (``vessels.<v>``, :mod:`mjasc.runs.metrics`)
and the formation error — the vessel's mean and max |lead| over its neighbours in metres of path,
as its coordination reports it (``vessels.<v>.coordination.mean_abs_error_m`` /
``max_abs_error_m``). Per family and overall (:func:`aggregate`): counts per status, collision and
near-miss rates with Wilson 95 % intervals, separation quantiles, compliance rate, actions,
``ended_before_cpa`` (completed encounter runs cut before a target's TCPA: counted, and said under
the printed table and the report, since their outcome says nothing about the encounter),
tracking means, throughput, and ``per_vessel``: quantiles (median p50, p95, …) of each per-vessel
value over every vessel of every completed run, with ``reference_short`` counting the vessels whose
reference never got as far as they did (no time cost).

A campaign comparing avoidance methods (runs stored with a method label) also gets ``methods``:
per label, the same statistics over that method's runs, overall and per family (``families``);
the top-level figures then pool every method's runs.
"""

from __future__ import annotations

import math
from collections import Counter, defaultdict

import numpy as np

__all__ = ["Z95", "wilson_interval", "quantiles", "run_outcome", "vessel_samples", "aggregate", "format_aggregate",
           "ended_before_cpa", "before_cpa_note", "method_order", "paired"]

#: Per-vessel values (:func:`vessel_samples`): name → (where in the summary, field).
PER_VESSEL = {"path_cost": ("cost", "path_cost"), "time_cost_s": ("cost", "time_cost_s"),
              "progress_lost_m": ("cost", "progress_lost_m"),
              "mean_cross_track_m": ("vessel", "mean_cross_track_m"),
              "max_cross_track_m": ("vessel", "max_cross_track_m"),
              "max_mission_offset_m": ("vessel", "max_mission_offset_m"),
              "formation_error_m": ("coordination", "mean_abs_error_m"),
              "formation_max_error_m": ("coordination", "max_abs_error_m")}

#: A vessel that ends more than this short of its reference's progress is counted ``behind`` [m].
BEHIND_M = 1.0

#: z for a two-sided 95 % interval.
Z95 = 1.959963984540054
QUANTILES = (0.0, 0.05, 0.25, 0.5, 0.75, 0.95, 1.0)


def wilson_interval(successes: int, n: int, z: float = Z95) -> tuple[float, float] | None:
    """Wilson score interval for a binomial proportion (Wilson 1927):
    ``(p̂ + z²/2n ± z·√(p̂(1−p̂)/n + z²/4n²)) / (1 + z²/n)``; None for n = 0."""
    if n <= 0:
        return None
    if not 0 <= successes <= n:
        raise ValueError(f"successes: must be in [0, n={n}], got {successes}")
    p = successes / n
    denom = 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    lo = 0.0 if successes == 0 else max(0.0, centre - half)  # exact 0 and 1 at the ends (no round-off)
    hi = 1.0 if successes == n else min(1.0, centre + half)
    return lo, hi


def quantiles(values) -> dict | None:
    """p0, p5, p25, p50, p75, p95, p100, mean, std, n of the non-None values (None when empty)."""
    x = np.asarray([v for v in values if v is not None], dtype=float)
    if x.size == 0:
        return None
    q = np.quantile(x, QUANTILES)
    out = {f"p{round(100 * p)}": round(float(v), 4) for p, v in zip(QUANTILES, q)}
    out.update(mean=round(float(x.mean()), 4), std=round(float(x.std(ddof=1)), 4) if x.size > 1 else 0.0, n=int(x.size))
    return out


def vessel_samples(summary: dict | None) -> dict:
    """Per-vessel values of a run (module docstring): ``{name in PER_VESSEL: [value per vessel that
    has it]}``, ``reference_short``: how many vessels' reference fell short (no time cost), and
    ``behind``: how many vessels ended more than :data:`BEHIND_M` short of their reference's
    progress (``progress_lost_m``: stopped, turned back or pushed back — costs taken at the run's
    own progress do not show it)."""
    s = summary or {}
    cost = (s.get("evaluation") or {}).get("cost") or {}
    out: dict = {k: [] for k in PER_VESSEL}
    short, behind = 0, None
    for name, v in (s.get("vessels") or {}).items():
        where = {"cost": cost.get(name) or {}, "vessel": v, "coordination": v.get("coordination") or {}}
        for key, (src, fld) in PER_VESSEL.items():
            if where[src].get(fld) is not None:
                out[key].append(where[src][fld])
        short += where["cost"].get("progress_short_m") is not None
        lost = where["cost"].get("progress_lost_m")
        if lost is not None:  # (a store made before 2026-12-06 has none: not 0 behind, unknown)
            behind = (behind or 0) + (lost > BEHIND_M)
    out["reference_short"] = short
    out["behind"] = behind
    return out


def _sum_known(values):
    """The sum of the values that are not None; None when none is known."""
    known = [v for v in values if v is not None]
    return sum(known) if known else None


def run_outcome(summary: dict | None, near_miss_m: float = 1.0) -> dict:
    """Per-run scalars from a run's summary (None where the run has no value)."""
    s = summary or {}
    vessels = s.get("vessels", {})
    clear = [v["min_clearance_to_any_m"] for v in vessels.values() if v.get("min_clearance_to_any_m") is not None]
    means = [v["mean_cross_track_m"] for v in vessels.values() if v.get("mean_cross_track_m") is not None]
    maxes = [v["max_cross_track_m"] for v in vessels.values() if v.get("max_cross_track_m") is not None]
    actions: Counter = Counter()
    for v in vessels.values():
        actions.update((v.get("avoidance") or {}).get("actions", {}))
    ev = s.get("evaluation") or {}
    enc = ev.get("encounters", [])
    tracking = list((ev.get("tracking") or {}).values())
    min_sep = min(clear) if clear else None
    collision = bool(s.get("any_collision"))
    mission = s.get("mission") or None  # a chained mission (docs/missions.md)
    gtf = (mission or {}).get("go_to_formation") or {}
    return {
        "collision": collision,
        "near_miss": (not collision) and min_sep is not None and min_sep < near_miss_m,
        "min_separation_m": min_sep,
        "mean_cross_track_m": round(float(np.mean(means)), 4) if means else None,
        "max_cross_track_m": max(maxes) if maxes else None,
        "actions": dict(actions),
        "encounters": len(enc),
        # compliance over the encounters with a role: `none` (no risk of collision) asks nothing and is not judged
        "encounters_judged": sum(e.get("role") != "none" for e in enc),
        "encounters_compliant": sum(bool(e.get("compliant")) and e.get("role") != "none" for e in enc),
        "roles": dict(Counter(e.get("role") for e in enc)),
        "gospa_mean_m": round(float(np.mean([t["gospa_mean_m"] for t in tracking])), 4) if tracking else None,
        "id_switches": sum(t.get("id_switches", 0) for t in tracking) if tracking else None,
        "position_rmse_m": _mean_of(t.get("position_rmse_m") for t in tracking),
        "sim_time_s": s.get("sim_time_s"),
        "per_vessel": vessel_samples(s),
        "mission_completed": None if mission is None else bool(mission.get("mission_completed")),
        "arrival_spread_s": gtf.get("arrival_spread_s"),
        "arrival_position_error_m": gtf.get("max_position_error_m"),
    }


def _mean_of(values) -> float | None:
    """The mean of the values that are not None (None: there are none)."""
    vals = [v for v in values if v is not None]
    return round(float(np.mean(vals)), 4) if vals else None


def _rate(k: int, n: int) -> dict:
    w = wilson_interval(k, n)
    return {"count": k, "n": n, "rate": round(k / n, 4) if n else None,
            "wilson95": [round(w[0], 4), round(w[1], 4)] if w else None}


def ended_before_cpa(parameters: dict | None) -> bool:
    """Whether an encounter run (its drawn ``parameters``) ended no later than a target's TCPA: its
    ``duration_s`` (a family's, or the Python API's ``with_overrides(duration_s=...)``) cut it
    before the encounter, so that its outcome says nothing about it. False for runs without
    targets (perturbation families)."""
    p = parameters or {}
    tcpas = [v for k, v in p.items() if (k == "tcpa_s" or k.endswith(".tcpa_s")) and isinstance(v, (int, float))]
    duration = p.get("duration_s")
    return bool(tcpas) and isinstance(duration, (int, float)) and duration <= max(tcpas)


def before_cpa_note(agg: dict) -> str | None:
    """The warning to print with a campaign's table when some completed runs ended before their
    encounter (:func:`ended_before_cpa`), else None."""
    k = agg.get("ended_before_cpa") or 0
    if not k:
        return None
    return (f"note: {k} of {agg['completed']} completed run(s) ended before their encounter's closest approach "
            f"(duration_s ≤ TCPA): they count as runs without contact but say nothing about the encounter — run "
            f"them longer (a family's duration_s past its last TCPA, or none: the default runs past it)")


def _group(runs, near_miss_m: float) -> dict:
    """Statistics of a group of stored runs (see the module docstring)."""
    statuses = Counter(r.status for r in runs)
    done = [r for r in runs if r.status == "completed"]
    outs = [run_outcome(r.metrics, near_miss_m) for r in done]
    n = len(done)
    actions: Counter = Counter()
    roles: Counter = Counter()
    for o in outs:
        actions.update(o["actions"])
        roles.update(o["roles"])
    n_enc = sum(o["encounters"] for o in outs)
    n_judged = sum(o["encounters_judged"] for o in outs)
    walls = [r.wall_time_s for r in runs if r.wall_time_s is not None]
    missions = [o for o in outs if o["mission_completed"] is not None]
    mission = None if not missions else {
        "completed": _rate(sum(o["mission_completed"] for o in missions), len(missions)),
        "arrival_spread_s": quantiles(o["arrival_spread_s"] for o in missions),
        "arrival_position_error_m": quantiles(o["arrival_position_error_m"] for o in missions)}
    return {
        "runs": len(runs), "statuses": dict(statuses), "completed": n,
        "ended_before_cpa": sum(ended_before_cpa(getattr(r, "parameters", None)) for r in done),
        "collision": _rate(sum(o["collision"] for o in outs), n),
        "near_miss": _rate(sum(o["near_miss"] for o in outs), n),
        "min_separation_m": quantiles(o["min_separation_m"] for o in outs),
        "mean_cross_track_m": quantiles(o["mean_cross_track_m"] for o in outs),
        "colreg": {"encounters": n_enc, "roles": dict(roles),
                   "compliant": _rate(sum(o["encounters_compliant"] for o in outs), n_judged)},
        "actions": dict(actions),
        "gospa_mean_m": quantiles(o["gospa_mean_m"] for o in outs),
        "id_switches": sum(o["id_switches"] or 0 for o in outs),
        "position_rmse_m": quantiles(o["position_rmse_m"] for o in outs),
        "per_vessel": {**{k: quantiles(x for o in outs for x in o["per_vessel"][k]) for k in PER_VESSEL},
                       "reference_short": sum(o["per_vessel"]["reference_short"] for o in outs),
                       "behind": _sum_known(o["per_vessel"].get("behind") for o in outs)},
        "sim_time_s_total": round(sum(o["sim_time_s"] or 0.0 for o in outs), 3),
        "run_wall_time_s": {"sum": round(sum(walls), 3), "mean": round(float(np.mean(walls)), 3) if walls else None},
        "mission": mission,
    }


def family_order(runs) -> list[str]:
    """The families of ``runs`` in the campaign file's order (a family's runs follow the one before
    it in the index space: ordered by each family's first run index)."""
    first: dict[str, int] = {}
    for r in runs:
        index = getattr(r, "index", 0)
        if r.family not in first or index < first[r.family]:
            first[r.family] = index
    return sorted(first, key=lambda f: (first[f], f))


def _by_family(runs, near_miss_m: float) -> dict:
    """Per family, in the campaign file's order (:func:`family_order`)."""
    by_family: dict[str, list] = defaultdict(list)
    for r in runs:
        by_family[r.family].append(r)
    return {f: _group(by_family[f], near_miss_m) for f in family_order(runs)}


def method_order(runs, methods=None) -> list[str]:
    """The method labels of ``runs``: those of ``methods`` first (the file's order), then any other
    stored label, sorted; empty for a campaign without methods."""
    stored = {getattr(r, "method", "") for r in runs} - {""}
    order = [m for m in (methods or []) if m]
    return order + sorted(stored - set(order))


def aggregate(runs, runs_defined: int | None = None, near_miss_m: float = 1.0, methods=None) -> dict:
    """Overall and per-family statistics of stored runs (:class:`~mjasc.campaigns.store.StoredRun`);
    with method labels (stored, or ``methods``: the compared labels in file order) also per method."""
    out = {"runs_defined": runs_defined, "runs_recorded": len(runs), **_group(runs, near_miss_m),
           "families": _by_family(runs, near_miss_m)}
    out["runs_failed"] = sum(n for s, n in out["statuses"].items() if s != "completed")
    labels = method_order(runs, methods)
    if labels:
        out["methods"] = {}
        for m in labels:
            rm = [r for r in runs if getattr(r, "method", "") == m]
            out["methods"][m] = {**_group(rm, near_miss_m), "families": _by_family(rm, near_miss_m)}
        if len(labels) > 1:
            out["paired"] = paired(runs, labels, near_miss_m)
    return out


def paired(runs, labels, near_miss_m: float = 1.0) -> dict:
    """Each method against the first (the baseline) on the same runs: per family (in the campaign
    file's order) and ``all``, per other method, over the indices both completed — ``pairs``,
    collisions only with the baseline / only with the other / with both, and how often the other's
    minimum separation was larger / smaller than the baseline's (ties counted in neither)."""
    base = labels[0]
    seps: dict = {}
    for r in runs:
        if r.status == "completed":
            o = run_outcome(r.metrics, near_miss_m)
            seps[(r.index, getattr(r, "method", ""))] = (r.family, o["collision"], o["min_separation_m"])
    out: dict = {}
    for m in labels[1:]:
        groups: dict[str, Counter] = defaultdict(Counter)
        for (i, lab), (fam, coll_b, sep_b) in seps.items():
            if lab != base or (i, m) not in seps:
                continue
            _, coll_m, sep_m = seps[(i, m)]
            for g in (fam, "all"):
                c = groups[g]
                c["pairs"] += 1
                c["collision_only_" + base] += coll_b and not coll_m
                c["collision_only_" + m] += coll_m and not coll_b
                c["collision_both"] += coll_b and coll_m
                if sep_b is not None and sep_m is not None:
                    c["separation_larger"] += sep_m > sep_b
                    c["separation_smaller"] += sep_m < sep_b
        keys = ("pairs", "collision_only_" + base, "collision_only_" + m, "collision_both", "separation_larger",
                "separation_smaller")
        order = [f for f in family_order(runs) if f in groups] + ["all"] * ("all" in groups)  # (the file's order)
        out[m] = {"baseline": base, **{g: {k: int(groups[g][k]) for k in keys} for g in order}}
    return out


def format_aggregate(agg: dict, name: str = "") -> str:
    """A short plain-text table (what ``mjasc campaign`` prints): per family and overall, runs,
    collision and near-miss rates with Wilson 95 % intervals, median and minimum separation, the
    median mission cost per vessel (extra path length, time)."""
    def rate(d):
        if d["rate"] is None:
            return "—"
        return f"{d['count']}/{d['n']} = {100 * d['rate']:.1f} % ({100 * d['wilson95'][0]:.1f}–{100 * d['wilson95'][1]:.1f} %)"

    def sep(q):
        return "—" if not q else f"min {q['p0']:.2f} m, median {q['p50']:.2f} m"

    def cost(pv):
        p, t = pv["path_cost"], pv["time_cost_s"]
        behind = f", {pv['behind']} behind" if pv.get("behind") else ""
        return "—" if not p else f"{100 * p['p50']:+.1f} % / " + ("—" if not t else f"{t['p50']:+.1f} s") + behind

    lines = [f"{name}: {agg['runs_recorded']} of {agg['runs_defined']} run(s) recorded, {agg['completed']} completed, "
             f"{agg['runs_failed']} failed"]
    rows = [("family", "runs", "collision (Wilson 95 %)", "near miss (Wilson 95 %)", "separation",
             "median cost: path / time (vessels behind)")]
    if agg.get("methods"):  # a comparison: one row per family and method
        rows = [("family", "method") + rows[0][1:]]
        fams = list(agg["families"]) + ["all"]
        for fam in fams:
            for m, gm in agg["methods"].items():
                g = gm if fam == "all" else gm["families"].get(fam)
                if g is not None:
                    rows.append((fam, m, str(g["completed"]), rate(g["collision"]), rate(g["near_miss"]),
                                 sep(g["min_separation_m"]), cost(g["per_vessel"])))
    else:
        for fam, g in list(agg["families"].items()) + [("all", agg)]:
            rows.append((fam, str(g["completed"]), rate(g["collision"]), rate(g["near_miss"]),
                         sep(g["min_separation_m"]), cost(g["per_vessel"])))
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    lines += ["  " + "  ".join(c.ljust(w) for c, w in zip(r, widths)) for r in rows]
    note = before_cpa_note(agg)
    if note:
        lines.append(note)
    return "\n".join(lines)
