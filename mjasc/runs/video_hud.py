"""The heads-up overlay of a video frame: text and map furniture drawn onto the rendered RGB image.

Drawn with Pillow (pixels; image rows grow downwards) after MuJoCo rendered the scene:

- top left: the scenario name and the simulation time ``t`` [s], then the view's own text rows
  (``FrameView.lines``: a suite episode's policy, reward and return, the task's state), then one
  line per vessel — its colour, its name, its mode (``mission``, ``avoidance:yield`` …; a suite
  vessel: its speed) and its latest conflict decision (while it avoids, or for
  :data:`~mjasc.runs.video_scene.DECISION_SHOWN_S` after it) — as many as fit above the scale bar,
  then one row summing up the rest (a fleet);
- the names of the first :data:`MAX_NAMES` vessels next to their hulls, at the pixels
  :class:`Projection` gives, moved or left out where they would overlap (:func:`name_labels`);
- bottom left: a scale bar of a round length ``L ∈ {1, 2, 5}·10^k`` m close to a fifth of the
  frame's width, ``L / s`` pixels long for ``s`` metres per pixel at the view's centre (top-down
  views only: an oblique view has no single scale);
- bottom right: a north arrow (the projected direction of world +y at the view's centre) and the
  current's arrow at the view's centre with its speed [m/s];
- a legend of the scene overlays (:mod:`mjasc.runs.video_scene`), the traffic and the structures
  (a suite episode: its task's goal, station, path or lanes, ``FrameView.legend``):
  top right, or where it overlaps no other box in a narrow frame (a split view's half), or not at
  all when the frame has no such room (:func:`place_legend`) or is narrower than 320 px or
  shorter than 240 px (:data:`LEGEND_MIN_PX`).
"""

from __future__ import annotations

import numpy as np
from PIL import Image, ImageDraw

from mjasc.physics.world import MOVING_RGBA
from mjasc.runs.video_scene import COLOURS, VELOCITY_ARROW_S
from mjasc.runs.video_text import frame_font

__all__ = ["Projection", "draw_hud", "hud_layout", "legend_items", "name_labels", "place_legend", "scale_bar_m",
           "LEGEND_ITEMS", "LEGEND_MIN_PX", "MAX_NAMES"]

#: The traffic's colour as MuJoCo draws it (RGBA 0–1), for the legend (the structures': STRUCTURE_SWATCH).
TRAFFIC_RGBA = tuple(float(x) for x in MOVING_RGBA.split())


class Projection:
    """World → pixel mapping of a rendered MuJoCo scene's camera (``mjvScene.camera``, the mean of
    its two eyes). Camera axes: forward ``f``, up ``u``, right ``r = f × u``; a point ``p`` at
    ``d = p − pos`` has depth ``z = d·f`` and lands at normalized coordinates
    ``x_n = (n·(d·r)/z − c_x) / w``, ``y_n = (n·(d·u)/z − c_y) / h`` on the near plane ``n``
    (half-height ``h = (top − bottom)/2``, ``c_y = (top + bottom)/2``, ``c_x`` the frustum centre,
    half-width ``w = h · W/H``), i.e. column ``(x_n + 1)·W/2``, row ``(1 − y_n)·H/2``."""

    def __init__(self, scene, width: int, height: int):
        cams = [scene.camera[0], scene.camera[1]]
        self.pos = np.mean([c.pos for c in cams], axis=0)
        self.forward = np.mean([c.forward for c in cams], axis=0)
        self.up = np.mean([c.up for c in cams], axis=0)
        self.right = np.cross(self.forward, self.up)
        c = cams[0]
        self.near = float(c.frustum_near)
        self.half_h = 0.5 * float(c.frustum_top - c.frustum_bottom)
        self.centre_y = 0.5 * float(c.frustum_top + c.frustum_bottom)
        self.centre_x = float(c.frustum_center)
        self.half_w = self.half_h * width / height
        self.width, self.height = int(width), int(height)
        self.top_down = abs(float(self.forward[2])) > 0.999

    def __call__(self, points_xyz) -> np.ndarray:
        """Pixels (n, 2) (column, row) of world points (n, 3) [m]; NaN behind the camera."""
        d = np.asarray(points_xyz, float).reshape(-1, 3) - self.pos
        z = d @ self.forward
        with np.errstate(divide="ignore", invalid="ignore"):
            xn = (self.near * (d @ self.right) / z - self.centre_x) / self.half_w
            yn = (self.near * (d @ self.up) / z - self.centre_y) / self.half_h
        px = np.column_stack([(xn + 1.0) * 0.5 * self.width, (1.0 - yn) * 0.5 * self.height])
        px[z <= 0] = np.nan
        return px

    def metres_per_pixel(self, at_xyz) -> float:
        """Ground distance [m] of one pixel at world point ``at_xyz`` (along the image's x)."""
        p = np.asarray(at_xyz, float)
        a, b = self(np.array([p, p + np.array([1.0, 0.0, 0.0])]))
        c, d = self(np.array([p, p + np.array([0.0, 1.0, 0.0])]))
        return 1.0 / max(np.hypot(*(b - a)), np.hypot(*(d - c)), 1e-9)


