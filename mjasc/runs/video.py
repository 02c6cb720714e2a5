"""Offscreen MP4 video of a run: MuJoCo's renderer (OSMesa by default) + imageio-ffmpeg (H.264).

Cameras (``[outputs] video_camera``): ``top_down`` a free camera looking straight down, north up,
fitted to the scenario's extent (the scene's fixed ``top_down`` camera only covers the area
around the origin); ``overview`` a free camera from the south, 50° down, framed on the same extent;
``chase:<vessel>`` that vessel's chase camera. The extent (``extent_xy``: lower-left and
upper-right corners, world ENU [m]) fits the frame with 10 % margin: the camera's distance is
``D = (s / 2) / tan(fovy / 2)`` for the vertical span ``s = 1.1 · max(Δy, Δx · H / W)``.

A run's frames (:meth:`VideoWriter.add_event`, one per ``video`` slot, given the slot's
:class:`~mjasc.runs.tick.SlotEvent`) show the scene overlays of :mod:`mjasc.runs.video_scene`
(sensor fan, tracks, predicted conflicts, the detour, paths and trails) drawn into MuJoCo's scene,
and the heads-up overlay of :mod:`mjasc.runs.video_hud` (time, names, modes, scale, north,
current, legend) drawn onto the image. :attr:`VideoWriter.seconds` keeps the wall time of each
stage of a frame (software GL rendering dominates; see the cheap visual profile in
assets/scene/water.xml).
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import imageio_ffmpeg
import mujoco
import numpy as np

from mjasc.runs.outputs import part_path
from mjasc.runs.video_hud import Projection, draw_hud
from mjasc.runs.video_scene import FrameView, VesselView, add_scene_geoms, frame_view

__all__ = ["VideoWriter", "TRAIL_PERIOD_S", "TRAIL_POINTS"]

#: A frame's trail keeps a point every TRAIL_PERIOD_S [s], at most TRAIL_POINTS of them.
TRAIL_PERIOD_S = 1.0
TRAIL_POINTS = 120
#: Static overlay polylines (mission paths) keep at most this many points each.
OVERLAY_POINTS = 150
#: The overview camera's elevation [deg] (negative: looking down).
OVERVIEW_ELEVATION_DEG = -50.0


class VideoWriter:
    """Render frames of a model/data pair and encode them to an MP4 file."""

    def __init__(self, path: str | Path, model, width: int, height: int, fps: float, camera: str = "top_down",
                 extent_xy: tuple[np.ndarray, np.ndarray] | None = None, overlays: list[np.ndarray] = (),
                 title: str = ""):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._part = part_path(self.path)  # encoded here, renamed to path by close()
        self.model = model
        self.width, self.height = int(width), int(height)
        self.title = str(title)
        self.renderer = mujoco.Renderer(model, height=self.height, width=self.width)
        self._span = 0.0
        self._centre = np.zeros(3)
        self.camera = self._camera(camera, extent_xy)
        # Map-symbol size for markers in the framed views (2 m hulls are a few pixels): 4 % of the span.
        self.marker_m = 0.04 * self._span if isinstance(self.camera, mujoco.MjvCamera) else 0.0
        # Paths thinned to at most OVERLAY_POINTS points: every line is a geom to render.
        self.overlays = [_thin(np.asarray(o, dtype=float), OVERLAY_POINTS) for o in overlays]
        self._writer = imageio_ffmpeg.write_frames(
            str(self._part), (self.width, self.height), fps=float(fps), codec="libx264", pix_fmt_out="yuv420p",
            quality=7, macro_block_size=2, ffmpeg_log_level="error")
        self._writer.send(None)
        self.frames = 0
        self._trails: list[list] = []
        self._trail_t = -np.inf
        #: Wall seconds per frame stage: view (reading the run), scene (user geoms), render, hud, encode.
        self.seconds = dict.fromkeys(("view", "scene", "render", "hud", "encode"), 0.0)

    def _camera(self, camera: str, extent_xy):
        m = self.model
        if camera in ("top_down", "overview") and extent_xy is not None:
            lo, hi = np.asarray(extent_xy[0], float), np.asarray(extent_xy[1], float)
            dx, dy = np.maximum(hi - lo, 20.0)
            span = 1.1 * max(dy, dx * self.height / self.width)
            cam = mujoco.MjvCamera()
            cam.type = mujoco.mjtCamera.mjCAMERA_FREE
            cam.lookat[:] = [*(0.5 * (lo + hi)), 0.0]
            cam.distance = 0.5 * span / np.tan(0.5 * np.deg2rad(m.vis.global_.fovy))
            cam.elevation = -90.0 if camera == "top_down" else OVERVIEW_ELEVATION_DEG
            cam.azimuth = 90.0  # looking north: x to the right, y up the frame
            self._span = span
            self._centre = np.array(cam.lookat)
            return cam
        name = camera.replace("chase:", "") + "/chase" if camera.startswith("chase:") else camera
        cid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_CAMERA, name)
        if cid < 0:
            raise ValueError(f"outputs.video_camera: no camera {name!r} in the model")
        return cid

    # ------------------------------------------------------------------ frames
    def add_event(self, event) -> np.ndarray:
        """Render and encode the frame of a run's ``video`` slot (a :class:`~mjasc.runs.tick.SlotEvent`)."""
        t0 = time.perf_counter()
        data = event.runner.sim.data
        centre = self._view_centre(data)
        view = frame_view(event, centre[:2])
        self._append_trails(view)
        self.seconds["view"] += time.perf_counter() - t0
        return self._frame(data, view, centre)

    def add_frame(self, data, markers=(), trails=()) -> np.ndarray:
        """Render and encode one frame without a runner (:mod:`mjasc.suite.render`): ``markers``
        (position (2,), heading, rgba 0–1) per vessel, ``trails`` (points (k, 2), rgba) polylines."""
        vessels = [VesselView(f"#{i}", tuple(int(255 * c) for c in rgba[:3]), np.asarray(p, float), float(h))
                   for i, (p, h, rgba) in enumerate(markers)]
        view = FrameView(float(data.time), vessels, np.zeros(2))
        self._trails = [[tuple(p) for p in pts] for pts, _ in trails]
        return self._frame(data, view, self._view_centre(data), hud=False)

    def _frame(self, data, view: FrameView, centre, hud: bool = True) -> np.ndarray:
        t0 = time.perf_counter()
        self.renderer.update_scene(data, camera=self.camera)
        scn = self.renderer.scene
        trails = [np.array([*t, tuple(v.position_m)]) if hud else np.array(t)
                  for t, v in zip(self._trails, view.vessels)] if view.vessels else []
        add_scene_geoms(scn, view, self.marker_m, trails, self.overlays)
        t1 = time.perf_counter()
        frame = self.renderer.render()
        t2 = time.perf_counter()
        if hud:
            frame = draw_hud(frame, view, Projection(scn, self.width, self.height), centre, self.title)
        t3 = time.perf_counter()
        self._writer.send(np.ascontiguousarray(frame))
        t4 = time.perf_counter()
        for k, dt in zip(("scene", "render", "hud", "encode"), (t1 - t0, t2 - t1, t3 - t2, t4 - t3)):
            self.seconds[k] += dt
        self.frames += 1
        return frame

    def _view_centre(self, data) -> np.ndarray:
        """World point the view looks at [m]: the extent's centre, or the chase camera's target."""
        if isinstance(self.camera, mujoco.MjvCamera):
            return self._centre
        body = self.model.cam_bodyid[self.camera]
        return np.array([*data.xpos[body][:2], 0.0])

    def _append_trails(self, view: FrameView) -> None:
        """A trail point per vessel every :data:`TRAIL_PERIOD_S` (the frame adds the position now)."""
        if not self._trails:
            self._trails = [[] for _ in view.vessels]
        if view.time_s - self._trail_t >= TRAIL_PERIOD_S:
            self._trail_t = view.time_s
            for trail, v in zip(self._trails, view.vessels):
                trail.append(tuple(v.position_m))
                del trail[:-TRAIL_POINTS]

    def close(self) -> None:
        """Finish the file and rename it from ``.video.part.mp4`` to its own name."""
        if self._writer is not None:
            self._writer.close()
            self._writer = None
            os.replace(self._part, self.path)
        self.renderer.close()


def _thin(points: np.ndarray, n: int) -> np.ndarray:
    """Every k-th point of a polyline (k = ⌈len / n⌉), its last point kept."""
    k = -(-len(points) // n)
    return points if k <= 1 else np.vstack([points[::k], points[-1:]])
