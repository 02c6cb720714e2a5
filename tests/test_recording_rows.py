"""The recorder's preallocated fleet rows (mjasc.runs.recording_rows) give the arrays a list of rows did."""

import numpy as np

from mjasc.runs.recording_rows import FleetRows


def test_uniform_rows_stack_as_a_list_of_rows_did():
    rng = np.random.default_rng(3)
    rows = [rng.normal(size=(3, 6, 2)) for _ in range(200)]  # past the first capacity: grown twice
    buf = FleetRows(rows[0])
    for k, r in enumerate(rows):
        buf.add(0.1 * k, r)
    assert buf.uniform()
    np.testing.assert_array_equal(buf.time_array(), [0.1 * k for k in range(200)])
    stacked = buf.stacked()
    assert stacked.flags.c_contiguous
    np.testing.assert_array_equal(stacked, np.stack(rows, axis=1))


def test_rows_of_changing_shape_are_kept_as_given():
    rows = [np.full((2, m, 2), float(m)) for m in (2, 2, 3, 4)]
    buf = FleetRows(rows[0])
    for k, r in enumerate(rows):
        buf.add(float(k), r)
    assert not buf.uniform()
    got = buf.rows()
    assert len(got) == 4 and got[2] is rows[2] and got[3] is rows[3]
    for a, b in zip(got, rows):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(buf.time_array(), [0.0, 1.0, 2.0, 3.0])