def scale_bar_m(metres_per_pixel: float, width_px: int) -> float:
    """The round length L ∈ {1, 2, 5}·10^k [m] closest below a fifth of the frame's width."""
    target = max(0.2 * width_px * metres_per_pixel, 1e-6)
    k = np.floor(np.log10(target))
    return float(max(m * 10.0 ** k for m in (1.0, 2.0, 5.0) if m * 10.0 ** k <= target))


def _c(rgba) -> tuple:
    return tuple(int(round(255 * v)) for v in rgba[:3])


def _arrow(draw, tail, tip, fill, width=2, head=6.0) -> None:
    tail, tip = np.asarray(tail, float), np.asarray(tip, float)
    d = tip - tail
    n = np.hypot(*d)
    if n < 1e-6:
        return
    u = d / n
    p = np.array([-u[1], u[0]])
    draw.line([tuple(tail), tuple(tip)], fill=fill, width=width)
    draw.polygon([tuple(tip), tuple(tip - head * u + 0.5 * head * p), tuple(tip - head * u - 0.5 * head * p)], fill=fill)


def _overlaps(a, b) -> bool:
    """Whether two boxes (x0, y0, x1, y1) [px] share any area."""
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def place_legend(size, W: int, H: int, taken, avoid=(), last=None) -> tuple | None:
    """The legend's box (x0, y0, x1, y1) [px] of ``size`` (w, h) in a W × H frame: the first of
    top right, below the top-left box (right, then left) and above the bottom boxes (right, then
    left) that lies inside the frame and overlaps none of the ``taken`` boxes — and, if one such
    place does, none of the ``avoid`` boxes either (the vessels and their names); None when no
    place is free of the ``taken`` boxes (a frame too small for it shows no legend rather than
    covering the text). ``last`` (the previous frame's box) is kept while it is such a place: the
    legend moves only when a vessel comes under it, not back and forth."""
    w, h = size
    below = max([b[3] for b in taken if b[1] < 0.5 * H] + [0]) + 4  # under the top-left box
    above = min([b[1] for b in taken if b[1] >= 0.5 * H] + [H]) - 4  # over the bottom boxes
    corners = ((W - 4 - w, 2), (W - 4 - w, below), (4, below), (W - 4 - w, above - h), (4, above - h))
    boxes = ([tuple(last)] if last is not None else []) + [(x0, y0, x0 + w, y0 + h) for x0, y0 in corners]
    free = [b for b in boxes if b[0] >= 0 and b[1] >= 0 and b[2] <= W and b[3] <= H
            and not any(_overlaps(b, t) for t in taken)]
    clear = [b for b in free if not any(_overlaps(b, a) for a in avoid)]
    if last is not None and free and free[0] == tuple(last) and not clear:
        return tuple(last)  # nowhere clear: stay
    return (clear or free or [None])[0]


