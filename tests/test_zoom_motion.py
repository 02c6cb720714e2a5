"""The zoom's relative motion in compiled passes (mjasc.avoidance.prediction.zoom_motion) against
the readable ``rel_at`` (the numpy form, through ``tests/test_zoom_kernels.py``'s reference zoom),
bit for bit, on real runs whose predictions hold turning tracks, team mates' plans, paths with
arcs, vessels under a velocity correction (γ(t) not a constant speed), one vessel and several."""

from dataclasses import replace
from pathlib import Path

import numpy as np

from mjasc.avoidance.prediction import cpa
from mjasc.avoidance.prediction.zoom_motion import ZoomMotion
from mjasc.guidance.segment_geometry import K
from mjasc.runs.runner import Runner
from mjasc.runs.scenario import load_scenario

from tests.test_zoom_kernels import _zoom_numpy

TASKS = Path(__file__).resolve().parents[1] / "tasks"


def test_the_compiled_levels_give_the_readable_forms_bits_on_real_runs(monkeypatch):
    compiled = cpa._zoom
    seen = dict(zooms=0, turning=0, plan=0, arc=0, not_steady=0, one_path=0, stacked=0)

    def both(rel_at, pairs, a, b):
        assert isinstance(rel_at, ZoomMotion)
        want = _zoom_numpy(rel_at.rel_at, pairs, a, b)
        got = compiled(rel_at, pairs, a, b)
        assert got[0].tobytes() == want[0].tobytes() and got[1].tobytes() == want[1].tobytes()
        _, kind, _, _ = rel_at._motion
        kinds = kind[rel_at._track[pairs]]
        table, first = rel_at._paths[0], rel_at._paths[1]
        seen["zooms"] += 1
        seen["turning"] += bool(np.any(kinds == 1))
        seen["plan"] += bool(np.any(kinds == 2))
        seen["arc"] += bool(np.any(table[K] != 0.0))
        seen["not_steady"] += not rel_at._all_steady
        seen["one_path" if first.size == 1 else "stacked"] += 1
        return got

    monkeypatch.setattr(cpa, "_zoom", both)
    for name, duration in (("demo", 90.0), ("thesis_6_4_bottleneck", 60.0)):
        sc = load_scenario(TASKS / f"{name}.toml").with_overrides(duration_s=duration)
        sc = replace(sc, outputs=replace(sc.outputs, recording=False, video=False))
        Runner(sc, None, progress=False).run()
    assert all(v > 0 for v in seen.values()), seen
