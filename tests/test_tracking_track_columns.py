"""TrackColumns (one store of a tracker's per-track columns, one compiled append and one compiled
in-place keep) against the numpy form — each column its own array, concatenated at births and
boolean-indexed at drops — bit for bit, through births, drops, growth beyond the capacity and
writes between them."""

from __future__ import annotations

import numpy as np
import pytest

from mjasc.perception.tracking.track_columns import TrackColumns

_F = ("born", "last", "radius", "nis")
_F2 = ("anchor", "hull_anchor")
_I = ("owner", "local_id", "hist", "scans", "n_upd")
_B = ("confirmed", "static", "anchored", "moved", "manoeuvring")
_O = ("team", "hull")


def _new(k, t, r, c, own, loc, confirm_now):
    one = np.ones(k, dtype=np.int64)
    no = np.zeros(k, dtype=bool)
    return {"born": t, "last": t, "radius": r, "nis": np.full(k, 2.0), "anchor": np.zeros((k, 2)), "hull_anchor": c,
            "owner": own, "local_id": loc, "hist": one, "scans": one, "n_upd": one,
            "confirmed": no | confirm_now, "static": no, "anchored": no, "moved": no, "manoeuvring": no,
            "team": np.full(k, None, dtype=object), "hull": np.full(k, None, dtype=object)}


@pytest.mark.parametrize("seed", range(8))
def test_append_and_keep_equal_concatenation_and_indexing(seed):
    rng = np.random.default_rng(seed)
    confirm_now = seed % 2 == 1
    cols = TrackColumns(confirm_now, capacity=int(rng.integers(1, 6)))
    ref = {name: np.asarray(getattr(cols, name)).copy() for name in _F + _F2 + _I + _B + _O}
    for step in range(40):
        k = int(rng.integers(0, 5))
        if k:
            t, r, c = rng.uniform(0, 9, k), rng.uniform(0.2, 3, k), rng.normal(size=(k, 2))
            own, loc = rng.integers(0, 4, k), rng.integers(0, 99, k)
            if step % 4 == 0:
                cols.append(float(t[0]), r)  # (a scalar time, no centres nor vessels)
                add = _new(k, np.full(k, float(t[0])), r, np.zeros((k, 2)), np.zeros(k, dtype=np.int64),
                           np.zeros(k, dtype=np.int64), confirm_now)
            else:
                cols.append(t, r, c, own, loc)
                add = _new(k, t, r, c, own, loc, confirm_now)
            ref = {name: np.concatenate([ref[name], add[name]]) for name in ref}
        n = cols.n
        if n and rng.random() < 0.5:  # writes through the views, as the components make them
            j = int(rng.integers(0, n))
            for name in _F + _I + _B:
                v = getattr(cols, name)
                v[j] = ref[name][j] = (rng.random() < 0.5) if v.dtype == bool else rng.integers(0, 50)
            cols.anchor[j] = ref["anchor"][j] = rng.normal(size=2)
            cols.hull_anchor[j] = ref["hull_anchor"][j] = rng.normal(size=2)
            cols.team[j] = ref["team"][j] = "mate"
            h = rng.normal(size=(3, 2))
            cols.hull[j] = h
            ref["hull"][j] = h
        if n and rng.random() < 0.5:
            keep = rng.random(n) < 0.7
            if step % 3 == 0:  # (one row dropped: the rows after it moved up by a slice's copy)
                keep[:] = True
                keep[int(rng.integers(0, n))] = False
            cols.keep(keep)
            ref = {name: ref[name][keep] for name in ref}
        assert len(cols) == ref["owner"].size
        for name in _F + _F2 + _I + _B:
            a, b = getattr(cols, name), ref[name]
            assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes(), name
        for name in _O:
            assert all(x is y for x, y in zip(getattr(cols, name), ref[name], strict=True)), name


def test_keep_needs_one_flag_per_row():
    cols = TrackColumns()
    cols.append(0.0, np.ones(3))
    with pytest.raises(IndexError):
        cols.keep(np.ones(4, dtype=bool))


def test_views_made_once_per_count_stay_the_tables_rows():
    """The columns' views are reused when the count of rows comes back (and made again for a copied
    store's tables): each is always the first n rows of its table."""
    import copy

    from mjasc.perception.tracking.track_columns import TrackColumns

    rng = np.random.default_rng(0)
    c = TrackColumns(capacity=4)
    for step in range(40):
        k = int(rng.integers(0, 4))
        c.append(rng.random(k), rng.random(k), rng.random((k, 2)), rng.integers(0, 3, k), rng.integers(0, 9, k))
        if step % 3 == 2:
            c = copy.deepcopy(c)
        c.keep(rng.random(c.n) < 0.7)
        n = c.n
        for name, table, row in (("born", c._f, 0), ("radius", c._f, 2), ("owner", c._i, 0), ("n_upd", c._i, 4),
                                 ("confirmed", c._b, 0), ("manoeuvring", c._b, 4), ("team", c._o, 0),
                                 ("hull", c._o, 1)):
            v = getattr(c, name)
            assert v.shape == (n,) and np.shares_memory(v, table) or n == 0
            v[...] = v  # (writable)
            assert (table[row, :n] == v).all()
        assert c.anchor.shape == (n, 2) and (n == 0 or np.shares_memory(c.anchor, c._f))
        assert c.hull_anchor.shape == (n, 2) and (n == 0 or np.shares_memory(c.hull_anchor, c._f))
