"""The video's camera framing, world → pixel projection, overlays and heads-up display."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import mujoco
import numpy as np
import pytest

from mjasc.perception.range_sensor import Scan
from mjasc.runs.blueprint import PALETTE
from mjasc.runs.runner import Runner
from mjasc.runs.scenario import load_scenario
from mjasc.runs.video import VideoWriter
from mjasc.runs.video_hud import Projection, scale_bar_m
from mjasc.runs.video_scene import FAN_DECIMATION, add_disc, frame_view, scan_outline

TASKS = Path(__file__).resolve().parents[1] / "tasks"

_WATER = """<mujoco><visual><global offwidth="640" offheight="480"/><quality shadowsize="0" offsamples="0"/></visual>
<worldbody><light pos="0 0 100" dir="0 0 -1"/><geom type="plane" size="500 500 1" rgba="0.1 0.3 0.5 1"/></worldbody>
</mujoco>"""


@pytest.fixture(scope="module")
def water():
    m = mujoco.MjModel.from_xml_string(_WATER)
    return m, mujoco.MjData(m)


@pytest.mark.parametrize("camera", ["top_down", "overview"])
def test_a_ball_lands_on_the_pixel_the_projection_predicts(tmp_path, water, camera):
    m, d = water
    extent = (np.array([40.0, -20.0]), np.array([240.0, 130.0]))
    w = VideoWriter(tmp_path / "v.mp4", m, 320, 240, 10, camera, extent)
    try:
        for target in ([140.0, 55.0], [80.0, 100.0], [200.0, -5.0]):
            w.renderer.update_scene(d, camera=w.camera)
            add_disc(w.renderer.scene, target, 5.0, (1.0, 0.0, 1.0, 1.0), 0.0, mujoco.mjtGeom.mjGEOM_SPHERE)
            img = w.renderer.render().astype(int)
            magenta = (img[..., 0] - img[..., 1] > 60) & (img[..., 2] - img[..., 1] > 60)
            assert magenta.sum() > 20, "the ball is in view"
            rows, cols = np.nonzero(magenta)
            px = Projection(w.renderer.scene, 320, 240)(np.array([[*target, 0.0]]))[0]
            assert np.hypot(cols.mean() + 0.5 - px[0], rows.mean() + 0.5 - px[1]) < 2.0
    finally:
        w.close()


def test_top_down_view_fits_the_extent_and_its_scale_is_span_over_height(tmp_path, water):
    m, d = water
    lo, hi = np.array([0.0, 0.0]), np.array([300.0, 100.0])  # wide: the width sets the span
    w = VideoWriter(tmp_path / "v.mp4", m, 320, 240, 10, "top_down", (lo, hi))
    try:
        w.renderer.update_scene(d, camera=w.camera)
        proj = Projection(w.renderer.scene, 320, 240)
        span = 1.1 * max(100.0, 300.0 * 240 / 320)  # vertical span [m]
        assert proj.top_down
        assert proj.metres_per_pixel([150.0, 50.0, 0.0]) == pytest.approx(span / 240, rel=1e-6)
        corners = proj(np.array([[0.0, 0.0, 0.0], [300.0, 100.0, 0.0]]))
        assert np.all((corners >= 0) & (corners <= [320, 240]))  # the extent is inside the frame
        assert corners[1, 1] < corners[0, 1]  # north is up
    finally:
        w.close()


@pytest.mark.parametrize("width, height", [(320, 480), (320, 360), (640, 480), (640, 240)])
@pytest.mark.parametrize("extent", [((0.0, 0.0), (300.0, 100.0)), ((-40.0, -60.0), (40.0, 160.0))])
def test_the_overview_fits_the_extent_in_its_pane_whatever_the_pane_s_shape(tmp_path, water, width, height, extent):
    """The oblique overview frames the extent's corners (at the water and 2 m up: the hulls) inside
    the pane with a margin, in a split view's narrow half (320 px of 640) too: fitted as a
    top-down view, the near corners (nearer, so wider apart) fell outside the frame."""
    m, d = water
    lo, hi = np.array(extent[0]), np.array(extent[1])
    w = VideoWriter(tmp_path / "v.mp4", m, width, height, 10, "overview", (lo, hi))
    try:
        w.renderer.update_scene(d, camera=w.camera)
        proj = Projection(w.renderer.scene, width, height)
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (0.0, 2.0)])
        px = proj(corners)
        assert np.all((px >= [0.02 * width, 0.02 * height]) & (px <= [0.98 * width, 0.98 * height])), px
        # and not smaller than needed: some corner within 10 % (+ a pixel) of the frame's edge
        gap = np.minimum(px, [width, height] - px) / [width, height]
        assert gap.min() < 0.06, gap.min()
    finally:
        w.close()


def _long_view():
    from mjasc.runs.video_scene import FrameView, VesselView

    vessels = [VesselView(name, PALETTE[i], np.zeros(2), 0.0, "avoidance:yield",
                          f"velocity_correction for T{i + 11} at 41 s", mission_phase="go to formation")
               for i, name in enumerate(("alpha", "bravo", "charlie"))]
    return FrameView(123.4, vessels, np.zeros(2))


@pytest.mark.parametrize("width, height, legend", [(320, 480, True), (320, 360, True), (640, 480, True),
                                                   (1280, 720, True), (320, 240, False)])
def test_the_hud_boxes_do_not_overlap_and_the_legend_moves_where_there_is_room(width, height, legend):
    """The title and modes (with long modes and decisions), the scale bar, the north/current box
    and the legend stay inside the frame and apart, in a split view's 320 px half too: the legend
    fixed at the top right covered the title and the modes there. A frame with no room for it
    (320 × 240) shows no legend rather than covering the text."""
    import itertools

    from PIL import Image, ImageDraw

    from mjasc.runs.video_hud import hud_layout

    draw = ImageDraw.Draw(Image.new("RGB", (width, height)), "RGBA")
    lay = hud_layout(draw, _long_view(), width, height, "thesis_6_4_crossing", True, 0.2 * width)
    names = [k for k in ("text", "scale", "north", "legend") if k in lay]
    assert ("legend" in names) == legend
    for k in names:
        x0, y0, x1, y1 = lay[k]
        assert 0 <= x0 < x1 <= width and 0 <= y0 < y1 <= height, k
    for a, b in itertools.combinations(names, 2):
        (a0, a1, a2, a3), (b0, b1, b2, b3) = lay[a], lay[b]
        assert a2 <= b0 or b2 <= a0 or a3 <= b1 or b3 <= a1, (a, b)


def test_the_legend_keeps_clear_of_the_vessels_where_it_can():
    """Of the places free of the text boxes the legend takes the first that covers no vessel or
    name; when every free place covers one, the first free place."""
    from mjasc.runs.video_hud import place_legend

    taken = [(4, 4, 150, 100), (8, 440, 80, 472), (490, 396, 636, 476)]
    first = place_legend((200, 120), 640, 480, taken)
    assert first == (436, 2, 636, 122)  # top right
    vessel = (500, 50, 560, 70)
    moved = place_legend((200, 120), 640, 480, taken, [vessel])
    assert moved is not None and not (moved[0] < vessel[2] and vessel[0] < moved[2] and moved[1] < vessel[3]
                                      and vessel[1] < moved[3])
    everywhere = [(0, 0, 640, 480)]
    assert place_legend((200, 120), 640, 480, taken, everywhere) == first
    # From frame to frame it stays where it went (no jumping back once the vessel has passed) ...
    assert place_legend((200, 120), 640, 480, taken, [], last=moved) == moved
    assert place_legend((200, 120), 640, 480, taken, everywhere, last=moved) == moved
    # ... unless the place is taken (a longer mode text).
    assert place_legend((200, 120), 640, 480, [*taken, moved], [], last=moved) != moved


def test_the_legend_names_the_traffic_and_the_structures_in_their_own_colours():
    """The traffic (dark grey, not the predicted conflict's red) and the structures have a legend
    row, in the colours MuJoCo draws them."""
    from mjasc.physics.world import MOVING_RGBA
    from mjasc.runs.video_hud import LEGEND_ITEMS, STRUCTURE_SWATCH
    from mjasc.runs.video_scene import COLOURS

    rows = {text.split(" ")[0]: rgba for _, rgba, text in LEGEND_ITEMS}
    assert rows["traffic"] == tuple(float(x) for x in MOVING_RGBA.split())
    # The structures: their walls' lit tops as rendered (tests/test_video_model.py renders one).
    assert rows["structure"][:3] == pytest.approx([c / 255 for c in STRUCTURE_SWATCH])
    traffic, conflict = np.array(rows["traffic"][:3]), np.array(COLOURS["conflict"][:3])
    assert np.abs(traffic - conflict).sum() > 0.9  # not a shade of the conflict marker's red
    assert all(np.abs(255 * traffic - np.array(c)).sum() > 150 for c in PALETTE)  # nor a vessel's colour


@pytest.mark.parametrize("mpp, width, expected", [(0.5, 640, 50.0), (1.0, 100, 20.0), (0.01, 640, 1.0),
                                                   (3.0, 640, 200.0)])
def test_scale_bar_is_the_round_length_below_a_fifth_of_the_width(mpp, width, expected):
    assert scale_bar_m(mpp, width) == expected


def test_fan_outline_keeps_every_return_and_ends_at_the_measured_ranges():
    n = 36
    angles = -np.pi + (np.arange(n) + 0.5) * 2 * np.pi / n
    hit = np.zeros(n, bool)
    hit[[4, 5, 20]] = True
    ranges = np.where(hit, 10.0, 50.0)
    scan = Scan(0.0, np.array([3.0, 4.0]), 0.5, angles, ranges, hit, np.flatnonzero(hit), np.zeros((3, 2)),
                np.zeros((3, 2)), np.full(n, -1), 50.0, 2 * np.pi / n, True)
    out = scan_outline(scan)
    keep = set(range(0, n, FAN_DECIMATION)) | {0, n - 1, 4, 5, 20}
    assert len(out) == len(keep) + 1 and np.allclose(out[0], out[-1])  # closed
    dist = np.hypot(*(out[:-1] - [3.0, 4.0]).T)
    assert sorted(np.round(dist, 9)) == sorted([10.0 if k in (4, 5, 20) else 50.0 for k in keep])
    end = out[1] - [3.0, 4.0]  # beam 4 is the second kept beam: world angle ψ + a_4
    assert np.arctan2(end[1], end[0]) == pytest.approx(np.angle(np.exp(1j * (0.5 + angles[4]))))


def test_demo_frames_show_what_each_vessel_senses_and_decides(tmp_path):
    """After the ferry is tracked, the frame view holds every vessel's fan and tracks, and the
    rendered frame shows each vessel's name in its colour next to its projected position."""
    sc = load_scenario(TASKS / "demo.toml").with_overrides(duration_s=12.0, video=True)
    sc = dataclasses.replace(sc, outputs=dataclasses.replace(sc.outputs, video_width=320, video_height=240,
                                                             video_fps=1.0))
    runner = Runner(sc, tmp_path, progress=False)
    seen = {}

    def grab(event):
        seen["view"] = frame_view(event, (0.0, 0.0))
        seen["frame"] = runner.video.add_event(event)  # one more frame, read back here
        seen["proj"] = Projection(runner.video.renderer.scene, 320, 240)

    runner.observe("video", grab)
    result = runner.run()
    view, frame, proj = seen["view"], seen["frame"], seen["proj"]
    assert [v.name for v in view.vessels] == ["alpha", "bravo", "charlie"]
    assert all(v.fan is not None and len(v.fan) > 10 for v in view.vessels)
    assert all(v.mode == "mission" for v in view.vessels)
    assert any(v.tracks for v in view.vessels)
    assert view.current_m_s == pytest.approx([0.0, 0.2])
    for v in view.vessels:  # the name label in the vessel's colour, by the hull (moved off another name)
        x, y = proj(np.array([[*v.position_m, 0.5]]))[0].astype(int)
        patch = frame[max(y - 40, 0):y + 30, max(x - 80, 0):x + 60].astype(int)
        assert (np.abs(patch - np.array(v.colour)).sum(axis=-1) < 60).sum() >= 5, v.name
    assert result.summary["video_frames"] == 2 * 13  # the slot's 13 and this test's 13
    assert set(result.summary["video_timing_s"]) == {"view", "scene", "render", "hud", "encode"}


def _demo_runner(tmp_path, camera: str, width: int, height: int, duration_s: float = 12.0):
    sc = load_scenario(TASKS / "demo.toml").with_overrides(duration_s=duration_s, video=True, video_camera=camera)
    sc = dataclasses.replace(sc, outputs=dataclasses.replace(sc.outputs, video_width=width, video_height=height,
                                                             video_fps=1.0, recording=False))
    return Runner(sc, tmp_path, progress=False)


def test_split_frame_shows_the_overview_left_and_the_first_vessels_chase_view_right(tmp_path):
    runner = _demo_runner(tmp_path, "split", 640, 240)
    seen = {}

    def grab(event):
        w = runner.video
        seen.update(frame=w.add_event(event), panes=[(p.chased, p.width, p.height) for p in w.panes])

    runner.observe("video", grab)
    runner.run()
    # split without a name: the first vessel's chase camera; each half is rendered at 320 × 240.
    assert seen["panes"] == [(None, 320, 240), ("alpha", 320, 240)]
    frame = seen["frame"].astype(int)
    assert frame.shape == (240, 640, 3)
    left, right = frame[:, :319], frame[:, 321:]
    assert np.abs(left - right).mean() > 20, "the halves show different views"
    # The chase half: the chased Otter's gold pontoons near the centre, large (not a map symbol).
    centre = right[60:200, 80:240]
    assert (np.abs(centre - np.array([245, 184, 20])).sum(axis=-1) < 90).sum() > 200
    # The overview half: the vessels' map symbols in their palette colours (gold, pink, lime).
    for colour in PALETTE[:3]:
        assert (np.abs(left - np.array(colour)).sum(axis=-1) < 60).sum() > 5, colour


@pytest.mark.parametrize("camera, message", [("split:zulu", "no vessel named 'zulu'"),
                                             ("chase:zulu", "no vessel named 'zulu'"),
                                             ("sideways", "must be top_down, overview")])
def test_a_bad_camera_is_one_line_naming_the_field(camera, message):
    from mjasc.runs.scenario import ScenarioError

    with pytest.raises(ScenarioError) as err:
        load_scenario(TASKS / "demo.toml").with_overrides(video_camera=camera)
    text = str(err.value)
    assert text.startswith("outputs.video_camera: ") and message in text and "\n" not in text


def test_overlay_colours_are_no_vessel_colour_and_show_on_the_water():
    """Every overlay colour is far from each vessel colour (RGB distance) and from the water."""
    from mjasc.runs.blueprint import PALETTE
    from mjasc.runs.video_hud import WATER_SWATCH
    from mjasc.runs.video_scene import COLOURS

    for key in ("path", "detour", "conflict", "svo", "field"):
        rgb = 255 * np.array(COLOURS[key][:3])
        assert min(np.linalg.norm(rgb - np.array(p)) for p in PALETTE) > 70, key
        assert np.linalg.norm(rgb - np.array(WATER_SWATCH)) > 90, key


def test_every_vessel_colour_stands_out_on_the_water():
    """WCAG's contrast ratio (L1 + 0.05) / (L2 + 0.05) of relative luminances, ≥ 3:1 for graphics,
    between each palette colour and both squares of the water's checker texture (assets)."""
    import xml.etree.ElementTree as ET

    root = ET.parse(Path(__file__).resolve().parent.parent / "assets" / "scene" / "water.xml").getroot()
    tex = next(t for t in root.iter("texture") if t.get("name") == "water")

    def luminance(rgb01):
        c = np.asarray(rgb01, float)
        c = np.where(c <= 0.03928, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
        return float(c @ [0.2126, 0.7152, 0.0722])

    for key in ("rgb1", "rgb2"):
        water = luminance([float(x) for x in tex.get(key).split()])
        for colour in PALETTE:
            ratio = (luminance(np.array(colour) / 255) + 0.05) / (water + 0.05)
            assert ratio >= 3.0, (colour, key, ratio)


def test_the_video_plays_in_real_time_when_the_frame_rate_does_not_divide_the_physics_rate(tmp_path):
    """20 fps asked at 50 Hz physics: a frame every 2 physics steps (25 fps); the MP4 is encoded at
    that rate, so its duration is the simulated time (it played 12 s of simulation in 15 s)."""
    import imageio_ffmpeg

    sc = load_scenario(TASKS / "demo.toml").with_overrides(duration_s=2.0, video=True)
    sc = dataclasses.replace(sc, outputs=dataclasses.replace(sc.outputs, video_width=320, video_height=240,
                                                             video_fps=20.0, recording=False))
    assert sc.rates.physics_hz == 50.0
    result = Runner(sc, tmp_path, progress=False).run()
    reader = imageio_ffmpeg.read_frames(str(tmp_path / "video.mp4"))
    meta = next(reader)
    frames = sum(1 for _ in reader)
    assert result.summary["rates_hz"]["video"] == 25.0 and meta["fps"] == pytest.approx(25.0)
    assert frames == result.summary["video_frames"] == 51
    assert (frames - 1) / meta["fps"] == pytest.approx(sc.duration_s)  # the first frame at t = 0, the last at 2 s


def test_the_scene_s_extent_holds_where_a_followed_target_goes():
    """The top-down view and the blueprint frame the scene's extent: with a target-tracking mission
    it holds the target's whole run (the team goes after it), not only its start."""
    from mjasc.physics.obstacles import MovingObstacleSet

    sc = load_scenario(TASKS / "target_tracking.toml")
    runner = Runner(sc, None, progress=False)
    lo, hi = runner.extent()
    target = next(o for o in sc.moving_obstacles if o.name == sc.mission.track_target.target)
    end = MovingObstacleSet([target]).state(sc.duration_s)[0][0]
    assert np.all(lo < end) and np.all(end < hi)
    assert np.linalg.norm(end - target.position_m) > 100.0  # (it does go far from its start)


def _fleet_view(n: int = 50, spread_m: float = 0.0):
    from mjasc.runs.video_scene import FrameView, VesselView

    vessels = [VesselView(f"v{i:03d}", PALETTE[i % len(PALETTE)], np.array([0.0, spread_m * i]), 0.0,
                          "avoidance:yield" if i % 3 == 0 else "mission",
                          f"velocity_correction for T{i} at 4.0 s" if i % 3 == 0 else "")
               for i in range(n)]
    return FrameView(4.0, vessels, np.zeros(2))


def _layout(view, width, height, vessels_px=None, furniture=True):
    from PIL import Image, ImageDraw

    from mjasc.runs.video_hud import hud_layout

    draw = ImageDraw.Draw(Image.new("RGB", (width, height)), "RGBA")
    return hud_layout(draw, view, width, height, "fleet_50", furniture, 0.2 * width, vessels_px)


@pytest.mark.parametrize("width, height", [(640, 480), (320, 240), (1280, 720)])
def test_a_fleet_s_modes_fit_above_the_scale_bar_and_the_rest_are_summed_up(width, height):
    """fleet_50's modes box listed 50 vessels and ran off the frame, under the scale bar: the rows
    that fit are listed, then one row sums up the rest (how many, how many in avoidance)."""
    lay = _layout(_fleet_view(), width, height)
    x0, y0, x1, y1 = lay["text"]
    assert y1 <= lay["scale"][1] and y1 <= height
    last = lay["rows"][-1][0]
    listed = sum(1 for _, _, v in lay["rows"] if v is not None)
    assert last.startswith("… and ") and f"and {50 - listed} more" in last
    avoiding = sum(1 for i in range(listed, 50) if i % 3 == 0)
    assert f"({avoiding} in avoidance)" in last
    # Three vessels fit: no summary row.
    assert not _layout(_long_view(), 640, 480)["rows"][-1][0].startswith("…")


@pytest.mark.parametrize("n, spread", [(50, 2.0), (3, 0.0), (6, 3.0)])
def test_no_two_names_by_the_hulls_overlap_and_the_first_vessels_keep_theirs(n, spread):
    """fleet_50's 50 names, 6 px apart, ran into one block, and thesis_6_2_dock's names overlapped
    at frame 0: a name that would cover an earlier one moves or is left out (at most 12)."""
    import itertools

    from mjasc.runs.video_hud import MAX_NAMES

    view = _fleet_view(n, spread)
    px = np.array([[300.0, 240.0 - v.position_m[1]] for v in view.vessels])
    for furniture in (True, False):
        names = _layout(view, 640, 480, px, furniture)["names"]
        assert 0 < len(names) <= MAX_NAMES
        assert names[0][0] is view.vessels[0]
        for (_, _, a), (_, _, b) in itertools.combinations(names, 2):
            assert a[2] <= b[0] or b[2] <= a[0] or a[3] <= b[1] or b[3] <= a[1]
    assert len(_layout(_fleet_view(3, 40.0), 640, 480, np.array([[300.0, 100.0 + 60 * i] for i in range(3)]))
               ["names"]) == 3


@pytest.mark.parametrize("width, height", [(200, 300), (319, 480), (640, 239)])
def test_a_pane_below_320_by_240_shows_no_legend(width, height):
    """A 400 × 300 split's 200 × 300 panes drew the legend over a name, though
    docs/architecture.md says a pane smaller than 320 × 240 px leaves it out."""
    from mjasc.runs.video_hud import LEGEND_MIN_PX

    assert LEGEND_MIN_PX == (320, 240)
    assert "legend" not in _layout(_fleet_view(1), width, height, np.array([[20.0, 280.0]]))
    assert "legend" in _layout(_fleet_view(1), 640, 480, np.array([[20.0, 280.0]]))
    doc = (Path(__file__).resolve().parents[1] / "docs" / "architecture.md").read_text()
    assert "narrower than 320 px or shorter than 240 px" in " ".join(doc.split())


def test_the_structure_swatch_is_an_outline_as_the_walls_are_drawn():
    """Structures are thin hollow walls; the legend showed a filled brown block."""
    from PIL import Image, ImageDraw

    from mjasc.runs.video_hud import LEGEND_ITEMS, _legend, _legend_size
    from mjasc.runs.video_text import frame_font as _font

    kinds = {text.split(" ")[0]: kind for kind, _, text in LEGEND_ITEMS}
    assert kinds["structure"] == "outline"
    img = Image.new("RGB", (400, 300))
    draw = ImageDraw.Draw(img, "RGBA")
    font = _font(12)
    w, h = _legend_size(draw, font)
    _legend(draw, (0, 0, w, h), font)
    line = font.size + 3
    y = 2 + (len(LEGEND_ITEMS) - 1) * line + line // 2
    centre = np.asarray(img)[y, 4 + 13]
    assert tuple(centre) == (30, 88, 138)  # the water shows inside: hollow


def test_the_water_reaches_the_edges_of_a_view_framed_beyond_the_scene_s_plane(tmp_path):
    """fleet_50's view reached past the scene's 1 km water plane: a light strip at the right edge.
    The rendered scene's plane is widened; the model's (no collisions, excluded from the sensor) is not."""
    from mjasc.physics.vessels import SCENE_XML

    m = mujoco.MjModel.from_xml_path(str(SCENE_XML))  # its water: a 1 km plane, "water"
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    size = m.geom_size.copy()
    w = VideoWriter(tmp_path / "v.mp4", m, 320, 240, 10, "top_down", (np.array([300.0, -100.0]),
                                                                      np.array([900.0, 100.0])))
    try:
        from mjasc.runs.video_scene import FrameView

        img = w._frame(d, FrameView(0.0, [], np.zeros(2)), hud=False).astype(int)
        water = img[120, 100]
        assert np.abs(img[:, -3:] - water).sum(axis=-1).max() < 30, "water up to the right edge"
    finally:
        w.close()
    assert np.array_equal(m.geom_size, size)


def test_the_decision_time_has_the_clock_s_decimal():
    """The HUD read 'at 1 s' while the clock read 0.6 s."""
    import types

    from mjasc.runs.video_scene import frame_view

    avoidance = types.SimpleNamespace(conflict_log=[{"decision": "pass", "track_id": 3, "time_s": 0.6}],
                                      last_prediction=None, detour=None)
    agent = types.SimpleNamespace(name="a", perception=None, avoidance=avoidance, mode="avoidance:pass",
                                  config=types.SimpleNamespace(path=None))
    current = types.SimpleNamespace(velocity=lambda p, t: np.zeros((1, 2)))
    runner = types.SimpleNamespace(agents=[agent], last_outputs=[None], sim=types.SimpleNamespace(current=current))
    states = types.SimpleNamespace(position_m=np.zeros((1, 2)), heading_rad=np.zeros(1))
    view = frame_view(types.SimpleNamespace(runner=runner, states=states, time_s=0.6), (0.0, 0.0))
    assert view.vessels[0].decision == "pass for T3 at 0.6 s"


def test_the_hud_shows_the_latest_decision_while_it_is_recent_or_the_vessel_avoids():
    """A decision from the run's first second was still in the HUD at 399 s (missions review), and
    past the summary's 50 logged conflicts the HUD showed the 50th for ever: it shows the latest
    (``last_conflict``) while the vessel avoids or for DECISION_SHOWN_S after it."""
    import types

    from mjasc.runs.video_scene import DECISION_SHOWN_S, frame_view

    def decision(mode, t_s, last=True):
        log = [{"decision": "replan", "track_id": 1, "time_s": 0.6}]  # (the capped log's last entry)
        latest = {"decision": "velocity_correction", "track_id": 7, "time_s": 350.0} if last else None
        avoidance = types.SimpleNamespace(conflict_log=log, last_conflict=latest, last_prediction=None, detour=None)
        agent = types.SimpleNamespace(name="a", perception=None, avoidance=avoidance, mode=mode,
                                      config=types.SimpleNamespace(path=None))
        current = types.SimpleNamespace(velocity=lambda p, t: np.zeros((1, 2)))
        runner = types.SimpleNamespace(agents=[agent], last_outputs=[None], sim=types.SimpleNamespace(current=current))
        states = types.SimpleNamespace(position_m=np.zeros((1, 2)), heading_rad=np.zeros(1))
        return frame_view(types.SimpleNamespace(runner=runner, states=states, time_s=t_s), (0.0, 0.0)).vessels[0].decision

    assert decision("avoidance:yield", 399.0) == "velocity_correction for T7 at 350.0 s"  # avoiding: the latest
    assert decision("mission", 350.0 + DECISION_SHOWN_S) == "velocity_correction for T7 at 350.0 s"
    assert decision("mission", 350.0 + DECISION_SHOWN_S + 0.1) == ""  # back on the mission, long after
    assert decision("mission", 399.0, last=False) == ""  # (a plugin's log only: its last entry, from 0.6 s)
    assert decision("mission", 10.0, last=False) == "replan for T1 at 0.6 s"


def test_where_two_trails_cross_the_pixels_do_not_depend_on_what_the_scene_slots_held(tmp_path, water):
    """The overlay's geoms fill scene slots after MuJoCo's own; a slot keeps what an earlier frame or
    uninitialised memory left in the fields ``mjv_initGeom`` does not set, and ``mjr_render`` sorts
    semi-transparent geoms by a distance that reads the object type: a stale "model geom" there
    changed which of two crossing trails was drawn on top (the flaky held-frame test's few pixels,
    gold against pink). The same overlay gives the same pixels whatever the slots held."""
    from mjasc.runs.video_scene import FrameView, VesselView, add_scene_geoms

    m, d = water
    mujoco.mj_forward(m, d)
    w = VideoWriter(tmp_path / "v.mp4", m, 320, 240, 10, "top_down", (np.array([0.0, 0.0]), np.array([100.0, 100.0])))
    vessels = [VesselView(n, c, np.array([50.0, 50.0]), 0.0) for n, c in (("a", (255, 200, 0)), ("b", (255, 100, 220)))]
    trails = [np.array([[10.0, 50.0], [90.0, 50.0]]), np.array([[50.0, 45.0], [50.0, 55.0]])]  # a long and a short one
    images = []
    try:
        for stale in (mujoco.mjtObj.mjOBJ_UNKNOWN, mujoco.mjtObj.mjOBJ_GEOM):
            w.renderer.update_scene(d, camera=w.camera)
            scn = w.renderer.scene
            for k in range(scn.ngeom, scn.ngeom + 8):  # (what an earlier frame's model geom left in the slots)
                scn.geoms[k].objtype, scn.geoms[k].objid = int(stale), 0
            add_scene_geoms(scn, FrameView(0.0, vessels, np.zeros(2)), 0.0, trails)
            images.append(w.renderer.render().copy())
    finally:
        w.close()
    water_rgb = images[0][5, 5]
    drawn = np.any(images[0] != water_rgb, axis=-1)
    assert drawn[:, 60:260].any(axis=1).sum() >= 10 and drawn[100:140].any(axis=0).sum() >= 100  # both trails drawn
    assert np.array_equal(images[0], images[1])


_CHECKERED = """<mujoco><visual><global offwidth="640" offheight="480"/><quality shadowsize="0" offsamples="0"/></visual>
<asset><texture name="t" type="2d" builtin="checker" width="64" height="64" rgb1="1 0 0" rgb2="0 0 1"/>
<material name="m" texture="t" texrepeat="8 8"/></asset>
<worldbody><light pos="0 0 100" dir="0 0 -1"/><geom type="plane" size="500 500 1" material="m"/></worldbody>
</mujoco>"""


def test_closing_one_writer_leaves_another_writer_s_frames_as_they_were(tmp_path):
    """Each writer's panes free their GL objects in their own context: MuJoCo's renderer frees them
    in the context current at the time, and closing one writer took the other's texture with it."""
    from mjasc.runs.video_scene import FrameView

    m = mujoco.MjModel.from_xml_string(_CHECKERED)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    extent = (np.array([0.0, 0.0]), np.array([100.0, 100.0]))
    first = VideoWriter(tmp_path / "a.mp4", m, 160, 120, 10, "top_down", extent)
    second = VideoWriter(tmp_path / "b.mp4", m, 160, 120, 10, "top_down", extent)
    view = FrameView(0.0, [], np.zeros(2))
    try:
        first._frame(d, view, hud=False)
        before = second._frame(d, view, hud=False).copy()  # (the second writer's context is current)
        first.close()
        after = second._frame(d, view, hud=False)
    finally:
        second.close()
    assert before[..., 0].max() > 200 and before[..., 2].max() > 200  # the checker's red and blue squares
    assert np.array_equal(before, after)


def test_a_frame_held_back_while_it_rasterises_gives_the_same_video(tmp_path, monkeypatch):
    """The runner holds each frame back while the renderer rasterises it (``add_event(later=True)``:
    its overlay and encoding at the next frame or the close): the MP4 is the same bytes as with
    every frame finished at once, the frame count the same, and the frame a held call returns is
    the one held before it."""
    from mjasc.runs import video as video_module

    def run(folder, later_allowed):
        sc = load_scenario(TASKS / "demo.toml").with_overrides(duration_s=3.0, video=True, video_camera="split")
        sc = dataclasses.replace(sc, outputs=dataclasses.replace(sc.outputs, video_width=320, video_height=120,
                                                                 recording=False))
        add_event = video_module.VideoWriter.add_event
        returned = []

        def spy(self, event, later=False):
            got = add_event(self, event, later=later and later_allowed)
            returned.append(None if got is None else got.copy())
            return got

        monkeypatch.setattr(video_module.VideoWriter, "add_event", spy)
        result = Runner(sc, tmp_path / folder, progress=False).run()
        monkeypatch.setattr(video_module.VideoWriter, "add_event", add_event)
        return (tmp_path / folder / "video.mp4").read_bytes(), result.summary["video_frames"], returned

    held, n_held, frames_held = run("held", True)
    now, n_now, frames_now = run("now", False)
    assert held == now and n_held == n_now == len(frames_now) > 10
    assert frames_held[0] is None and all(np.array_equal(a, b) for a, b in zip(frames_held[1:], frames_now[:-1]))


@pytest.mark.parametrize("where", ["scene", "last_overlay"])
def test_a_run_whose_video_fails_keeps_the_frames_before_as_without_holding(tmp_path, monkeypatch, where):
    """A frame that fails while its scene is built (the 5th) still finishes the one held before it;
    the last frame's overlay failing (finished after the loop) fails the run as any error does,
    with its summary and the video of the frames before: the same MP4 bytes as without holding."""
    from mjasc.runs import video as video_module
    from mjasc.runs.runner import RunFailed

    def run(folder, later_allowed):
        sc = load_scenario(TASKS / "demo.toml").with_overrides(duration_s=3.0, video=True)
        sc = dataclasses.replace(sc, outputs=dataclasses.replace(sc.outputs, video_width=320, video_height=240,
                                                                 recording=False))
        add_event, geoms, hud = video_module.VideoWriter.add_event, video_module.add_scene_geoms, video_module.draw_hud
        calls = {"n": 0}

        def failing(real, k):
            def call(*args, **kwargs):
                calls["n"] += 1
                if calls["n"] == k:
                    raise RuntimeError("the video failed")
                return real(*args, **kwargs)
            return call

        if where == "scene":
            monkeypatch.setattr(video_module, "add_scene_geoms", failing(geoms, 5))
        else:
            monkeypatch.setattr(video_module, "draw_hud", failing(hud, 31))  # (3 s at 10 fps: 31 frames)
        monkeypatch.setattr(video_module.VideoWriter, "add_event",
                            lambda self, event, later=False: add_event(self, event, later=later and later_allowed))
        with pytest.raises(RunFailed, match="the video failed"):
            Runner(sc, tmp_path / folder, progress=False).run()
        monkeypatch.undo()
        summary = json.loads((tmp_path / folder / "summary.json").read_text())
        return (tmp_path / folder / "video.mp4").read_bytes(), summary["status"], summary["video_frames"]

    held, now = run("held", True), run("now", False)
    assert held == now and held[1] == "error" and held[2] == (4 if where == "scene" else 30)


def test_the_hud_shows_what_was_done_for_the_running_manoeuvre_s_track():
    """A reviewer saw "avoidance:pass / velocity_correction for T131" while charlie passed T130 (the
    latest logged conflict, answered with stand-on), and "replan" for a vessel yielding: the line
    shows the triage's answer (``action``) and, during a yield or pass, its track's decision."""
    import types

    from mjasc.runs.video_scene import frame_view

    def decision(correction, log, latest):
        avoidance = types.SimpleNamespace(conflict_log=log, last_conflict=latest, last_prediction=None, detour=None,
                                          correction=correction)
        agent = types.SimpleNamespace(name="a", perception=None, avoidance=avoidance, mode="avoidance:pass",
                                      config=types.SimpleNamespace(path=None))
        current = types.SimpleNamespace(velocity=lambda p, t: np.zeros((1, 2)))
        runner = types.SimpleNamespace(agents=[agent], last_outputs=[None], sim=types.SimpleNamespace(current=current))
        states = types.SimpleNamespace(position_m=np.zeros((1, 2)), heading_rad=np.zeros(1))
        event = types.SimpleNamespace(runner=runner, states=states, time_s=101.2)
        return frame_view(event, (0.0, 0.0)).vessels[0].decision

    passing = {"decision": "velocity_correction", "track_id": 130, "time_s": 101.1, "action": "pass first (speed up)"}
    standing = {"decision": "velocity_correction", "track_id": 131, "time_s": 101.1,
                "action": "team right of way: stand-on, keeps its speed"}
    corr = types.SimpleNamespace(track_id=130, kind="pass", emergency=False)
    assert decision(corr, [passing, standing], standing) == "pass first (speed up) for T130 at 101.1 s"
    assert decision(None, [passing, standing], standing) == \
        "team right of way: stand-on, keeps its speed for T131 at 101.1 s"  # (no manoeuvre: the latest)
    assert decision(corr, [standing], standing) == "pass for T130 at 101.2 s"  # (its entry past the capped log)
    assert decision(None, [], {"decision": "replan", "track_id": 1, "time_s": 101.1}) == "replan for T1 at 101.1 s"


def test_the_conflict_log_says_what_the_triage_did():
    """σ said re-plan where a give-way vessel yields to a team mate (the §6.4.2 head-on's bravo at
    112.1 s; the §6.4.3 bottleneck's bravo at 101.1 s until session 60's team clearance check changed
    that run's course): the entry's ``action`` is the answer, beside the prediction's ``decision``."""
    from mjasc.runs.runner import Runner

    sc = load_scenario(TASKS / "thesis_6_4_head_on.toml").with_overrides(duration_s=114.0)
    s = Runner(sc, None, progress=False).run().summary
    entries = [c for v in s["vessels"].values() for c in v["avoidance"]["conflicts"] if "track_id" in c]
    assert entries and all(c.get("action") for c in entries if c["time_s"] > 5.0)
    assert any(c["decision"] == "replan" and "yield" in c["action"] for c in entries)
    assert any("stand-on" in c["action"] for c in entries)


def test_a_name_is_not_written_over_another_hull_or_the_north_box():
    """A reviewer found "bravo" written on charlie's hull and "charlie" inside the north/current box
    (the names avoided each other and the modes box only)."""
    import types

    from PIL import Image, ImageDraw

    from mjasc.runs.video_hud import _overlaps, name_labels
    from mjasc.runs.video_text import frame_font

    draw = ImageDraw.Draw(Image.new("RGB", (640, 480)))
    font = frame_font(13)
    vessels = [types.SimpleNamespace(name=n) for n in ("bravo", "charlie")]
    px = np.array([[300.0, 300.0], [318.0, 282.0]])  # charlie's hull where bravo's first choice would write
    north = (490, 396, 636, 476)
    labels = name_labels(draw, vessels, px, font, 640, 480, [north])
    bravo = next(box for v, _, box in labels if v.name == "bravo")
    assert not _overlaps(bravo, (318.0 - 8, 282.0 - 8, 318.0 + 8, 282.0 + 8))
    corner = name_labels(draw, vessels[1:], np.array([[560.0, 430.0]]), font, 640, 480, [north])
    assert corner and not _overlaps(corner[0][2], north)
    # a moving obstacle where the first choice would write (a reviewer found the ferry under "charlie")
    alone = name_labels(draw, vessels[1:], np.array([[300.0, 300.0]]), font, 640, 480, [north])
    first = alone[0][2]
    ferry = ((first[0] + first[2]) / 2, (first[1] + first[3]) / 2)
    moved = name_labels(draw, vessels[1:], np.array([[300.0, 300.0]]), font, 640, 480, [north], [ferry])
    assert not _overlaps(moved[0][2], (ferry[0] - 12, ferry[1] - 12, ferry[0] + 12, ferry[1] + 12))


def test_the_legend_keeps_clear_of_the_traffic():
    """A missions user found the tracked whale under the legend: the legend kept clear of the
    vessels and their names only. A moving obstacle where the legend would go moves it."""
    from PIL import Image, ImageDraw

    from mjasc.runs.video_hud import _overlaps, hud_layout

    view = _fleet_view(1)
    draw = ImageDraw.Draw(Image.new("RGB", (640, 480)), "RGBA")
    first = hud_layout(draw, view, 640, 480, "t", True, 100.0, np.array([[320.0, 300.0]]))["legend"]
    whale = np.array([[0.5 * (first[0] + first[2]), 0.5 * (first[1] + first[3])]])  # under the legend's first place
    moved = hud_layout(draw, view, 640, 480, "t", True, 100.0, np.array([[320.0, 300.0]]), None, whale)["legend"]
    x, y = whale[0]
    assert moved != first and not _overlaps(moved, (x - 12, y - 12, x + 12, y + 12))
