"""The default Rerun blueprint of a run and its legend: the views a recording opens with.

On the left, tabs of 3-D views of the world (ENU, z up, looked at from above: Rerun's 2-D views
draw y downwards): the top-down overview framed on the scene's extent (the tab shown first), then
one "follow <vessel>" view per vessel whose eye tracks that vessel's hull. On the right, tabs of
time series and panels grouped per vessel — "fleet" (the avoidance mode of every vessel as a state
timeline, one lane per vessel, and the speed, cross-track, heading and thrust plots), then one tab
per vessel with its body-frame sensor view (FLU: x forward drawn up, y to port drawn left) beside
its threat panel, its mode lane and its own plots — above tabs with the event log, the legend and
the scenario text. Every vessel has a stable colour (:func:`vessel_colour`) that the recording
(hull, name, trail, tracks, plots, comms links) and the video reuse; the legend lists those
colours and the overlay classes (:data:`LEGEND_CLASSES`, colours apart from every vessel colour
and from each other) both as a Rerun annotation context (``world``) and as a markdown document
(``legend``). View and container ids are derived from the run (:func:`stable_blueprint_ids`) so
that the same run gives the same blueprint.
"""

from __future__ import annotations

import uuid

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # rerun loads when a recording is made (a run without one never imports it)
    import rerun as rr
    import rerun.blueprint as rrb

__all__ = ["default_blueprint", "stable_blueprint_ids", "vessel_colour", "view_vessels", "MAX_VIEW_VESSELS", "OTHERS",
           "PALETTE",
           "LEGEND_CLASSES",
           "VESSEL_COLOURED", "legend_colour", "legend_classes", "annotation_context", "legend_markdown",
           "MODE_STATES", "FOLLOW_EYE_OFFSET_M"]

#: Stable colours per vessel index (RGB), chosen to stand out on the blue water of the videos (a
#: luminance contrast of at least 3:1 against both squares of its checker, tests/test_video.py) and
#: on Rerun's dark background, and apart from the red of traffic and predicted conflicts and the cyan
#: of detours: gold, pink, lime, orange, violet, white, olive, salmon, mint.
PALETTE = [(255, 200, 0), (255, 130, 200), (120, 230, 50), (255, 150, 30), (200, 165, 255), (240, 240, 240),
           (200, 200, 90), (255, 160, 130), (130, 255, 190)]

def vessel_colour(i: int) -> tuple[int, int, int]:
    return PALETTE[i % len(PALETTE)]


#: The legend's classes beyond the vessels (ids 1…n): id → (label, RGB). The recording's annotation
#: context (``world``) and the legend document (``legend``) list the same classes and colours. The
#: classes in :data:`VESSEL_COLOURED` are drawn in each vessel's colour (their RGB here is only the
#: legend's placeholder); every other class has its own colour, at least 70 (RGB distance) from
#: every :data:`PALETTE` colour and 70 from every other class (``tests/test_recording_views.py``).
LEGEND_CLASSES = {100: ("mission path (vessel colour, pale)", (200, 200, 200)),
                  101: ("trail (vessel colour)", (200, 200, 200)),
                  102: ("track: a vessel's estimate of another body (vessel colour)", (200, 200, 200)),
                  103: ("predicted conflict: the track's predicted motion; own position at closest approach (dot)",
                        (255, 0, 0)),
                  104: ("obstructed stretch of the path", (170, 0, 60)),
                  105: ("static virtual obstacle", (255, 0, 255)),
                  106: ("detour (re-planned path)", (0, 220, 255)),
                  107: ("potential-field obstacle", (120, 60, 200)),
                  108: ("virtual target", (0, 140, 140)),
                  109: ("moving traffic (truth)", (220, 60, 60)),
                  110: ("static obstacle (truth)", (160, 100, 50)),
                  111: ("mapped structure (a vessel's map)", (95, 55, 15)),
                  112: ("water current", (120, 200, 255)),
                  113: ("comms: a message delivered, sender → receiver (sender's colour)", (200, 200, 200)),
                  114: ("comms: a message lost", (140, 140, 140)),
                  115: ("sensor fan (body frame)", (50, 90, 160)),
                  116: ("detection (a cluster of sensor returns)", (255, 255, 150)),
                  117: ("predicted own motion", (20, 200, 80))}

#: Legend classes drawn in the vessel's own colour (no colour of their own).
VESSEL_COLOURED = frozenset({100, 101, 102, 113})


def legend_colour(class_id: int) -> tuple[int, int, int]:
    """The RGB of an overlay class of :data:`LEGEND_CLASSES`."""
    return LEGEND_CLASSES[class_id][1]


