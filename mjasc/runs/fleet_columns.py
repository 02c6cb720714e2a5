"""Preallocated record-tick rows of fleet groups: what the truth writes at every record tick (hulls,
positions, the plot table) kept in arrays that grow, not in lists of per-tick arrays.

:class:`FleetColumns` holds named arrays (capacity, *shape) that share one row per record tick and
its time [s]; a compiled kernel writes a tick's values straight into :meth:`FleetColumns.add`'s row.
:class:`ColumnGroup` is one recorder group's view of them (one array, optionally one index along its
second axis, the first ``width`` entities): the recorder's :meth:`~mjasc.runs.recording.Recorder.flush`
reads its times and its rows entity first — the arrays ``np.stack(rows, axis=1)`` of the per-tick
rows gave, the same values, so the same chunks.
"""

from __future__ import annotations

import numpy as np

__all__ = ["FleetColumns", "ColumnGroup"]


class FleetColumns:
    """Rows (one per record tick) of named float64 arrays of fixed row shapes and their times [s]."""

    def __init__(self, shapes: dict[str, tuple[int, ...]], capacity: int = 64):
        capacity = max(int(capacity), 1)
        self.times = np.empty(capacity)
        self.arrays = {name: np.empty((capacity, *shape)) for name, shape in shapes.items()}
        self.n = 0

    def add(self, t_s: float) -> int:
        """A new row at time t_s: its index (the arrays double when full)."""
        n = self.n
        if n == len(self.times):
            self.times = np.concatenate([self.times, np.empty(n)])
            self.arrays = {k: np.concatenate([a, np.empty_like(a)]) for k, a in self.arrays.items()}
        self.times[n] = t_s
        self.n = n + 1
        return n

    def clear(self) -> None:
        """Forget the rows (the recorder wrote them)."""
        self.n = 0


class ColumnGroup:
    """One recorder fleet group's rows in :class:`FleetColumns`: array ``name``, at ``index`` along
    its second axis (None: the whole row), the first ``width`` entities."""

    __slots__ = ("columns", "name", "index", "width")

    def __init__(self, columns: FleetColumns, name: str, index: int | None, width: int):
        self.columns, self.name, self.index, self.width = columns, name, index, width

    def entity_first(self) -> tuple[np.ndarray, np.ndarray]:
        """The rows' times (T,) [s] and values entity first, (width, T, ...), C-contiguous."""
        c = self.columns
        rows = c.arrays[self.name][:c.n]
        if self.index is not None:
            rows = rows[:, self.index]
        return c.times[:c.n].copy(), np.ascontiguousarray(np.moveaxis(rows[:, :self.width], 0, 1))

    def clear(self) -> None:
        self.columns.clear()
