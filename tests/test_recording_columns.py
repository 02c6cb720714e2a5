"""The recorder's column builders (mjasc.runs.recording): the fast paths give the same arrow arrays
as the readable forms."""

import numpy as np

from mjasc.runs.recording import _strip_column


def test_strip_column_of_one_length_array_is_the_list_form():
    rng = np.random.default_rng(7)
    strips = rng.normal(scale=50.0, size=(37, 6, 2))
    per_row = np.ones(len(strips), dtype=np.int32)
    fast = _strip_column(strips, 0.2, per_row).as_arrow_array()
    ref = _strip_column(list(strips), 0.2, per_row).as_arrow_array()
    assert fast.equals(ref)
    assert fast.to_pylist() == ref.to_pylist()
