"""The drops' compiled compactions (IMMBank.keep_rows in its cycle buffers, StartupFilters.keep,
TrackManagement.keep) against the boolean indexing they replaced, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from mjasc.perception.imm import IMMBank
from mjasc.perception.imm.startup import StartupFilters
from mjasc.perception.tracking import TrackingConfig
from mjasc.perception.tracking.management import TrackManagement


def _same(a, b):
    assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


@pytest.mark.parametrize("seed", range(6))
def test_bank_keep_rows_equals_boolean_indexing(seed):
    rng = np.random.default_rng(seed)
    bank = IMMBank()
    n = int(rng.integers(1, 20))
    bank.add_tracks(rng.normal(size=(n, 2)) * 30, 0.0)
    for step in range(1, 6):
        bank.update(rng.normal(size=(n, 2)) * 30, 0.5 * step, rng.random(n) < 0.8)
    assert bank._side is not None
    keep = rng.random(n) < 0.6
    want = {name: getattr(bank, name)[keep].copy() for name in IMMBank._PER_TRACK if name != "_Pc"}
    want["_Pc"] = bank._covariances()[keep].copy()
    st = bank._startup
    want_st = (st.active[keep], st.x[keep], st.P[keep], st.n_meas[keep])
    bank._Pc_stale = False  # (the combined covariances are current: compare the stored ones)
    bank.keep_rows(keep)
    for name, a in want.items():
        _same(getattr(bank, name), a)
    for a, b in zip((st.active, st.x, st.P, st.n_meas), want_st):
        _same(a, b)
    assert st.n_active == int(np.count_nonzero(st.active))
    with pytest.raises(IndexError):
        bank.keep_rows(np.ones(len(bank) + 1, dtype=bool))


@pytest.mark.parametrize("seed", range(6))
def test_management_and_startup_keep_equal_boolean_indexing(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(0, 15))
    keep = rng.random(n) < 0.5
    mg = TrackManagement(TrackingConfig())
    mg.append(rng.uniform(0, 10, n), rng.uniform(0.2, 2.0, n))
    names = ("_hist", "_scans", "_n_upd", "_confirmed", "_static", "_born", "_last", "_radius", "_anchor",
             "_anchored", "_moved")
    for name in names:  # random contents of each array's type
        a = getattr(mg, name)
        if a.dtype == np.bool_:
            a[...] = rng.random(a.shape) < 0.5
        elif a.dtype.kind == "i":
            a[...] = rng.integers(0, 100, a.shape)
        else:
            a[...] = rng.normal(size=a.shape)
    want = [getattr(mg, name)[keep] for name in names]
    mg.keep(keep)
    for name, a in zip(names, want):
        _same(getattr(mg, name), a)

    sf = StartupFilters(IMMBank().config)
    sf.append_started(rng.normal(size=(n, 2)), 0.25)
    sf.active[...] = rng.random(n) < 0.5
    sf.x[...] = rng.normal(size=sf.x.shape)
    sf.P[...] = rng.normal(size=sf.P.shape)
    sf.n_meas[...] = rng.integers(1, 9, n)
    want = (sf.active[keep], sf.x[keep], sf.P[keep], sf.n_meas[keep])
    sf.keep(keep)
    for a, b in zip((sf.active, sf.x, sf.P, sf.n_meas), want):
        _same(a, b)
    assert sf.n_active == int(np.count_nonzero(want[0])) and type(sf.n_active) is int
