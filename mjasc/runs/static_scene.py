"""The recording's static scene of a run (:class:`~mjasc.runs.runner.Runner`), written once when
the recording opens: what does not change over the run — the water, the legend, each vessel's
entities, colours and mission path, the obstacles, the current field on a grid (its arrows, static
when the field is steady) and the scenario table."""

from __future__ import annotations

import json

import numpy as np

from mjasc.runs.blueprint import OTHERS

__all__ = ["log_static_scene", "PATH_POINTS"]

#: Paths are drawn with points every 0.5 m (traffic 1 m), or this many points on a longer path.
PATH_POINTS = 400


def log_static_scene(rec, sc, lo, hi, plot_series: dict) -> tuple[np.ndarray, float]:
    """Write scenario ``sc``'s static scene to the recorder ``rec`` over the extent ``lo``, ``hi``
    (2,) world [m]: the annotation context and legend, the water, each vessel's entities and plot
    styles (the vessels without views batched into one entity per kind), its mission path, the
    obstacles, the current's arrows (static when the field is steady) and the scenario table.
    ``plot_series``: the runner's per-vessel plot series (kind → entity template) to style.
    Returns the current's arrow grid (k, 2) [m] and scale (the runner redraws an unsteady field)."""
    import rerun as rr

    from mjasc.runs.recording import annotation_context, legend_markdown, vessel_colour

    names = tuple(v.name for v in sc.vessels)
    rec.static("world", annotation_context(names))
    rec.static("legend", rr.TextDocument(legend_markdown(names), media_type="text/markdown"))
    rec.static("world/water", rr.Boxes3D(centers=[[*(0.5 * (lo + hi)), -0.05]],
                                         half_sizes=[[*(0.5 * (hi - lo)), 0.01]], colors=[[40, 90, 150, 60]],
                                         fill_mode="solid"))
    others = [(i, v) for i, v in enumerate(sc.vessels) if v.name in rec.batched]
    if others:  # the vessels without views: one entity per kind, an instance per vessel
        cols = [vessel_colour(i) for i, _ in others]
        ids = [i + 1 for i, _ in others]
        base = f"world/vessels/{OTHERS}"
        rec.static(f"{base}/hull", rr.LineStrips3D.from_fields(colors=cols, radii=[0.08], class_ids=ids,
                                                               show_labels=[False]))
        rec.static(f"{base}/position", rr.Points3D.from_fields(colors=cols, radii=[0.3], class_ids=ids,
                                                               labels=[v.name for _, v in others],
                                                               show_labels=[True]))
        for trail in ("trail", "trail/recent"):
            rec.static(f"{base}/{trail}", rr.LineStrips3D.from_fields(colors=[(*c, 140) for c in cols],
                                                                      radii=[0.05], class_ids=[101],
                                                                      show_labels=[False]))
        paths = [(c, v.path.sample(max(0.5, v.path.length / PATH_POINTS))) for c, (_, v) in zip(cols, others)
                 if v.path is not None]
        if paths:
            rec.static(f"{base}/mission_path", rr.LineStrips3D(
                [np.column_stack([xy, np.zeros(len(xy))]) for _, xy in paths], colors=[(*c, 120) for c, _ in paths],
                radii=[0.06], class_ids=[100], show_labels=[False]))
    for i, v in enumerate(sc.vessels):
        col = vessel_colour(i)
        base = f"world/vessels/{v.name}"
        if v.name not in rec.batched:  # (the others: one entity per kind, above)
            rec.static(f"{base}/hull", rr.LineStrips3D.from_fields(colors=[col], radii=[0.08], class_ids=[i + 1],
                                                                   show_labels=[False]))
            rec.static(f"{base}/position", rr.Points3D.from_fields(colors=[col], radii=[0.3], labels=[v.name],
                                                                   show_labels=[True], class_ids=[i + 1]))
            rec.static(f"{base}/trail", rr.LineStrips3D.from_fields(colors=[(*col, 140)], radii=[0.05],
                                                                    class_ids=[101], show_labels=[False]))
            rec.static(f"{base}/trail/recent", rr.LineStrips3D.from_fields(colors=[(*col, 140)], radii=[0.05],
                                                                           class_ids=[101], show_labels=[False]))
            if v.path is not None:
                xy = v.path.sample(max(0.5, v.path.length / PATH_POINTS))
                rec.static(f"{base}/mission_path", rr.LineStrips3D([np.column_stack([xy, np.zeros(len(xy))])],
                                                                   colors=[(*col, 120)], radii=[0.06],
                                                                   class_ids=[100], show_labels=[False]))
        rec.vessel_series_style(plot_series["speed"], v.name, f"{v.name} speed", col, 2.0)
        rec.vessel_series_style(plot_series["speed_ref"], v.name, f"{v.name} reference", (*col, 120), 1.0)
        rec.vessel_series_style(plot_series["thrust_port"], v.name, f"{v.name} port", col)
        rec.vessel_series_style(plot_series["thrust_starboard"], v.name, f"{v.name} starboard", (*col, 140))
        rec.vessel_series_style(plot_series["cross_track"], v.name, f"{v.name}", col)
        rec.vessel_series_style(plot_series["heading"], v.name, f"{v.name} heading", col)
    for o in sc.static_obstacles:
        poly = o.vertices if hasattr(o, "vertices") else o.polygon(32)
        closed = np.vstack([poly, poly[:1]])
        rec.static(f"world/obstacles/static/{o.name}", rr.LineStrips3D(
            [np.column_stack([closed, np.full(len(closed), 0.5)])], colors=[(150, 110, 80)], radii=[0.15],
            labels=[o.name], class_ids=[110]))
    for o in sc.moving_obstacles:
        rec.static(f"world/obstacles/moving/{o.name}", rr.Points3D.from_fields(
            radii=[o.radius_m], colors=[(220, 60, 60, 160)], labels=[o.name], show_labels=[True],
            class_ids=[109]))
        if o.path is not None:
            xy = o.path.sample(max(1.0, o.path.length / PATH_POINTS))
            rec.static(f"world/obstacles/moving/{o.name}_path", rr.LineStrips3D(
                [np.column_stack([xy, np.zeros(len(xy))])], colors=[(220, 60, 60, 90)], radii=[0.05]))
    # Current arrows on a grid over the scenario area (static when the field is steady).
    gx = np.linspace(lo[0], hi[0], 9)
    gy = np.linspace(lo[1], hi[1], 7)
    grid = np.array([[x, y] for x in gx for y in gy])
    scale = 0.08 * float(np.max(hi - lo))
    vel = sc.current.velocity(grid, 0.0)
    if sc.current.is_steady:
        rec.static("world/current", rr.Arrows3D(origins=np.column_stack([grid, np.zeros(len(grid))]),
                                                vectors=np.column_stack([scale * vel,
                                                                         np.zeros(len(grid))]),
                                                colors=[(120, 200, 255, 150)], radii=[0.12]))
    else:
        rec.static("world/current", rr.Arrows3D.from_fields(colors=[(120, 200, 255, 150)], radii=[0.12]))
    rec.static("scenario", rr.TextDocument(json.dumps(sc.raw, indent=2, default=str), media_type="text/plain"))
    return grid, scale
