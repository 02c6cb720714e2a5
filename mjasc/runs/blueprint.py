"""The default Rerun blueprint of a run and its legend: the views a recording opens with.

The top-down 3-D view of the world (ENU, z up, looked at from above: Rerun's 2-D views draw y
downwards) framed on the scene's extent, tabs of time series grouped per vessel, and the event
log, legend and scenario text. Every vessel has a stable colour (:func:`vessel_colour`) that the
recording (hull, name, trail, tracks, plots) and the video reuse; the legend lists those colours
and the overlay classes both as a Rerun annotation context (``world``) and as a markdown document
(``legend``). View and container ids are derived from the run (:func:`stable_blueprint_ids`) so
that the same run gives the same blueprint.
"""

from __future__ import annotations

import uuid

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

__all__ = ["default_blueprint", "stable_blueprint_ids", "vessel_colour", "PALETTE", "LEGEND_CLASSES",
           "legend_classes", "annotation_context", "legend_markdown"]

#: Stable colours per vessel index (RGB), chosen to stand out on the blue water of the videos and
#: on Rerun's dark background, and apart from the red of traffic and predicted conflicts and the cyan
#: of detours: gold, pink, lime, orange, violet, white, olive, salmon, mint.
PALETTE = [(255, 200, 0), (255, 85, 170), (120, 230, 50), (255, 140, 20), (185, 140, 255), (240, 240, 240),
           (200, 200, 90), (255, 160, 130), (130, 255, 190)]

def vessel_colour(i: int) -> tuple[int, int, int]:
    return PALETTE[i % len(PALETTE)]


#: The legend's classes beyond the vessels (ids 1…n): id → (label, RGB). The recording's annotation
#: context (``world``) and the legend document (``legend``) list the same classes and colours.
LEGEND_CLASSES = {100: ("mission path (vessel colour, pale)", (200, 200, 200)),
                  101: ("trail (vessel colour)", (200, 200, 200)),
                  102: ("track: a vessel's estimate of another body (vessel colour)", (200, 200, 200)),
                  103: ("predicted conflict: own position at closest approach", (255, 0, 0)),
                  104: ("obstructed stretch of the path", (255, 140, 0)),
                  105: ("static virtual obstacle", (255, 200, 0)),
                  106: ("detour (re-planned path)", (0, 220, 255)),
                  107: ("potential-field obstacle", (200, 120, 255)),
                  108: ("virtual target", (230, 60, 60)),
                  109: ("moving traffic (truth)", (220, 60, 60)),
                  110: ("static obstacle (truth)", (150, 110, 80)),
                  111: ("mapped structure (a vessel's map)", (160, 120, 60)),
                  112: ("water current", (120, 200, 255))}


def legend_classes(vessels: tuple[str, ...]) -> list[tuple[int, str, tuple[int, int, int]]]:
    """(class id, label, RGB) of every legend entry: the vessels (ids 1…n, :func:`vessel_colour`),
    then :data:`LEGEND_CLASSES`."""
    return [(i + 1, name, vessel_colour(i)) for i, name in enumerate(vessels)] + \
           [(k, label, col) for k, (label, col) in LEGEND_CLASSES.items()]


def annotation_context(vessels: tuple[str, ...]) -> rr.AnnotationContext:
    """The legend as a Rerun annotation context (log it static at ``world``)."""
    return rr.AnnotationContext([rr.AnnotationInfo(id=k, label=label, color=col)
                                 for k, label, col in legend_classes(vessels)])


def legend_markdown(vessels: tuple[str, ...]) -> str:
    """The legend as a markdown document: each class with its colour (hex RGB)."""
    rows = ["| colour | what |", "|---|---|"]
    rows += [f"| `#{c[0]:02x}{c[1]:02x}{c[2]:02x}` | {'vessel ' if k <= len(vessels) else ''}{label} |"
             for k, label, c in legend_classes(vessels)]
    return ("# Legend\n\nEach vessel's colour is reused for its hull, name, trail, mission path, the tracks "
            "it holds and its plots. Track labels (`<vessel>:T<id>`) show on hover or selection.\n\n"
            + "\n".join(rows) + "\n")


