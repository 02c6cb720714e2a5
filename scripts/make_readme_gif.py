"""Make the README's animated GIF (docs/media/demo.gif) from the demo's video.

    .venv/bin/python -m mjasc run demo --video --out runs/demo
    .venv/bin/python scripts/make_readme_gif.py runs/demo/video.mp4 docs/media/demo.gif

The demo's video is 640 × 480 at 10 frames per second of simulated time. The GIF keeps the stretch
from ``--start`` to ``--end`` seconds (default 30–85 s: the ferry crosses ahead of the formation;
the vessels sense it, track it and yield), every ``--every``-th frame (default 5: 0.5 s of
simulation per GIF frame), each shown for ``--frame-ms`` milliseconds (default 100: five times real
time), ``--width`` pixels wide (default 640, the video's own), colours reduced to one 128-colour
palette shared by all frames (no flicker between frames) that holds the vessels' and overlays'
exact colours. It prints the GIF's size (3.8 MB for the defaults); keep it under ~4 MB.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import imageio.v3 as iio
import numpy as np
from PIL import Image


def read_stretch(src: str, start_s: float, end_s: float, every: int, fps: float) -> list[np.ndarray]:
    """Frames of ``src`` from ``start_s`` to ``end_s`` [s of video at ``fps``], every ``every``-th."""
    first, last = int(round(start_s * fps)), int(round(end_s * fps))
    return [f for i, f in enumerate(iio.imiter(src)) if first <= i <= last and (i - first) % every == 0]


def exact_colours() -> list[tuple[int, int, int]]:
    """The vessel palette, the video's overlay colours and the structures' walls (RGB 0–255), black and white."""
    from mjasc.runs.blueprint import PALETTE
    from mjasc.runs.video_hud import STRUCTURE_SWATCH
    from mjasc.runs.video_scene import COLOURS

    overlays = [tuple(int(round(255 * c)) for c in v[:3]) for v in COLOURS.values() if isinstance(v, tuple)]
    return list(dict.fromkeys([*PALETTE, *overlays, STRUCTURE_SWATCH, (0, 0, 0), (255, 255, 255)]))


def to_gif(frames: list[np.ndarray], dst: str | Path, width: int, frame_ms: int, colours: int = 128) -> int:
    """Write ``frames`` as a looping GIF ``width`` pixels wide on one shared palette; returns its bytes."""
    images = [Image.fromarray(f) for f in frames]
    if images[0].width != width:
        h = round(images[0].height * width / images[0].width)
        images = [im.resize((width, h), Image.LANCZOS) for im in images]
    # One palette from a strip of every 8th frame, so that colours do not flicker between frames,
    # plus the vessels' and overlays' exact colours (the water would otherwise claim most entries
    # and the small coloured marks come out dull).
    sample = Image.fromarray(np.vstack([np.asarray(im) for im in images[::8]]))
    fixed = exact_colours()
    common = sample.quantize(colours - len(fixed), method=Image.Quantize.MEDIANCUT).getpalette()
    entries = common[:3 * (colours - len(fixed))] + [c for rgb in fixed for c in rgb]
    palette = Image.new("P", (1, 1))
    palette.putpalette(entries + [0] * (768 - len(entries)))
    quantized = [im.quantize(palette=palette, dither=Image.Dither.NONE) for im in images]
    dst = Path(dst)
    dst.parent.mkdir(parents=True, exist_ok=True)
    quantized[0].save(dst, save_all=True, append_images=quantized[1:], duration=frame_ms, loop=0, optimize=True,
                      disposal=1)
    return dst.stat().st_size


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("video", help="the demo's video.mp4")
    p.add_argument("gif", help="the GIF to write, e.g. docs/media/demo.gif")
    p.add_argument("--start", type=float, default=30.0, help="first second of the stretch [s] (default: 30)")
    p.add_argument("--end", type=float, default=85.0, help="last second of the stretch [s] (default: 85)")
    p.add_argument("--every", type=int, default=5, help="keep every N-th video frame (default: 5)")
    p.add_argument("--fps", type=float, default=10.0, help="the video's frames per second (default: 10, the demo's)")
    p.add_argument("--frame-ms", type=int, default=100, help="display time of a GIF frame [ms] (default: 100)")
    p.add_argument("--width", type=int, default=640, help="GIF width [px] (default: 640)")
    a = p.parse_args(argv)
    frames = read_stretch(a.video, a.start, a.end, a.every, a.fps)
    if not frames:
        raise SystemExit(f"{a.video}: no frames between {a.start} s and {a.end} s")
    size = to_gif(frames, a.gif, a.width, a.frame_ms)
    print(f"{a.gif}: {len(frames)} frames, {frames[0].shape[1]}×{frames[0].shape[0]} px in, "
          f"{a.width} px wide, {size / 1e6:.2f} MB")


if __name__ == "__main__":
    main()
