"""The thesis avoidance scenarios with and without collision avoidance: a markdown table.

    .venv/bin/python scripts/avoidance_table.py [--seeds 0 1 2]

"Without" removes every vessel's avoidance (and the sensing it alone uses); all else is equal.
With --seeds, each scenario also runs with those seeds (the scenario's own seed is always run).
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import mjasc  # noqa: F401
from mjasc.runs.runner import RunFailed, run_scenario
from mjasc.runs.scenario import load_scenario

TASKS = Path(__file__).resolve().parent.parent / "tasks"
SCENARIOS = ["thesis_6_2_dock", "thesis_6_3_velocity_correction", "thesis_6_4_crossing", "thesis_6_4_head_on",
             "thesis_6_4_bottleneck"]


def without_avoidance(sc):
    vessels = tuple(dataclasses.replace(v, options={k: o for k, o in v.options.items()
                                                    if k not in ("avoidance", "sensor", "tracking")})
                    for v in sc.vessels)
    return dataclasses.replace(sc, vessels=vessels)


def outcome(sc) -> tuple[str, float, str]:
    try:
        s = run_scenario(sc, None, progress=False).summary
    except RunFailed as exc:
        return f"failed: {exc}", float("nan"), ""
    hull = sorted({"–".join(c["between"]) for c in s["collisions"]})
    clearance = min(v["min_clearance_to_any_m"] for v in s["vessels"].values())
    actions = {}
    for v in s["vessels"].values():
        for k, n in (v.get("avoidance", {}).get("actions") or {}).items():
            actions[k] = actions.get(k, 0) + n
    text = ", ".join(f"{n} {k}" for k, n in actions.items() if n)
    return ("**contact**: " + "; ".join(hull)) if hull else "no contact", clearance, text


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, nargs="*", default=[])
    args = ap.parse_args()
    print("| scenario | seed | with avoidance | min clearance [m] | actions | without avoidance | min clearance [m] |")
    print("|---|---:|---|---:|---|---|---:|")
    for name in SCENARIOS:
        base = load_scenario(TASKS / f"{name}.toml")
        for seed in [base.seed, *args.seeds]:
            sc = base.with_overrides(seed=seed)
            on = outcome(sc)
            off = outcome(without_avoidance(sc))
            print(f"| {name} | {seed} | {on[0]} | {on[1]:.2f} | {on[2]} | {off[0]} | {off[1]:.2f} |", flush=True)


if __name__ == "__main__":
    main()
