"""``mjasc figures``: every thesis-style figure the project makes, written as PNG (or SVG, PDF) files.

* tracking (thesis Fig. 6.1–6.2): true vs estimated speed, turn rate and heading — tracking_figures
* potential fields (Fig. 6.3–6.4): the dock safety-ratio sweep and the field's gradient — potential_field_figures
* collision avoidance (§6.3–6.4): top-down runs with predicted conflicts and detours — avoidance_figures
* missions (docs/missions.md): the chained mission from above, its phases and station errors — missions

Each figure is written once per format (``formats``, of :data:`FORMATS`) under the same stem.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["make_all_figures", "figure_backend", "save_figure", "FORMATS"]

#: The file formats a figure can be written in.
FORMATS = ("png", "svg", "pdf")


def figure_backend(out_dir: str | Path):
    """matplotlib's pyplot on the file-only Agg backend (no display needed) and the output folder,
    created if needed: the common start of every figure maker."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    return plt, out


def save_figure(fig, path: str | Path, formats=("png",), dpi: int = 110) -> list[Path]:
    """Write ``fig`` as ``path`` with each suffix of ``formats`` (of :data:`FORMATS`); returns the paths."""
    bad = [f for f in formats if f not in FORMATS]
    if bad or not formats:
        raise ValueError(f"formats: must be some of {', '.join(FORMATS)}, got {', '.join(bad) or 'none'}")
    paths = [Path(path).with_suffix(f".{f}") for f in formats]
    for p in paths:
        fig.savefig(p, dpi=dpi)
    return paths


def make_all_figures(out_dir: str | Path, formats=("png",), progress=None) -> list[Path]:
    """Make every figure in each of ``formats``; ``progress(text)`` is told what starts and what was
    written (the groups run simulations: ~50 s in all). Returns the written paths."""
    from mjasc.figures.avoidance import make_avoidance_figures
    from mjasc.figures.missions import make_mission_figures
    from mjasc.figures.potential_field import make_figures as make_potential_field_figures
    from mjasc.figures.tracking import make_tracking_figures

    say = progress or (lambda text: None)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths: list[Path] = []
    for what, make, sub in (("tracking (thesis Fig. 6.1-6.2): two tracking runs", make_tracking_figures, "tracking"),
                            ("potential fields (Fig. 6.3-6.4): the dock safety-ratio sweep",
                             make_potential_field_figures, "potential_field"),
                            ("collision avoidance (6.3-6.4): one run per scenario", make_avoidance_figures,
                             "avoidance"),
                            ("missions: the chained mission", make_mission_figures, "missions")):
        say(f"{what} ...")
        written = make(out / sub, formats=formats)
        for p in written:
            say(f"  wrote {p}")
        paths += written
    return paths
