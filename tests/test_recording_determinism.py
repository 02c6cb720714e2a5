"""The same scenario and seed give the same recording content: ``rerun rrd compare`` finds the two
files equal (the recording id is derived from the scenario name and seed, no wall-clock log time),
and a different seed is found different. Not the same bytes: the Rerun 0.41 SDK stamps every row
and chunk with a time-based TUID and gives the blueprint store a random id, and has no API to set
them (docs: known limits)."""

import subprocess
import sys
from pathlib import Path

import pytest

from mjasc.runs.runner import run_scenario
from mjasc.runs.scenario import load_scenario

ROOT = Path(__file__).resolve().parent.parent
RERUN = Path(sys.executable).parent / "rerun"


@pytest.mark.skipif(not RERUN.exists(), reason="the rerun CLI is not installed next to this Python")
def test_same_seed_same_recording_content_different_seed_different(tmp_path):
    sc = load_scenario(ROOT / "tasks" / "thesis_6_1_static.toml").with_overrides(duration_s=3.0)
    paths = []
    for k, seed in enumerate((5, 5, 6)):
        out = tmp_path / f"r{k}"
        run_scenario(sc.with_overrides(seed=seed), out, progress=False)
        paths.append(out / "recording.rrd")

    def same(a, b) -> bool:
        return subprocess.run([str(RERUN), "rrd", "compare", str(a), str(b)], capture_output=True,
                              timeout=120).returncode == 0

    assert same(paths[0], paths[1])
    assert not same(paths[0], paths[2])


@pytest.mark.skipif(not RERUN.exists(), reason="the rerun CLI is not installed next to this Python")
def test_recording_holds_no_wall_clock_start_time_and_derived_blueprint_ids(tmp_path):
    import re
    import uuid

    from mjasc.runs.recording import Recorder, default_blueprint

    rec = Recorder(tmp_path / "r.rrd", "x", 3, default_blueprint(vessels=("a",), avoidance=True))
    rec.close()
    text = subprocess.run([str(RERUN), "rrd", "print", "-vv", str(tmp_path / "r.rrd")], capture_output=True,
                          text=True, timeout=120).stdout
    assert "RecordingInfo:name" in text and "start_time" not in text
    ids = set(re.findall(r"/(?:view|container)/([0-9a-f-]{36})", text))
    assert len(ids) >= 5 and all(uuid.UUID(i).version == 5 for i in ids)
    key = "mjasc/x/3/blueprint"
    assert str(uuid.uuid5(uuid.NAMESPACE_URL, f"{key}/1")) in ids  # the first view under the root container
