"""What the demo recording shows beyond the overview: follow views, the mode as a state timeline,
the body-frame sensor view, the threat panel, the comms links and overlay colours that do not
clash with the vessels' (issue 13). Every check reads the recording back with Rerun's own reader."""

from __future__ import annotations

import itertools
import math
import re
from pathlib import Path

import numpy as np
import pytest
import rerun as rr

from mjasc.avoidance.request import MODES
from mjasc.runs.blueprint import LEGEND_CLASSES, MODE_STATES, PALETTE, VESSEL_COLOURED
from mjasc.runs.recording import vessel_colour
from mjasc.runs.runner import Runner
from mjasc.runs.scenario import load_scenario

TASKS = Path(__file__).resolve().parents[1] / "tasks"


def _rows(store) -> dict[str, list]:
    """'entity:Archetype:field' → [(time [s] or None, value), ...] over every chunk of a store."""
    out: dict[str, list] = {}
    for chunk in store.stream():
        batch = chunk.to_record_batch()
        times = batch.column("sim_time").to_pylist() if "sim_time" in batch.schema.names else [None] * batch.num_rows
        times = [None if t is None else t.total_seconds() if hasattr(t, "total_seconds") else t / 1e9 for t in times]
        for name in batch.schema.names:
            if ":" in name:
                out.setdefault(f"{chunk.entity_path}:{name}", []).extend(zip(times, batch.column(name).to_pylist()))
    for rows in out.values():
        rows.sort(key=lambda r: -1.0 if r[0] is None else r[0])
    return out


def _views(blueprint: dict) -> dict[str, dict]:
    """View id → {kind, origin, name, eye: {field: value}} of a blueprint's columns."""
    views: dict[str, dict] = {}
    for key, rows in blueprint.items():
        path, archetype, field = key.split(":")
        if path.startswith("/view/"):
            vid = "/".join(path.split("/")[:3])
            v = views.setdefault(vid, {"eye": {}})
            value = rows[0][1][0] if rows[0][1] else None
            if archetype == "EyeControls3D":
                v["eye"][field] = value
            elif field in ("class_identifier", "space_origin", "display_name"):
                v[{"class_identifier": "kind", "space_origin": "origin", "display_name": "name"}[field]] = value
    return views


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    """The demo up to 60 s: bravo yields to the ferry at ~36 s (its first predicted conflict)."""
    out = tmp_path_factory.mktemp("demo")
    runner = Runner(load_scenario(TASKS / "demo.toml").with_overrides(duration_s=60.0), out, progress=False)
    runner.run()
    reader = rr.chunk.RrdReader(out / "recording.rrd")
    return runner, _rows(reader.store(store=reader.blueprints()[0])), _rows(reader.store())


def test_a_follow_view_per_vessel_tracks_its_hull_and_the_overview_is_shown_first(demo):
    runner, blueprint, _ = demo
    views = _views(blueprint)
    for v in runner.scenario.vessels:
        follow = [x for x in views.values() if x["eye"].get("tracking_entity") == f"world/vessels/{v.name}/hull"]
        assert len(follow) == 1 and follow[0]["kind"] == "3D" and follow[0]["origin"] == "world"
        assert np.allclose(follow[0]["eye"]["look_target"][:2], v.position_m)  # starts on the vessel
    top = next(vid for vid, x in views.items() if x.get("name", "").startswith("Top-down"))
    tabs = [rows[0][1][0] for key, rows in blueprint.items() if key.endswith("ContainerBlueprint:active_tab")
            and rows[0][1]]
    assert f"view/{top.split('/')[-1]}" in [t.lstrip("/") for t in tabs]  # the overview is the visible tab


