"""The vessel library: one folder per hull, built in under ``assets/vessels/<name>/`` or a user's own.

Each folder holds ``<name>.xml`` (MJCF: geometry, mass, inertia, propeller sites, shaft-lag
actuators), ``hydrodynamics.toml`` (added mass, damping, cross-flow, propellers, limits — every
number with its source) and a README. This module reads them into a typed :class:`VesselType`.

A vessel ``type`` is a built-in name (``"otter"``: :func:`available_vessels`) or the path of a
vessel folder (``"hulls/heron"``, ``"~/boats/heron"``, ``"./heron"``: a value holding a ``/`` or
starting with ``~`` or ``.``). :func:`resolve_vessel_type` turns what a file wrote into what the
rest of mjasc holds — the built-in name unchanged, a folder as its absolute path, checked against
the contract (:mod:`mjasc.physics.vessel_contract`) — once, where the file is read;
:func:`load_vessel_type` takes either.
"""

from __future__ import annotations

import functools
import os
from dataclasses import dataclass
from pathlib import Path

from mjasc.core.config_tables import dataclass_from_table, load_toml, number
from mjasc.core.resources import assets_dir
from mjasc.physics.hydrodynamics import HydroCoefficients
from mjasc.physics.thrusters import PropellerCoefficients

ASSETS_DIR = assets_dir()
VESSELS_DIR = ASSETS_DIR / "vessels"
SCENE_XML = ASSETS_DIR / "scene" / "water.xml"

__all__ = ["VesselType", "available_vessels", "load_vessel_type", "resolve_vessel_type", "is_vessel_path",
           "vessel_files", "VesselFiles", "vessel_fingerprint", "ASSETS_DIR", "SCENE_XML"]


@dataclass(frozen=True)
class VesselType:
    """Everything mjasc knows about one hull design (SI units, FLU body frame)."""

    name: str
    description: str
    mjcf_path: Path
    hydro: HydroCoefficients
    propellers: PropellerCoefficients
    length_m: float
    beam_m: float
    draft_m: float
    radius_m: float  # circle bounding the hull, for collision prediction
    top_speed_m_s: float
    cruise_speed_m_s: float


def available_vessels() -> list[str]:
    """Names of the vessel folders that hold an MJCF and a hydrodynamics.toml."""
    if not VESSELS_DIR.is_dir():
        return []
    return sorted(
        p.name for p in VESSELS_DIR.iterdir() if (p / f"{p.name}.xml").is_file() and (p / "hydrodynamics.toml").is_file()
    )


def _get(table: dict, key: str, where: str, default=None):
    if key not in table:
        if default is not None:
            return default
        raise ValueError(f"{where}.{key}: missing")
    return number(table[key], f"{where}.{key}")


def is_vessel_path(value: str) -> bool:
    """Whether a ``type`` value names a folder (a ``/``, or a leading ``~`` or ``.``) rather than a built-in."""
    return "/" in value or os.sep in value or value.startswith(("~", "."))


def resolve_vessel_type(value: str, base_dir: str | Path | None = None) -> str:
    """A ``type`` as a file wrote it → what :func:`load_vessel_type` takes: a built-in name
    unchanged; a vessel folder's path (``~`` expanded, relative to ``base_dir``, default the
    current folder) as its absolute path, after checking the folder against the contract.
    Raises ValueError (one line: the reason, and the value as written)."""
    if "\x00" in value:
        raise ValueError(f"not a vessel folder's path (it holds a NUL character), got {value!r}")
    try:
        return _resolve(value, base_dir)
    except (OSError, RuntimeError) as exc:  # a name too long for the file system, an unknown ~user, ...
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc).rstrip(".")
        raise ValueError(f"not a readable vessel folder's path ({reason}), got {value!r}") from None


