"""The video's render-only model copy (mjasc.runs.video_model): hulls in their vessels' palette
colours, structure walls that keep their colour through the MP4's 4:2:0 chroma, the far plane
beyond a distant camera — and the run's own model untouched."""

from __future__ import annotations

import imageio_ffmpeg
import mujoco
import numpy as np
import pytest

from mjasc.physics.obstacles import PolygonObstacle
from mjasc.physics.vessels import load_vessel_type
from mjasc.physics.world import OBSTACLE_RGBA, build_world
from mjasc.runs.blueprint import PALETTE
from mjasc.runs.video import VideoWriter
from mjasc.runs.video_hud import STRUCTURE_SWATCH, Projection
from mjasc.runs.video_model import model_vessels
from mjasc.runs.video_scene import FrameView

#: The model colours the liveries replace: the Otter's yellow pontoons, the Delfim's red.
OTTER_YELLOW, DELFIM_RED = (245, 184, 20), (204, 26, 26)


def _world(statics=(), poses=((0.0, 0.0, 0.0), (0.0, 4.0, 0.0), (7.0, 1.0, 0.0))):
    types = [load_vessel_type(t) for t in ("otter", "otter", "delfim")][:len(poses)]
    world = build_world([(n, t) for n, t in zip(("alpha", "bravo", "charlie"), types)], list(statics))
    d = mujoco.MjData(world.model)
    for i, (x, y, yaw) in enumerate(poses):
        d.qpos[world.qpos_adr[i]] = (x, y, yaw)
    mujoco.mj_forward(world.model, d)
    return world.model, d


def _render(tmp_path, m, d, camera, extent, size=(320, 240)):
    """One frame without overlays, as rendered (before encoding) and as the MP4 decodes it."""
    w = VideoWriter(tmp_path / "v.mp4", m, *size, 10, camera, extent)
    try:
        img = w._frame(d, FrameView(0.0, [], np.zeros(2)), hud=False)
        proj = Projection(w.renderer.scene, *size)
    finally:
        w.close()
    frames = imageio_ffmpeg.read_frames(str(tmp_path / "v.mp4"))
    next(frames)
    decoded = np.frombuffer(next(frames), np.uint8).reshape(size[1], size[0], 3)
    return img.astype(int), decoded.astype(int), proj


def _near(patch, rgb, tol=0.35):
    """Lit pixels of ``patch`` of the hue of ``rgb``: each colour divided by its largest channel
    (lighting brightens or darkens a surface, it keeps its proportions), within ``tol`` (sum of
    absolute differences)."""
    p = np.asarray(patch, float).reshape(-1, 3)
    bright = p.max(axis=1)
    ref = np.asarray(rgb, float) / max(rgb)
    return int(((np.abs(p / np.maximum(bright, 1.0)[:, None] - ref).sum(axis=1) < tol) & (bright > 100)).sum())


def test_each_hull_carries_its_vessel_s_palette_colour_and_the_run_s_model_keeps_its_own(tmp_path):
    """A second Otter looked like alpha (both yellow); the Delfim was red whatever its colour in the key."""
    m, d = _world()
    before = (m.mat_rgba.copy(), m.geom_rgba.copy(), m.geom_size.copy(), m.vis.map.zfar)
    assert [n for n, _ in model_vessels(m)] == ["alpha", "bravo", "charlie"]
    img, _, proj = _render(tmp_path, m, d, "top_down", (np.array([-4.0, -4.0]), np.array([11.0, 7.0])), (640, 480))
    own = {"alpha": OTTER_YELLOW, "bravo": OTTER_YELLOW, "charlie": DELFIM_RED}
    # From above an Otter shows its pontoons' edges and bows around the dark deck strips; the
    # Delfim its deck strips and housing.
    for i, (name, xy, least) in enumerate((("alpha", (0.0, 0.0), 10), ("bravo", (0.0, 4.0), 10),
                                           ("charlie", (7.0, 1.0), 200))):
        x, y = proj(np.array([[*xy, 0.0]]))[0].astype(int)
        patch = img[y - 30:y + 30, x - 50:x + 50]
        others = [c for k, c in enumerate(PALETTE[:3]) if k != i]
        assert _near(patch, PALETTE[i]) >= least, name
        assert max(_near(patch, c) for c in others) < 5, name
        if name != "alpha":  # (alpha's gold is close to the Otter's yellow)
            assert _near(patch, own[name]) < 5, f"{name} keeps its model colour"
    assert np.array_equal(m.mat_rgba, before[0]) and np.array_equal(m.geom_rgba, before[1])
    assert np.array_equal(m.geom_size, before[2]) and m.vis.map.zfar == before[3]


