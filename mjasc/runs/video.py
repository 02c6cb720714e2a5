"""Offscreen MP4 video of a run: MuJoCo's renderer (OSMesa by default) + imageio-ffmpeg (H.264).

The ``top_down`` view is a free camera fitted to the scenario's extent (the scene's fixed
``top_down`` camera only covers the area around the origin); ``chase:<vessel>`` uses that vessel's
chase camera; ``overview`` the scene's oblique camera. Mission paths are drawn into the frames as
line overlays. Software GL is the bottleneck (see the cheap visual profile in assets/scene/water.xml).
"""

from __future__ import annotations

import os
from pathlib import Path

import imageio_ffmpeg
import mujoco
import numpy as np

from mjasc.runs.outputs import part_path

__all__ = ["VideoWriter"]


class VideoWriter:
    """Render frames of a model/data pair and encode them to an MP4 file."""

    def __init__(self, path: str | Path, model, width: int, height: int, fps: float, camera: str = "top_down",
                 extent_xy: tuple[np.ndarray, np.ndarray] | None = None, overlays: list[np.ndarray] = ()):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._part = part_path(self.path)  # encoded here, renamed to path by close()
        self.model = model
        self.width, self.height = int(width), int(height)
        self.renderer = mujoco.Renderer(model, height=self.height, width=self.width)
        self._span = 0.0
        self.camera = self._camera(camera, extent_xy)
        # Map-symbol size for markers in the top-down view: 4 % of the view span.
        self.marker_m = 0.04 * self._span if isinstance(self.camera, mujoco.MjvCamera) else 0.0
        self.overlays = [np.asarray(o, dtype=float) for o in overlays]
        self._writer = imageio_ffmpeg.write_frames(
            str(self._part), (self.width, self.height), fps=float(fps), codec="libx264", pix_fmt_out="yuv420p",
            quality=7, macro_block_size=2, ffmpeg_log_level="error")
        self._writer.send(None)
        self.frames = 0

    def _camera(self, camera: str, extent_xy):
        m = self.model
        if camera == "top_down" and extent_xy is not None:
            lo, hi = np.asarray(extent_xy[0], float), np.asarray(extent_xy[1], float)
            cam = mujoco.MjvCamera()
            cam.type = mujoco.mjtCamera.mjCAMERA_FREE
            cam.lookat[:] = [*(0.5 * (lo + hi)), 0.0]
            span = max(float(np.max(hi - lo)), 20.0) * 1.15
            fovy = np.deg2rad(m.vis.global_.fovy)
            cam.distance = 0.5 * span / np.tan(0.5 * fovy) * max(1.0, self.height / self.width)
            cam.elevation = -90.0
            self._span = span
            cam.azimuth = 90.0
            return cam
        name = camera.replace("chase:", "") + "/chase" if camera.startswith("chase:") else camera
        cid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_CAMERA, name)
        if cid < 0:
            raise ValueError(f"outputs.video_camera: no camera {name!r} in the model")
        return cid

    def _line(self, scn, a, b, rgba, width=2.0) -> None:
        if scn.ngeom >= scn.maxgeom:
            return
        g = scn.geoms[scn.ngeom]
        mujoco.mjv_initGeom(g, mujoco.mjtGeom.mjGEOM_LINE, np.zeros(3), np.zeros(3), np.zeros(9),
                            np.asarray(rgba, dtype=np.float32))
        mujoco.mjv_connector(g, mujoco.mjtGeom.mjGEOM_LINE, width, np.array([a[0], a[1], 0.05]),
                             np.array([b[0], b[1], 0.05]))
        scn.ngeom += 1

    def add_frame(self, data, markers=(), trails=()) -> np.ndarray:
        """Render and encode one frame. ``markers``: (position (2,), heading, rgba) per vessel, drawn
        as map-symbol arrows in the top-down view (a 2 m hull is a few pixels at 200 m);
        ``trails``: (points (k, 2), rgba) polylines of where the vessels have been."""
        self.renderer.update_scene(data, camera=self.camera)
        scn = self.renderer.scene
        for points, rgba in trails:
            for a, b in zip(points[:-1], points[1:]):
                self._line(scn, a, b, rgba, 3.0)
        if self.marker_m > 0:
            for pos, heading, rgba in markers:
                if scn.ngeom >= scn.maxgeom:
                    break
                tip = np.array([pos[0] + self.marker_m * np.cos(heading), pos[1] + self.marker_m * np.sin(heading), 0.6])
                tail = np.array([pos[0] - 0.5 * self.marker_m * np.cos(heading),
                                 pos[1] - 0.5 * self.marker_m * np.sin(heading), 0.6])
                g = scn.geoms[scn.ngeom]
                mujoco.mjv_initGeom(g, mujoco.mjtGeom.mjGEOM_ARROW, np.zeros(3), np.zeros(3), np.zeros(9),
                                    np.asarray(rgba, dtype=np.float32))
                mujoco.mjv_connector(g, mujoco.mjtGeom.mjGEOM_ARROW, 0.35 * self.marker_m, tail, tip)
                scn.ngeom += 1
        for line in self.overlays:
            for a, b in zip(line[:-1], line[1:]):
                self._line(scn, a, b, (1.0, 1.0, 1.0, 0.5), 1.5)
        frame = self.renderer.render()
        self._writer.send(np.ascontiguousarray(frame))
        self.frames += 1
        return frame

    def close(self) -> None:
        """Finish the file and rename it from ``.video.part.mp4`` to its own name."""
        if self._writer is not None:
            self._writer.close()
            self._writer = None
            os.replace(self._part, self.path)
        self.renderer.close()
