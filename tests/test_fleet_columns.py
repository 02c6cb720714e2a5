"""The truth's preallocated record rows (mjasc.runs.fleet_columns) give the recorder the arrays the
per-tick rows stacked entity first gave (np.stack(rows, axis=1)), across growth and a flush."""

import numpy as np

from mjasc.runs.fleet_columns import ColumnGroup, FleetColumns


def test_groups_read_the_stacked_rows_across_growth_and_clear():
    rng = np.random.default_rng(3)
    columns = FleetColumns({"hull": (5, 6, 2), "table": (3, 5)}, capacity=2)
    hull = ColumnGroup(columns, "hull", None, 4)
    series = [ColumnGroup(columns, "table", k, 4) for k in range(3)]
    for rounds in (7, 3):  # (grows from 2 rows; then again after a clear)
        times, hulls, tables = [], [], []
        for i in range(rounds):
            t = 0.1 * i + rounds
            row = columns.add(t)
            h, tab = rng.normal(size=(5, 6, 2)), rng.normal(size=(3, 5))
            columns.arrays["hull"][row], columns.arrays["table"][row] = h, tab
            times.append(t), hulls.append(h[:4]), tables.append(tab)
        t, data = hull.entity_first()
        assert np.array_equal(t, times) and np.array_equal(data, np.stack(hulls, axis=1))
        assert data.flags.c_contiguous
        for k, group in enumerate(series):
            t, data = group.entity_first()
            assert np.array_equal(data, np.stack([tab[k, :4] for tab in tables], axis=1)) and data.flags.c_contiguous
        hull.clear()
        assert columns.n == 0