def test_a_chase_view_shows_the_chased_hull_in_its_colour(tmp_path):
    m, d = _world()
    img, _, _ = _render(tmp_path, m, d, "chase:bravo", None)
    centre = img[80:220, 80:240]
    assert _near(centre, PALETTE[1]) > 200  # bravo's pink pontoons, large
    assert _near(centre, OTTER_YELLOW) < 20


def test_a_structure_s_walls_stay_brown_in_the_encoded_video_of_a_large_view(tmp_path):
    """In a view hundreds of metres across a 0.4 m wall is under a pixel: the MP4's 4:2:0 chroma
    (one colour per 2 × 2 pixels) gave it the water's blue (a blue-grey line), while the rendered
    frame had it brown. The render model draws it 3 pixels thick."""
    quay = PolygonObstacle("quay", np.array([[0.0, -40.0], [30.0, -40.0], [30.0, 40.0], [0.0, 40.0]]))
    m, d = _world([quay], poses=((-100.0, 0.0, 0.0),))
    size = m.geom_size.copy()
    img, decoded, proj = _render(tmp_path, m, d, "top_down", (np.array([-300.0, -220.0]), np.array([300.0, 220.0])))
    assert np.array_equal(m.geom_size, size)
    brown = np.array([float(c) for c in OBSTACLE_RGBA.split()[:3]])
    assert brown[0] > brown[2] + 0.15  # the structure colour is red over blue; the water the reverse
    for a, b in ((0.0, -40.0), (30.0, -40.0)), ((30.0, -40.0), (30.0, 40.0)), ((0.0, 40.0), (0.0, -40.0)):
        for s in (0.3, 0.5, 0.7):  # points along the edge: the reddest pixel nearby is the wall's
            x, y = proj(np.array([[a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1]), 1.5]]))[0].astype(int)
            patch = decoded[y - 2:y + 3, x - 2:x + 3].reshape(-1, 3)
            reddest = patch[np.argmax(patch[:, 0] - patch[:, 2])]
            assert reddest[0] - reddest[2] > 20, (a, b, s, reddest.tolist())
            top = img[y - 2:y + 3, x - 2:x + 3].reshape(-1, 3)  # the frame as rendered: the legend's swatch
            assert np.abs(top - np.array(STRUCTURE_SWATCH)).sum(axis=1).min() < 30, (a, b, s)


def test_a_camera_framed_from_beyond_a_kilometre_still_sees_the_water(tmp_path):
    """The scene's far plane is 1 km (zfar 20 × extent 50 m): a view of a 2 km scene was all sky."""
    m, d = _world()
    img, _, _ = _render(tmp_path, m, d, "top_down", (np.array([-1000.0, -700.0]), np.array([1000.0, 700.0])))
    water = img[100:140, 140:180].reshape(-1, 3).mean(axis=0)
    assert water[2] > water[0] + 60, water  # the water's blue, not the pale sky


@pytest.mark.parametrize("camera", ["top_down", "split:bravo"])
def test_the_same_frames_give_the_same_bytes(tmp_path, camera):
    m, d = _world()
    files = []
    for k in range(2):
        extent = (np.array([-4.0, -4.0]), np.array([11.0, 7.0]))
        w = VideoWriter(tmp_path / f"v{k}.mp4", m, 320, 240, 10, camera, extent)
        for _ in range(3):
            w._frame(d, FrameView(0.0, [], np.zeros(2)), hud=False)
        w.close()
        files.append((tmp_path / f"v{k}.mp4").read_bytes())
    assert files[0] == files[1]
