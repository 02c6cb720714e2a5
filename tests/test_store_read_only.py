"""Reading a campaign store (reports, extracts) writes nothing and works in a read-only folder: a
valid store is never called invalid for want of write access, and no SQLite ``-wal``/``-shm``
file is left beside a store that was only read, or that turned out not to be a store."""

import os
import shutil
import sqlite3
import tempfile
from pathlib import Path

import pytest

from mjasc.campaigns.store import CampaignStore, StoreError


def _store(folder: Path) -> Path:
    with CampaignStore(folder, "abc", name="c", runs_defined=2) as s:
        for k in range(2):
            s.record(k, family="head_on", parameters={"dcpa_m": 1.0}, seed=k, scenario="seed = 1\n",
                     status="completed", metrics={"min_separation_m": 3.0})
    return folder


def _listing(folder: Path) -> dict:
    return {p.name: p.read_bytes() for p in folder.iterdir()}


def test_reading_a_store_writes_nothing_beside_it(tmp_path):
    from mjasc.campaigns.report import format_report, report_data

    before = _listing(_store(tmp_path))
    with CampaignStore.open_existing(tmp_path) as s:
        assert len(s.runs()) == 2
        assert sorted(os.listdir(tmp_path)) == ["campaign.sqlite"]  # (not even while open)
    assert "2 of 2" in format_report(report_data(tmp_path)) or report_data(tmp_path)["runs_recorded"] == 2
    assert _listing(tmp_path) == before


def test_a_store_with_results_in_its_wal_reads_them(tmp_path):
    """A campaign running (or killed) keeps its latest results in campaign.sqlite-wal: read too."""
    _store(tmp_path)
    writer = sqlite3.connect(tmp_path / "campaign.sqlite", isolation_level=None)
    writer.execute("PRAGMA wal_autocheckpoint=0")
    writer.execute("UPDATE campaigns SET runs_defined = 7")
    assert (tmp_path / "campaign.sqlite-wal").stat().st_size > 0
    try:
        with CampaignStore.open_existing(tmp_path) as s:
            assert s.info()["runs_defined"] == 7
    finally:
        writer.close()


def _read_as_nobody(folder: Path) -> str:
    """Open the store in ``folder`` from a child without write access to it; 'ok <runs>' or the error."""
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: no write access (root's is dropped: root ignores permission bits)
        os.close(r)
        try:
            if os.geteuid() == 0:
                os.setgid(65534)
                os.setuid(65534)
            with CampaignStore.open_existing(folder) as s:
                text = f"ok {len(s.runs())}"
        except BaseException as exc:  # noqa: BLE001
            text = f"{type(exc).__name__}: {exc}"
        os.write(w, text.encode())
        os._exit(0)
    os.close(w)
    with os.fdopen(r) as f:
        text = f.read()
    os.waitpid(pid, 0)
    return text


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork")
def test_a_read_only_folder_reads(tmp_path):
    base = Path(tempfile.mkdtemp(prefix="mjasc-ro-"))  # (not under pytest's 0700 folder: the child must see it)
    try:
        os.chmod(base, 0o755)
        folder = _store(base / "camp")
        before = _listing(folder)
        os.chmod(folder / "campaign.sqlite", 0o444)
        os.chmod(folder, 0o555)
        assert _read_as_nobody(folder) == "ok 2"
        assert _listing(folder) == before
    finally:
        for p in (base / "camp", base):
            if p.exists():
                os.chmod(p, 0o755)
        shutil.rmtree(base)


@pytest.mark.parametrize("damage", ["garbage", "truncated", "header only"])
def test_a_damaged_store_leaves_no_wal_or_shm(tmp_path, damage):
    good = _store(tmp_path / "good") / "campaign.sqlite"
    data = good.read_bytes()
    bad = tmp_path / "bad"
    bad.mkdir()
    if damage == "garbage":
        data = os.urandom(len(data))
    elif damage == "truncated":
        data = data[: len(data) // 2]
    else:
        data = data[:100] + os.urandom(len(data) - 100)
    (bad / "campaign.sqlite").write_bytes(data)
    for opener in (lambda: CampaignStore.open_existing(bad), lambda: CampaignStore(bad, "abc")):
        try:
            opener().close()
        except StoreError:
            pass
        assert sorted(os.listdir(bad)) == ["campaign.sqlite"]


def test_the_store_file_alone_holds_every_stored_result(tmp_path):
    """Results are moved from the -wal into campaign.sqlite as they are stored and when the store
    closes: a copy of campaign.sqlite alone (while a campaign runs, or after it ended) is the store."""
    copy = tmp_path / "copy"
    copy.mkdir()
    s = CampaignStore(tmp_path / "c", "abc", name="c", runs_defined=3)
    try:
        s.record(0, family="f", parameters={}, seed=0, scenario="", status="completed", metrics={})
        shutil.copy(tmp_path / "c" / "campaign.sqlite", copy / "campaign.sqlite")  # (while it runs)
        with CampaignStore.open_existing(copy) as c:
            assert [r.index for r in c.runs()] == [0]
        s.record(1, family="f", parameters={}, seed=1, scenario="", status="completed", metrics={})
    finally:
        s.close()
    wal = tmp_path / "c" / "campaign.sqlite-wal"
    assert not wal.exists() or wal.stat().st_size == 0
    shutil.copy(tmp_path / "c" / "campaign.sqlite", copy / "campaign.sqlite")
    with CampaignStore.open_existing(copy) as c:
        assert [r.index for r in c.runs()] == [0, 1]


def test_the_report_of_a_store_without_runs_says_so(tmp_path):
    from mjasc.campaigns.report import format_report, report_data

    CampaignStore(tmp_path, "abc", name="c", runs_defined=3).close()
    text = format_report(report_data(tmp_path))
    assert "(statuses: )" not in text and "no run stored yet" in text
