"""Offscreen MP4 video of a run: MuJoCo's renderer (OSMesa by default) + imageio-ffmpeg (H.264).

Cameras (``[outputs] video_camera``): ``top_down`` a free camera looking straight down, north up,
fitted to the scenario's extent (the scene's fixed ``top_down`` camera only covers the area
around the origin); ``overview`` a free camera from the south, 50° down, framed on the same extent;
``chase:<vessel>`` that vessel's chase camera; ``split:<vessel>`` (``split``: the first vessel) both
side by side in one frame, the overview in the left half and the chase view in the right, each half
rendered on its own (``W/2 × H`` pixels) with its own heads-up overlay (the chase half: time and
names only). The extent (``extent_xy``: lower-left and
upper-right corners, world ENU [m]) fits the frame (each pane's own width and height) with 10 %
margin: the top-down camera's distance is ``D = (s / 2) / tan(fovy / 2)`` for the vertical span
``s = 1.1 · max(Δy, Δx · H / W)``; the oblique overview's is the least distance at which the
extent's corners (at the water and 2 m up) project inside the frame shrunk by 10 %
(:func:`fit_distance_m`: its near edge looks wider than its centre, and a split view's half-width
pane is narrow).

A run's frames (:meth:`VideoWriter.add_event`, one per ``video`` slot, given the slot's
:class:`~mjasc.runs.tick.SlotEvent`) show the scene overlays of :mod:`mjasc.runs.video_scene`
(sensor fan, tracks, predicted conflicts, the detour, paths and trails) drawn into MuJoCo's scene,
and the heads-up overlay of :mod:`mjasc.runs.video_hud` (time, names, modes, scale, north,
current, legend) drawn onto the image. :attr:`VideoWriter.seconds` keeps the wall time of each
stage of a frame (software GL rendering dominates; see the cheap visual profile in
assets/scene/water.xml).

Each pane renders its own copy of the model (:func:`mjasc.runs.video_model.render_model`): the
hulls in their vessels' palette colours (``vessel_colours``: (name, RGB) per vessel, by default
the model's vessels in order), and in a framed view the water widened, the structures' walls at
least 3 pixels thick and the far plane beyond the view. The run's own model is never changed.
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
from mjasc.runs.video_model import render_model
from mjasc.runs.video_scene import FrameView, VesselView, add_scene_geoms, frame_view

__all__ = ["VideoWriter", "split_cameras", "fit_distance_m", "TRAIL_PERIOD_S", "TRAIL_POINTS"]

#: A frame's trail keeps a point every TRAIL_PERIOD_S [s], at most TRAIL_POINTS of them.
TRAIL_PERIOD_S = 1.0
TRAIL_POINTS = 120
#: Static overlay polylines (mission paths) keep at most this many points each.
OVERLAY_POINTS = 150
#: The overview camera's elevation [deg] (negative: looking down).
OVERVIEW_ELEVATION_DEG = -50.0
#: The overview fits the extent's corners at the water and this high [m] (hulls, masts) in its frame.
OVERVIEW_FIT_HEIGHT_M = 2.0


class _Pane:
    """One camera's view: its renderer, the camera, the view's span and centre [m]."""

    def __init__(self, model, camera: str, width: int, height: int, extent_xy, vessel_colours=None):
        self.width, self.height = int(width), int(height)
        self.span = 0.0
        self.centre = np.zeros(3)
        self.camera = self._camera(model, camera, extent_xy)
        framed = isinstance(self.camera, mujoco.MjvCamera)
        # Its own copy of the model, changed only in what is drawn (liveries; framed: water, walls, far plane).
        self.model = render_model(model, vessel_colours, self.centre, self.span if framed else 0.0,
                                  self.width / self.height, self.span / self.height,
                                  self.camera.distance if framed else 0.0)
        self.renderer = mujoco.Renderer(self.model, height=self.height, width=self.width)
        #: Whether the renderer's two halves can be called apart (:meth:`start_render`, :meth:`read_pixels`).
        self._deferrable = all(hasattr(self.renderer, a) for a in ("_gl_context", "_rect", "_mjr_context"))
        # Map-symbol size for markers in the framed views (2 m hulls are a few pixels): 4 % of the span.
        self.marker_m = 0.04 * self.span if framed else 0.0
        #: The vessel of a chase camera (its sensing and decisions alone are drawn), else None.
        self.chased = camera[len("chase:"):] if camera.startswith("chase:") else None
        #: What the heads-up overlay keeps from frame to frame (the legend's place).
        self.hud_memory: dict = {}

    def _camera(self, m, camera: str, extent_xy):
        if camera in ("top_down", "overview") and extent_xy is not None:
            lo, hi = np.asarray(extent_xy[0], float), np.asarray(extent_xy[1], float)
            dx, dy = np.maximum(hi - lo, 20.0)
            span = 1.1 * max(dy, dx * self.height / self.width)
            cam = mujoco.MjvCamera()
            cam.type = mujoco.mjtCamera.mjCAMERA_FREE
            cam.lookat[:] = [*(0.5 * (lo + hi)), 0.0]
            tan_half = np.tan(0.5 * np.deg2rad(m.vis.global_.fovy))
            cam.distance = 0.5 * span / tan_half
            cam.elevation = -90.0 if camera == "top_down" else OVERVIEW_ELEVATION_DEG
            cam.azimuth = 90.0  # looking north: x to the right, y up the frame
            if camera == "overview":  # oblique: the near edge looks wider than the centre, fit it
                corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                                    for z in (0.0, OVERVIEW_FIT_HEIGHT_M)])
                cam.distance = fit_distance_m(cam.lookat, cam.azimuth, cam.elevation, tan_half,
                                              self.width / self.height, corners, 1.1)
                span = 2.0 * cam.distance * tan_half  # the view's height at the look-at point
            self.span = span
            self.centre = np.array(cam.lookat)
            return cam
        name = camera.replace("chase:", "") + "/chase" if camera.startswith("chase:") else camera
        cid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_CAMERA, name)
        if cid < 0:
            names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_CAMERA, i) or "" for i in range(m.ncam)]
            chased = [n[: -len("/chase")] for n in names if n.endswith("/chase")]
            raise ValueError(f"camera: no camera {name!r} in the model (its vessels: {', '.join(chased) or 'none'})")
        return cid

    def start_render(self) -> None:
        """Start rendering the pane's scene: the first half of ``mujoco.Renderer.render`` (its GL
        context, viewport and buffers), then a flush, after which the software renderer rasterises
        on its own threads while the caller goes on (:meth:`read_pixels` waits for it). A renderer
        without those parts (another MuJoCo) renders in :meth:`read_pixels` instead."""
        r = self.renderer
        if not self._deferrable:
            return
        if r._gl_context:
            r._gl_context.make_current()
        mujoco.mjr_render(r._rect, r.scene, r._mjr_context)
        from OpenGL.raw.GL.VERSION.GL_1_0 import glFlush  # (PyOpenGL's raw call: no error check of its own)

        glFlush()

    def read_pixels(self) -> np.ndarray:
        """The pane's rendered image (height, width, 3) uint8, top row first: the second half of
        ``mujoco.Renderer.render`` after :meth:`start_render` (the same calls, the same pixels)."""
        r = self.renderer
        if not self._deferrable:
            return r.render()
        if r._mjr_context is None:
            raise RuntimeError("render cannot be called after close.")
        if r._gl_context:
            r._gl_context.make_current()
        out = np.empty((self.height, self.width, 3), dtype=np.uint8)
        mujoco.mjr_readPixels(out, None, r._rect, r._mjr_context)
        if r._gl_context:  # (OSMesa, EGL and GLFW images come bottom row first)
            out[:] = np.flipud(out)
        return out

    def close(self) -> None:
        """Free the renderer with its own GL context current: ``mujoco.Renderer.close`` frees its GL
        objects in whatever context is current, another pane's or writer's (whose objects of the
        same names went: its later frames lost their textures)."""
        gl = getattr(self.renderer, "_gl_context", None)
        if gl and getattr(self.renderer, "_mjr_context", None) is not None:
            gl.make_current()
        self.renderer.close()

    def view_centre(self, model, data) -> np.ndarray:
        """World point the view looks at [m]: the extent's centre, or the chase camera's target."""
        if isinstance(self.camera, mujoco.MjvCamera):
            return self.centre
        return np.array([*data.xpos[model.cam_bodyid[self.camera]][:2], 0.0])


def fit_distance_m(lookat, azimuth_deg: float, elevation_deg: float, tan_half_fovy: float, aspect: float,
                   points_xyz, margin: float = 1.1) -> float:
    """The distance [m] from ``lookat`` at which a free camera (MuJoCo's: forward
    ``(cos e cos a, cos e sin a, sin e)``, up ``(−sin e cos a, −sin e sin a, cos e)``) sees every
    point of ``points_xyz`` (n, 3) [m] within the frame shrunk by ``margin`` (1.1: 10 % on each
    side), for a frame of ``aspect`` = width / height and half vertical field of view
    ``atan(tan_half_fovy)``. A point at ``q = p − lookat`` lands at ``(q·r, q·u) / (q·f + D)`` on the
    unit image plane, which shrinks monotonically as D grows: bisection."""
    a, e = np.deg2rad(azimuth_deg), np.deg2rad(elevation_deg)
    f = np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
    u = np.array([-np.sin(e) * np.cos(a), -np.sin(e) * np.sin(a), np.cos(e)])
    r = np.cross(f, u)
    q = np.asarray(points_xyz, float).reshape(-1, 3) - np.asarray(lookat, float)
    qf, qr, qu = q @ f, q @ r, q @ u
    limit_x, limit_y = tan_half_fovy * aspect / margin, tan_half_fovy / margin

    def fits(d: float) -> bool:
        z = qf + d
        return bool(np.all(z > 1e-6) and np.all(np.abs(qr) <= limit_x * z) and np.all(np.abs(qu) <= limit_y * z))

    lo, hi = 0.0, max(1.0, float(np.abs(q).max()))
    while not fits(hi):
        lo, hi = hi, 2.0 * hi
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if fits(mid) else (mid, hi)
    return hi


def split_cameras(model, camera: str) -> list[str]:
    """The cameras of each pane, left to right: ``split:NAME`` → overview and NAME's chase camera
    (``split``: the first vessel's, the model's first ``*/chase`` camera); any other camera alone."""
    if camera != "split" and not camera.startswith("split:"):
        return [camera]
    name = camera[len("split:"):]
    if not name:
        chases = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_CAMERA, k) or "" for k in range(model.ncam)]
        chases = [c[:-len("/chase")] for c in chases if c.endswith("/chase")]
        if not chases:
            raise ValueError("camera: split needs a vessel's chase camera, the model has none")
        name = chases[0]
    return ["overview", f"chase:{name}"]


class VideoWriter:
    """Render frames of a model/data pair and encode them to an MP4 file."""

    def __init__(self, path: str | Path, model, width: int, height: int, fps: float, camera: str = "top_down",
                 extent_xy: tuple[np.ndarray, np.ndarray] | None = None, overlays: list[np.ndarray] = (),
                 title: str = "", vessel_colours=None, chase_title: str = "{vessel}: what it senses"):
        self.path = Path(path)
        self.model = model
        self.width, self.height = int(width), int(height)
        self.title = str(title)
        #: The chase half's title of a split frame (``{vessel}``: the chased vessel's name).
        self.chase_title = str(chase_title)
        cameras = split_cameras(model, camera)  # raises before any file is made
        self.panes = [_Pane(model, c, self.width // len(cameras), self.height, extent_xy, vessel_colours)
                      for c in cameras]
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._part = part_path(self.path)  # encoded here, renamed to path by close()
        # Paths thinned to at most OVERLAY_POINTS points: every line is a geom to render.
        self.overlays = [_thin(np.asarray(o, dtype=float), OVERLAY_POINTS) for o in overlays]
        self._writer = imageio_ffmpeg.write_frames(
            str(self._part), (self.width, self.height), fps=float(fps), codec="libx264", pix_fmt_out="yuv420p",
            quality=7, macro_block_size=2, ffmpeg_log_level="error")
        self._writer.send(None)
        self.frames = 0
        #: A frame held back (:meth:`add_event` with ``later``): its view, overlay flag and each pane's
        #: projection and view centre, its pixels still in the panes' buffers.
        self._held: tuple | None = None
        self._trails: list[list] = []
        self._trail_t = -np.inf
        #: Wall seconds per frame stage: view (reading the run), scene (user geoms), render, hud, encode.
        self.seconds = dict.fromkeys(("view", "scene", "render", "hud", "encode"), 0.0)

    # The first pane's renderer, camera and marker size (the whole frame unless split).
    @property
    def renderer(self):
        return self.panes[0].renderer

    @property
    def camera(self):
        return self.panes[0].camera

    @property
    def marker_m(self) -> float:
        return self.panes[0].marker_m

    # ------------------------------------------------------------------ frames
    def add_event(self, event, later: bool = False) -> np.ndarray | None:
        """Render and encode the frame of a run's ``video`` slot (a :class:`~mjasc.runs.tick.SlotEvent`)
        and return it. ``later`` (the runner's own frames): hold the frame back while the renderer
        rasterises it — its overlay is drawn and it is encoded at the next frame, at
        :meth:`finish_held` or at :meth:`close`, the same pixels in the same order — and return the
        frame held before, finished now (None: there was none). A held frame's pixels are in the
        panes' buffers: nothing else may render with the panes until it is finished (the next call
        of this method reads them first), and an error in its overlay or encoding comes one frame
        later."""
        t0 = time.perf_counter()
        data = event.runner.sim.data
        view = frame_view(event, self.panes[0].view_centre(self.model, data)[:2])
        self._append_trails(view)
        self.seconds["view"] += time.perf_counter() - t0
        return self._frame(data, view, later=later)

    def add_frame(self, data, markers=(), trails=(), *, names=(), modes=(), lines=(), legend=(),
                  current_m_s=(0.0, 0.0), hud: bool = True) -> np.ndarray:
        """Render and encode one frame without a runner (:mod:`mjasc.suite.render`): ``markers``
        (position (2,), heading, rgba 0–1) per vessel, ``trails`` (points (k, 2), rgba) polylines.
        With ``hud`` the heads-up overlay of :mod:`mjasc.runs.video_hud` is drawn on the image:
        the title and time, the text rows ``lines``, per vessel its colour, name (``names``, by
        default ``#i``) and mode (``modes``), the names by the hulls, the scale, north, the current
        ``current_m_s`` (2,) [m/s] at the view's centre and the legend's rows ``legend`` (kind,
        RGBA 0–1, text; empty: none). The scene drawn into MuJoCo is the same either way."""
        names, modes = list(names), list(modes)
        vessels = [VesselView(names[i] if i < len(names) else f"#{i}", tuple(int(255 * c) for c in rgba[:3]),
                              np.asarray(p, float), float(h), modes[i] if i < len(modes) else "")
                   for i, (p, h, rgba) in enumerate(markers)]
        view = FrameView(float(data.time), vessels, np.asarray(current_m_s, float).reshape(2), list(lines),
                         tuple(legend))
        return self._frame(data, view, hud=hud, trails=[np.asarray(pts, float) for pts, _ in trails])

    def _frame(self, data, view: FrameView, hud: bool = True, trails=None, later: bool = False) -> np.ndarray | None:
        """Render, overlay and encode a frame; ``trails`` (k, 2) per vessel, by default the run's
        kept trail points and each vessel's position now; ``later``: as :meth:`add_event`'s."""
        if trails is None:
            trails = [np.array([*t, tuple(v.position_m)]) for t, v in zip(self._trails, view.vessels)] \
                if view.vessels else []
        held, self._held = self._held, None
        images = self._read_panes() if held is not None else None  # (before the panes render again)
        places = []
        try:
            for pane in self.panes:
                t0 = time.perf_counter()
                pane.renderer.update_scene(data, camera=pane.camera)
                scn = pane.renderer.scene
                add_scene_geoms(scn, view, pane.marker_m, trails, self.overlays, only=pane.chased)
                t1 = time.perf_counter()
                # (what the overlay needs of this moment: the camera's projection, the view's centre)
                places.append((Projection(scn, pane.width, pane.height), pane.view_centre(self.model, data)) if hud
                              else None)
                t2 = time.perf_counter()
                pane.start_render()
                self.seconds["scene"] += t1 - t0
                self.seconds["hud"] += t2 - t1
                self.seconds["render"] += time.perf_counter() - t2
        except BaseException:  # (this frame failed: the one held before is still finished, then the error)
            if held is not None:
                self._finish(images, *held)
            raise
        before = self._finish(images, *held) if held is not None else None  # (while this frame rasterises)
        if later:
            self._held = (view, hud, places)
            return before
        return self._finish(self._read_panes(), view, hud, places)

    def _read_panes(self) -> list:
        t = time.perf_counter()
        images = [pane.read_pixels() for pane in self.panes]
        self.seconds["render"] += time.perf_counter() - t
        return images

    def _finish(self, images: list, view: FrameView, hud: bool, places: list) -> np.ndarray:
        """Draw the overlay on each pane's image (its projection and view centre at the frame's
        moment), put the panes side by side and encode the frame."""
        t = time.perf_counter()
        if hud:
            for k, (pane, (proj, centre)) in enumerate(zip(self.panes, places)):
                images[k] = draw_hud(images[k], view, proj, centre, self.title, memory=pane.hud_memory) if k == 0 \
                    else draw_hud(images[k], view, proj, centre, self.chase_title.format(vessel=pane.chased),
                                  furniture=False)
        frame = images[0] if len(images) == 1 else _side_by_side(images)
        t3 = time.perf_counter()
        self.seconds["hud"] += t3 - t
        self._writer.send(np.ascontiguousarray(frame))
        self.seconds["encode"] += time.perf_counter() - t3
        self.frames += 1
        return frame

    def _append_trails(self, view: FrameView) -> None:
        """A trail point per vessel every :data:`TRAIL_PERIOD_S` (the frame adds the position now)."""
        if not self._trails:
            self._trails = [[] for _ in view.vessels]
        if view.time_s - self._trail_t >= TRAIL_PERIOD_S:
            self._trail_t = view.time_s
            for trail, v in zip(self._trails, view.vessels):
                trail.append(tuple(v.position_m))
                del trail[:-TRAIL_POINTS]

    def finish_held(self) -> None:
        """Draw and encode the frame held back (:meth:`add_event` with ``later``), if any."""
        held, self._held = self._held, None
        if held is not None:
            self._finish(self._read_panes(), *held)

    def close(self) -> None:
        """Finish the frame held back, then the file, and rename it from ``.video.part.mp4`` to its
        own name. A held frame is left here only when its producer failed first (the runner
        finishes its last frame with :meth:`finish_held`): it is finished if it can be, else the
        file keeps the frames before it (the producer's error is the one to report)."""
        try:
            if self._writer is not None:
                try:
                    self.finish_held()
                except Exception:  # noqa: BLE001 - (the producer failed already; see above)
                    self._held = None
                finally:
                    self._writer.close()
                    self._writer = None
                    os.replace(self._part, self.path)
        finally:
            for pane in self.panes:
                pane.close()

    def discard(self) -> None:
        """Stop encoding and remove the temporary file: nothing under the final name (a video whose
        producer failed midway)."""
        self._held = None
        if self._writer is not None:
            try:
                self._writer.close()
            finally:
                self._writer = None
                self._part.unlink(missing_ok=True)
        for pane in self.panes:
            pane.close()


def _side_by_side(images) -> np.ndarray:
    """The panes left to right, a 2-pixel dark line between neighbours."""
    frame = np.concatenate(images, axis=1)
    x = 0
    for image in images[:-1]:
        x += image.shape[1]
        frame[:, x - 1:x + 1] = 20
    return frame


def _thin(points: np.ndarray, n: int) -> np.ndarray:
    """Every k-th point of a polyline (k = ⌈len / n⌉), its last point kept."""
    k = -(-len(points) // n)
    return points if k <= 1 else np.vstack([points[::k], points[-1:]])
