"""Which hull a suite task sails: the ``vessel`` task argument (``task_kwargs={"vessel": ...}``).

Every domain sails its own hull by default (``otter``: the Otter, ``delfim``: the Delfim,
``otter_team``: three Otters). ``vessel`` replaces it — the single vessel of ``otter`` and
``delfim``, every vessel of ``otter_team`` — with

* a built-in vessel type's name (``"otter"``, ``"delfim"``: ``mjasc list``), or
* a vessel folder's path (assets/README.md, "Your own hull"): a ``str`` holding a ``/`` or
  starting with ``~`` or ``.`` (as a scenario's ``type``), or any ``os.PathLike`` (always a
  folder, never a built-in name). A relative path is relative to the current folder, as
  ``mjasc trial --vessel PATH``'s; the folder is made absolute and checked against the
  contract (:func:`mjasc.physics.vessels.resolve_vessel_type`) once, when the environment is built.

The observation and action specs keep their shapes (the tasks scale with the hull's own cruise
speed; observations are body-frame velocities, errors and ranges in SI units). The vessel's
name in the model — its cameras ``<name>/chase``, the HUD, a team's observation prefixes
``<name><i>_`` — is the hull's name (the folder's name). Bad input is a one-line ValueError
``task_kwargs.vessel: reason, got value``.
"""

from __future__ import annotations

import os

from mjasc.physics.vessels import available_vessels, is_vessel_path, load_vessel_type, resolve_vessel_type
from mjasc.physics.world import is_valid_vessel_name

__all__ = ["suite_vessel_type", "hull_name"]

_WHERE = "task_kwargs.vessel"


def suite_vessel_type(vessel, default: str) -> str:
    """The vessel type (what :func:`mjasc.physics.vessels.load_vessel_type` takes) a task sails:
    ``default`` (the domain's own built-in hull) when ``vessel`` is None, else ``vessel`` checked
    and resolved as the module docstring says. Raises ValueError (one line, naming the key)."""
    if vessel is None:
        return default
    if isinstance(vessel, os.PathLike):
        text = os.fspath(vessel)
        if not isinstance(text, str):
            raise ValueError(f"{_WHERE}: a path must be text, not bytes, got {vessel!r}")
        if text and not is_vessel_path(text):
            text = os.path.join(".", text)  # (a Path names a folder: Path("heron") is ./heron)
    elif isinstance(vessel, str):
        text = vessel
    else:
        raise ValueError(f"{_WHERE}: must be a built-in vessel type's name ({', '.join(available_vessels())}) "
                         f"or a vessel folder's path (str or os.PathLike), got {type(vessel).__name__} {vessel!r}")
    if not text.strip():
        raise ValueError(f"{_WHERE}: must be a built-in vessel type's name ({', '.join(available_vessels())}) "
                         f"or a vessel folder's path, got {vessel!r}")
    try:
        vessel_type = resolve_vessel_type(text)
    except ValueError as exc:  # (the reason as resolve_vessel_type or the contract words it)
        raise ValueError(f"{_WHERE}: {exc}") from None
    name = hull_name(vessel_type)
    if not is_valid_vessel_name(name):  # (the hull's name names the vessel, its cameras, a team's prefixes)
        raise ValueError(f"{_WHERE}: the hull's name {name!r} (its folder's) must be letters, digits, '_' or '-' "
                         f"and not start with 'obstacle': it names the vessel in the model, got {vessel!r}")
    return vessel_type


def hull_name(vessel_type: str) -> str:
    """The hull's name (a built-in name, or a vessel folder's name): the vessel's name in the model."""
    return load_vessel_type(vessel_type).name
