"""Campaigns comparing avoidance methods: runs multiply by methods on identical scenario texts but for
the avoidance tables, the store keys runs by (index, method) and migrates older stores, resume works
per (run, method), the report groups by method, bad method names are one-line errors, and a
campaign without methods is exactly what it was (digest, run ids, texts)."""

from __future__ import annotations

import csv
import hashlib
import json
import sqlite3
import tomllib
from pathlib import Path

import pytest

from mjasc.campaigns.engine import run_campaign
from mjasc.campaigns.perturbation import CampaignError
from mjasc.campaigns.report import format_report, report_data, write_report
from mjasc.campaigns.spec import load_campaign_spec, parse_campaign_spec
from mjasc.campaigns.store import CampaignStore
from mjasc.plugins import AvoidanceMethod, available, register, unregister
from tests.test_plugins import StopNearTracks

ROOT = Path(__file__).resolve().parent.parent
TINY = {"name": "tiny", "families": [
    {"kind": "head_on", "runs_per_point": 2, "duration_s": 5.0},
    {"kind": "imazu", "parameters": {"case": {"grid": [1, 2]}}, "duration_s": 5.0}]}
#: TINY and its runs before methods existed (commit e693670): a campaign without methods must not change.
TINY_DIGEST = "f8c64ce3fbe15efaba406620b80aabc0b4a423704007c69054d9867de279c9aa"
#: (header: draws; session 66 added the Imazu runs' duration_s to their drawn parameters, so their header lines
#: changed: 3090476a5147021f, b71c657d85d69519 before)
TINY_TEXTS = ["c967abb9b3a3e087", "7251d46bc678bd74", "d00a1c08e4d378aa", "5ea93eb58a334bf3"]
ENCOUNTERS_DIGEST = "2c8d5046f3d7577663afe364fbe1a9c7e089597ed398495c14d437b7597d1a2d"
METHODS = ["thesis", {"name": "test_stop", "label": "stop5", "stop_below_m": 5.0}]


@pytest.fixture
def stop_method():
    register("avoidance", StopNearTracks)
    yield StopNearTracks
    unregister("avoidance", "test_stop")


