"""Arrow columns for Rerun's ``send_columns``: the recorder's buffered rows written column-wise.

Each builder makes the arrow array the Rerun SDK's own archetype ``columns(...)`` would make for the
same rows (float32 ``Vec3D`` points, float64 scalars, int32 list offsets, ``sim_time`` durations in
ns), without the SDK's per-call checks (~0.4 ms a call, a call per column): the recording's bytes
are those of the SDK's path (tests/test_recording_columns.py).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import pyarrow as pa
import rerun as rr
from rerun.encodings import Vec3DBatch

__all__ = ["TIMELINE", "ArrowBatch", "Column", "TimeColumn", "SharedTimes", "strip_column", "flat_strip_column",
           "offsets_of", "vec3_array", "vec3_at", "packed_colours", "sparse_column",
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
        return flat_strip_column(strips.reshape(-1, 2), np.full(len(strips), strips.shape[1], dtype=np.int32), z,
                                 per_row)
    return flat_strip_column(concat_xy(strips), np.fromiter(map(len, strips), dtype=np.int32, count=len(strips)), z,
                             per_row)


def flat_strip_column(flat_xy: np.ndarray, lengths: np.ndarray, z: float, per_row) -> rr.ComponentColumn:
    """:func:`strip_column` of strips given as their points one after the other (flat_xy (p, 2)
    world xy [m]) and their lengths (int32, one per strip)."""
    points = vec3_at(flat_xy, z)
    array = pa.ListArray.from_arrays(pa.array(offsets_of(lengths)), points, type=STRIP_TYPE)
    return rr.ComponentColumn(rr.LineStrips3D.descriptor_strips(), ArrowBatch(array), lengths=per_row)


def offsets_of(lengths) -> np.ndarray:
    """int32 list offsets (n + 1,) of lists of ``lengths`` (n,): 0 then their running sum."""
    offsets = np.zeros(len(lengths) + 1, dtype=np.int32)
    np.cumsum(lengths, dtype=np.int32, out=offsets[1:])
    return offsets


VEC3_TYPE = Vec3DBatch._ARROW_DATATYPE


def vec3_array(xyz) -> pa.Array:
    """Points (k, 3) as float32 ``Vec3D`` arrow values: the array ``Vec3DBatch(xyz).as_arrow_array()``
    builds (its own conversion: flat float32, contiguous, a fixed-size list of 3), without its
    per-call checks (~0.4 ms a call, a call per column)."""
    flat = np.ascontiguousarray(np.asarray(xyz, dtype=np.float32).reshape(-1, 3)).reshape(-1)
    return pa.FixedSizeListArray.from_arrays(flat, type=VEC3_TYPE)


def vec3_at(points_xy, z: float) -> pa.Array:
    """Points (k, 2) world xy [m] at height z as float32 ``Vec3D`` arrow values: the array
    ``vec3_array(xyz_at(points_xy, z))`` builds (each coordinate cast to float32 as there), written
    straight into one float32 buffer."""
    p = np.asarray(points_xy, dtype=np.float64).reshape(-1, 2)
    xyz = np.empty((len(p), 3), dtype=np.float32)
    xyz[:, :2] = p
    xyz[:, 2] = z
    return pa.FixedSizeListArray.from_arrays(xyz.reshape(-1), type=VEC3_TYPE)


def packed_colours(colours: list) -> pa.Array:
    """RGBA colours (tuples of four 0–255 ints) as Rerun's packed ``0xRRGGBBAA`` uint32 values: the
    array ``rr.components.ColorBatch(np.array(colours, dtype=np.uint8).reshape(-1, 4))`` builds,
    each distinct colour packed once (a run's colours are a few, repeated)."""
    packed = {c: (c[0] << 24) | (c[1] << 16) | (c[2] << 8) | c[3] for c in set(colours)}
    return pa.array(np.array([packed[c] for c in colours], dtype=np.uint32), pa.uint32())


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
    lengths = [0 if r is None else len(r) for r in rows]
    values = to_arrow([v for r in rows if r is not None for v in r])
    mask = pa.array(np.array([r is None for r in rows], dtype=bool))
    return Column(descriptor, pa.ListArray.from_arrays(pa.array(offsets_of(lengths)), values, mask=mask))


SCALARS = rr.Scalars.descriptor_scalars()
POSITIONS = rr.Points3D.descriptor_positions()


def list_offsets(n_rows: int, per_row) -> pa.Array:
    """int32 list offsets of ``n_rows`` rows of ``per_row`` values each (an int, or one per row)."""
    if np.ndim(per_row) == 0:
        return _even_offsets(n_rows, int(per_row))
    return pa.array(offsets_of(per_row))


@lru_cache(maxsize=64)
def _even_offsets(n_rows: int, per_row: int) -> pa.Array:
    """int32 list offsets of ``n_rows`` rows of ``per_row`` values each (arrow arrays are immutable:
    the columns of a run's entities with as many rows share one)."""
    return pa.array(np.arange(n_rows + 1, dtype=np.int32) * np.int32(per_row))


def scalar_column(values, per_row=1) -> Column:
    """The ``Scalars:scalars`` column of float64 ``values``, ``per_row`` (an int, or one per row)
    to a row: the arrays ``rr.Scalars.columns(...).partition(...)`` builds, without its per-call cost."""
    v = pa.array(np.asarray(values, dtype=np.float64).reshape(-1))
    n_rows = len(v) // per_row if np.ndim(per_row) == 0 else len(per_row)
    return Column(SCALARS, pa.ListArray.from_arrays(list_offsets(n_rows, per_row), v))


def points_column(points_xy: np.ndarray, z: float, per_row) -> Column:
    """The ``Points3D:positions`` column of points (k, 2) world xy [m] at height z, ``per_row`` (an
    int, or one per row) to a row (float32 xyz, as ``rr.Points3D.columns`` writes them)."""
    points = vec3_at(points_xy, z)
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


class SharedTimes:
    """:func:`time_column` for the entities of one flush: those with the same times (a list or an
    array [s]; the entities a record tick writes) share one column, converted once."""

    def __init__(self):
        self._seen: dict[tuple, list] = {}  # (count, first, last) → [(times, column), ...]

    def __call__(self, times) -> TimeColumn:
        n = len(times)
        if not n:
            return time_column(times)
        is_list = type(times) is list
        key = (n, float(times[0]), float(times[-1]))
        seen = self._seen.setdefault(key, [])
        for other, column in seen:
            if (other == times if is_list and type(other) is list else
                    np.array_equal(np.asarray(other, dtype=np.float64), np.asarray(times, dtype=np.float64))):
                return column
        column = time_column(times)
        seen.append((times, column))
        return column


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
