"""Rerun recordings: every run is a ``.rrd`` file with a default blueprint for timeline review.

Entities live in a 3-D world (ENU, z up, everything on z ≈ 0) viewed from above, because Rerun's
2-D views draw y downwards and the world frame here is y-north-up. Timelines: ``sim_time``
(simulation seconds) and ``step`` (record tick). Wall-clock log time is disabled so that two runs
with the same seed produce the same content (not the same bytes: compare content, never hashes).

High-rate data (poses, speeds, thrust, errors) is buffered and written column-wise with
``send_columns`` when the recording is flushed (16× cheaper than one ``log`` per row); sporadic
data (events, re-planned paths) is logged as it happens. :meth:`Recorder.close` always flushes,
so a run that stops on an error keeps everything recorded until then.
"""

from __future__ import annotations

import uuid
from collections import defaultdict
from pathlib import Path

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

__all__ = ["Recorder", "default_blueprint", "TIMELINE"]

TIMELINE = "sim_time"

#: Stable colours per vessel index (RGB).
PALETTE = [(31, 119, 180), (255, 127, 14), (44, 160, 44), (148, 103, 189), (140, 86, 75), (227, 119, 194),
           (127, 127, 127), (188, 189, 34), (23, 190, 207)]


def vessel_colour(i: int) -> tuple[int, int, int]:
    return PALETTE[i % len(PALETTE)]


def default_blueprint(extent_m: float = 200.0, vessels: tuple[str, ...] = (), perception: bool = False,
                      avoidance: bool = False, coordination: bool = False) -> rrb.Blueprint:
    """Top-down world view on the left; on the right tabs of time series (speed, thrust,
    cross-track, and the plots of whichever onboard components the run has) above the event log."""
    top = rrb.Spatial3DView(
        origin="world",
        name="Top-down (ENU, y north up)",
        eye_controls=rrb.EyeControls3D(position=(0.0, -0.01 * extent_m, 1.6 * extent_m), look_target=(0.0, 0.0, 0.0),
                                        eye_up=(0.0, 1.0, 0.0)),
        line_grid=rrb.LineGrid3D(visible=True, spacing=10.0, plane=rr.components.Plane3D.XY),
    )
    tabs = [rrb.TimeSeriesView(origin="plots/speed", name="speed [m/s]"),
            rrb.TimeSeriesView(origin="plots/cross_track", name="cross-track [m]"),
            rrb.TimeSeriesView(origin="plots/thrust", name="thrust [N]"),
            rrb.TimeSeriesView(origin="plots/heading", name="heading [deg]")]
    if avoidance:
        tabs.append(rrb.TimeSeriesView(origin="plots/mode", name="avoidance mode"))
        tabs.append(rrb.TimeSeriesView(origin="plots/gamma", name="virtual target γ [m]"))
    if coordination:
        for quantity, title in (("spread_m", "formation spread [m]"), ("speed_factor", "coordination speed factor"),
                                ("gamma_normalized", "γ/L")):
            tabs.append(rrb.TimeSeriesView(origin="plots/coordination", name=title,
                                           contents=[f"plots/coordination/{v}/{quantity}" for v in vessels]))
    if perception:
        tabs.append(rrb.TimeSeriesView(origin="plots/tracking", name="tracks: ω̂, V̂, mode probabilities"))
    return rrb.Blueprint(
        rrb.Horizontal(
            top,
            rrb.Vertical(rrb.Tabs(*tabs), rrb.TextLogView(origin="events", name="events"), row_shares=[3, 2]),
            column_shares=[3, 2],
        ),
        rrb.TimePanel(state="collapsed"),
        collapse_panels=False,
    )


