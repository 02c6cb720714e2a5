"""Parameters of collision prediction (docs/thesis.md §3; defaults thesis §6.1), each declared once.

The fields are read from a vessel's ``[vessels.avoidance]`` table (the avoidance config nests this
one, flattened). ``window_s = "dynamic"`` in a table selects the dynamic window δ = v₀/a_brake + ζ
(``None`` in code). Every bound violation of a number, a wrong type or a non-finite value reads
``"<table>.<field>: must be finite and > 0, got <value>"`` (or ``≥ 0``). Built directly in code,
the config has no table name: its errors name the field alone (``"window_s: must be ..."``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from mjasc.core.config_tables import ConfigError, check_params, number, param, show

__all__ = ["CollisionPredictionConfig", "read_window_s"]

_POSITIVE = "must be finite and > 0"
_NONNEG = "must be finite and ≥ 0"


def read_window_s(value: Any, where: str) -> float | None:
    """Reader of ``window_s`` in a table: ``"dynamic"`` → None (δ = v/a_brake + ζ), else a number
    [s] (its sign is checked with the other fields)."""
    if isinstance(value, str):
        if value != "dynamic":
            raise ConfigError(f'{where}: must be a number [s] or "dynamic", got {show(value)}')
        return None
    return number(value, where)


@dataclass(frozen=True)
class CollisionPredictionConfig:
    """Parameters of collision prediction (defaults: thesis §6.1)."""

    window_s: float | None = param(30.0, positive=True, maximum=3600.0, unit="s",
                                   phrase="must be finite, > 0 and ≤ 3600 s", reader=read_window_s,
                                   doc='fixed prediction window δ; None (a table: "dynamic") → dynamic '
                                       "δ = v₀/a_brake + ζ (thesis: 30 s; at most an hour)")
    brake_decel_m_s2: float = param(0.1, positive=True, unit="m/s²", phrase=_POSITIVE,
                                    doc="a_brake of the dynamic window")
    margin_s: float = param(10.0, nonneg=True, unit="s", phrase=_NONNEG, doc="ζ of the dynamic window")
    safety_distance_m: float = param(1.0, nonneg=True, maximum=10_000.0, unit="m",
                                     phrase="must be finite, ≥ 0 and ≤ 10 km",
                                     doc="added to R_vh + R_ob (thesis: 1 m; at most 10 km)")
    obstruction_threshold_s: float = param(15.0, positive=True, unit="s", phrase=_POSITIVE,
                                           doc="Δt_threshold of σ (thesis: 15 s in §6.1, 35 s in §6.4)")
    time_step_s: float = param(0.5, positive=True, unit="s", phrase=_POSITIVE, doc="grid step on the window")
    max_range_m: float | None = param(None, positive=True, unit="m", phrase=_POSITIVE,
                                      doc="tracks farther than this from the vessel now are not checked "
                                          "(thesis: 20 m); None → no limit")
    stop_at_first_minimum: bool = param(False, doc="True → the thesis's rule (only the first local minimum "
                                                   "of d(t) counts)")
    svo_vertices: int = param(32, minimum=8, doc="target vertex count of an SVO polygon (each edge becomes "
                                                 "a planner panel)")

    def __post_init__(self):
        check_params(self, "")