def test_the_mode_is_a_state_lane_per_vessel_with_named_coloured_states(demo):
    runner, blueprint, rec = demo
    origins = {x.get("origin") for x in _views(blueprint).values() if x.get("kind") == "StateTimeline"}
    assert "modes" in origins and {f"modes/{a.name}" for a in runner.agents} <= origins
    assert set(MODE_STATES) == set(MODES)
    switches = {}
    for t, text in rec["/events:TextLog:text"]:
        m = re.match(r"(\w+): mode (\S+) → (\S+)", text[0])
        if m:
            assert switches.get(m[1], [(None, None)])[-1][1] != m[3]  # (each change once in the log)
            switches.setdefault(m[1], []).append((t, m[3]))
    assert switches.get("bravo")  # bravo yields to the ferry
    for a in runner.agents:
        config = rec[f"/modes/{a.name}:StateConfiguration:values"][0][1]
        assert config == list(MODE_STATES)
        colours = rec[f"/modes/{a.name}:StateConfiguration:colors"][0][1]
        assert len(set(colours)) == len(MODE_STATES)
        states = rec[f"/modes/{a.name}:StateChange:state"]
        assert states[0][1] == ["mission"]
        changes = [(t, s[0]) for t, s in states[1:]]
        assert [s for _, s in changes] == [s for _, s in switches.get(a.name, [])]
        for (t, _), (t_event, _) in zip(changes, switches.get(a.name, [])):
            assert t_event <= t <= t_event + 0.1 + 1e-9  # written at the next record tick


def test_the_body_frame_sensor_view_shows_the_fan_and_team_mates_where_they_are(demo):
    runner, blueprint, rec = demo
    views = {x.get("origin"): x for x in _views(blueprint).values()}
    alpha = runner.agents[0]
    assert alpha.name == "alpha"
    r_max = alpha.perception.sensor_config.max_range_m
    view = views["sensor/alpha"]
    assert view["kind"] == "3D" and np.allclose(view["eye"]["eye_up"], (1.0, 0.0, 0.0))  # forward up
    fan = rec["/sensor/alpha/fan:LineStrips3D:strips"][0][1]
    assert np.isclose(max(np.hypot(p[0], p[1]) for strip in fan for p in strip), r_max, rtol=1e-5)
    hits = [(t, np.array(p)) for t, p in rec["/sensor/alpha/hits_body:Points3D:positions"] if p]
    assert hits and all(np.all(np.hypot(p[:, 0], p[:, 1]) <= r_max + 1.0) for _, p in hits)
    # A body-frame (FLU) detection put back into the world with alpha's pose lands on a team mate.
    pos = {t: np.array(p[0][:2]) for t, p in rec["/world/vessels/alpha/position:Points3D:positions"]}
    heading = {round(t, 3): math.radians(v[0]) for t, v in rec["/plots/heading/alpha:Scalars:scalars"]}
    mates = {n: {round(t, 3): np.array(p[0][:2]) for t, p in rec[f"/world/vessels/{n}/position:Points3D:positions"]}
             for n in ("bravo", "charlie")}
    matched = 0
    for t, dets in rec["/sensor/alpha/detections_body:Points3D:positions"]:
        k = round(t, 3)
        if not dets or k not in heading:
            continue
        c, s = math.cos(heading[k]), math.sin(heading[k])
        world = np.array(dets)[:, :2] @ np.array([[c, s], [-s, c]]) + pos[t]
        for m in mates.values():
            if k in m and np.min(np.hypot(*(world - m[k]).T)) < 2.0:
                matched += 1
    assert matched >= 10


def test_the_threat_panel_lists_the_conflict_with_the_avoidance_stage_values(demo):
    runner, _, rec = demo
    bravo = runner.agents[1].avoidance
    conflict = bravo.conflict_log[0]  # what the avoidance stage predicted (not the truth)
    docs = rec["/threats/bravo:TextDocument:text"]
    at = [text[0] for t, text in docs if abs(t - conflict["time_s"]) < 0.11]
    assert at, [t for t, _ in docs]
    row = next(line for line in at[0].splitlines() if line.startswith(f"| **T{conflict['track_id']}**"))
    cells = [c.strip().strip("*") for c in row.strip("|").split("|")]
    assert float(cells[2]) == pytest.approx(conflict["d_min_m"], abs=0.051)  # CPA [m]
    assert float(cells[4]) == pytest.approx(conflict["t_c"] - conflict["time_s"], abs=0.51)  # TCPA [s]
    assert "yield" in cells[5]  # the triage's answer
    assert any("team mate" in text[0] for _, text in docs)  # the team mates' tracks are listed too
    assert len(docs) < 3 * bravo.stats["predictions"]  # written when it changes, not every tick