class Recorder:
    """Writes one ``.rrd`` file. Buffered rows are flushed by :meth:`flush` / :meth:`close`."""

    def __init__(self, path: str | Path, recording_name: str, seed: int, blueprint: rrb.Blueprint | None = None):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        rid = str(uuid.uuid5(uuid.NAMESPACE_URL, f"mjasc/{recording_name}/{seed}"))
        self.rec = rr.RecordingStream("mjasc", recording_id=rid)
        self.rec.set_log_time_enabled(False)
        self.rec.save(str(self.path), default_blueprint=blueprint or default_blueprint())
        self.rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        self._scalars: dict[str, tuple[list, list]] = defaultdict(lambda: ([], []))
        self._points: dict[str, tuple[list, list]] = defaultdict(lambda: ([], []))
        self._strips: dict[str, tuple[list, list]] = defaultdict(lambda: ([], []))
        self._arrows: dict[str, tuple[list, list, list]] = defaultdict(lambda: ([], [], []))
        self._closed = False

    # ---------------------------------------------------------------- immediate logging
    def static(self, entity: str, archetype) -> None:
        self.rec.log(entity, archetype, static=True)

    def log(self, entity: str, archetype, t_s: float) -> None:
        self.rec.set_time(TIMELINE, duration=float(t_s))
        self.rec.log(entity, archetype)

    def event(self, t_s: float, text: str, level: str = "INFO") -> None:
        """A line in the ``events`` text log (mode changes, detections, warnings)."""
        self.log("events", rr.TextLog(text, level=level), t_s)

    def series_style(self, entity: str, name: str, colour=None, width: float = 1.5) -> None:
        self.static(entity, rr.SeriesLines(names=name, colors=colour if colour is not None else [200, 200, 200],
                                           widths=width))

    # ---------------------------------------------------------------- buffered rows
    def scalar(self, entity: str, t_s: float, value: float) -> None:
        times, values = self._scalars[entity]
        times.append(t_s)
        values.append(float(value))

    def points(self, entity: str, t_s: float, positions_xy: np.ndarray, z: float = 0.0) -> None:
        times, rows = self._points[entity]
        times.append(t_s)
        rows.append(_xyz(positions_xy, z))

    def strips(self, entity: str, t_s: float, strips_xy: list[np.ndarray], z: float = 0.0) -> None:
        times, rows = self._strips[entity]
        times.append(t_s)
        rows.append([_xyz(s, z) for s in strips_xy])

    def arrows(self, entity: str, t_s: float, origins_xy: np.ndarray, vectors_xy: np.ndarray, z: float = 0.0) -> None:
        times, origins, vectors = self._arrows[entity]
        times.append(t_s)
        origins.append(_xyz(origins_xy, z))
        vectors.append(_xyz(vectors_xy, 0.0))

    def flush(self) -> None:
        """Write every buffered row column-wise and empty the buffers."""
        for entity, (times, values) in self._scalars.items():
            if times:
                self.rec.send_columns(entity, indexes=[rr.TimeColumn(TIMELINE, duration=times)],
                                      columns=rr.Scalars.columns(scalars=values))
        for entity, (times, rows) in self._points.items():
            if times:
                self.rec.send_columns(
                    entity, indexes=[rr.TimeColumn(TIMELINE, duration=times)],
                    columns=rr.Points3D.columns(positions=np.concatenate(rows)).partition([len(r) for r in rows]))
        for entity, (times, rows) in self._strips.items():
            if times:
                flat = [s for row in rows for s in row]
                self.rec.send_columns(
                    entity, indexes=[rr.TimeColumn(TIMELINE, duration=times)],
                    columns=rr.LineStrips3D.columns(strips=flat).partition([len(r) for r in rows]))
        for entity, (times, origins, vectors) in self._arrows.items():
            if times:
                self.rec.send_columns(
                    entity, indexes=[rr.TimeColumn(TIMELINE, duration=times)],
                    columns=rr.Arrows3D.columns(origins=np.concatenate(origins), vectors=np.concatenate(vectors))
                    .partition([len(o) for o in origins]))
        self._scalars.clear()
        self._points.clear()
        self._strips.clear()
        self._arrows.clear()

    def close(self) -> None:
        """Flush and write the file footer (a reader needs it). Safe to call twice."""
        if self._closed:
            return
        try:
            self.flush()
        finally:
            self.rec.flush()
            self.rec.disconnect()
            self._closed = True

    def __enter__(self) -> "Recorder":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _xyz(points_xy, z: float) -> np.ndarray:
    p = np.asarray(points_xy, dtype=np.float64).reshape(-1, 2)
    return np.column_stack([p, np.full(len(p), z)])
