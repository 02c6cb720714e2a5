"""The video overlay's font remembers what it rendered (mjasc/runs/video_text.py) and draws the same
pixels as Pillow's own default font: every string, place (fractional ones too), stroke and size."""

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from mjasc.runs import video_text
from mjasc.runs.video_text import frame_font

CALLS = [((10, 5), "demo  t = 120.0 s", {}), ((10.5, 30.25), "alpha: avoidance:yield", {}),
         ((200.7, 100.2), "bravo", {"stroke_width": 2, "stroke_fill": (0, 0, 0)}), ((5, 200), "50 m", {}),
         ((300, 250), "N", {}), ((40, 150), "track: disc, 2-sigma, 10 s of velocity", {}),
         ((120.9, 60.6), "current 0.20 m/s", {})]


def _drawn(font_of, repeats: int) -> np.ndarray:
    img = Image.new("RGB", (400, 300), (30, 88, 138))
    draw = ImageDraw.Draw(img, "RGBA")
    for _ in range(repeats):  # (the second time from memory)
        for size in (12, 10):
            for xy, text, kw in CALLS:
                draw.text(xy, text, font=font_of(size), fill=(255, 200, 0), **kw)
                draw.textlength(text, font=font_of(size))
                draw.textbbox(xy, text, font=font_of(size), stroke_width=kw.get("stroke_width", 0))
    return np.asarray(img)


def test_the_remembering_font_draws_pillow_s_pixels():
    plain = _drawn(lambda size: ImageFont.load_default(size=size), 2)
    remembered = _drawn(frame_font, 2)
    assert np.array_equal(plain, remembered)
    font = frame_font(12)
    for _, text, _ in CALLS:
        assert font.getlength(text) == ImageFont.load_default(size=12).getlength(text)
    assert font._memory["getmask2"]  # (it did remember)


def test_the_memory_is_bounded(monkeypatch):
    monkeypatch.setattr(video_text, "MEMORY_ENTRIES", 8)
    frame_font.cache_clear()
    font = frame_font(11)
    draw = ImageDraw.Draw(Image.new("RGB", (200, 50)))
    for k in range(30):  # a time row: a new string every frame
        draw.text((3, 3), f"t = {k:.1f} s", font=font, fill=(255, 255, 255))
    assert 0 < len(font._memory["getmask2"]) <= 8
    frame_font.cache_clear()
