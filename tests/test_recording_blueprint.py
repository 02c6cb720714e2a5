"""The demo recording's default blueprint opens on the scene, with a legend and per-vessel colours."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import rerun as rr

from mjasc.runs.recording import LEGEND_CLASSES, legend_classes, vessel_colour
from mjasc.runs.runner import Runner
from mjasc.runs.scenario import load_scenario
from mjasc.runs.truth_recording import PLOT_SERIES

TASKS = Path(__file__).resolve().parents[1] / "tasks"


def _columns(store) -> dict[str, list]:
    """Every component column of a store: 'entity:Archetype:field' → its values (row lists)."""
    out: dict[str, list] = {}
    for chunk in store.stream():
        batch = chunk.to_record_batch()
        for name in batch.schema.names:
            if ":" in name:
                out.setdefault(f"{chunk.entity_path}:{name}", []).extend(batch.column(name).to_pylist())
    return out


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    out = tmp_path_factory.mktemp("demo")
    sc = load_scenario(TASKS / "demo.toml").with_overrides(duration_s=6.0)
    runner = Runner(sc, out, progress=False)
    runner.run()
    reader = rr.chunk.RrdReader(out / "recording.rrd")
    return runner, _columns(reader.store(store=reader.blueprints()[0])), _columns(reader.store())


def test_top_down_view_looks_at_the_scene_not_the_origin(demo):
    runner, blueprint, _ = demo
    lo, hi = runner.extent()
    top = [k.split(":")[0] for k, v in blueprint.items()
           if k.endswith("ViewBlueprint:display_name") and v[0][0].startswith("Top-down")]
    assert len(top) == 1
    target = np.array(blueprint[f"{top[0]}/EyeControls3D:EyeControls3D:look_target"][0][0])
    eye = np.array(blueprint[f"{top[0]}/EyeControls3D:EyeControls3D:position"][0][0])
    assert np.all(target[:2] > lo) and np.all(target[:2] < hi)  # inside the extent
    assert np.allclose(target[:2], 0.5 * (lo + hi))
    assert np.linalg.norm(target[:2]) > 50.0  # the demo's centre is far from the origin
    assert eye[2] > np.max(hi - lo) and np.allclose(eye[:2], target[:2], atol=0.02 * np.max(hi - lo))


def test_the_legend_exists_with_every_vessel_in_its_colour(demo):
    runner, blueprint, rec = demo
    context = rec["/world:AnnotationContext:context"][0][0]
    infos = {c["class_id"]: c["class_description"]["info"] for c in context}
    names = [a.name for a in runner.agents]
    for i, name in enumerate(names):
        info = infos[i + 1]
        assert info["label"] == name
        r, g, b = vessel_colour(i)
        assert info["color"] == (r << 24) | (g << 16) | (b << 8) | 0xFF
    assert set(LEGEND_CLASSES) <= set(infos)
    assert len(infos) == len(legend_classes(tuple(names)))
    legend = rec["/legend:TextDocument:text"][0][0]
    assert all(name in legend for name in names)
    views = {k.split(":")[0]: v[0][0] for k, v in blueprint.items() if k.endswith("ViewBlueprint:space_origin")}
    kinds = {k.split(":")[0]: v[0][0] for k, v in blueprint.items() if k.endswith("ViewBlueprint:class_identifier")}
    assert any(origin == "legend" and kinds[view] == "TextDocument" for view, origin in views.items())
    assert {f"plots/speed/{n}" for n in names} <= set(views.values())  # plots grouped per vessel
    assert {f"modes/{n}" for n in names} <= set(views.values())  # the mode as a state lane per vessel


def test_track_labels_are_off_by_default_and_plots_use_the_vessel_colour(demo):
    runner, _, rec = demo
    for i, agent in enumerate(runner.agents):
        assert rec[f"/world/vessels/{agent.name}/tracks/positions:Points3D:show_labels"][0] == [False]
        r, g, b = vessel_colour(i)
        assert rec[f"/plots/speed/{agent.name}/actual:SeriesLines:colors"][0] == [(r << 24) | (g << 16) | (b << 8) | 0xFF]
        for template in PLOT_SERIES.values():  # (every plot of the truth: named, in the vessel's colour)
            entity = "/" + template.format(agent.name)
            assert rec[f"{entity}:SeriesLines:names"][0][0].startswith(agent.name), entity
            assert rec[f"{entity}:SeriesLines:colors"][0][0] >> 8 == (r << 16) | (g << 8) | b, entity


def test_the_formation_plots_of_a_large_fleet_include_the_shared_entity():
    """Beyond MAX_VIEW_VESSELS the vessels' formation series share one entity (standard detail):
    the coordination views must list it, or the plots would show the first vessels only."""
    import rerun.blueprint as rrb

    from mjasc.runs.blueprint import MAX_VIEW_VESSELS, OTHERS, default_blueprint

    def contents(detail):
        names = tuple(f"v{i:03d}" for i in range(MAX_VIEW_VESSELS + 3))
        bp = default_blueprint(vessels=names, coordination=True, detail=detail)
        out, stack = [], [bp.root_container]
        while stack:
            node = stack.pop()
            if isinstance(node, rrb.TimeSeriesView) and node.origin == "plots/coordination":
                out += list(node.contents)
            stack += list(getattr(node, "contents", None) or []) if not isinstance(node, rrb.TimeSeriesView) else []
        return " ".join(str(c) for c in out)

    std, full = contents("standard"), contents("full")
    assert f"plots/coordination/{OTHERS}/spread_m" in std and f"v{MAX_VIEW_VESSELS + 2:03d}" not in std
    assert OTHERS not in full and f"plots/coordination/v{MAX_VIEW_VESSELS + 2:03d}/spread_m" in full