def _resolve(value: str, base_dir: str | Path | None) -> str:
    from mjasc.physics.vessel_contract import VesselContractError

    folder = Path(value).expanduser()
    relative = not folder.is_absolute()
    if relative:
        folder = Path(base_dir if base_dir is not None else ".") / folder
    folder = folder.resolve()
    if value not in available_vessels() and folder.is_file():  # (hulls/tern/tern.xml for hulls/tern)
        raise ValueError(f"names a file; a vessel type is the path of the vessel folder that holds it "
                         f"({folder.parent}), got {value!r}")
    if not is_vessel_path(value):
        if value in available_vessels():
            return value
        hint = f"; a folder named so here is written ./{value}" if folder.is_dir() else ""
        raise ValueError(f"must be one of {', '.join(available_vessels())} or a vessel folder's path{hint}, "
                         f"got {value!r}")
    if not folder.is_dir():
        if relative:
            where = "the file's" if base_dir is not None else "the current"
            raise ValueError(f"no such vessel folder (relative to {where} folder: {folder}), got {value!r}")
        raise ValueError(f"no such vessel folder ({folder}), got {value!r}")
    for f in (f"{folder.name}.xml", "hydrodynamics.toml"):
        if not (folder / f).is_file():
            # (the usual slip: a copied folder whose MJCF keeps the old name, otter.xml)
            others = sorted(p.name for p in folder.glob("*.xml") if p.name != "scene.xml") if f.endswith(".xml") else []
            found = f"; it has {', '.join(others)}: rename it to {f}, the folder's name" if others else ""
            raise ValueError(f"the vessel folder has no {f} (it holds <folder name>.xml and hydrodynamics.toml, "
                             f"assets/README.md{found}), got {value!r}")
    try:
        load_vessel_type(str(folder))
    except VesselContractError as exc:  # (named as the user wrote it)
        raise ValueError(str(exc).replace(str(folder), value.rstrip("/" + os.sep), 1)) from None
    return str(folder)


class VesselFiles(dict):
    """:func:`vessel_files`' hashes (a dict, which the digest covers as it is), with ``core``: those
    of the MJCF and hydrodynamics.toml alone, all that a digest covered before the MJCF's
    references were (a store written then holds its campaign under the digest of ``core``:
    :attr:`mjasc.campaigns.spec.CampaignSpec.earlier_digests`)."""

    core: dict[str, str]


def vessel_files(vessel_type: str) -> dict[str, str]:
    """The SHA-256 of the files mjasc reads from a vessel folder (a resolved ``type``; {} for a
    built-in name), by content: what a campaign's digest covers, so that an edited hull is a new
    campaign and, as for the campaign file, a comment is not (the TOML as parsed, the MJCF in
    canonical form without comments, files the MJCF references — meshes, textures — byte for byte:
    :mod:`mjasc.physics.hull_files`). The folder's README.md and scene.xml, which mjasc never
    reads, are not covered: documenting the hull does not start the campaign over."""
    from mjasc.physics.hull_files import HULL_FILES, content_hashes, folder_files

    if not os.path.isabs(vessel_type):
        return {}
    folder = Path(vessel_type)
    paths = folder_files(folder, outside_ok=True)  # (a file outside the folder: by its path)
    out = VesselFiles(content_hashes(folder.name, {rel: path.read_bytes() for rel, path in paths.items()}))
    out.core = {rel: out[rel] for rel in list(paths)[:len(HULL_FILES)]}
    return out


def vessel_fingerprint(vessel_type: str) -> str:
    """A vessel folder's short content tag (:func:`mjasc.physics.hull_files.fingerprint` of
    :func:`vessel_files`): what a campaign report names a folder's hull by besides its name; "" for
    a built-in name."""
    from mjasc.physics.hull_files import fingerprint

    files = vessel_files(vessel_type)
    return fingerprint(files) if files else ""