def _sha(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _without_avoidance(text: str) -> dict:
    doc = tomllib.loads(text)
    for v in doc.get("vessels", []):
        v.pop("avoidance", None)
    return doc


def test_a_campaign_without_methods_is_unchanged():
    s = parse_campaign_spec(TINY)
    assert s.digest == TINY_DIGEST and s.methods == () and s.method_labels == ("",)
    runs = list(s.runs())
    assert [r.index for r in runs] == [0, 1, 2, 3] and {r.method for r in runs} == {""}
    assert [_sha(r.scenario_toml) for r in runs] == TINY_TEXTS
    assert s.runs_defined == s.runs_per_method == 4
    assert load_campaign_spec(ROOT / "tasks" / "campaigns" / "encounters.toml").digest == ENCOUNTERS_DIGEST
    with pytest.raises(ValueError, match="compares no methods"):
        s.run(0, "thesis")


def test_runs_multiply_by_methods_on_the_same_scenario_but_its_avoidance(stop_method):
    s = parse_campaign_spec({**TINY, "methods": METHODS})
    assert s.method_labels == ("thesis", "stop5") and s.runs_per_method == 4 and s.runs_defined == 8
    assert s.digest != TINY_DIGEST  # the methods are part of the campaign
    runs = list(s.runs())
    assert [(r.index, r.method) for r in runs] == [(k, m) for k in range(4) for m in ("thesis", "stop5")]
    for k in range(4):
        plain, thesis, stop = parse_campaign_spec(TINY).run(k), s.run(k, "thesis"), s.run(k, "stop5")
        assert plain.seed == thesis.seed == stop.seed and plain.parameters == thesis.parameters == stop.parameters
        # identical but for the avoidance tables (and the header's comment lines)
        assert _without_avoidance(plain.scenario_toml) == _without_avoidance(thesis.scenario_toml) \
            == _without_avoidance(stop.scenario_toml)
        plain_av = tomllib.loads(plain.scenario_toml)["vessels"][0]["avoidance"]
        assert tomllib.loads(thesis.scenario_toml)["vessels"][0]["avoidance"] == {"method": "thesis", **plain_av}
        # the thesis options (window_s, safety_distance_m) are not the test method's: dropped
        assert tomllib.loads(stop.scenario_toml)["vessels"][0]["avoidance"] == {"method": "test_stop",
                                                                                "stop_below_m": 5.0}
        assert "Avoidance method: stop5 (test_stop: stop_below_m = 5)" in stop.scenario_toml
        assert stop.scenario().vessels[0].options["avoidance"].name == "test_stop"
    with pytest.raises(ValueError, match="say which run"):
        s.run(0)
    assert s.with_overrides(runs=1).runs_defined == 2  # --runs N: the first N runs, each with every method


def test_a_vessel_without_avoidance_is_untouched(stop_method, tmp_path):
    scenario = {"name": "two", "duration_s": 5.0, "seed": 1, "vessels": [
        {"name": "a", "type": "otter", "position_m": [0, 0], "heading_deg": 0,
         "controller": {"type": "path_following", "waypoints": [[0, 0], [100, 0]]},
         "sensor": {}, "avoidance": {"window_s": 30.0}},
        {"name": "b", "type": "otter", "position_m": [0, 30], "heading_deg": 0,
         "controller": {"type": "path_following", "waypoints": [[0, 30], [100, 30]]}}]}
    from mjasc.campaigns.scenario_text import scenario_toml

    (tmp_path / "two.toml").write_text(scenario_toml(scenario))
    data = {"methods": ["thesis", "test_stop"],
            "families": [{"kind": "perturbation", "scenario": "two.toml", "runs_per_point": 1}]}
    s = parse_campaign_spec(data, str(tmp_path / "c.toml"), tmp_path)
    a, b = (tomllib.loads(s.run(0, m).scenario_toml)["vessels"] for m in ("thesis", "test_stop"))
    assert a[0]["avoidance"] == {"method": "thesis", "window_s": 30.0} and b[0]["avoidance"] == {"method": "test_stop"}
    assert a[1] == b[1] and "avoidance" not in a[1]


def _write(tmp_path: Path, methods) -> Path:
    from mjasc.campaigns.scenario_text import scenario_toml

    path = tmp_path / "cmp.toml"
    path.write_text(scenario_toml({"methods": methods, "families": [{"kind": "head_on"}]}))
    return path


@pytest.mark.parametrize("methods, message", [
    (["thesis", "nope"], r"methods\[1\]: unknown avoidance method 'nope' \(available: .*thesis"),
    ([{"name": "nope"}], r"methods\[0\]\.name: unknown avoidance method 'nope'"),
    ([], r"methods: must be a non-empty list"),
    (["thesis", "thesis"], r"methods\[1\]\.label: duplicate label 'thesis'"),
    ([{"name": "thesis", "gain_k": -1.0}], r"methods\[0\]\.gain_k: must be"),
    ([{"name": "thesis", "label": "a b"}], r"methods\[0\]\.label: must be 1–64 letters"),
    ([{"label": "x"}], r"methods\[0\]\.name: missing"),
])
def test_a_bad_method_entry_is_a_one_line_error_naming_file_and_field(tmp_path, methods, message):
    path = _write(tmp_path, methods)
    with pytest.raises(CampaignError) as info:
        load_campaign_spec(path)
    text = str(info.value)
    assert "\n" not in text and text.startswith(f"{path}: ")
    import re

    assert re.search(message, text), text


def test_the_shipped_comparison_names_thesis_and_velocity_obstacle():
    for name, per_method in (("compare_methods", 8 * 3 + 22 * 3), ("compare_methods_full", 8 * 20 + 22 * 10)):
        path = ROOT / "tasks" / "campaigns" / f"{name}.toml"
        data = tomllib.loads(path.read_text())
        assert data["methods"] == ["thesis", "velocity_obstacle"]
        if "velocity_obstacle" in available("avoidance"):
            s = load_campaign_spec(path)
            assert s.runs_per_method == per_method and s.runs_defined == 2 * per_method
        else:  # until the method lands: the one-line error names it
            with pytest.raises(CampaignError, match=r"methods\[1\]: unknown avoidance method 'velocity_obstacle'"):
                load_campaign_spec(path)
        data["methods"] = ["thesis", {"name": "thesis", "label": "thesis_k2", "gain_k": 2.0}]
        s = parse_campaign_spec(data, str(path), path.parent)
        assert s.runs_per_method == per_method and [f.name for f in s.families][-1] == "imazu"


# ---------------------------------------------------------------------- the store
_OLD_SCHEMA = """
CREATE TABLE campaigns (digest TEXT PRIMARY KEY, name TEXT NOT NULL, source TEXT, file_text TEXT,
    runs_defined INTEGER NOT NULL, created_unix_s REAL NOT NULL);
CREATE TABLE runs (digest TEXT NOT NULL, idx INTEGER NOT NULL, family TEXT, parameters TEXT, seed INTEGER,
    scenario TEXT, status TEXT NOT NULL, attempts INTEGER NOT NULL, error TEXT, metrics TEXT, wall_time_s REAL,
    worker TEXT, finished_unix_s REAL, PRIMARY KEY (digest, idx));
"""


def test_a_store_without_the_method_column_is_migrated(tmp_path):
    db = sqlite3.connect(tmp_path / "campaign.sqlite")
    db.executescript(_OLD_SCHEMA)
    db.execute("INSERT INTO campaigns VALUES ('abc', 'old', 'x.toml', '{}', 3, 1.0)")
    for k, status in enumerate(["completed", "error"]):
        db.execute("INSERT INTO runs VALUES ('abc', ?, 'head_on', '{}', ?, 'seed = 1', ?, 1, NULL, '{\"k\": 1}', 1.5, "
                   "'w', 2.0)", (k, k, status))
    db.commit()
    db.close()
    with CampaignStore.open_existing(tmp_path) as s:  # (read-only: read as migrated, nothing written)
        assert [(r.index, r.method) for r in s.runs()] == [(0, ""), (1, "")] and s.done(2) == {0}
    assert "method" not in {r[1] for r in sqlite3.connect(tmp_path / "campaign.sqlite").execute(
        "PRAGMA table_info(runs)")}
    with CampaignStore(tmp_path, "abc") as s:  # (a command that writes: migrated on disk)
        runs = s.runs()
        assert [(r.index, r.method, r.status) for r in runs] == [(0, "", "completed"), (1, "", "error")]
        assert runs[0].metrics == {"k": 1} and s.done(2) == {0} and s.attempts() == {0: 1, 1: 1}
        assert s.record(1, family="head_on", parameters={}, seed=1, scenario="s", status="completed") == 2
        assert s.done(2) == {0, 1} and s.methods() == [""]
        files = s.export()
        assert "method" not in next(csv.reader(open(files["csv"])))  # no method column without methods
    with CampaignStore.open_existing(tmp_path) as s:  # opened again: nothing to migrate
        assert len(s.runs()) == 2


def test_the_store_keys_runs_by_index_and_method(tmp_path):
    with CampaignStore(tmp_path, "abc", name="c", runs_defined=4) as s:
        for m in ("thesis", "vo"):
            s.record(0, method=m, family="f", parameters={}, seed=0, scenario=m, status="completed", metrics={"m": m})
        s.record(1, method="vo", family="f", parameters={}, seed=1, scenario="vo", status="crashed")
        assert s.done(2, "thesis") == {0} and s.done(2, "vo") == {0} and s.done(1, "vo") == {0, 1}
        assert s.done(2) == set() and s.attempts("vo") == {0: 1, 1: 1}
        assert [(r.index, r.method) for r in s.runs()] == [(0, "thesis"), (0, "vo"), (1, "vo")]
        assert [r.scenario for r in s.runs(method="vo")] == ["vo", "vo"] and s.methods() == ["thesis", "vo"]
        rows = list(csv.DictReader(open(s.export()["csv"])))
        assert [(r["index"], r["method"]) for r in rows] == [("0", "thesis"), ("0", "vo"), ("1", "vo")]
        import pyarrow.parquet as pq

        assert pq.read_table(tmp_path / "runs.parquet").column("method").to_pylist() == ["thesis", "vo", "vo"]


# ---------------------------------------------------------------------- a tiny real campaign
def test_a_tiny_comparison_runs_resumes_and_reports_by_method(stop_method, tmp_path, capsys):
    """2 methods × 3 very short runs in this process (the test method reaches the runs' child process
    by its import path): every (run, method) stored once, resume per (run, method), the report's
    counts per family and method, the exports and extract carry the method."""
    spec = parse_campaign_spec({"name": "tiny", "methods": METHODS, "families": [
        {"kind": "head_on", "runs_per_point": 2, "duration_s": 4.0},
        {"kind": "imazu", "parameters": {"case": {"grid": [1]}}, "duration_s": 4.0}]})
    out = tmp_path / "c"
    res = run_campaign(spec, out, workers=0, progress=False)
    assert res.info["runs_to_do"] == 6 and res.info["already_done"] == 0
    assert sorted((r.index, r.method, r.status) for r in res.runs) == [
        (k, m, "completed") for k in range(3) for m in ("stop5", "thesis")]
    assert {r.metrics["vessels"]["own"]["avoidance"]["method"] for r in res.runs if r.method == "stop5"} == {"test_stop"}
    # resume: nothing to do; one (run, method) forgotten → only it runs again
    assert run_campaign(spec, out, workers=0, progress=False).info["runs_to_do"] == 0
    with sqlite3.connect(out / "campaign.sqlite") as db:
        db.execute("DELETE FROM runs WHERE idx = 1 AND method = 'stop5'")
    again = run_campaign(spec, out, workers=0, progress=False)
    assert again.info["runs_to_do"] == 1 and again.info["already_done"] == 5 and len(again.runs) == 6

    data = report_data(out)
    assert list(data["methods"]) == ["thesis", "stop5"]  # the file's order
    for m in ("thesis", "stop5"):
        g = data["methods"][m]
        assert g["completed"] == 3 and g["families"]["head_on"]["completed"] == 2
        assert g["families"]["imazu"]["completed"] == 1 and g["collision"]["n"] == 3
    assert data["paired"]["stop5"]["all"]["pairs"] == 3 and data["paired"]["stop5"]["head_on"]["pairs"] == 2
    json.dumps(data)  # --json
    md = format_report(data)
    assert "| family | method | runs | collision [Wilson 95 %]" in md
    assert "| head_on | thesis | 2 |" in md and "| head_on | stop5 | 2 |" in md and "| **all** | stop5 | 3 |" in md
    assert "min / p5 / median" in md and "stop5 against thesis on the same runs" in md
    files = {p.name for p in write_report(out, formats=("png",))["files"]}
    assert {"report.md", "rates.png", "separation.png"} <= files
    rows = list(csv.DictReader(open(out / "runs.csv")))
    assert sorted((r["index"], r["method"]) for r in rows) == [(str(k), m) for k in range(3) for m in ("stop5", "thesis")]

    from mjasc.cli import main

    assert main(["extract", str(out), "1", "--out", str(tmp_path / "x")]) == 0
    written = sorted(p.name for p in (tmp_path / "x").iterdir())
    assert written == ["run_1_stop5.toml", "run_1_thesis.toml"]
    assert _without_avoidance((tmp_path / "x" / written[0]).read_text()) == \
        _without_avoidance((tmp_path / "x" / written[1]).read_text())


def test_a_method_registered_only_here_and_not_importable_runs_only_in_this_process(tmp_path):
    class Local(AvoidanceMethod):  # defined in a function: child processes cannot import it
        method = "test_local"

        def control(self, t, nav, guidance, report, team=None):
            from mjasc.avoidance.request import AvoidanceRequest

            return AvoidanceRequest()

    register("avoidance", Local)
    try:
        spec = parse_campaign_spec({"name": "local", "methods": ["thesis", "test_local"],
                                    "evaluation": {"mission_cost": False},
                                    "families": [{"kind": "head_on", "duration_s": 2.0}]})
        with pytest.raises(ValueError, match=r"'test_local' is registered only in this process .* cannot be imported "
                                             r"by name.*workers=0, isolate=False") as info:
            run_campaign(spec, tmp_path / "a", workers=0, progress=False)
        assert "\n" not in str(info.value)
        res = run_campaign(spec, tmp_path / "b", workers=0, isolate=False, progress=False)
        assert sorted((r.method, r.status) for r in res.runs) == [("test_local", "completed"), ("thesis", "completed")]
    finally:
        unregister("avoidance", "test_local")


def test_outcome_maps_use_the_parameters_every_run_of_the_family_has(tmp_path):
    """An Imazu family mixes one-target and multi-target cases (``t2.dcpa_m`` only in some runs): the
    outcome map is drawn over parameters every run has, as a comparison and as a single method."""
    for methods in ([""], ["thesis", "other"]):
        out = tmp_path / ("plain" if methods == [""] else "cmp")
        with CampaignStore(out, "abc", name="c", runs_defined=4) as s:
            for k in range(4):
                params = {"case": k + 1, "t1.dcpa_m": 0.5 * k, "t1.tcpa_s": 30.0 + k}
                if k % 2:
                    params["t2.dcpa_m"] = 1.0 * k
                for m in methods:
                    s.record(k, method=m, family="imazu", parameters=params, seed=k, scenario="", status="completed",
                             metrics={"vessels": {"own": {"min_clearance_to_any_m": 1.0 + k}}, "any_collision": False})
        names = {p.name for p in write_report(out, formats=("png",))["files"]}
        assert ("outcomes_imazu.png" if methods == [""] else "outcomes_imazu_other.png") in names


def test_trackers_compared_on_the_same_runs(tmp_path):
    """compare_stage = "tracking": every run once per tracker, the same scenario but for its
    [vessels.tracking] tables; each summary names the tracker that ran; the report says which
    tables differ. The stage is checked when the file is read."""
    spec = parse_campaign_spec({"name": "trackers", "compare_stage": "tracking", "methods": ["imm", "filterpy_imm"],
                                "families": [{"kind": "head_on", "runs_per_point": 2, "duration_s": 4.0}]})
    assert spec.compare_stage == "tracking" and spec.method_labels == ("imm", "filterpy_imm")
    texts = {m: spec.run(1, m).scenario_toml for m in spec.method_labels}

    def without_tracking(text):
        doc = tomllib.loads(text)
        for v in doc.get("vessels", []):
            v.pop("tracking", None)
        return doc

    assert without_tracking(texts["imm"]) == without_tracking(texts["filterpy_imm"])
    assert [v["tracking"]["method"] for v in tomllib.loads(texts["filterpy_imm"])["vessels"] if "tracking" in v] \
        == ["filterpy_imm"]
    res = run_campaign(spec, tmp_path / "c", workers=0, progress=False)
    assert sorted((r.index, r.method, r.status) for r in res.runs) == [
        (k, m, "completed") for k in range(2) for m in ("filterpy_imm", "imm")]
    ran = {r.method: r.metrics["vessels"]["own"]["perception"]["tracking_method"] for r in res.runs}
    assert ran == {"imm": "imm", "filterpy_imm": "filterpy_imm"}
    md = format_report(report_data(tmp_path / "c"))
    assert "for its tracking tables" in md and "| head_on | filterpy_imm | 2 |" in md


@pytest.mark.parametrize("extra, message", [
    ({"compare_stage": "control", "methods": ["thesis"]}, r"^compare_stage: must be one of avoidance, tracking"),
    ({"compare_stage": "tracking"}, r"^compare_stage: given without methods"),
    ({"compare_stage": "tracking", "methods": ["thesis"]}, r"^methods\[0\]: unknown tracking method 'thesis'"),
])
def test_a_bad_compare_stage_is_a_one_line_error(extra, message):
    with pytest.raises(CampaignError, match=message) as info:
        parse_campaign_spec({"name": "x", **extra, "families": [{"kind": "head_on"}]})
    assert "\n" not in str(info.value)