#: The avoidance modes (:data:`mjasc.avoidance.request.MODES`) as states of the mode timeline:
#: mode → (label, RGB). Mission is dim, the avoidance modes bright and apart from each other.
MODE_STATES = {"mission": ("mission", (90, 110, 130)),
               "avoidance:yield": ("yield (slow down)", (255, 170, 0)),
               "avoidance:pass": ("pass first (speed up)", (0, 200, 255)),
               "avoidance:detour": ("detour", (255, 0, 255)),
               "avoidance:steer": ("steer (velocity obstacle)", (0, 220, 120))}

#: The follow views' eye relative to the tracked hull at the start [m] (world ENU): behind (south
#: of) and above it, so the vessel and ~40 m around it fill the view.
FOLLOW_EYE_OFFSET_M = (0.0, -25.0, 45.0)

#: Per-vessel views (a follow view, a tab with the body-frame sensor view, threat panel, mode lane
#: and plots) are made for the first MAX_VIEW_VESSELS vessels only: each adds a few views (~5 kB
#: each) and the data only they show, and 50 tabs are not a layout anyone reads. The fleet tab,
#: the top-down view and every vessel's world data cover the whole fleet.
MAX_VIEW_VESSELS = 12
#: In place of a vessel name, the entity holding one series per vessel without views
#: (``plots/speed/_others/actual``; :meth:`mjasc.runs.recording.Recorder.vessel_entity`).
OTHERS = "_others"


def view_vessels(vessels: tuple[str, ...]) -> tuple[str, ...]:
    """The vessels that get per-vessel views: the first :data:`MAX_VIEW_VESSELS`."""
    return tuple(vessels)[:MAX_VIEW_VESSELS]


def legend_classes(vessels: tuple[str, ...]) -> list[tuple[int, str, tuple[int, int, int]]]:
    """(class id, label, RGB) of every legend entry: the vessels (ids 1…n, :func:`vessel_colour`),
    then :data:`LEGEND_CLASSES`."""
    return [(i + 1, name, vessel_colour(i)) for i, name in enumerate(vessels)] + \
           [(k, label, col) for k, (label, col) in LEGEND_CLASSES.items()]


def annotation_context(vessels: tuple[str, ...]) -> rr.AnnotationContext:
    """The legend as a Rerun annotation context (log it static at ``world``)."""
    import rerun as rr

    return rr.AnnotationContext([rr.AnnotationInfo(id=k, label=label, color=col)
                                 for k, label, col in legend_classes(vessels)])


def legend_markdown(vessels: tuple[str, ...]) -> str:
    """The legend as a markdown document: each class with its colour (hex RGB)."""
    rows = ["| colour | what |", "|---|---|"]
    rows += [f"| `#{c[0]:02x}{c[1]:02x}{c[2]:02x}` | {'vessel ' if k <= len(vessels) else ''}{label} |"
             for k, label, c in legend_classes(vessels)]
    return ("# Legend\n\nEach vessel's colour is reused for its hull, name, trail, mission path, the tracks "
            "it holds, its plots and the comms links it sends. Track labels (`<vessel>:T<id>`) and the "
            "predicted conflicts' labels show on hover or selection.\n\n"
            + "\n".join(rows) + "\n")