def load_vessel_type(name: str) -> VesselType:
    """A built-in name (``assets/vessels/<name>/``) or a vessel folder's absolute path (checked
    against the contract: :func:`resolve_vessel_type`) → :class:`VesselType`; errors name the file
    and the field."""
    if os.path.isabs(name):
        folder = Path(name)
        stamp = tuple((p.stat().st_mtime_ns, p.stat().st_size) if p.is_file() else None
                      for p in (folder / f"{folder.name}.xml", folder / "hydrodynamics.toml"))
        return _load_folder(name, stamp)
    return _load_builtin(name)


@functools.lru_cache(maxsize=None)
def _load_builtin(name: str) -> VesselType:
    if name not in available_vessels():
        raise ValueError(f"vessel type {name!r}: unknown; available: {', '.join(available_vessels()) or 'none'}")
    folder = VESSELS_DIR / name
    return _read(folder, str((folder / "hydrodynamics.toml").relative_to(ASSETS_DIR.parent)))


@functools.lru_cache(maxsize=64)
def _load_folder(path: str, stamp: tuple) -> VesselType:
    """A user's vessel folder (``stamp``: its files' times and sizes — an edited file is read again)."""
    from mjasc.physics.vessel_contract import check_vessel_folder

    folder = Path(path)
    check_vessel_folder(folder)
    return _read(folder, str(folder / "hydrodynamics.toml"))


def _read(folder: Path, where: str) -> VesselType:
    """Read ``folder``'s hydrodynamics.toml (``where``: the file as errors name it)."""
    name = folder.name
    toml_path = folder / "hydrodynamics.toml"
    t = load_toml(toml_path, ValueError, "hydrodynamics")
    geo, am, dmp = t.get("geometry", {}), t.get("added_mass", {}), t.get("damping", {})
    cf, prop, lim = t.get("cross_flow", {}), t.get("propellers", {}), t.get("limits", {})
    length = _get(geo, "length_m", f"{where}: geometry")
    draft = _get(geo, "draft_m", f"{where}: geometry")
    hydro = HydroCoefficients(
        X_udot=_get(am, "X_udot", f"{where}: added_mass"),
        Y_vdot=_get(am, "Y_vdot", f"{where}: added_mass"),
        N_rdot=_get(am, "N_rdot", f"{where}: added_mass"),
        Y_rdot=_get(am, "Y_rdot", f"{where}: added_mass", 0.0),
        N_vdot=_get(am, "N_vdot", f"{where}: added_mass", 0.0),
        X_u=_get(dmp, "X_u", f"{where}: damping"),
        Y_v=_get(dmp, "Y_v", f"{where}: damping"),
        N_r=_get(dmp, "N_r", f"{where}: damping"),
        X_uu=_get(dmp, "X_uu", f"{where}: damping", 0.0),
        N_r_nonlinear_gain=_get(dmp, "N_r_nonlinear_gain", f"{where}: damping", 0.0),
        cross_flow=bool(cf.get("enabled", False)),
        drag_coefficient_2d=_get(cf, "drag_coefficient_2d", f"{where}: cross_flow", 0.0),
        strips=int(_get(cf, "strips", f"{where}: cross_flow", 20.0)),
        water_density_kg_m3=_get(cf, "water_density_kg_m3", f"{where}: cross_flow", 1025.0),
        length_m=length,
        draft_m=draft,
    )
    propellers = dataclass_from_table(PropellerCoefficients, prop, f"{where}: propellers",
                                      check=PropellerCoefficients.check)
    return VesselType(
        name=name,
        description=str(t.get("description", "")),
        mjcf_path=folder / f"{name}.xml",
        hydro=hydro,
        propellers=propellers,
        length_m=length,
        beam_m=_get(geo, "beam_m", f"{where}: geometry"),
        draft_m=draft,
        radius_m=_get(geo, "radius_m", f"{where}: geometry"),
        top_speed_m_s=_get(lim, "top_speed_m_s", f"{where}: limits"),
        cruise_speed_m_s=_get(lim, "cruise_speed_m_s", f"{where}: limits"),
    )
