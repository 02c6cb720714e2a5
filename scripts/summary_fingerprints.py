"""Run every shipped scenario and write its summary without timing fields, to compare two versions.

    python scripts/summary_fingerprints.py OUT_DIR [--seeds 1 2] [--only NAME ...]
    python scripts/summary_fingerprints.py --compare DIR_A DIR_B

Used to check that a refactor changes no result: run it before and after, then compare. Timing
fields (wall time, real-time factor) are dropped; everything else must be equal.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

TIMING_KEYS = {"wall_time_s", "real_time_factor", "timing_s"}  # and every "*_us" (mean µs per call)


def _strip(obj):
    if isinstance(obj, dict):
        return {k: _strip(v) for k, v in obj.items() if k not in TIMING_KEYS and not k.endswith("_us")}
    if isinstance(obj, list):
        return [_strip(v) for v in obj]
    return obj


def _scenarios():
    import mjasc

    return mjasc.bundled_scenarios() if hasattr(mjasc, "bundled_scenarios") else {
        p.stem: p for p in sorted((Path(__file__).resolve().parent.parent / "tasks").glob("*.toml"))}


def run_all(out: Path, seeds: list[int] | None, only: list[str] | None) -> None:
    import mjasc

    load = getattr(mjasc, "load_scenario", None)
    run = getattr(mjasc, "run_scenario", None)
    if load is None:
        from mjasc.runs.runner import run_scenario as run
        from mjasc.runs.scenario import load_scenario as load
    out.mkdir(parents=True, exist_ok=True)
    for name, path in _scenarios().items():
        if only and name not in only:
            continue
        sc = load(path)
        for seed in [None] + list(seeds or []):
            s = sc.with_overrides(seed=seed, video=False)
            with tempfile.TemporaryDirectory() as tmp:
                try:
                    summary = run(s, tmp, progress=False).summary
                except Exception as exc:  # a failed run is a result too
                    summary = {"failed": type(exc).__name__, "message": str(exc).split(";")[0]}
            tag = f"{name}" + (f"_seed{seed}" if seed is not None else "")
            target = out / f"{tag}.json"  # a scenario in a subfolder (imazu/…) keeps its folder
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_text(json.dumps(_strip(summary), indent=1, sort_keys=True))
            print(tag, "written", flush=True)


def compare(a: Path, b: Path) -> int:
    bad = 0
    for fa in sorted(a.rglob("*.json")):
        fb = b / fa.relative_to(a)
        if not fb.exists():
            print(f"{fa.relative_to(a)}: missing in {b}")
            bad += 1
            continue
        ja, jb = _strip(json.loads(fa.read_text())), _strip(json.loads(fb.read_text()))
        if ja != jb:
            bad += 1
            print(f"{fa.name}: DIFFERENT")
            _diff(ja, jb, fa.stem)
        else:
            print(f"{fa.name}: same")
    return 1 if bad else 0


def _diff(x, y, where):
    if isinstance(x, dict) and isinstance(y, dict):
        for k in sorted(set(x) | set(y)):
            if k not in x or k not in y:
                print(f"  {where}.{k}: only in {'first' if k in x else 'second'}")
            else:
                _diff(x[k], y[k], f"{where}.{k}")
    elif x != y:
        print(f"  {where}: {str(x)[:120]} != {str(y)[:120]}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", nargs="?", type=Path)
    ap.add_argument("--seeds", type=int, nargs="*")
    ap.add_argument("--only", nargs="*")
    ap.add_argument("--compare", nargs=2, type=Path)
    a = ap.parse_args(argv)
    if a.compare:
        return compare(*a.compare)
    run_all(a.out, a.seeds, a.only)
    return 0


if __name__ == "__main__":
    sys.exit(main())
