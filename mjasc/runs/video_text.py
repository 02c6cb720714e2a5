"""Text on video frames, each distinct string rendered once.

A frame's overlay (:mod:`mjasc.runs.video_hud`) writes ~20 strings, most of them the same from frame
to frame (the legend's rows, the vessels' names and modes, the scale, north), and Pillow rasterises
every one again each time through FreeType: ~4 ms of a demo frame's ~40 ms. :func:`frame_font` is
Pillow's default font (``ImageFont.load_default``, the FreeType font it embeds) with its glyph
masks, text lengths and boxes remembered per distinct call: ``ImageDraw.text`` then draws the very
same mask at the very same place, so a frame's pixels are those of the uncached font. A memory
holds :data:`MEMORY_ENTRIES` results at most (then starts again: the time row changes every frame);
a colour mask (``RGBA``, which Pillow writes into) is never remembered.
"""

from __future__ import annotations

from functools import lru_cache

from PIL import ImageFont

__all__ = ["frame_font", "MEMORY_ENTRIES"]

#: Results a font remembers at most (per method) before it forgets them all.
MEMORY_ENTRIES = 2048


def _key(args, kwargs) -> tuple:
    return (*(tuple(a) if isinstance(a, list) else a for a in args), *sorted(kwargs.items()))


class _RememberingFont(ImageFont.FreeTypeFont):
    """A FreeType font whose ``getmask2``, ``getlength`` and ``getbbox`` remember their results per
    distinct call (the same arguments give the same result: the font never changes)."""

    _memory: dict

    def _remembered(self, method: str, compute, args, kwargs):
        memory = self._memory.setdefault(method, {})
        key = _key(args, kwargs)
        got = memory.get(key)
        if got is None:
            got = compute(*args, **kwargs)
            if len(memory) >= MEMORY_ENTRIES:
                memory.clear()
            memory[key] = got
        return got

    def getmask2(self, text, mode="", *args, **kwargs):
        if mode == "RGBA":  # (Pillow fills the colour mask's alpha band in place: not shared)
            return super().getmask2(text, mode, *args, **kwargs)
        return self._remembered("getmask2", super().getmask2, (text, mode, *args), kwargs)

    def getlength(self, text, *args, **kwargs):
        return self._remembered("getlength", super().getlength, (text, *args), kwargs)

    def getbbox(self, text, *args, **kwargs):
        return self._remembered("getbbox", super().getbbox, (text, *args), kwargs)


@lru_cache(maxsize=4)
def frame_font(size: int) -> ImageFont.FreeTypeFont:
    """Pillow's default font at ``size`` pixels, remembering what it rendered (module docstring); the
    font as Pillow gives it when it is not a FreeType font (Pillow without FreeType)."""
    font = ImageFont.load_default(size=size)
    if type(font) is ImageFont.FreeTypeFont:
        font.__class__ = _RememberingFont
        font._memory = {}
    return font
