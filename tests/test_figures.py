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


def test_bottleneck_conflict_labels_do_not_overlap_and_the_axis_frames_the_action():
    """The bottleneck run predicts the same conflicts again and again at the narrows: their labels
    are merged into numbered groups whose boxes (as the renderer draws them) do not overlap, each
    in the axes; the axis spans where the vessels sailed, not the 250 m of their mission paths."""
    import itertools

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from mjasc.figures.avoidance import trace_figure, trace_run
    from mjasc.figures.conflict_labels import LABEL_GID

    trace = trace_run("thesis_6_4_bottleneck")
    raw = sum(len(v) for v in trace.collision_points.values())
    fig = trace_figure(trace, "bottleneck", plt)
    try:
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        ax = fig.axes[0]
        labels = [t for t in ax.texts if t.get_gid() == LABEL_GID]
        assert 2 <= len(labels) < raw  # merged, but not into one
        assert [t.get_text() for t in labels] == [str(k) for k in range(1, len(labels) + 1)]
        boxes = [t.get_bbox_patch().get_window_extent(renderer) for t in labels]
        for a, b in itertools.combinations(boxes, 2):
            assert not a.overlaps(b), (a, b)
        axes_box = ax.get_window_extent(renderer)
        assert all(axes_box.contains(b.x0, b.y0) and axes_box.contains(b.x1, b.y1) for b in boxes)
        (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
        pts = np.array([p for v in trace.collision_points.values() for _, p, _, _ in v])
        assert np.all((pts >= [x0, y0]) & (pts <= [x1, y1]))  # no conflict cropped away
        assert y1 < 150.0, "the mission paths' northern 100 m of empty water are cut off"
        key = " ".join(t.get_text() for t in fig.axes[2].texts)
        assert all(f"{k}: " in key for k in range(1, len(labels) + 1)) and " s" in key  # units
    finally:
        plt.close(fig)


def test_the_chain_mission_figure_s_legend_covers_no_name_title_or_axis_label():
    """The top-down view's legend (as drawn) overlaps neither a vessel's or the traffic's name label
    nor the title or the axis labels, and every name label lies inside the axes: the legend inside
    the axes covered the ferry's label where its track enters the frame."""
    import itertools

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from mjasc.core.resources import tasks_dir
    from mjasc.figures.missions import FIGURE_SCENARIOS, NAME_LABEL_GID, mission_figure, trace_mission
    from mjasc.runs.scenario import load_scenario

    (stem,) = FIGURE_SCENARIOS
    sc = load_scenario(tasks_dir() / f"{stem}.toml")
    tr, summary = trace_mission(sc)
    fig = mission_figure(sc, tr, summary, FIGURE_SCENARIOS[stem], plt)
    try:
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        ax = fig.axes[0]
        labels = [t for t in ax.texts if t.get_gid() == NAME_LABEL_GID]
        names = {t.get_text() for t in labels}
        assert {v.name for v in sc.vessels} | {"ferry"} <= names
        legend = ax.get_legend().get_window_extent(renderer)
        axes_box = ax.get_window_extent(renderer)
        for t in [*labels, ax.title, ax.xaxis.label, ax.yaxis.label]:
            box = t.get_window_extent(renderer)
            assert not legend.overlaps(box), t.get_text()
        for t in labels:
            box = t.get_window_extent(renderer)
            inside = axes_box.x0 <= box.x0 and box.x1 <= axes_box.x1 and axes_box.y0 <= box.y0 and box.y1 <= axes_box.y1
            assert inside, t.get_text()
        for a, b in itertools.combinations(labels, 2):
            box_a, box_b = a.get_window_extent(renderer), b.get_window_extent(renderer)
            assert not box_a.overlaps(box_b), (a.get_text(), b.get_text())
    finally:
        plt.close(fig)


def test_the_dock_figure_shows_the_moored_vessels_and_a_legend_entry_for_every_style():
    """The §6.2 dock: the two moored team mates (a track of one point draws nothing) are drawn as
    hulls at their berths and named in the legend, and the legend lists the structures, the
    detours, the potential field's obstacles and the static virtual obstacles the view draws."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from mjasc.figures.avoidance import HULL_GID, trace_figure, trace_run

    trace = trace_run("thesis_6_2_dock", duration_s=8.0)
    assert trace.detours and trace.svos  # the first re-plans come within 8 s
    fig = trace_figure(trace, "dock", plt)
    try:
        ax = fig.axes[0]
        hulls = [p for p in ax.patches if p.get_gid() == HULL_GID]
        assert len(hulls) == 3
        last = np.array(trace.positions[-1])
        for hull, p in zip(hulls, last):  # each hull drawn where its vessel ended, in data coordinates
            xy = hull.get_path().vertices
            assert np.allclose(xy[:-1].mean(axis=0), p, atol=0.3)
        texts = [t.get_text() for t in ax.get_legend().get_texts()]
        for want in ("vessel1 (moored)", "vessel3 (moored)", "vessel2 track", "structure", "detour",
                     "potential-field obstacle", "static virtual obstacle"):
            assert any(want in t for t in texts), (want, texts)
    finally:
        plt.close(fig)


def test_legend_rows_match_what_is_drawn_for_traffic_and_detours():
    """A detour's swatch is dash-dot (the traffic's track is dashed grey: the two rows looked
    alike), and the traffic's row shows a hull marker only when its hull at the end is in view
    (in the §6.4.1 crossing the ship has left the view: its track alone)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from mjasc.figures.avoidance import DETOUR_DASHES, trace_figure, trace_run

    assert len(DETOUR_DASHES) == 4  # dash-dot
    trace = trace_run("thesis_6_4_crossing", duration_s=60.0)
    fig = trace_figure(trace, "crossing", plt)
    try:
        legend = fig.axes[0].get_legend()
        rows = {t.get_text(): h for t, h in zip(legend.get_texts(), legend.legend_handles)}
        assert "traffic: track" in rows and not any("hull at the end" in k and "traffic" in k for k in rows)
        assert rows["traffic: track"].get_marker() in ("None", "", None)
    finally:
        plt.close(fig)
