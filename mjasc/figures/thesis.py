"""``mjasc figures``: every thesis-style figure the project makes, written as PNG files.

* tracking (thesis Fig. 6.1–6.2): true vs estimated speed, turn rate and heading — tracking_figures
* potential fields (Fig. 6.3–6.4): the dock safety-ratio sweep and the field's gradient — potential_field_figures
* collision avoidance (§6.3–6.4): top-down runs with predicted conflicts and detours — avoidance_figures
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["make_all_figures", "figure_backend"]


def figure_backend(out_dir: str | Path):
    """matplotlib's pyplot on the file-only Agg backend (no display needed) and the output folder,
    created if needed: the common start of every figure maker."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    return plt, out


def make_all_figures(out_dir: str | Path) -> list[Path]:
    from mjasc.figures.avoidance import make_avoidance_figures
    from mjasc.figures.potential_field import make_figures as make_potential_field_figures
    from mjasc.figures.tracking import make_tracking_figures

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths: list[Path] = []
    paths += make_tracking_figures(out / "tracking")
    paths += make_potential_field_figures(out / "potential_field")
    paths += make_avoidance_figures(out / "avoidance")
    return paths
