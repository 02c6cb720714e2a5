"""Parameters of one vessel's collision avoidance: the ``[vessels.avoidance]`` table.

Each parameter is declared once below (bounds, unit, doc); validation and the TOML reader derive
from the declarations (:mod:`mjasc.core.config_tables`). The collision-prediction parameters
(:class:`~mjasc.avoidance.prediction.CollisionPredictionConfig`: window, braking, margin, safety
distance, obstruction threshold, time step, range) are nested as ``prediction`` and read from the
same, flat table, so ``[vessels.avoidance] window_s = 40`` sets ``config.prediction.window_s``
(``config.window_s`` reads it too).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

from mjasc.avoidance.prediction import CollisionPredictionConfig
from mjasc.core.config_tables import ConfigError, check_params, dataclass_from_table, param, show

__all__ = ["AvoidanceConfig", "parse_avoidance_options", "check_avoidance"]

_PREDICTION_FIELDS = frozenset(f.name for f in dataclasses.fields(CollisionPredictionConfig))


@dataclass(frozen=True)
class AvoidanceConfig:
    """Parameters of one vessel's collision avoidance (docs/thesis.md §3–5; defaults: thesis §6.1 where it
    gives a value). When no action is possible at all, the vessel slows to ``emergency_speed_m_s``
    (an emergency yield: by default it stops), and a give-way vessel never goes around a team mate
    (it yields, or stops). A stand-on vessel whose team mate comes up from abaft its beam never slows
    down (that would let the give-way vessel, coming from behind, run into it; COLREG rule 13): at
    the last resort it may only speed up (pass first). A team mate stopped or creeping there is
    answered as any conflict."""

    enabled: bool = param(True, doc="false: predict and record conflicts but never act (monitor only)")
    prediction: CollisionPredictionConfig = param(
        default_factory=CollisionPredictionConfig, flatten=True,
        doc="collision prediction (window_s, brake_decel_m_s2, margin_s, safety_distance_m, "
            "obstruction_threshold_s, time_step_s, max_range_m, ...), read from the same table")
    # velocity correction (docs/thesis.md §5)
    gain_k: float = param(0.3, positive=True, unit="1/s", doc="virtual-target gain k of the speed law")
    speed_min_m_s: float = param(0.2, nonneg=True, unit="m/s", doc="slowest commanded speed (steerage way)")
    emergency_speed_m_s: float = param(0.0, nonneg=True, unit="m/s",
                                       doc="speed of the emergency slow-down when no manoeuvre clears a conflict "
                                           "(0: take all way off, COLREG rule 8(e))")
    speed_max_m_s: float | None = param(None, positive=True, unit="m/s",
                                        doc="fastest commanded speed; unset: the vessel's top speed")
    correction_margin_m: float = param(2.0, nonneg=True, unit="m",
                                       doc="the virtual target's goal is γ_A − margin (yield) or γ_B + margin (pass)")
    allow_pass_first: bool = param(True, doc="speed up and pass first when yielding is impossible")
    slow_down_decel_m_s2: float = param(
        1.0, nonneg=True, unit="m/s²",
        doc="the own vessel is predicted to shed a velocity correction's speed above the mission speed (a pass "
            "first's) at this deceleration after the correction's goal time, not at once as planned (an Otter "
            "went from 2.92 to 0.82 m/s in 2 s, 1.2 m beyond the stepped plan); 0: at once")
    # re-planning (docs/thesis.md §4)
    safety_ratio: float = param(0.5, nonneg=True, maximum=1.0, doc="r of the robust rule V_j = r·a_max·L_j")
    sink_strength: float | None = param(None, positive=True, unit="m²/s",
                                        doc="λ_g of the goal's sink; unset: max(30, 2 U (width + 10 m))")
    uniform_speed: float = param(1.0, positive=True, unit="m/s", doc="U of the field's uniform flow")
    goal_margin_m: float = param(10.0, nonneg=True, unit="m",
                                 doc="the detour's goal lies this far beyond the obstruction on the mission path")
    streamline_step_m: float = param(0.5, positive=True, unit="m", doc="step of the streamline tracer")
    static_inflation_m: float | None = param(None, nonneg=True, unit="m",
                                             doc="growth of mapped static polygons; unset: half beam + safety distance")
    static_range_m: float = param(60.0, positive=True, unit="m",
                                  doc="static polygons this close to the route enter the field")
    max_panel_length_m: float = param(3.0, positive=True, unit="m", doc="longest panel of the panel method")
    replan_margin_m: float = param(1.0, nonneg=True, unit="m",
                                   doc="SVOs handed to the planner are grown by this much, so that the detour, "
                                       "followed with some cross-track error, is not itself flagged by the next "
                                       "prediction (hysteresis against re-plan churn)")
    withdraw_offset_m: float = param(10.0, nonneg=True, unit="m",
                                     doc="a detour around tracks is withdrawn when the mission path, this close or "
                                         "closer, is clear and every track it went around is gone (team mates' stale "
                                         "copies, or lost) or, the vessel yielding or stopped on it, it now leads into "
                                         "one of them (the mission path then clear of every track by "
                                         "replan_margin_m): the vessel returns to it; 0: never withdraw")
    withdraw_false_alarms: bool = param(
        False, doc="withdraw a yield to a stranger decided on its track's first estimates (withdraw_new_track_s) "
                   "once the track, predicted again along the path at the mission speed, has passed clear by "
                   "correction_withdraw_margin_m for withdraw_confirm_s: the vessel resumes its mission speed (a new "
                   "track's first velocity estimate can predict a collision that the next estimates clear). Off: the "
                   "thesis holds every correction to its goal; on, the perturbed demo (its ferry emerging beside the "
                   "pontoon, where later estimates are the worse ones) had 2 contacts in 200 runs against 0")
    correction_withdraw_margin_m: float = param(
        5.0, nonneg=True, unit="m",
        doc="with withdraw_false_alarms: how far outside the collision distance the track must pass")
    withdraw_confirm_s: float = param(
        3.0, nonneg=True, unit="s",
        doc="with withdraw_false_alarms: the yield is withdrawn once its track has passed clear at the mission "
            "speed in every check (one a second while it runs) for this long: a later estimate is not always the "
            "better one")
    withdraw_new_track_s: float = param(
        5.0, nonneg=True, unit="s",
        doc="with withdraw_false_alarms: a yield is withdrawable when decided within this time of its track's "
            "first prediction; later yields, passes first, the emergency stop and yields to team mates are held "
            "to their goal")
    sharp_turn_deg: float = param(60.0, nonneg=True, maximum=180.0, unit="deg",
                                  doc="on a detour, an aim point 5 m ahead this far off the heading is a sharp turn: "
                                      "it is sailed at sharp_turn_speed_m_s; 180: never")
    sharp_turn_speed_m_s: float = param(0.3, nonneg=True, unit="m/s",
                                        doc="speed for a sharp turn on a detour (the hull turns tighter and advances "
                                            "less toward what it turns away from)")
    detour_structure_slack_m: float = param(
        0.5, nonneg=True, unit="m",
        doc="a detour around a moving track is not taken when it passes a mapped structure (or a static track's "
            "outline) closer than R_vh + safety distance and closer by more than this than the vessel is now: "
            "the vessel stops instead (emergency) and looks again every second")
    deadlock_s: float = param(
        45.0, nonneg=True, unit="s",
        doc="two team mates stopped (below 0.1 m/s) this long with their centres inside their collision distance "
            "(neither can clear the other: each one's path runs through the other) move apart: the earlier name sails "
            "straight away from the other to the collision distance plus 2 × replan_margin_m, then plans on as usual "
            "(a vessel stuck with an earlier name too waits twice this; the time is counted at its predictions, about "
            "one a second); longer than the waits that end by themselves (the §6.4.3 bottleneck's team mates waited "
            "up to 29 s in the gap); 0: never")
    # when to predict again
    track_deviation_m: float = param(5.0, positive=True, unit="m",
                                     doc="predict again at once when a track (or a team mate's plan) is this far "
                                         "from where the last prediction put it")
    speed_change_m_s: float = param(0.2, positive=True, unit="m/s",
                                    doc="... or when the mission speed (with the coordination factor) changed by this")
    static_speed_m_s: float = param(0.15, nonneg=True, unit="m/s",
                                    doc="tracks estimated slower than this are taken as static (a moored boat's IMM "
                                        "speed is noise around zero)")
    structure_speed_m_s: float = param(0.5, nonneg=True, unit="m/s",
                                       doc="a track slower than this whose disc overlaps a mapped static polygon is "
                                           "that structure seen again (a false track formed by its returns) and is "
                                           "taken as static; 0: off")
    last_resort_s: float = param(10.0, nonneg=True, unit="s",
                                 doc="a stand-on vessel acts too when the collision is this close in time "
                                     "(COLREG rule 17)")
    traffic_rule: str = param("thesis", choices=("thesis", "colreg"),
                              doc="towards traffic outside the team: 'thesis' always gives way (slows down, or "
                                  "re-plans); 'colreg' acts by the vessel's role (rules 13–17): head-on → lane change "
                                  "to starboard; crossing give-way → slow down and pass astern, never ahead; "
                                  "stand-on (crossing from port, being overtaken) → keep course and speed until "
                                  "the collision is stand_on_s away, then act; overtaking → keep out of the way")
    stand_on_s: float = param(20.0, nonneg=True, unit="s",
                              doc="with traffic_rule = 'colreg': a stand-on vessel keeps course and speed until the "
                                  "predicted collision is this close in time (rule 17 (a)(ii): the give-way vessel "
                                  "is evidently not acting)")
    team_broadcast_max_age_s: float = param(3.0, nonneg=True, unit="s",
                                            doc="a team mate is predicted from its own broadcast (position, "
                                                "velocity, heading rate, plan) when that is at most this old; "
                                                "0: from its IMM track only")

    def __post_init__(self):
        check_params(self, "avoidance")
        check_avoidance(self, "avoidance")

    def __getattr__(self, name: str) -> Any:
        """The prediction parameters read flat, as in the TOML table (``config.window_s``)."""
        if name in _PREDICTION_FIELDS:
            return getattr(self.prediction, name)
        raise AttributeError(f"{type(self).__name__!s} has no attribute {name!r}")

    def prediction_config(self) -> CollisionPredictionConfig:
        return self.prediction


def check_avoidance(c: AvoidanceConfig, where: str) -> None:
    """Cross-field checks of an :class:`AvoidanceConfig` (each field's own bounds are declared)."""
    if c.speed_max_m_s is not None and c.speed_max_m_s <= c.speed_min_m_s:
        raise ConfigError(f"{where}.speed_max_m_s: must exceed speed_min_m_s ({c.speed_min_m_s}), "
                          f"got {show(c.speed_max_m_s)}")


def parse_avoidance_options(table: dict, where: str = "avoidance") -> AvoidanceConfig:
    """Validate a ``[vessels.avoidance]`` table into an :class:`AvoidanceConfig`.

    ``window_s = "dynamic"`` selects the dynamic window δ = v/a_brake + ζ; every other field is a
    number or a boolean as declared. Unknown keys, wrong types and out-of-range values raise
    ValueError naming ``f"{where}.{key}"`` (:func:`mjasc.core.config_tables.dataclass_from_table`)."""
    config = dataclass_from_table(AvoidanceConfig, table, where, check=check_avoidance)
    # options of a mode the table does not choose would be ignored: say so instead
    if "stand_on_s" in table and config.traffic_rule != "colreg":
        raise ConfigError(f"{where}.stand_on_s: only with traffic_rule = \"colreg\" (the thesis rule gives way to "
                          f"every stranger: no stand-on to time)")
    for key in ("brake_decel_m_s2", "margin_s"):
        if key in table and config.window_s is not None:
            raise ConfigError(f"{where}.{key}: only with window_s = \"dynamic\" (a fixed window of "
                              f"{show(config.window_s)} s does not use it)")
    if config.window_s is not None and config.time_step_s > config.window_s:
        raise ConfigError(f"{where}.time_step_s: must not exceed the window ({show(config.window_s)} s), "
                          f"got {show(config.time_step_s)}")
    return config