def test_comms_links_in_the_sender_colour_and_lost_messages_counted(demo):
    runner, _, rec = demo
    names = [a.name for a in runner.agents]
    colours = {int.from_bytes(bytes((*vessel_colour(i), 160)), "big") for i in range(len(names))}  # translucent
    rows = rec["/world/comms/delivered:LineStrips3D:colors"]
    assert rows and {c for _, cs in rows for c in cs} <= colours
    strips = [s for _, ss in rec["/world/comms/delivered:LineStrips3D:strips"] for s in ss]
    assert strips and all(len(s) == 2 for s in strips)
    for n in names:
        stats = runner.network.stats(n)
        assert stats["lost"] > 0  # the demo's link loses 10 %
        assert rec[f"/plots/comms/{n}/lost:Scalars:scalars"][-1][1] == [stats["lost"]]
        # the plots end where the run ends, at the summary's counts (the received count is written
        # at most every 5 s while the run goes on: its last row is the run's end)
        t_end, received = rec[f"/plots/comms/{n}/received:Scalars:scalars"][-1]
        assert received == [stats["delivered"]] and t_end == pytest.approx(runner.sim.time_s)
    assert any(s for _, s in rec["/world/comms/lost:LineStrips3D:strips"])


def _distance(a, b) -> float:
    return math.dist(a[:3], b[:3])


def test_overlay_colours_stand_apart_from_the_vessels_and_each_other():
    overlays = {k: c for k, (_, c) in LEGEND_CLASSES.items() if k not in VESSEL_COLOURED}
    assert {104, 105} <= set(overlays)  # the obstructed stretch and the SVO have colours of their own
    assert min(_distance(v, c) for v in PALETTE for c in overlays.values()) >= 80.0
    assert min(_distance(a, b) for a, b in itertools.combinations(overlays.values(), 2)) >= 70.0


def test_overlays_are_drawn_in_their_legend_colours_and_conflict_labels_hidden(demo):
    _, _, rec = demo
    packed = {k: int.from_bytes(bytes((*c, 255)), "big") for k, (_, c) in LEGEND_CLASSES.items()}
    base = "/world/vessels/bravo/avoidance"
    for entity, k in (("svo", 105), ("obstructed", 104), ("collision_points", 103), ("detour", 106),
                      ("virtual_target", 108)):
        archetype = "Points3D" if entity in ("collision_points", "virtual_target") else "LineStrips3D"
        assert rec[f"{base}/{entity}:{archetype}:colors"][0][1] == [packed[k]], entity
        assert rec[f"{base}/{entity}:{archetype}:class_ids"][0][1] == [k], entity
    assert rec[f"{base}/collision_points:Points3D:show_labels"][0][1] == [False]
    assert rec["/world/vessels/bravo/static_map:LineStrips3D:colors"][0][1] == [packed[111]]


def test_the_fan_outline_of_a_sector_has_its_edges_at_half_the_field_of_view():
    from mjasc.perception.recording import fan_outline_body

    arc, blind, left, right = fan_outline_body(120.0, 100.0, 2.0)
    assert np.allclose(np.hypot(*arc.T), 100.0) and np.allclose(np.hypot(*blind.T), 2.0)
    assert np.degrees(np.arctan2(arc[0, 1], arc[0, 0])) == pytest.approx(-60.0)  # starboard edge (y < 0)
    assert np.degrees(np.arctan2(arc[-1, 1], arc[-1, 0])) == pytest.approx(60.0)  # port edge (FLU: y > 0)
    assert np.allclose(left[1], arc[0]) and np.allclose(right[1], arc[-1])
    assert len(fan_outline_body(360.0, 100.0)) == 1  # a full circle: the outer arc only


def test_large_teams_get_comms_counts_but_no_lines():
    from mjasc.cooperation.recording import MAX_LINE_VESSELS, CommsLog

    assert CommsLog(tuple(f"v{i}" for i in range(MAX_LINE_VESSELS))).lines
    assert not CommsLog(tuple(f"v{i}" for i in range(MAX_LINE_VESSELS + 1))).lines  # n(n-1) lines a period


