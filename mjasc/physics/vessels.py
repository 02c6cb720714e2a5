"""The vessel library: one folder per hull under ``assets/vessels/<name>/``.

Each folder holds ``<name>.xml`` (MJCF: geometry, mass, inertia, propeller sites, shaft-lag
actuators), ``hydrodynamics.toml`` (added mass, damping, cross-flow, propellers, limits — every
number with its source) and a README. This module reads them into a typed :class:`VesselType`.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path

from mjasc.core.config_tables import dataclass_from_table, load_toml, number
from mjasc.core.resources import assets_dir
from mjasc.physics.hydrodynamics import HydroCoefficients
from mjasc.physics.thrusters import PropellerCoefficients

ASSETS_DIR = assets_dir()
VESSELS_DIR = ASSETS_DIR / "vessels"
SCENE_XML = ASSETS_DIR / "scene" / "water.xml"

__all__ = ["VesselType", "available_vessels", "load_vessel_type", "ASSETS_DIR", "SCENE_XML"]


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


@functools.lru_cache(maxsize=None)
def load_vessel_type(name: str) -> VesselType:
    """Read ``assets/vessels/<name>/``; errors name the file and the field."""
    folder = VESSELS_DIR / name
    if name not in available_vessels():
        raise ValueError(f"vessel type {name!r}: unknown; available: {', '.join(available_vessels()) or 'none'}")
    toml_path = folder / "hydrodynamics.toml"
    t = load_toml(toml_path, ValueError, "hydrodynamics")
    where = str(toml_path.relative_to(ASSETS_DIR.parent))
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
