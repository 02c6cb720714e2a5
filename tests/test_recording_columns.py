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
