"""Multi-target tracking parameters: :class:`TrackingConfig`, each parameter declared once (bounds,
unit, doc; ``describe_params(TrackingConfig)`` lists them, the IMM's and the detector's nested), and
the reader of a scenario's ``[vessels.tracking]`` table (:func:`parse_tracking_options`). Defaults
and their reasons: docs/perception.md.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from mjasc.core.config_tables import ConfigError, check_params, dataclass_from_table, param, show
from mjasc.perception.detection import DetectionConfig, parse_detection_options
from mjasc.perception.imm.config import IMMConfig, parse_imm_options

__all__ = ["TrackingConfig", "parse_tracking_options", "check_tracking"]


@dataclass(frozen=True)
class TrackingConfig:
    """Track management parameters (SI). Defaults in docs/perception.md.

    With ``use_detection_variance`` (default) each update uses the σ² of its detection, and
    ``imm.measurement_variance_m2`` only seeds association before a first update. The checks that
    relate fields (M ≤ N, the manoeuvre hysteresis, a fading factor < 1) are :func:`check_tracking`.
    """

    imm: IMMConfig = param(default_factory=IMMConfig, reader=parse_imm_options,
                           doc="the IMM bank (thesis Table 6.1 defaults; :mod:`mjasc.perception.imm`)")
    detection: DetectionConfig = param(
        default_factory=DetectionConfig, reader=parse_detection_options,
        doc="clustering and centre estimation (:class:`mjasc.perception.detection.DetectionConfig`)")
    use_detection_variance: bool = param(
        True, doc="update with each detection's own σ² (else imm.measurement_variance_m2)")
    gate_probability: float = param(0.9999, positive=True, maximum=1.0, doc="association gate (chi-square, 2 dof)")
    confirm_hits: int = param(4, minimum=1, maximum=30,
                              doc="M of M-of-N confirmation: updated in M of the last N scans; ≤ confirm_window")
    confirm_window: int = param(6, minimum=1, maximum=30, doc="N of M-of-N confirmation [scans]")
    max_coast_s: float = param(10.0, positive=True, unit="s", doc="a confirmed track not updated for this long is lost")
    max_position_std_m: float = param(
        10.0, positive=True, unit="m", doc="a track whose 1-σ position uncertainty exceeds this is lost")
    range_margin_m: float = param(
        5.0, nonneg=True, unit="m", doc="a track predicted beyond the sensor's range + this margin is dropped")
    merge_fraction: float = param(
        0.5, nonneg=True, maximum=2.0,
        doc="two tracks closer than this × the larger radius are merged (at most 2: beyond, tracks of separate "
            "boats a few hull lengths apart would merge)")
    static_speed_m_s: float = param(
        0.2, nonneg=True, unit="m/s", doc="static-object test: speed below this (moving again above twice it)")
    static_min_age_s: float = param(10.0, nonneg=True, unit="s", doc="static-object test: age above this")
    radius_grow_gain: float = param(
        0.3, positive=True, maximum=1.0, doc="smoothing gain per scan of a track's radius when it grows")
    radius_shrink_gain: float = param(
        0.02, positive=True, maximum=1.0, doc="smoothing gain per scan of a track's radius when it shrinks")
    team_match_distance_m: float = param(
        5.0, nonneg=True, unit="m", doc="gate between a track and a team mate's broadcast position")
    team_max_age_s: float = param(5.0, nonneg=True, unit="s", doc="broadcasts older than this are not used")
    map_cell_m: float = param(
        1.0, positive=True, unit="m", doc="static map cell size (:mod:`mjasc.perception.static_map`)")
    map_min_hits: int = param(3, minimum=1, doc="scans needed to occupy a static map cell")
    outline_reset_m: float = param(
        1.5, positive=True, unit="m",
        doc="a slow track's outline (the hull of its returns) restarts when its centre has moved this far from "
            "where the accumulation started")
    manoeuvre_fading: float = param(
        0.8, nonneg=True,
        doc="manoeuvre detector (:mod:`mjasc.perception.tracking.manoeuvre`): fading factor α of the average of "
            "the normalized innovations squared; < 1")
    manoeuvre_threshold: float = param(
        6.0, nonneg=True, doc="level of that average (2 without a manoeuvre) above which the track is manoeuvring")
    manoeuvre_end_threshold: float = param(
        3.0, nonneg=True, doc="the level below which the manoeuvre has ended (hysteresis); ≤ manoeuvre_threshold")
    manoeuvre_speed_noise_m2_s3: float = param(
        0.5, nonneg=True, unit="m²/s³",
        doc="process noise intensity added to every model's Q_V while a track manoeuvres (0 and 0: detector off)")
    manoeuvre_heading_noise_rad2_s: float = param(
        0.01, nonneg=True, unit="rad²/s", doc="process noise intensity added to every model's Q_θ while a track "
                                              "manoeuvres")

    def __post_init__(self):
        check_params(self, "tracking")
        check_tracking(self, "tracking")

    @property
    def gate_threshold(self) -> float:
        p = self.gate_probability
        return math.inf if p >= 1.0 else -2.0 * math.log1p(-p)


def check_tracking(c: TrackingConfig, where: str) -> None:
    """The checks of a :class:`TrackingConfig` that relate fields or need a strict bound (the
    single-field bounds are declared with the fields). ConfigError naming ``f"{where}.{key}"``."""
    def bad(key, reason, value):
        raise ConfigError(f"{where}.{key}: {reason}, got {show(value)}")

    if c.confirm_hits > c.confirm_window:
        bad("confirm_hits", f"must be ≤ confirm_window ({c.confirm_window})", c.confirm_hits)
    if not c.manoeuvre_fading < 1.0:
        bad("manoeuvre_fading", "must be < 1", c.manoeuvre_fading)
    if c.manoeuvre_end_threshold > c.manoeuvre_threshold:
        bad("manoeuvre_end_threshold", f"must be ≤ manoeuvre_threshold ({c.manoeuvre_threshold})",
            c.manoeuvre_end_threshold)


def parse_tracking_options(table: Mapping | None, where: str = "tracking") -> TrackingConfig:
    """Validate a scenario's ``[vessels.tracking]`` table (None: all defaults; optional ``imm`` and
    ``detection`` sub-tables) into a :class:`TrackingConfig`. Unknown keys, wrong types and
    out-of-range values raise ValueError naming ``f"{where}.{key}"``
    (:func:`mjasc.core.config_tables.dataclass_from_table`)."""
    return dataclass_from_table(TrackingConfig, {} if table is None else table, where, check=check_tracking)
