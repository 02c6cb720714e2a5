"""Turn a run's video.mp4 into the README's animated GIF (every Nth frame, downscaled).

    .venv/bin/python scripts/make_readme_gif.py runs/demo/video.mp4 docs/media/demo.gif
"""

import sys

import imageio.v3 as iio
import numpy as np


def main(src: str, dst: str, every: int = 12, scale: int = 2) -> None:
    frames = [f[::scale, ::scale] for i, f in enumerate(iio.imiter(src)) if i % every == 0]
    iio.imwrite(dst, np.stack(frames), duration=80, loop=0)
    print(f"{dst}: {len(frames)} frames")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
