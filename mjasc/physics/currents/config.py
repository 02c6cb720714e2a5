"""The scenario's ``[current]`` table → a current field (:func:`current_from_config`).

``type`` selects the field; the other keys are the parameters its dataclass declares
(:class:`~mjasc.physics.currents.analytic.UniformConfig`, ``ShearConfig``, ``VortexConfig``,
``GridConfig``, ``TidalConfig``, ``GaussMarkovConfig``, ``SumConfig``), read by
:func:`~mjasc.core.config_tables.dataclass_from_table`. A ``tidal`` base and the ``sum``
components are nested field tables, read recursively under their own paths. The schema with an
example of every type is the docstring of :mod:`mjasc.physics.currents`.

Errors are ValueErrors (:class:`~mjasc.core.config_tables.ConfigError`) naming the full field path,
the reason and the value: ``current.components[1].core_radius_m: must be > 0, got -2.0``.
"""

from __future__ import annotations

import dataclasses
import zlib
from collections.abc import Mapping
from typing import Any

import numpy as np

from mjasc.core.config_tables import ConfigError, dataclass_from_table, integer, show
from mjasc.core.config_tables import table as as_table
from mjasc.physics.currents.analytic import LinearShear, ShearConfig, UniformConfig, UniformCurrent
from mjasc.physics.currents.base import CurrentField, SumConfig, SumCurrent
from mjasc.physics.currents.gauss_markov import GaussMarkovConfig, GaussMarkovCurrent
from mjasc.physics.currents.grid import GridConfig, GriddedCurrent
from mjasc.physics.currents.tidal import TidalConfig, TidalCurrent
from mjasc.physics.currents.vortex import Vortex, VortexConfig

__all__ = ["CURRENT_TYPES", "current_from_config"]

CURRENT_TYPES: dict[str, tuple[type, type[CurrentField]]] = {
    "uniform": (UniformConfig, UniformCurrent),
    "shear": (ShearConfig, LinearShear),
    "vortex": (VortexConfig, Vortex),
    "grid": (GridConfig, GriddedCurrent),
    "tidal": (TidalConfig, TidalCurrent),
    "gauss_markov": (GaussMarkovConfig, GaussMarkovCurrent),
    "sum": (SumConfig, SumCurrent),
}
"""``type`` of a ``[current]`` table → (its parameter dataclass, the field class)."""


def _components(value: Any, where: str, seed: int | None) -> tuple[CurrentField, ...]:
    """Reader of a sum's ``components``: a non-empty list of field tables."""
    if not isinstance(value, (list, tuple)):
        raise ConfigError(f"{where}: must be a list of tables ([[...components]]), got {show(value)}")
    if not value:
        raise ConfigError(f"{where}: must contain at least one component")
    return tuple(current_from_config(item, path=f"{where}[{i}]", seed=seed) for i, item in enumerate(value))


def _derived_seed(scenario_seed: int, path: str) -> int:
    """A Gauss–Markov table's seed from the scenario's: distinct per table path, so that two
    components never share one noise sequence."""
    integer(scenario_seed, "seed", minimum=0)
    sequence = np.random.SeedSequence([scenario_seed, zlib.crc32(path.encode())])
    return int(sequence.generate_state(1, dtype=np.uint32)[0])


def current_from_config(
    table: Mapping[str, Any], *, path: str = "current", seed: int | None = None
) -> CurrentField:
    """Build a field from a scenario's ``[current]`` TOML table (schema in the package docstring).

    path: the table's location, used in error messages (``current.components[1].core_radius_m``).
    seed: the scenario's seed. A ``gauss_markov`` table without its own ``seed`` gets one derived
    from (seed, its path) — reproducible, and distinct for each component; ``describe()`` shows
    it. Without ``seed``, such a table must give its own.
    Raises ValueError naming the offending field path and the reason; unknown keys are errors."""
    tbl = as_table(table, path)
    if "type" not in tbl:
        raise ConfigError(f"{path}.type: missing (one of: {', '.join(CURRENT_TYPES)})")
    kind = tbl["type"]
    if not isinstance(kind, str) or kind not in CURRENT_TYPES:
        raise ConfigError(f"{path}.type: unknown current type {show(kind)} (one of: {', '.join(CURRENT_TYPES)})")
    config_type, field_type = CURRENT_TYPES[kind]
    keys = [f.name for f in dataclasses.fields(config_type)]
    for key in tbl:
        if key != "type" and key not in keys:
            raise ConfigError(f"{path}.{key}: unknown key for type {kind!r} (expected: {', '.join(keys)})")
    nested = {
        "base": lambda v, w: current_from_config(v, path=w, seed=seed),
        "components": lambda v, w: _components(v, w, seed),
    }
    config = dataclass_from_table(config_type, {k: v for k, v in tbl.items() if k != "type"}, path, nested,
                                  check=getattr(config_type, "check", None))
    if config_type is GaussMarkovConfig and config.seed is None:
        if seed is None:
            raise ConfigError(f"{path}.seed: missing")
        config = dataclasses.replace(config, seed=_derived_seed(seed, path))
    return field_type.from_config(config)
