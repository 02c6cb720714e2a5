"""What a side-effect-free piece of a run costs, all told: the run with it and without it, paired.

    python scripts/knock_out.py tasks/thesis_6_4_crossing.toml mjasc.perception.pipeline:Perception.log
    python scripts/knock_out.py SCENARIO TARGET [TARGET ...] [--rounds 6] [--duration 20] [--no-recording]

Each TARGET is ``module:Attribute.path`` (a function or a method, e.g.
``mjasc.avoidance.system:CollisionAvoidance.log``); the script runs the scenario alternately as it
is and with every target replaced by a function that does nothing and returns None, in fresh
``Runner`` objects of one process (one untimed run of each first: the kernels' caches and the
imports are warm), and prints the medians of the run's wall time (``summary["wall_time_s"]``: the
main loop and the closing of the outputs), of its ``record`` stage and of the other stages, with
the per-round differences.

Only pieces whose results nothing else reads can be knocked out: the recording's per-vessel log
methods, the recorder's row calls. What it measures is what profiles miss: a piece's own time, its
share of the close (the rows it buffered are built into columns, encoded and re-encoded there) and
what its memory traffic costs the other stages (docs/speed.md, "What the recording costs"). A
knocked-out run's outputs are not the product's (a recording without those entities).
"""

from __future__ import annotations

import argparse
import importlib
import statistics
import sys
import tempfile
from dataclasses import replace
from pathlib import Path


def resolve(target: str) -> tuple[object, str]:
    """The object holding ``target``'s attribute and the attribute's name (``module:A.b``)."""
    module, sep, path = target.partition(":")
    if not sep or not module or not path:
        raise SystemExit(f"knock_out: target {target!r}: expected module:Attribute.path")
    try:
        obj = importlib.import_module(module)
    except ImportError as e:
        raise SystemExit(f"knock_out: target {target!r}: {e}") from None
    *owners, name = path.split(".")
    for part in owners:
        obj = getattr(obj, part, None)
        if obj is None:
            raise SystemExit(f"knock_out: target {target!r}: no {part!r} in {module}")
    if not callable(getattr(obj, name, None)):
        raise SystemExit(f"knock_out: target {target!r}: {path} is not a function of {module}")
    return obj, name


def _nothing(*_args, **_kwargs) -> None:
    return None


def measure(scenario_path: str, targets: list[str], rounds: int, duration_s: float | None,
            recording: bool) -> dict:
    """Medians and per-round differences (with − without) [s] of wall, record and other stages."""
    import mjasc
    from mjasc.runs.runner import Runner

    sc = mjasc.load_scenario(scenario_path)
    if duration_s is not None:
        sc = sc.with_overrides(duration_s=duration_s)
    sc = replace(sc, outputs=replace(sc.outputs, recording=recording, video=False))
    # (owner, name, its own attribute or None when inherited: then restored by deleting the no-op)
    held = [(obj, name, vars(obj).get(name)) for obj, name in map(resolve, targets)]

    def run(knocked: bool) -> tuple[float, float, float]:
        if knocked:
            for obj, name, _ in held:
                setattr(obj, name, _nothing)
        try:
            with tempfile.TemporaryDirectory() as tmp:
                runner = Runner(sc, tmp if recording else None, progress=False)
                wall = runner.run().summary["wall_time_s"]
                record = runner.stage_seconds.get("record", 0.0)
        finally:
            for obj, name, original in held:
                if original is not None:
                    setattr(obj, name, original)
                elif name in vars(obj):
                    delattr(obj, name)
        return wall, record, wall - record

    run(False), run(True)  # (warm: imports, kernel caches)
    base, knocked = [], []
    for _ in range(rounds):
        base.append(run(False))
        knocked.append(run(True))
    out = {}
    for j, label in enumerate(("wall", "record", "other stages")):
        a, b = [x[j] for x in base], [x[j] for x in knocked]
        out[label] = (statistics.median(a), statistics.median(b), [x - y for x, y in zip(a, b)])
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenario", help="scenario TOML file")
    ap.add_argument("targets", nargs="+", help="module:Attribute.path of each piece to replace by a no-op")
    ap.add_argument("--rounds", type=int, default=6, help="alternated pairs (default 6)")
    ap.add_argument("--duration", type=float, default=None, help="simulated seconds (default: the scenario's)")
    ap.add_argument("--no-recording", action="store_true", help="run without the recording")
    args = ap.parse_args(argv)
    if args.rounds < 1:
        ap.error("--rounds: must be at least 1")
    if not Path(args.scenario).is_file():
        ap.error(f"{args.scenario}: no such scenario file")
    res = measure(args.scenario, args.targets, args.rounds, args.duration, not args.no_recording)
    print(f"{args.scenario}, {args.rounds} alternated pairs; knocked out: {', '.join(args.targets)}")
    print(f"{'':14s} {'as is [ms]':>11s} {'without [ms]':>13s} {'difference [ms]':>16s}   per pair [ms]")
    for label, (a, b, diffs) in res.items():
        pairs = " ".join(str(round(1000 * d)) for d in diffs)
        print(f"{label:14s} {1000 * a:11.1f} {1000 * b:13.1f} {1000 * (a - b):16.1f}   {pairs}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
