"""Where mjasc's bundled data lives, in a checkout and in an installed wheel alike.

The vessel models and the water scene (the repository's ``assets/``) and the shipped scenarios and
campaigns (``tasks/``) are package data: ``pyproject.toml`` maps them to the packages
``mjasc.assets`` and ``mjasc.tasks``, and :mod:`importlib.resources` finds them wherever mjasc is
installed (editable checkout or wheel). MuJoCo reads files by path, so mjasc must be installed
unzipped (pip always does this).

A scenario or campaign is named on the command line and in :func:`mjasc.load_scenario` either by a
file path (relative to the current folder) or by its bundled name: the file's path under
``tasks/`` without ``.toml`` (``demo``, ``thesis_6_2_dock``, ``campaigns/demo_monte_carlo``).
"""

from __future__ import annotations

import importlib.resources
from pathlib import Path

__all__ = ["assets_dir", "tasks_dir", "bundled_scenarios", "bundled_campaigns", "resolve_bundled"]


def _package_dir(package: str) -> Path:
    """The folder of the data package ``mjasc.<name>``: in the source checkout this mjasc was
    imported from when it is one (``<checkout>/<name>`` beside ``pyproject.toml``), else where the
    installed package maps it. (A second checkout put first on ``PYTHONPATH`` read the installed
    checkout's scenarios and hulls: an editable install maps the data packages to its own folders.)"""
    here = Path(__file__).resolve().parents[2]  # (mjasc/core/resources.py → the checkout, in a checkout)
    own = here / package.rpartition(".")[2]
    if (here / "pyproject.toml").is_file() and (here / "mjasc" / "__init__.py").is_file() and own.is_dir():
        return own
    root = importlib.resources.files(package)
    if not isinstance(root, Path):  # a zipped install: MuJoCo and dm_control need real files
        raise RuntimeError(f"{package}: mjasc must be installed unzipped (found {root!r})")
    return root


def assets_dir() -> Path:
    """The folder of vessel models (``vessels/<name>/``) and the scene (``scene/water.xml``)."""
    return _package_dir("mjasc.assets")


def tasks_dir() -> Path:
    """The folder of shipped scenarios (``*.toml``) and campaigns (``campaigns/*.toml``)."""
    return _package_dir("mjasc.tasks")


def _bundled(kind: str) -> dict[str, Path]:
    root = tasks_dir()
    out = {}
    for p in sorted(root.rglob("*.toml")):
        rel = p.relative_to(root).with_suffix("").as_posix()
        is_campaign = rel.startswith("campaigns/")
        if is_campaign == (kind == "campaign"):
            out[rel] = p
    return out


def bundled_scenarios() -> dict[str, Path]:
    """Shipped scenarios by name (path under ``tasks/`` without ``.toml``), sorted."""
    return _bundled("scenario")


def bundled_campaigns() -> dict[str, Path]:
    """Shipped campaign files by name (``campaigns/<stem>``), sorted."""
    return _bundled("campaign")


def resolve_bundled(ref: str | Path, kind: str = "scenario") -> Path:
    """``ref`` itself when it names an existing file (relative to the current folder), else the
    bundled scenario (``kind="scenario"``) or campaign (``"campaign"``) of that name (``demo``,
    ``thesis_6_2_dock.toml``, ``campaigns/demo_monte_carlo``; a campaign may omit ``campaigns/``).
    Unknown names are returned unchanged, so the loader reports the missing file by its name."""
    path = Path(ref)
    try:
        if path.is_file():
            return path
    except (OSError, ValueError):  # an over-long or NUL-containing name: not a file
        return path
    name = path.as_posix()
    name = name[:-5] if name.endswith(".toml") else name
    table = bundled_scenarios() if kind == "scenario" else bundled_campaigns()
    for key in (name, f"campaigns/{name}"):
        if key in table:
            return table[key]
    return path