#: The smallest pane (width, height) [px] that shows the legend.
LEGEND_MIN_PX = (320, 240)

#: At most this many names are drawn by the hulls (the first vessels: the chased one first).
MAX_NAMES = 12
#: Half the side [px] of the square the names and the legend keep off around a moving obstacle's centre.
TRAFFIC_MARK_PX = 12.0


def _marks(points_px, half_px: float) -> list:
    """The squares (x0, y0, x1, y1) [px] of side 2·``half_px`` around the finite points of
    ``points_px`` ((n, 2), or None: none)."""
    pts = np.asarray([] if points_px is None else points_px, float).reshape(-1, 2)
    return [(x - half_px, y - half_px, x + half_px, y + half_px) for x, y in pts if np.isfinite(x) and np.isfinite(y)]


def name_labels(draw, vessels, vessels_px, font, W: int, H: int, keep_off=(), traffic_px=None) -> list:
    """The names drawn by the hulls, as (vessel, text origin (x, y), box (x0, y0, x1, y1)) [px]:
    up and right of the hull, or — when that box would overlap an earlier name's or leave the
    frame or cover a ``keep_off`` box (the modes, the scale bar, the north arrow) or another
    vessel's hull or a moving obstacle (``traffic_px``, their centres [px], or None) — one line down, two up,
    then left of the hull (where none is clear of those, the first free place off the boxes, then
    inside the frame); a name with no free place, or past the first :data:`MAX_NAMES` vessels, is
    left out (the modes box lists it). No two boxes overlap."""
    fs = font.size
    out = []
    pts = np.asarray(vessels_px, float).reshape(-1, 2)
    half = max(6.0, 0.6 * fs)  # (a hull's mark on the frame: a name is not written over another vessel)
    hulls = [(k, (x - half, y - half, x + half, y + half)) for k, (x, y) in enumerate(pts)
             if np.isfinite(x) and np.isfinite(y)]
    # (the traffic too, as the legend keeps off it: a reviewer found the ferry under a vessel's name)
    hulls += [(-1, box) for box in _marks(traffic_px, TRAFFIC_MARK_PX)]
    for i, (v, (x, y)) in enumerate(zip(vessels, pts)):
        if len(out) >= MAX_NAMES:
            break
        if not (np.isfinite(x) and np.isfinite(y) and -50 < x < W + 50 and -50 < y < H + 50):
            continue
        tw = draw.textlength(v.name, font=font)
        free = []
        for dx, dy in ((8, -fs - 4), (8, 4), (8, -2 * fs - 10), (-tw - 10, -fs - 4), (-tw - 10, 4),
                       (8, fs + 10), (8, -3 * fs - 16)):
            ox, oy = x + dx, y + dy
            x0, y0, x1, y1 = draw.textbbox((ox, oy), v.name, font=font, stroke_width=2)
            box = (x0 - 1, y0 - 1, x1 + 1, y1 + 1)
            if not any(_overlaps(box, b) for _, _, b in out):
                free.append((v, (ox, oy), box))
        inside = [f for f in free if f[2][0] >= 0 and f[2][2] <= W and f[2][1] >= 0 and f[2][3] <= H]
        clear = [f for f in inside if not any(_overlaps(f[2], b) for b in keep_off)]
        apart = [f for f in clear if not any(k != i and _overlaps(f[2], b) for k, b in hulls)]
        if free:  # inside the frame, off the boxes and off the other hulls first
            out.append((apart or clear or inside or free)[0])
    return out


