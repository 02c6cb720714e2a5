"""`mjasc figures`: each figure maker writes real, non-blank PNGs (the potential-field figures are
tested in test_potential_field.py)."""

import imageio.v3 as iio

from mjasc.figures.avoidance import make_avoidance_figures
from mjasc.figures.tracking import make_tracking_figures


def _check_pngs(paths):
    assert paths
    for p in paths:
        img = iio.imread(p)
        assert img.ndim == 3 and img.shape[0] > 200 and img.shape[1] > 200
        assert img.std() > 10, p  # a plot, not a blank canvas


def test_tracking_figures(tmp_path):
    paths = make_tracking_figures(tmp_path)
    assert {p.name for p in paths} == {"thesis_fig_6_1_tracking.png", "thesis_fig_6_2_static.png"}
    _check_pngs(paths)


def test_avoidance_figure_of_a_short_run(tmp_path):
    paths = make_avoidance_figures(tmp_path, scenarios=["thesis_6_4_crossing"], duration_s=30.0)
    assert [p.name for p in paths] == ["avoidance_thesis_6_4_crossing.png"]
    _check_pngs(paths)
