"""Arrow columns for Rerun's ``send_columns``: the recorder's buffered rows written column-wise.

Each builder makes the arrow array the Rerun SDK's own archetype ``columns(...)`` would make for the
same rows (float32 ``Vec3D`` points, float64 scalars, int32 list offsets, ``sim_time`` durations in
ns), without the SDK's per-call checks (~0.4 ms a call, a call per column): the recording's bytes
are those of the SDK's path (tests/test_recording_columns.py).
"""

from __future__ import annotations

import numpy as np
import pyarrow as pa
import rerun as rr
from rerun.encodings import Vec3DBatch

__all__ = ["TIMELINE", "ArrowBatch", "Column", "TimeColumn", "strip_column", "vec3_array", "sparse_column",
           "scalar_column", "points_column", "list_offsets", "time_column", "stack_rows", "concat_xy", "rgba", "xyz_at"]

#: The recording's timeline: simulation seconds.
TIMELINE = "sim_time"


class ArrowBatch:
    """A ready arrow array as a component batch (for :class:`rerun.ComponentColumn`)."""

    def __init__(self, array: pa.Array):
        self._array = array

    def as_arrow_array(self) -> pa.Array:
        return self._array


STRIP_TYPE = rr.components.LineStrip3DBatch._ARROW_DATATYPE


def strip_column(strips: list[np.ndarray], z: float, per_row) -> rr.ComponentColumn:
    """The ``LineStrips3D:strips`` column of rows holding ``per_row`` strips each (strips (m, 2)
    world xy at height z, or an array (k, m, 2) of strips of one length), built as one arrow list
    array (no per-strip conversion)."""
    if isinstance(strips, np.ndarray):
        lengths, flat = np.full(len(strips), strips.shape[1], dtype=np.int32), strips.reshape(-1, 2)
    else:
        lengths, flat = np.fromiter((len(s) for s in strips), dtype=np.int32, count=len(strips)), concat_xy(strips)
    offsets = np.concatenate([[0], np.cumsum(lengths, dtype=np.int32)]).astype(np.int32)
    points = vec3_array(xyz_at(flat, z))
    array = pa.ListArray.from_arrays(pa.array(offsets, pa.int32()), points, type=STRIP_TYPE)
    return rr.ComponentColumn(rr.LineStrips3D.descriptor_strips(), ArrowBatch(array), lengths=per_row)


VEC3_TYPE = Vec3DBatch._ARROW_DATATYPE


def vec3_array(xyz) -> pa.Array:
    """Points (k, 3) as float32 ``Vec3D`` arrow values: the array ``Vec3DBatch(xyz).as_arrow_array()``
    builds (its own conversion: flat float32, contiguous, a fixed-size list of 3), without its
    per-call checks (~0.4 ms a call, a call per column)."""
    flat = np.ascontiguousarray(np.asarray(xyz, dtype=np.float32).reshape(-1, 3)).reshape(-1)
    return pa.FixedSizeListArray.from_arrays(flat, type=VEC3_TYPE)


class Column:
    """A ready arrow list array (a row each) as a component column for ``send_columns``."""

    def __init__(self, descriptor, array: pa.Array):
        self._descriptor, self._array = descriptor, array

    def component_descriptor(self):
        return self._descriptor

    def as_arrow_array(self) -> pa.Array:
        return self._array


def sparse_column(descriptor, rows: list, to_arrow) -> Column:
    """A column with a list of values (``to_arrow(flat values)``) in the rows where ``rows`` has
    one and null in those where it holds None: Rerun's latest-at skips null rows, so rows without
    labels (or colours) keep the latest ones, as rows of an entity of their own did."""
    lengths = np.fromiter((0 if r is None else len(r) for r in rows), dtype=np.int32, count=len(rows))
    offsets = pa.array(np.concatenate([[0], np.cumsum(lengths, dtype=np.int32)]).astype(np.int32))
    values = to_arrow([v for r in rows if r is not None for v in r])
    mask = pa.array(np.fromiter((r is None for r in rows), dtype=bool, count=len(rows)))
    return Column(descriptor, pa.ListArray.from_arrays(offsets, values, mask=mask))


SCALARS = rr.Scalars.descriptor_scalars()
POSITIONS = rr.Points3D.descriptor_positions()


def list_offsets(n_rows: int, per_row) -> pa.Array:
    """int32 list offsets of ``n_rows`` rows of ``per_row`` values each (an int, or one per row)."""
    if np.ndim(per_row) == 0:
        return pa.array(np.arange(n_rows + 1, dtype=np.int32) * np.int32(per_row))
    return pa.array(np.concatenate([[0], np.cumsum(per_row, dtype=np.int32)]).astype(np.int32))


def scalar_column(values, per_row=1) -> Column:
    """The ``Scalars:scalars`` column of float64 ``values``, ``per_row`` (an int, or one per row)
    to a row: the arrays ``rr.Scalars.columns(...).partition(...)`` builds, without its per-call cost."""
    v = pa.array(np.asarray(values, dtype=np.float64).reshape(-1))
    n_rows = len(v) // per_row if np.ndim(per_row) == 0 else len(per_row)
    return Column(SCALARS, pa.ListArray.from_arrays(list_offsets(n_rows, per_row), v))


def points_column(xyz: np.ndarray, per_row) -> Column:
    """The ``Points3D:positions`` column of points (k, 3) [m], ``per_row`` (an int, or one per row)
    to a row (float32 xyz, as ``rr.Points3D.columns`` writes them)."""
    points = vec3_array(xyz)
    n_rows = len(points) // per_row if np.ndim(per_row) == 0 else len(per_row)
    return Column(POSITIONS, pa.ListArray.from_arrays(list_offsets(n_rows, per_row), points))


class TimeColumn:
    """A ``sim_time`` index column (what ``rr.TimeColumn(..., duration=...)`` gives ``send_columns``)."""

    def __init__(self, ns: np.ndarray):
        self._array = pa.array(ns.astype("timedelta64[ns]"), pa.duration("ns"))

    @staticmethod
    def timeline_name() -> str:
        return TIMELINE

    def as_arrow_array(self) -> pa.Array:
        return self._array


def time_column(times) -> TimeColumn:
    """Simulation times [s] as a ``sim_time`` column (rounded to ns like ``set_time``)."""
    return TimeColumn(np.rint(np.asarray(times, dtype=np.float64) * 1e9).astype(np.int64))


def stack_rows(rows: list[np.ndarray]) -> np.ndarray:
    """Rows of one shape (T of them, each (n, ...): one item per entity) entity first, (n, T, ...):
    ``np.stack(rows, axis=1)``'s array, through ``np.array`` (its C sequence conversion: a third of
    ``np.stack``'s time on a run's thousands of small rows)."""
    try:
        out = np.array(rows)
    except ValueError:  # (rows of different shapes: np.stack's own error)
        return np.stack(rows, axis=1)
    if out.dtype == object or out.ndim == 0:
        return np.stack(rows, axis=1)
    return np.ascontiguousarray(np.moveaxis(out, 0, 1))


def concat_xy(arrays: list[np.ndarray]) -> np.ndarray:
    return np.concatenate(arrays) if arrays else np.zeros((0, 2))


def rgba(colour) -> tuple[int, int, int, int]:
    c = tuple(int(v) for v in colour)
    return c if len(c) == 4 else (*c, 255)


def xyz_at(points_xy, z: float) -> np.ndarray:
    p = np.asarray(points_xy, dtype=np.float64).reshape(-1, 2)
    return np.column_stack([p, np.full(len(p), z)])
