"""The recorder's column builders (mjasc.runs.recording): the fast paths give the same arrow arrays
as the readable forms."""

import numpy as np
import pytest

from mjasc.runs.recording_columns import strip_column as _strip_column


def test_strip_column_of_one_length_array_is_the_list_form():
    rng = np.random.default_rng(7)
    strips = rng.normal(scale=50.0, size=(37, 6, 2))
    per_row = np.ones(len(strips), dtype=np.int32)
    fast = _strip_column(strips, 0.2, per_row).as_arrow_array()
    ref = _strip_column(list(strips), 0.2, per_row).as_arrow_array()
    assert fast.equals(ref)
    assert fast.to_pylist() == ref.to_pylist()


def test_vec3_array_is_the_sdks_vec3d_batch():
    """_vec3_array gives the array (type, values, buffers) rerun's Vec3DBatch builds, for float64,
    float32, reversed (strided) and Fortran-ordered points, and none."""
    from rerun.encodings import Vec3DBatch

    from mjasc.runs.recording_columns import vec3_array as _vec3_array

    rng = np.random.default_rng(3)
    for n in (0, 1, 7, 500):
        x = rng.normal(scale=100.0, size=(n, 3))
        for points in (x, x.astype(np.float32), x[::-1], np.asfortranarray(x)):
            ref = Vec3DBatch(np.asarray(points, dtype=np.float32)).as_arrow_array()
            fast = _vec3_array(points)
            assert fast.type == ref.type and fast.equals(ref)
            assert [b is None for b in fast.buffers()] == [b is None for b in ref.buffers()]
            assert [b.to_pybytes() for b in fast.buffers() if b is not None] == \
                [b.to_pybytes() for b in ref.buffers() if b is not None]


def test_stack_rows_is_np_stack_entity_first():
    from mjasc.runs.recording_columns import stack_rows

    rng = np.random.default_rng(5)
    for shape in [(3,), (3, 2), (3, 6, 2), (0, 2)]:
        rows = [rng.normal(size=shape) for _ in range(17)]
        got, want = stack_rows(rows), np.stack(rows, axis=1)
        assert got.shape == want.shape and got.dtype == want.dtype and got.flags.c_contiguous
        np.testing.assert_array_equal(got, want)
    with pytest.raises(ValueError):
        stack_rows([np.zeros((3, 2)), np.zeros((3, 4, 2))])


def _same_array(a, b):
    """Same arrow array: type, length and buffers (what the recording's bytes are made of; NaN bits included)."""
    assert a.type == b.type and len(a) == len(b) and a.offset == b.offset and a.null_count == b.null_count
    assert [x is None for x in a.buffers()] == [x is None for x in b.buffers()]
    assert [x.to_pybytes() for x in a.buffers() if x is not None] == \
        [x.to_pybytes() for x in b.buffers() if x is not None]


def test_vec3_at_is_vec3_array_of_xyz_at():
    from mjasc.runs.recording_columns import vec3_array, vec3_at, xyz_at

    rng = np.random.default_rng(4)
    for n in (0, 1, 9, 300):
        xy = rng.normal(scale=1e3, size=(n, 2))
        xy[rng.random((n, 2)) < 0.05] = np.nan
        for points in (xy, xy[::-1], np.asfortranarray(xy), list(xy)):
            for z in (0.0, 0.15, 0.3, -1.7):
                _same_array(vec3_at(points, z), vec3_array(xyz_at(points, z)))


def test_packed_colours_are_the_sdks_colour_batch():
    import rerun as rr

    from mjasc.runs.recording_columns import packed_colours

    rng = np.random.default_rng(6)
    palette = [tuple(int(v) for v in rng.integers(0, 256, 4)) for _ in range(5)] + [(255, 255, 255, 255), (0, 0, 0, 0)]
    for n in (0, 1, 2, 40):
        flat = [palette[k] for k in rng.integers(0, len(palette), n)]
        ref = rr.components.ColorBatch(np.array(flat, dtype=np.uint8).reshape(-1, 4)).as_arrow_array()
        _same_array(packed_colours(flat), ref)


def test_shared_times_give_time_column_once_per_distinct_times():
    from mjasc.runs.recording_columns import SharedTimes, time_column

    t = [k * 0.2 for k in range(50)]
    times = SharedTimes()
    a = times(t)
    _same_array(a.as_arrow_array(), time_column(t).as_arrow_array())
    assert times(list(t)) is a and times(np.array(t)) is a  # (equal times, a list or an array: the same column)
    other = list(t)
    other[7] += 1e-12
    b = times(other)
    assert b is not a
    _same_array(b.as_arrow_array(), time_column(other).as_arrow_array())
    arr = np.array(t[:10]) + 0.05
    c = times(arr)
    assert times(list(arr)) is c
    _same_array(c.as_arrow_array(), time_column(arr).as_arrow_array())
    _same_array(times([]).as_arrow_array(), time_column([]).as_arrow_array())


def test_flat_strip_column_is_the_strips_list_form():
    from mjasc.runs.recording_columns import flat_strip_column

    rng = np.random.default_rng(8)
    rows = [rng.normal(size=(3, m, 2)) for m in (2, 5, 0, 7)]  # rows (entities, m, 2) of different m
    flat = np.concatenate(rows, axis=1)
    lengths = np.array([r.shape[1] for r in rows], dtype=np.int32)
    ones = np.ones(len(rows), dtype=np.int32)
    for j in range(3):
        fast = flat_strip_column(flat[j], lengths, 0.1, ones).as_arrow_array()
        ref = _strip_column([r[j] for r in rows], 0.1, ones).as_arrow_array()
        _same_array(fast, ref)