def hud_layout(draw, view, W: int, H: int, title: str = "", furniture: bool = True, scale_bar_px: float = 0.0,
               vessels_px=None, last_legend=None, traffic_px=None):
    """Where the heads-up overlay's boxes go in a W × H frame, as a dict of name → box (x0, y0, x1,
    y1) [px] (``text``: the title and the modes, top left; ``scale``: the scale bar, bottom left,
    ``scale_bar_px`` long (0: none); ``north``: the north arrow and the current, bottom right;
    ``legend``: placed by :func:`place_legend`, clear of the vessels and their names at
    ``vessels_px`` (n, 2) [px] where it can be, kept at ``last_legend`` while that place serves,
    or absent), with the fonts and rows drawn:
    ``fs`` (font size [px]), ``font``, ``small``, ``rows`` (text, font, vessel or None)."""
    fs = max(10, min(16, H // 36))
    font, small = frame_font(fs), frame_font(max(9, fs - 2))
    line = fs + 4
    # Top left: title and time, then per vessel its mode and (smaller, below) its last decision.
    rows = [(f"{title}  t = {view.time_s:6.1f} s".strip(), font, None)]
    if furniture:  # a suite episode's policy, reward … (once: not again in a split frame's chase half)
        rows += [(text, font, None) for text in getattr(view, "lines", ())]
    # The modes box ends above the bottom boxes (the scale bar's top): a fleet's rows past that are
    # summed up in one row rather than running off the frame and under the scale bar.
    bottom = H - 16 - fs - 10 - 4 if furniture else H - 4
    max_rows = max(1, (bottom - 8) // line)
    shown = list(view.vessels) if furniture else []
    for i, v in enumerate(shown):
        phase = f"{v.mission_phase} · " if getattr(v, "mission_phase", "") else ""
        new = [(f"{v.name}: {phase}{v.mode or '-'}", font, v)] + ([(v.decision, small, None)] if v.decision else [])
        rest = shown[i + 1:]
        if len(rows) + len(new) + (1 if rest else 0) > max_rows:
            rest = shown[i:]
            avoiding = sum(1 for r in rest if str(r.mode or "").startswith("avoidance"))
            rows.append((f"… and {len(rest)} more ({avoiding} in avoidance)", font, None))
            break
        rows.extend(new)
    box_w = 12 + fs + max(draw.textlength(text, font=f) for text, f, _ in rows)
    out = {"fs": fs, "font": font, "small": small, "rows": rows, "text": (4, 4, 4 + box_w, 8 + line * len(rows))}
    if furniture:
        if scale_bar_px > 0:
            out["scale"] = (8, H - 16 - fs - 10, 14 + scale_bar_px + 8, H - 8)
        out["north"] = (W - 150, H - 84, W - 4, H - 4)
    out["names"] = [] if vessels_px is None else name_labels(
        draw, view.vessels, vessels_px, font, W, H, [out[k] for k in ("text", "scale", "north") if k in out],
        traffic_px)
    if not furniture:
        return out
    taken = [out[k] for k in ("text", "scale", "north") if k in out]
    avoid = _marks(vessels_px, 6.0) + [b for _, _, b in out["names"]] + \
        _marks(traffic_px, TRAFFIC_MARK_PX)  # (the traffic too: a tracked target under the legend)
    # A pane narrower than LEGEND_MIN_PX[0] or shorter than LEGEND_MIN_PX[1] has no room for the
    # legend beside the names and the modes (docs/architecture.md, "Limits"): left out.
    items = legend_items(view)
    legend = None if W < LEGEND_MIN_PX[0] or H < LEGEND_MIN_PX[1] or not items else \
        place_legend(_legend_size(draw, small, items), W, H, taken, avoid, last_legend)
    if legend is not None:
        out["legend"] = legend
    return out


def draw_hud(frame: np.ndarray, view, proj: Projection, centre_xyz, title: str = "",
             furniture: bool = True, memory: dict | None = None) -> np.ndarray:
    """The frame (H, W, 3 uint8) with the heads-up overlay of ``view`` (a
    :class:`~mjasc.runs.video_scene.FrameView`) drawn on it; without ``furniture`` only the title
    with the time and the names by the hulls (the chase half of a split frame). The boxes do not
    overlap (:func:`hud_layout`); ``memory`` (a dict kept per pane from frame to frame) keeps the
    legend's place."""
    img = Image.fromarray(frame)
    draw = ImageDraw.Draw(img, "RGBA")
    W, H = img.size
    mpp = L = 0.0
    if furniture and proj.top_down:
        mpp = proj.metres_per_pixel(centre_xyz)
        L = scale_bar_m(mpp, W)
    px = proj(np.array([[*v.position_m, 0.5] for v in view.vessels]).reshape(-1, 3))
    memory = {} if memory is None else memory
    traffic = getattr(view, "traffic_m", None)
    tpx = None if traffic is None else proj(np.column_stack([traffic, np.full(len(traffic), 0.5)]))
    lay = hud_layout(draw, view, W, H, title, furniture, L / mpp if mpp > 0 else 0.0, px, memory.get("legend"), tpx)
    memory["legend"] = lay.get("legend")
    fs, font, small, rows = lay["fs"], lay["font"], lay["small"], lay["rows"]
    line = fs + 4
    draw.rectangle(lay["text"], fill=(0, 0, 0, 140))
    for k, (text, f, v) in enumerate(rows):
        y = 6 + line * k
        if v is not None:
            draw.rectangle([10, y + 3, 10 + fs - 5, y + fs - 2], fill=tuple(v.colour))
        draw.text((10 if k == 0 else 10 + fs, y), text, font=f, fill=(255, 255, 255) if f is font else (200, 200, 200))
    # Names by the hulls.
    for v, origin, _ in lay["names"]:
        draw.text(origin, v.name, font=font, fill=tuple(v.colour), stroke_width=2, stroke_fill=(0, 0, 0))
    if not furniture:
        return np.asarray(img)
    # Bottom left: scale bar (top-down views only).
    if "scale" in lay:
        n = L / mpp
        x0, y0 = 14, H - 16
        draw.rectangle(lay["scale"], fill=(0, 0, 0, 140))
        draw.line([(x0, y0), (x0 + n, y0)], fill=(255, 255, 255), width=3)
        for x in (x0, x0 + n):
            draw.line([(x, y0 - 5), (x, y0 + 3)], fill=(255, 255, 255), width=2)
        draw.text((x0, y0 - fs - 7), f"{L:g} m", font=small, fill=(255, 255, 255))
    # Bottom right: north arrow and current.
    cx, cy = W - 40, H - 44
    draw.rectangle(lay["north"], fill=(0, 0, 0, 140))
    c = np.asarray(centre_xyz, float)
    a, b = proj(np.array([c, c + np.array([0.0, 1.0, 0.0])]))
    d = (b - a) / max(np.hypot(*(b - a)), 1e-9)
    _arrow(draw, (cx - 14 * d[0], cy - 14 * d[1]), (cx + 22 * d[0], cy + 22 * d[1]), (255, 255, 255), 3, 9)
    draw.text((cx + 26 * d[0] - 4, cy + 26 * d[1] - fs), "N", font=font, fill=(255, 255, 255))
    speed = float(np.hypot(*view.current_m_s))
    ux, uy = W - 112, H - 44
    if speed > 1e-6:
        a, b = proj(np.array([c, c + np.array([*(view.current_m_s / speed), 0.0])]))
        d = (b - a) / max(np.hypot(*(b - a)), 1e-9)
        _arrow(draw, (ux - 18 * d[0], uy - 18 * d[1]), (ux + 18 * d[0], uy + 18 * d[1]), (120, 200, 255), 3, 8)
    draw.text((W - 146, H - 20), f"current {speed:.2f} m/s", font=small, fill=(120, 200, 255))
    if "legend" in lay:
        _legend(draw, lay["legend"], small, legend_items(view))
    return np.asarray(img)


#: The legend's swatches are drawn on the water's colour (assets/scene/water.xml, as rendered), so a
#: dark overlay (the black static virtual obstacle) shows on the legend's dark box too.
WATER_SWATCH = (30, 88, 138)
#: The structures' swatch: their walls' tops as rendered from above (the brown OBSTACLE_RGBA in the
#: scene's light), 3 pixels thick as the video draws thin walls (mjasc.runs.video_model: a thinner
#: line loses its colour to the MP4's 4:2:0 chroma).
STRUCTURE_SWATCH = (206, 171, 133)

#: The legend's rows: (swatch kind, RGBA 0–1, text).
LEGEND_ITEMS = (("line", COLOURS["path"], "mission path"), ("line", COLOURS["detour"], "detour"),
                ("disc", (0.85, 0.85, 0.85, 1.0), f"track: disc, 2-sigma, {VELOCITY_ARROW_S:g} s of velocity"),
                ("thin", (0.85, 0.85, 0.85, 1.0), "sensor fan, returns"),
                ("dot", COLOURS["conflict"], "predicted conflict (CPA)"),
                ("line", COLOURS["svo"], "static virtual obstacle"),
                ("line", COLOURS["field"], "potential-field obstacle"),
                ("traffic", TRAFFIC_RGBA, "traffic (true hull, white bow)"),
                ("outline", tuple(c / 255 for c in STRUCTURE_SWATCH) + (1.0,), "structure (quay, island, pontoon)"))


def legend_items(view) -> tuple:
    """The legend's rows of a frame: the view's own (a suite task's), else :data:`LEGEND_ITEMS`."""
    items = getattr(view, "legend", None)
    return LEGEND_ITEMS if items is None else tuple(items)


def _legend_size(draw, font, items=LEGEND_ITEMS) -> tuple[int, int]:
    """The legend box's width and height [px] in ``font``."""
    line = font.size + 3
    return int(38 + max(draw.textlength(t, font=font) for _, _, t in items)), line * len(items) + 4


def _legend(draw, box, font, items=LEGEND_ITEMS) -> None:
    fs = font.size
    line = fs + 3
    draw.rectangle(box, fill=(0, 0, 0, 140))
    x0, y0 = box[0] + 4, box[1] + 2
    for k, (kind, rgba, text) in enumerate(items):
        y = y0 + k * line + line // 2
        col = _c(rgba)
        draw.rectangle([x0, y - line // 2 + 1, x0 + 26, y + line // 2 - 1], fill=WATER_SWATCH)  # as on the water
        if kind == "line":
            draw.line([(x0 + 2, y), (x0 + 22, y)], fill=col, width=3)
        elif kind == "thin":
            draw.line([(x0 + 2, y), (x0 + 22, y)], fill=col, width=1)
            draw.ellipse([x0 + 20, y - 2, x0 + 24, y + 2], fill=col)
        elif kind == "disc":
            draw.ellipse([x0 + 4, y - 5, x0 + 14, y + 5], outline=col, width=1, fill=(*col, 90))
            draw.line([(x0 + 9, y), (x0 + 24, y)], fill=col, width=2)
        elif kind == "traffic":
            r = line // 2 - 1
            draw.ellipse([x0 + 13 - r, y - r, x0 + 13 + r, y + r], fill=col, outline=(0, 0, 0))
            draw.line([(x0 + 14, y), (x0 + 13 + r, y)], fill=(255, 255, 255), width=2)
        elif kind == "target":  # the suite's target site: a disc and its heading bar
            draw.ellipse([x0 + 6, y - 5, x0 + 16, y + 5], fill=col)
            draw.line([(x0 + 11, y), (x0 + 25, y)], fill=col, width=2)
        elif kind == "outline":  # structures are thin hollow walls: an outline, not a filled block
            draw.rectangle([x0 + 4, y - line // 2 + 1, x0 + 22, y + line // 2 - 1], outline=col, width=3)
        else:
            draw.ellipse([x0 + 8, y - 4, x0 + 16, y + 4], fill=col)
        draw.text((x0 + 30, y - fs // 2 - 1), text, font=font, fill=(255, 255, 255))
