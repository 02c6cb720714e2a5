"""Write a fleet scenario file from mjasc.runs.fleet.formation_among_traffic (tasks/fleet_50.toml).

    python scripts/make_fleet_scenario.py                        # writes tasks/fleet_50.toml
    python scripts/make_fleet_scenario.py --vessels 20 --out my_fleet.toml --duration 60
    python scripts/make_fleet_scenario.py --check                # exit 1 if tasks/fleet_50.toml is stale

The shipped file is this script's output with its defaults: edit the generator (or the options
here), not the file. ``--check`` compares the file with what the script would write.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_OUT = ROOT / "tasks" / "fleet_50.toml"
DEFAULTS = {"vessels": 50, "duration": 120.0, "seed": 1}


def _value(v) -> str:
    """One TOML value: strings, booleans, numbers, arrays and inline tables (all the generator uses)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(float(v)) if isinstance(v, float) else str(v)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {_value(x)}" for k, x in v.items()) + " }" if v else "{}"
    raise TypeError(f"no TOML form for {type(v).__name__}: {v!r}")


def to_toml(doc: dict, header: str = "") -> str:
    """The scenario document as TOML: top-level values, then plain tables, then arrays of tables
    (their sub-tables inline, one entry per line, like the hand-written files in tasks/)."""
    lines = [f"# {line}".rstrip() for line in header.splitlines()]
    scalars = {k: v for k, v in doc.items() if not isinstance(v, (dict, list))}
    tables = {k: v for k, v in doc.items() if isinstance(v, dict)}
    arrays = {k: v for k, v in doc.items() if isinstance(v, list)}
    lines += [f"{k} = {_value(v)}" for k, v in scalars.items()]
    for name, t in tables.items():
        lines += ["", f"[{name}]", *(f"{k} = {_value(v)}" for k, v in t.items())]
    for name, items in arrays.items():
        for item in items:
            lines += ["", f"[[{name}]]", *(f"{k} = {_value(v)}" for k, v in item.items())]
    return "\n".join(lines) + "\n"


HEADER = """A large formation among traffic (written by scripts/make_fleet_scenario.py from
mjasc.runs.fleet.formation_among_traffic: edit those, not this file).
{n} Otters in a grid on a common path (each vessel's path is the reference line translated by its
place in the grid, so equal γ/L means "in formation"); every vessel senses with its own range
sensor, tracks with its IMM tracker, predicts and avoids collisions, and coordinates its speed
over a lossy radio link. Boats cross ahead of the front row in turn: the vessels they threaten
slow down to let them pass, then the formation closes up again. One boat passes alongside.
Run: mjasc run fleet_{n}   (slow today: benchmarks/bench_fullstack.py measures it)"""


def render(vessels: int, duration: float, seed: int) -> str:
    sys.path.insert(0, str(ROOT))
    from mjasc.runs.fleet import formation_among_traffic_doc

    doc = formation_among_traffic_doc(vessels, duration_s=duration, seed=seed)
    return to_toml(doc, HEADER.format(n=vessels))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--vessels", type=int, default=DEFAULTS["vessels"])
    ap.add_argument("--duration", type=float, default=DEFAULTS["duration"], help="simulated seconds")
    ap.add_argument("--seed", type=int, default=DEFAULTS["seed"])
    ap.add_argument("--out", type=Path, default=DEFAULT_OUT)
    ap.add_argument("--check", action="store_true", help="exit 1 if --out differs from what would be written")
    a = ap.parse_args(argv)
    text = render(a.vessels, a.duration, a.seed)
    if a.check:
        same = a.out.is_file() and a.out.read_text() == text
        print(f"{a.out}: {'up to date' if same else 'STALE (run scripts/make_fleet_scenario.py)'}")
        return 0 if same else 1
    a.out.write_text(text)
    print(f"wrote {a.out} ({a.vessels} vessels, {a.duration:g} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