def test_a_large_fleet_gets_per_vessel_views_for_its_first_vessels_only(tmp_path):
    """Beyond MAX_VIEW_VESSELS, no follow view, vessel tab, body-frame sensor data or threat panel
    (their fixed cost per vessel made a 50-vessel recording 1.6 MB per vessel-minute); the
    world data of every vessel stays."""
    import rerun as rr

    from mjasc.runs.blueprint import MAX_VIEW_VESSELS
    from mjasc.runs.fleet import formation_among_traffic
    from mjasc.runs.runner import run_scenario

    sc = formation_among_traffic(MAX_VIEW_VESSELS + 2, duration_s=3.0)
    names = [v.name for v in sc.vessels]
    run_scenario(sc, tmp_path, progress=False)
    paths = set(rr.chunk.RrdReader(str(tmp_path / "recording.rrd")).store().schema().entity_paths())
    first, last = names[0], names[-1]
    assert f"/sensor/{first}/fan" in paths and f"/sensor/{last}/fan" not in paths
    assert not any(p.startswith(f"/sensor/{last}") or p.startswith(f"/threats/{last}") for p in paths)
    assert f"/world/vessels/{first}/hull" in paths and f"/modes/{last}" in paths  # the follow views' hulls
    assert f"/plots/comms/{first}/received" in paths and f"/plots/comms/{last}/received" not in paths
    # The vessels without views share one entity per kind (each entity costs footer space per
    # component): their hulls, positions, trails and paths an instance each, their plots a series each.
    others = [n for n in names if n not in names[:MAX_VIEW_VESSELS]]
    for kind in ("world/vessels/{}/hull", "world/vessels/{}/position", "world/vessels/{}/mission_path",
                 "plots/speed/{}/actual", "plots/heading/{}", "plots/coordination/{}/spread_m"):
        assert "/" + kind.format("_others") in paths and "/" + kind.format(last) not in paths, kind
    assert "/" + "plots/speed/{}/actual".format(first) in paths
    store = rr.chunk.RrdReader(str(tmp_path / "recording.rrd")).store()
    speed = [c.to_record_batch() for c in store.stream() if c.entity_path == "/plots/speed/_others/actual"]
    names_col = [b.column(b.schema.get_field_index("SeriesLines:names")) for b in speed
                 if "SeriesLines:names" in b.schema.names]
    assert [str(s) for s in names_col[0][0].as_py()] == [f"{n} speed" for n in others]
    values = [row for b in speed if "Scalars:scalars" in b.schema.names
              for row in b.column(b.schema.get_field_index("Scalars:scalars")).to_pylist()]
    assert values and all(len(row) == len(others) for row in values)  # a series per vessel, every row


def test_a_velocity_obstacle_vessel_s_mode_changes_are_logged_once(tmp_path):
    """The velocity-obstacle method logs its mode changes itself; the runner logged each again
    (a reviewer found every switch twice in the event log). Its threat panel shows its latest
    decision (it has no prediction to tabulate)."""
    Runner(load_scenario(TASKS / "velocity_obstacle_crossing.toml").with_overrides(duration_s=70.0), tmp_path,
           progress=False).run()
    rec = _rows(rr.chunk.RrdReader(tmp_path / "recording.rrd").store())
    changes = [(t, text[0]) for t, text in rec["/events:TextLog:text"] if re.match(r"\w+: mode \S+ → \S+", text[0])]
    assert changes and len(changes) == len(set(changes))
    # its threat panel said "no prediction yet" for the whole run: it says how the method decides
    # and, from its first conflict, the latest decision
    panel = [(t, v[0] if isinstance(v, list) else v) for t, v in rec["/threats/north:TextDocument:text"]]
    assert all("no prediction yet" not in text and "velocity obstacles" in text for _, text in panel)
    steer = next(t for t, text in changes if text.startswith("north: mode mission → avoidance:steer"))
    assert any(t == steer and "latest decision: **steer (crossing_give_way)** for T0" in text for t, text in panel)