def default_blueprint(extent_m: float = 200.0, vessels: tuple[str, ...] = (), perception: bool = False,
                      avoidance: bool = False, coordination: bool = False, detail: str = "full",
                      extent_xy: tuple | None = None, starts_xy: dict | None = None,
                      sensor_range_m: dict | None = None, comms: bool = False, mission: bool = False) -> rrb.Blueprint:
    """The default layout (module docstring). The top-down view looks at the centre of
    ``extent_xy`` (lower-left, upper-right corners, world ENU [m]; a square of side ``extent_m``
    around the origin without it) from ``1.2 ×`` its larger side above. ``starts_xy``: vessel name
    → start position (world [m]), where each follow view's eye begins (offset
    :data:`FOLLOW_EYE_OFFSET_M`; it then tracks the hull). ``sensor_range_m``: vessel name → its
    sensor's range [m] (a body-frame sensor view for each; with ``perception``). ``avoidance``:
    mode timelines and threat panels; ``coordination`` / ``comms``: the formation and link plots;
    ``mission``: the mission phase as a lane per vessel (a chained mission, docs/missions.md).
    (Every view adds ~5 kB to the recording.)"""
    import rerun as rr
    import rerun.blueprint as rrb

    if extent_xy is None:
        lo, hi = -0.5 * np.full(2, extent_m), 0.5 * np.full(2, extent_m)
    else:
        lo, hi = np.asarray(extent_xy[0], float), np.asarray(extent_xy[1], float)
    centre, span = 0.5 * (lo + hi), float(np.max(hi - lo))
    grid = rrb.LineGrid3D(visible=True, spacing=10.0, plane=rr.components.Plane3D.XY)
    top = rrb.Spatial3DView(
        origin="world",
        name="Top-down (ENU, y north up)",
        eye_controls=rrb.EyeControls3D(position=(centre[0], centre[1] - 0.01 * span, 1.2 * span),
                                        look_target=(centre[0], centre[1], 0.0), eye_up=(0.0, 1.0, 0.0)),
        line_grid=grid,
    )
    starts_xy = starts_xy or {}
    follow = []
    off = np.asarray(FOLLOW_EYE_OFFSET_M)
    for v in view_vessels(vessels):
        s = np.asarray(starts_xy.get(v, centre), float)
        follow.append(rrb.Spatial3DView(
            origin="world", name=f"follow {v}", line_grid=grid,
            eye_controls=rrb.EyeControls3D(kind=rrb.Eye3DKind.Orbital, position=(s[0] + off[0], s[1] + off[1], off[2]),
                                            look_target=(s[0], s[1], 0.0), eye_up=(0.0, 0.0, 1.0),
                                            tracking_entity=f"world/vessels/{v}/hull")))
    world_views = rrb.Tabs(top, *follow, active_tab=0, name="world") if follow else top
    fleet = [rrb.TimeSeriesView(origin="plots/speed", name="speed [m/s]"),
             rrb.TimeSeriesView(origin="plots/cross_track", name="cross-track [m]"),
             rrb.TimeSeriesView(origin="plots/heading", name="heading [deg]"),
             rrb.TimeSeriesView(origin="plots/thrust", name="thrust [N]")]
    if avoidance and vessels:
        fleet.insert(0, rrb.StateTimelineView(origin="modes", name="avoidance mode (a lane per vessel)"))
    if mission and vessels:
        fleet.insert(0, rrb.StateTimelineView(origin="missions", name="mission phase (a lane per vessel)"))
    lanes = min(1.0 + len(vessels), 6.0)  # the state lanes' share beside 2 per plot (a lane is ~35 UI points)
    shares = [lanes if isinstance(v, rrb.StateTimelineView) else 2.0 for v in fleet]
    tabs = [rrb.Vertical(*fleet, row_shares=shares if len(fleet) > 4 else None, name="fleet")]
    sensor_range_m = sensor_range_m or {}
    for v in view_vessels(vessels):
        panels = []
        if perception and v in sensor_range_m:
            r = float(sensor_range_m[v])
            panels.append(rrb.Spatial3DView(
                origin=f"sensor/{v}", name=f"{v} sensor (body FLU: x forward up, y port left)",
                eye_controls=rrb.EyeControls3D(position=(0.01 * r, 0.0, 2.4 * r), look_target=(0.0, 0.0, 0.0),
                                                eye_up=(1.0, 0.0, 0.0)),
                line_grid=grid))
        if avoidance:
            panels.append(rrb.TextDocumentView(origin=f"threats/{v}", name=f"{v} threats: CPA, TCPA, role"))
        views = [rrb.Horizontal(*panels)] if panels else []
        shares = [4] if panels else []
        if avoidance:
            views.append(rrb.StateTimelineView(origin=f"modes/{v}", name=f"{v} avoidance mode"))
            shares.append(2)  # header, lane name and bar: at 1 share the bar was cut off
        views += [rrb.TimeSeriesView(origin=f"plots/speed/{v}", name=f"{v} speed [m/s]"),
                  rrb.TimeSeriesView(origin=f"plots/cross_track/{v}", name=f"{v} cross-track [m]")]
        shares += [2, 2]
        if perception and detail == "full":
            views.append(rrb.TimeSeriesView(origin=f"plots/tracking/{v}", name=f"{v} tracks: ω̂, V̂, μ"))
            shares.append(2)
        tabs.append(rrb.Vertical(*views, row_shares=shares, name=v))
    if coordination:
        # (vessels beyond the views share one entity per quantity at standard detail: Recorder.vessel_entity)
        shown = list(vessels) if detail == "full" or len(vessels) <= MAX_VIEW_VESSELS else \
            [*view_vessels(vessels), OTHERS]
        team = [rrb.TimeSeriesView(origin="plots/coordination", name=title,
                                   contents=[f"plots/coordination/{v}/{quantity}" for v in shown])
                for quantity, title in (("spread_m", "formation spread [m]"),
                                        ("speed_factor", "coordination speed factor"),
                                        ("gamma_normalized", "γ/L"))]
        if comms:
            team.append(rrb.TimeSeriesView(origin="plots/comms", name="messages received and lost (count)"))
        tabs.append(rrb.Vertical(*team, name="coordination"))
    texts = rrb.Tabs(rrb.TextLogView(origin="events", name="events"),
                     rrb.TextDocumentView(origin="legend", name="legend"),
                     rrb.TextDocumentView(origin="scenario", name="scenario"))
    return rrb.Blueprint(
        rrb.Horizontal(
            world_views,
            rrb.Vertical(rrb.Tabs(*tabs), texts, row_shares=[3, 1]),
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
