"""An IMM cycle of some of a bank's tracks: the rows are taken out as a bank of their own, cycled,
and written back; the other tracks are untouched (not even coasted).

A fleet's bank (:mod:`mjasc.perception.tracking.fleet`) holds the tracks of every vessel; when only
some vessels scanned at a tick, or vessels last scanned at different times, each group of vessels
sharing its last and new time is cycled on its own, with one scalar Ts as in a bank of its own
(the numbers of a row do not depend on the other rows: :mod:`mjasc.perception.imm.compiled_cycle`).
"""

from __future__ import annotations

import numpy as np

from mjasc.perception.imm.cycle_buffers import CycleBuffers

__all__ = ["take_rows", "put_rows"]

_SHARED = ("config", "_r", "_omega", "_mu0", "_consts", "_R", "_R_cov", "_var", "_floor", "_gate", "_next_id",
           "_compiled_fields", "_sv2", "_q_cv")


def take_rows(bank, rows):
    """A bank of its own holding copies of ``rows`` (indices) of ``bank``."""
    sub = object.__new__(type(bank))
    for name in _SHARED:
        setattr(sub, name, getattr(bank, name))
    for name in bank._PER_TRACK:
        setattr(sub, name, getattr(bank, name)[rows])
    sub._Pc[:] = bank._covariances()[rows]
    sub._Pc_stale = False
    sub._startup = bank._startup.take(rows)
    t = sub._t
    sub._t_common = float(t[0]) if t.size and np.all(t == t[0]) else None
    n = t.size
    cycles = bank._sub_cycles  # CycleBuffers per subset size (not the bank's own: its state is a
    cyc = cycles.get(n)        # side of those; a subset's state is copied back by put_rows)
    if cyc is None:
        if len(cycles) >= 32:
            cycles.clear()
        cyc = cycles[n] = CycleBuffers(n, sub._r)
    sub._cyc, sub._side = cyc, None
    sub._rb, sub._rv = None, ()  # (no row buffers: a subset's arrays are its own)
    sub._flagged = True
    sub._mv = None
    return sub


def put_rows(bank, rows, sub) -> None:
    """Write the rows of a :func:`take_rows` bank back into ``bank``."""
    for name in bank._PER_TRACK:
        if name != "_Pc":
            getattr(bank, name)[rows] = getattr(sub, name)
    Pc = sub._covariances()
    bank._covariances()[rows] = Pc
    bank._startup.put(rows, sub._startup)
    t = bank._t
    bank._t_common = float(t[0]) if t.size and np.all(t == t[0]) else None
    bank._flagged = True