def default_blueprint(extent_m: float = 200.0, vessels: tuple[str, ...] = (), perception: bool = False,
                      avoidance: bool = False, coordination: bool = False, detail: str = "full",
                      extent_xy: tuple | None = None) -> rrb.Blueprint:
    """Top-down world view on the left, framed on the scene: looking at the centre of
    ``extent_xy`` (lower-left, upper-right corners, world ENU [m]; a square of side ``extent_m``
    around the origin without it) from ``1.2 ×`` its larger side above. On the right, tabs of time
    series — "fleet" (every vessel's speed, cross-track, heading and thrust), then one tab per
    vessel with its own speed (the virtual target's included), cross-track, avoidance mode, and
    with ``detail = "full"`` its per-track plots, then the coordination plots — above tabs with
    the event log, the legend and the scenario text. (Every view adds ~5 kB to the recording.)"""
    if extent_xy is None:
        lo, hi = -0.5 * np.full(2, extent_m), 0.5 * np.full(2, extent_m)
    else:
        lo, hi = np.asarray(extent_xy[0], float), np.asarray(extent_xy[1], float)
    centre, span = 0.5 * (lo + hi), float(np.max(hi - lo))
    top = rrb.Spatial3DView(
        origin="world",
        name="Top-down (ENU, y north up)",
        eye_controls=rrb.EyeControls3D(position=(centre[0], centre[1] - 0.01 * span, 1.2 * span),
                                        look_target=(centre[0], centre[1], 0.0), eye_up=(0.0, 1.0, 0.0)),
        line_grid=rrb.LineGrid3D(visible=True, spacing=10.0, plane=rr.components.Plane3D.XY),
    )
    tabs = [rrb.Vertical(rrb.TimeSeriesView(origin="plots/speed", name="speed [m/s]"),
                         rrb.TimeSeriesView(origin="plots/cross_track", name="cross-track [m]"),
                         rrb.TimeSeriesView(origin="plots/heading", name="heading [deg]"),
                         rrb.TimeSeriesView(origin="plots/thrust", name="thrust [N]"), name="fleet")]
    for v in vessels:
        views = [rrb.TimeSeriesView(origin=f"plots/speed/{v}", name=f"{v} speed [m/s]"),
                 rrb.TimeSeriesView(origin=f"plots/cross_track/{v}", name=f"{v} cross-track [m]")]
        if avoidance:
            views.append(rrb.TimeSeriesView(origin=f"plots/mode/{v}", name=f"{v} avoidance mode"))
        if perception and detail == "full":
            views.append(rrb.TimeSeriesView(origin=f"plots/tracking/{v}", name=f"{v} tracks: ω̂, V̂, μ"))
        tabs.append(rrb.Vertical(*views, name=v))
    if coordination:
        tabs.append(rrb.Vertical(*[rrb.TimeSeriesView(origin="plots/coordination", name=title,
                                                      contents=[f"plots/coordination/{v}/{quantity}" for v in vessels])
                                   for quantity, title in (("spread_m", "formation spread [m]"),
                                                           ("speed_factor", "coordination speed factor"),
                                                           ("gamma_normalized", "γ/L"))], name="coordination"))
    texts = rrb.Tabs(rrb.TextLogView(origin="events", name="events"),
                     rrb.TextDocumentView(origin="legend", name="legend"),
                     rrb.TextDocumentView(origin="scenario", name="scenario"))
    return rrb.Blueprint(
        rrb.Horizontal(
            top,
            rrb.Vertical(rrb.Tabs(*tabs), texts, row_shares=[3, 2]),
            column_shares=[3, 2],
        ),
        rrb.TimePanel(state="collapsed"),
        collapse_panels=False,
    )


def stable_blueprint_ids(blueprint: rrb.Blueprint, key: str) -> None:
    """Give the blueprint's views and containers ids derived from ``key`` (uuid5 of ``key/k``, k in
    tree order) instead of the random uuid4 Rerun draws: the same run gives the same blueprint."""
    from rerun.blueprint.api import Container, View

    k = 0

    def walk(node) -> None:
        nonlocal k
        if isinstance(node, (Container, View)):
            node.id = uuid.uuid5(uuid.NAMESPACE_URL, f"{key}/{k}")
            k += 1
            if isinstance(node, Container):
                for child in node.contents:
                    walk(child)

    walk(getattr(blueprint, "root_container", None))
