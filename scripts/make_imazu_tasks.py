"""Write the Imazu scenario files and their campaign from mjasc/campaigns/imazu.py.

    python scripts/make_imazu_tasks.py           # writes tasks/imazu/imazu_01.toml … imazu_22.toml
                                                 # and tasks/campaigns/imazu.toml
    python scripts/make_imazu_tasks.py --check   # exit 1 if a file differs from the generator

The cases, the scaling to small craft and the NED → ENU conversion are documented in the
docstring of mjasc.campaigns.imazu; each written file repeats them for its case in its header.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

TASKS = Path(__file__).resolve().parent.parent / "tasks"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="only compare; exit 1 when a file is out of date")
    args = ap.parse_args(argv)
    from mjasc.campaigns.imazu import task_files

    stale = []
    for rel, text in task_files().items():
        path = TASKS / rel
        if path.is_file() and path.read_text() == text:
            continue
        stale.append(rel)
        if not args.check:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text)
    verb = "out of date" if args.check else "written"
    print(f"{len(stale)} file(s) {verb}" + (": " + ", ".join(stale) if stale else ""))
    return 1 if args.check and stale else 0


if __name__ == "__main__":
    sys.exit(main())
