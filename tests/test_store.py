"""The campaign store: results written one transaction per run survive a SIGKILL of the writer;
final results are never replaced, retryable ones are counted; exports to CSV and Parquet."""

import os
import signal
import subprocess
import sys
import textwrap
import time

import pyarrow.parquet as pq

from mjasc.campaigns.store import CampaignStore


def _put(store, k, status="completed", **kw):
    return store.record(k, family="head_on", parameters={"dcpa_m": float(k)}, seed=k, scenario=f"seed = {k}\n",
                        status=status, metrics={"min_separation_m": 1.5 * k, "vessels": {"a": {"x": [1, 2]}}}, **kw)


def test_results_are_kept_and_retries_counted(tmp_path):
    with CampaignStore(tmp_path, "abc", name="c", runs_defined=5) as s:
        _put(s, 0)
        assert _put(s, 1, status="error", error="boom") == 1
        assert _put(s, 1, status="timeout") == 2
        assert s.done(max_attempts=3) == {0}
        assert s.done(max_attempts=2) == {0, 1}
        assert _put(s, 1) == 3 and s.done(max_attempts=5) == {0, 1}
        assert _put(s, 0, status="error") == 1  # a final result is never replaced
        assert s.counts() == {"completed": 2}
        assert s.info()["runs_defined"] == 5
    with CampaignStore(tmp_path, "other") as s2:  # another campaign file in the same folder
        assert s2.runs() == []


def test_a_folder_with_several_campaigns_reports_the_one_run_last(tmp_path, monkeypatch):
    """Two campaign files in one folder: the report reads the campaign a command ran last (also an
    older one resumed), says the store holds two, and each keeps the largest run count asked."""
    from mjasc.campaigns import store as store_module
    from mjasc.campaigns.report import format_report, report_data

    clock = iter(float(t) for t in range(100, 200))
    monkeypatch.setattr(store_module.time, "time", lambda: next(clock))
    with CampaignStore(tmp_path, "aaa", name="first", runs_defined=2) as s:
        _put(s, 0)
        _put(s, 1)
    with CampaignStore(tmp_path, "bbb", name="second", runs_defined=1) as s:
        _put(s, 0)
    assert CampaignStore.open_existing(tmp_path).digest == "bbb"
    with CampaignStore(tmp_path, "aaa", name="first", runs_defined=6) as s:  # the first one resumed, more runs
        assert s.info()["runs_defined"] == 6
    with CampaignStore(tmp_path, "aaa", name="first", runs_defined=3) as s:  # a shorter call: still 6
        assert s.info()["runs_defined"] == 6 and s.info()["campaigns_in_store"] == 2
    with CampaignStore.open_existing(tmp_path) as s:
        assert s.digest == "aaa"
    data = report_data(tmp_path)
    assert data["campaign"]["name"] == "first" and (data["runs_recorded"], data["runs_defined"]) == (2, 6)
    assert "holds 2 campaigns" in format_report(data)
    with CampaignStore(tmp_path / "one", "ccc", name="only", runs_defined=1) as s:
        _put(s, 0)
    assert "campaigns" not in format_report(report_data(tmp_path / "one")).split("\n", 2)[2]


def test_a_store_from_before_the_run_time_column_opens_and_keeps_its_campaign(tmp_path):
    import sqlite3

    db = sqlite3.connect(tmp_path / "campaign.sqlite")
    db.executescript("""CREATE TABLE campaigns (digest TEXT PRIMARY KEY, name TEXT NOT NULL, source TEXT,
        file_text TEXT, runs_defined INTEGER NOT NULL, created_unix_s REAL NOT NULL);
        INSERT INTO campaigns VALUES ('old', 'c', '', '', 4, 1.0);""")
    db.commit()
    db.close()
    with CampaignStore.open_existing(tmp_path) as s:
        assert s.info()["runs_defined"] == 4 and s.digest == "old"
    with CampaignStore(tmp_path, "old", name="c", runs_defined=5) as s:
        assert s.info()["runs_defined"] == 5


