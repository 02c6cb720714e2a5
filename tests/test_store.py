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
