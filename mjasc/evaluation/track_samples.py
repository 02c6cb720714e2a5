"""Every vessel's confirmed tracks at each record tick of a run, kept for its evaluation
(:class:`~mjasc.evaluation.run_evaluation.RunEvaluator`) in growing flat arrays.

A fleet tracker's (:class:`~mjasc.perception.tracking.fleet.FleetTracker`) confirmed tracks at one
tick are its confirmed rows, in bank order: their vessel, their id in that vessel's numbering,
their position (x, y) [m] predicted to the tick (:func:`~mjasc.core.estimates.predicted_to`) and
their static flag — what ``FleetTracker.confirmed_rows`` gives, moved on to the tick (the
evaluation scores a static track as one that may stand for a stopped object, never as a false one:
:mod:`mjasc.evaluation.tracking_metrics`). :meth:`TrackSamples.add`
copies them from the tracker's columns and the bank's states (``bank.state_rows``, read at once)
into the arrays in one compiled call per tick (the numpy form is about ten small calls, the record
tick's largest cost); :meth:`TrackSamples.of` hands one vessel's rows of a range of ticks back
flat, as :meth:`~mjasc.evaluation.tracking_metrics.TrackingScore.add_rows` takes them.
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.compiled import kernel

__all__ = ["TrackSamples"]


@kernel
def append_confirmed(confirmed, static, owner, local_id, x_rows, t_rows, t_s, out_owner, out_id, out_xy, out_static,
                     n):
    """Append the rows r with ``confirmed[r]``, in order, at index n of the outputs: owner, id,
    position predicted to t_s along the row's velocity (x, y) + dt·V·(cos θ, sin θ) with
    ``[x, y, θ, V] = x_rows[r]`` and dt = max(t_s − t_rows[r], 0)
    (:func:`~mjasc.core.estimates.predicted_to`), static flag. Returns the new count, or −1 when the
    outputs have no room left (then rows from n on may have been written)."""
    cap = out_owner.shape[0]
    for r in range(confirmed.shape[0]):
        if confirmed[r]:
            if n >= cap:
                return -1
            out_owner[n] = owner[r]
            out_id[n] = local_id[r]
            dv = max(t_s - t_rows[r], 0.0) * x_rows[r, 3]
            out_xy[n, 0] = x_rows[r, 0] + dv * math.cos(x_rows[r, 2])
            out_xy[n, 1] = x_rows[r, 1] + dv * math.sin(x_rows[r, 2])
            out_static[n] = static[r]
            n += 1
    return n


class TrackSamples:
    """The confirmed tracks of one fleet tracker at each tick (module docstring)."""

    def __init__(self, capacity: int = 1024):
        self._owner = np.empty(capacity, dtype=np.int64)
        self._id = np.empty(capacity, dtype=np.int64)
        self._xy = np.empty((capacity, 2))
        self._static = np.empty(capacity, dtype=bool)
        self._ends: list[int] = []  # per tick: the number of rows up to and with it
        self._n = 0

    def __len__(self) -> int:
        """The number of ticks."""
        return len(self._ends)

    def add(self, fleet, t_s: float) -> None:
        """One tick at ``t_s`` [s]: the confirmed tracks of ``fleet`` (a FleetTracker, after its pending
        steps), their positions predicted to t_s (:func:`~mjasc.core.estimates.predicted_to`)."""
        c = fleet.cols
        x_rows, t_rows = fleet.bank.state_rows, fleet.bank.time_rows
        n = append_confirmed(c.confirmed, c.static, c.owner, c.local_id, x_rows, t_rows, t_s, self._owner, self._id,
                             self._xy, self._static, self._n)
        while n < 0:  # (no room: twice the room, and the tick again)
            grow = self._owner.shape[0] + max(self._owner.shape[0], c.confirmed.shape[0])
            self._owner = np.concatenate([self._owner[:self._n], np.empty(grow - self._n, dtype=np.int64)])
            self._id = np.concatenate([self._id[:self._n], np.empty(grow - self._n, dtype=np.int64)])
            self._xy = np.concatenate([self._xy[:self._n], np.empty((grow - self._n, 2))])
            self._static = np.concatenate([self._static[:self._n], np.empty(grow - self._n, dtype=bool)])
            n = append_confirmed(c.confirmed, c.static, c.owner, c.local_id, x_rows, t_rows, t_s, self._owner,
                                 self._id, self._xy, self._static, self._n)
        self._n = n
        self._ends.append(n)

    def rows(self, k0: int, k1: int) -> tuple[np.ndarray, ...]:
        """The ticks k0 … k1 − 1: per row its tick (counted from k0), vessel, id, position (R, 2) [m]
        and static flag."""
        ends = np.array(self._ends[k0:k1], dtype=np.int64)
        a = self._ends[k0 - 1] if k0 > 0 else 0
        b = int(ends[-1]) if ends.size else a
        counts = np.diff(ends, prepend=a)
        tick = np.repeat(np.arange(ends.size), counts)
        return tick, self._owner[a:b], self._id[a:b], self._xy[a:b], self._static[a:b]

    def of(self, owners, k0: int, k1: int) -> dict:
        """Each vessel of ``owners`` (its tracker's owner index) at the ticks k0 … k1 − 1, flat:
        owner → (tracks per tick (k,), ids (R,) int64, positions (R, 2) [m], static flags (R,)), each
        tick's rows one after the other in bank order."""
        tick, owner, ids, xy, static = self.rows(k0, k1)
        out = {}
        for o in owners:
            sel = owner == o
            out[o] = (np.bincount(tick[sel], minlength=k1 - k0), ids[sel], xy[sel], static[sel])
        return out