def test_exports(tmp_path):
    with CampaignStore(tmp_path, "abc", name="c", runs_defined=3) as s:
        for k in range(3):
            _put(s, k, status="completed" if k else "diverged")
        files = s.export()
    table = pq.read_table(files["parquet"]).to_pylist()
    assert [r["index"] for r in table] == [0, 1, 2] and table[2]["metric.min_separation_m"] == 3.0
    assert table[0]["param.dcpa_m"] == 0.0 and table[1]["metric.vessels.a.x"] == "[1, 2]"
    assert files["csv"].read_text().splitlines()[0].startswith("index,family,seed,status")


def test_sigkill_of_the_writer_loses_no_finished_run(tmp_path):
    code = textwrap.dedent(f"""
        import sys, time
        from mjasc.campaigns.store import CampaignStore
        s = CampaignStore({str(tmp_path)!r}, "abc", name="c", runs_defined=100000)
        k = 0
        while True:
            s.record(k, family="f", parameters={{}}, seed=k, scenario="x", status="completed", metrics={{"k": k}})
            print(k, flush=True)
            k += 1
    """)
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True,
                            env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)})
    acknowledged = -1
    t0 = time.time()
    while acknowledged < 200 and time.time() - t0 < 60:
        acknowledged = int(proc.stdout.readline())
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    with CampaignStore(tmp_path, "abc") as s:
        runs = s.runs()
    idx = [r.index for r in runs]
    assert idx == list(range(len(idx)))          # no gap, no duplicate
    assert len(idx) >= acknowledged + 1          # every acknowledged write is there
    assert all(r.metrics == {"k": r.index} for r in runs)


def test_the_report_has_a_tracking_table_when_runs_were_scored(tmp_path):
    """report.md shows each family's mean GOSPA per run (median / p95 / max) and identity switches,
    with and without compared methods; a campaign whose runs have no tracking score shows none."""
    from mjasc.campaigns.report import format_report, report_data

    def scored(gospa, switches):
        return {"any_collision": False, "vessels": {"own": {"min_clearance_to_any_m": 3.0}},
                "evaluation": {"encounters": [], "tracking": {"own": {"gospa_mean_m": gospa, "id_switches": switches,
                                                                      "position_rmse_m": gospa / 10}}}}

    with CampaignStore(tmp_path / "a", "abc", name="c", runs_defined=3) as s:
        for k, (g, n) in enumerate([(0.5, 0), (1.5, 2), (1.0, 1)]):
            s.record(k, family="head_on", parameters={}, seed=k, scenario="", status="completed", metrics=scored(g, n))
    md = format_report(report_data(tmp_path / "a"))
    assert "| family | runs scored | mean GOSPA per run [m] | position RMSE per run [m] | identity switches |" in md
    assert "| head_on | 3 | 1.000 / 1.450 / 1.500 | 0.100 / 0.145 / 0.150 | 3 |" in md
    with CampaignStore(tmp_path / "b", "abc", name="c", runs_defined=1) as s:
        for m, g in (("imm", 0.25), ("nn_cv", 0.5)):
            s.record(0, method=m, family="f", parameters={}, seed=0, scenario="", status="completed",
                     metrics=scored(g, 1))
    md = format_report(report_data(tmp_path / "b"))
    assert "| f | imm | 1 | 0.250 / 0.250 / 0.250 | 0.025 / 0.025 / 0.025 | 1 |" in md
    assert "| f | nn_cv | 1 | 0.500 / 0.500 / 0.500 | 0.050 / 0.050 / 0.050 | 1 |" in md
    with CampaignStore(tmp_path / "c", "abc", name="c", runs_defined=1) as s:
        _put(s, 0)
    assert "mean GOSPA" not in format_report(report_data(tmp_path / "c"))
