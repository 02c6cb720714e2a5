"""The recorder's buffer of a group of entities' rows: one row per record tick, written into
preallocated arrays.

A fleet's row at a record tick (every vessel's hull, position or plot value, world ENU metres or the
series' unit) has the same shape tick after tick, so :class:`FleetRows` copies it into one
preallocated float64 array (grown by doubling) instead of keeping a list of thousands of small
arrays to be stacked — and freed — when the recorder flushes. Rows whose shape changes between
ticks (a trail growing by a point) are kept as a list, as they come (the arrays given, not copies).
:meth:`FleetRows.stacked` gives the rows as ``np.stack(rows, axis=1)`` would (entity first), so
the columns written are the same numbers either way.
"""

from __future__ import annotations

import numpy as np

__all__ = ["FleetRows"]

_FIRST_CAPACITY = 64


class FleetRows:
    """Times [s] and rows (arrays of one shape, or of several: then a list) of one group of entities."""

    __slots__ = ("times", "data", "n", "ragged")

    def __init__(self, row: np.ndarray):
        self.times = np.empty(_FIRST_CAPACITY)
        self.data = np.empty((_FIRST_CAPACITY, *row.shape))
        self.n = 0
        self.ragged: list | None = None  # the rows as a list once their shapes differ

    def add(self, t_s: float, row: np.ndarray) -> None:
        """Append the row ``row`` (float64) at ``t_s``: copied into the buffer while every row has
        the first one's shape, else kept (and the rows before turned into a list)."""
        n = self.n
        if n == len(self.times):
            self.times = np.concatenate([self.times, np.empty(n)])
            if self.ragged is None:
                self.data = np.concatenate([self.data, np.empty_like(self.data)])
        self.times[n] = t_s
        if self.ragged is None:
            if row.shape == self.data.shape[1:]:
                self.data[n] = row
                self.n = n + 1
                return
            self.ragged = list(self.data[:n])
        self.ragged.append(row)
        self.n = n + 1

    def time_array(self) -> np.ndarray:
        """The rows' times (T,) [s]."""
        return self.times[:self.n]

    def rows(self) -> list[np.ndarray]:
        """The rows, one array each (views of the buffer while they share one shape)."""
        return self.ragged if self.ragged is not None else list(self.data[:self.n])

    def uniform(self) -> bool:
        """Do all the rows have one shape?"""
        return self.ragged is None

    def stacked(self) -> np.ndarray:
        """The rows of one shape stacked entity first, (n entities, T, ...): ``np.stack(rows, axis=1)``."""
        return np.ascontiguousarray(np.moveaxis(self.data[:self.n], 0, 1))
