"""The declared parameters of an encounter family (:mod:`mjasc.campaigns.encounters`): the
conditions of a run (own vessel, water, sensing), a team's and a bottleneck's layout, and one
target's undisturbed motion relative to the own vessel, with each role's defaults. Each is a
frozen dataclass whose fields carry their bound, unit and doc; a family's ``[families.parameters]``
laws are checked against them."""

from __future__ import annotations

from dataclasses import dataclass

from mjasc.core.config_tables import check_params, param

__all__ = ["Conditions", "Team", "Bottleneck", "TargetParameters", "ROLE_DEFAULTS"]


@dataclass(frozen=True)
class Conditions:
    """The own vessel, the water and the sensing of a run."""

    own_heading_deg: float = param(90.0, minimum=-180.0, maximum=360.0, unit="deg",
                                   doc="own course, ENU: counter-clockwise from east (90 = north)")
    own_speed_m_s: float | None = param(None, positive=True, unit="m/s",
                                        doc="mission speed (none: the own vessel type's cruise speed)")
    current_m_s: float = param(0.0, nonneg=True, maximum=1.0, unit="m/s", doc="uniform current speed")
    current_direction_deg: float = param(0.0, minimum=-180.0, maximum=180.0, unit="deg",
                                         doc="where the current flows to, clockwise from the own course "
                                             "(0: from astern; 90: setting to starboard)")
    sensor_range_noise_m: float = param(0.05, nonneg=True, maximum=5.0, unit="m", doc="1-σ range noise of the sensor")
    sensor_dropout: float = param(0.02, nonneg=True, maximum=0.95, doc="probability a true return is lost")
    after_cpa_s: float = param(30.0, nonneg=True, unit="s", doc="run time after the last target's TCPA")
    seed: int | None = param(None, nonneg=True, doc="the scenario seed (none: base_seed + run index)")

    def __post_init__(self):
        check_params(self, "parameters")


@dataclass(frozen=True)
class Team:
    """team_vs_traffic: the team in line abreast, its centre on the reference track."""

    team_size: int = param(3, minimum=2, maximum=8, doc="number of own vessels")
    team_spacing_m: float = param(12.0, minimum=4.0, maximum=100.0, unit="m", doc="lateral spacing")
    comms_loss: float = param(0.05, nonneg=True, maximum=1.0, doc="packet loss probability near the sender")

    def __post_init__(self):
        check_params(self, "parameters")


@dataclass(frozen=True)
class Bottleneck:
    """bottleneck: two rectangular islands across the own track, centred where the own vessel is at
    the first target's TCPA, leaving a gap centred on the track."""

    gap_width_m: float = param(24.0, minimum=6.0, maximum=200.0, unit="m", doc="width of the gap")
    island_length_m: float = param(30.0, positive=True, maximum=500.0, unit="m", doc="island extent along the track")
    island_width_m: float = param(30.0, positive=True, maximum=500.0, unit="m", doc="island extent across the track")

    def __post_init__(self):
        check_params(self, "parameters")


@dataclass(frozen=True)
class TargetParameters:
    """One target's undisturbed motion relative to the own vessel (defaults per role: ROLE_DEFAULTS)."""

    relative_bearing_deg: float | None = param(None, minimum=-180.0, maximum=180.0, unit="deg",
                                               doc="bearing at t = 0, clockwise from the own bow; given → the "
                                                   "course follows")
    relative_course_deg: float | None = param(None, minimum=-180.0, maximum=180.0, unit="deg",
                                              doc="the aspect: target course − own course, clockwise (180: "
                                                  "reciprocal); given → the bearing follows")
    speed_ratio: float = param(1.0, nonneg=True, maximum=4.0, doc="target speed / own speed")
    dcpa_m: float = param(0.0, minimum=-200.0, maximum=200.0, unit="m",
                          doc="signed distance at the CPA of the undisturbed motion (> 0: the side the rules ask)")
    tcpa_s: float = param(40.0, positive=True, maximum=1000.0, unit="s", doc="time of that CPA")
    target_radius_m: float = param(2.0, positive=True, maximum=8.0, unit="m", doc="the target's bounding radius")


ROLE_DEFAULTS = {
    "head_on": {"relative_course_deg": 180.0, "speed_ratio": 1.0, "tcpa_s": 35.0},
    "crossing_give_way": {"relative_course_deg": -90.0, "speed_ratio": 1.0, "tcpa_s": 50.0},
    "crossing_stand_on": {"relative_course_deg": 90.0, "speed_ratio": 1.0, "tcpa_s": 50.0},
    "overtaking": {"relative_course_deg": 0.0, "speed_ratio": 0.4, "tcpa_s": 90.0},
    "overtaken": {"relative_course_deg": 0.0, "speed_ratio": 1.6, "tcpa_s": 90.0},
}
"""Per role, the defaults that differ from :class:`TargetParameters`'s."""
