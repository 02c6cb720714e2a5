"""The options of the velocity-obstacle method: the ``[vessels.avoidance]`` table with
``method = "velocity_obstacle"``, each declared once (default, bounds, unit, doc; the table is
validated from it and ``describe_params`` documents it: docs/avoidance.md)."""

from __future__ import annotations

from dataclasses import dataclass

from mjasc.core.config_tables import ConfigError, check_params, param, show

__all__ = ["VelocityObstacleOptions", "check_options"]


@dataclass(frozen=True)
class VelocityObstacleOptions:
    """Options of :class:`~mjasc.avoidance.velocity_obstacles.method.VelocityObstacleAvoidance`."""

    safety_distance_m: float = param(2.0, nonneg=True, maximum=10_000.0, unit="m",
                                     doc="added to the own and the obstacle's radius: the combined radius R of a cone "
                                         "(at most 10 km)")
    horizon_s: float = param(30.0, positive=True, unit="s",
                             doc="time horizon T: collisions later than T do not count (truncated cone)")
    course_candidates: int = param(37, minimum=3, maximum=721,
                                   doc="candidate courses, evenly over ±course_span_deg about the preferred course "
                                       "(odd: the preferred course itself is one)")
    course_span_deg: float = param(120.0, positive=True, maximum=180.0, unit="deg",
                                   doc="largest candidate course change either side of the preferred course")
    speed_candidates: int = param(5, minimum=2, maximum=41,
                                  doc="candidate speeds, evenly from the preferred speed down to 0 (stop), and "
                                      "speed_candidates − 1 more evenly above it up to top_speed_m_s")
    top_speed_m_s: float | None = param(None, positive=True, unit="m/s",
                                        doc="the highest candidate speed; unset: the hull's top speed (none above "
                                            "the preferred speed when it is lower)")
    weight_course: float = param(1.0, nonneg=True, unit="1/rad", doc="cost of a course change from the preferred one")
    weight_speed: float = param(1.0, nonneg=True,
                                doc="cost of a speed change, per fraction of the preferred speed")
    weight_change: float = param(2.0, nonneg=True,
                                 doc="cost of changing the chosen velocity from the last choice, per preferred "
                                     "speed (against chattering)")
    weight_collision: float = param(10.0, positive=True,
                                    doc="penalty of a velocity inside a VO: weight · (1 + T / τ_c); above every "
                                        "deviation cost, so a collision-free velocity is taken when one exists")
    weight_colreg: float = param(5.0, nonneg=True,
                                 doc="penalty of a velocity COLREG forbids (wrong side, crossing ahead, stand-on "
                                     "turning to port)")
    colreg: bool = param(True, doc="apply Kuwata et al.'s COLREG constraints (roles, forbidden half-planes, stand on)")
    give_way_starboard: bool = param(True, doc="a head-on or give-way vessel alters to starboard: courses more than "
                                               "5° to port of the preferred one cost weight_colreg (rules 14, 16)")
    colreg_departure: bool = param(True, doc="when no candidate is admissible and the cheapest is collision-free but "
                                             "passes a head-on or give-way track on the forbidden side, depart from "
                                             "the rule for that track and keep the side taken until it is past "
                                             "(rule 2 (b), 17 (b)), if the hull can still reach it (turn_rate_deg_s)")
    turn_rate_deg_s: float = param(15.0, positive=True, maximum=180.0, unit="deg/s",
                                   doc="the hull's turn rate assumed when checking that a departure from the rule "
                                       "is within reach (the departure begins once the hull has come round)")
    stand_on_ttc_s: float = param(12.0, nonneg=True, unit="s",
                                  doc="a stand-on vessel keeps course and speed until keeping them would collide "
                                      "within this time (rule 17)")
    hysteresis_s: float = param(5.0, nonneg=True, unit="s",
                                doc="steering continues this long after the preferred velocity left every VO, and "
                                    "a track's role is kept this long after its last conflict")
    team_reciprocal: bool = param(True, doc="team mates (tracks with team_member) as reciprocal velocity obstacles: "
                                            "each takes half the avoidance")
    covariance_sigmas: float = param(2.0, nonneg=True,
                                     doc="the combined radius grows by this many standard deviations of the "
                                         "track's position (largest axis)")
    static_speed_m_s: float = param(0.2, nonneg=True, unit="m/s",
                                    doc="tracks slower than this are static obstacles (their outline when they "
                                        "have one)")
    static_spacing_m: float = param(1.0, positive=True, unit="m",
                                    doc="spacing of the discs covering static polygons' edges")
    static_range_m: float = param(60.0, positive=True, unit="m",
                                  doc="static edge points farther than this from the vessel are ignored")
    lookahead_m: float | None = param(None, positive=True, unit="m",
                                      doc="lookahead Δ of the preferred (line-of-sight) course; unset: 3 hull "
                                          "lengths, at least 5 m (the path follower's default)")

    def __post_init__(self):
        check_params(self, "avoidance")
        check_options(self, "avoidance")


def check_options(options: VelocityObstacleOptions, where: str) -> None:
    """Cross-field checks: an odd number of course candidates (the preferred course among them)."""
    if options.course_candidates % 2 == 0:
        raise ConfigError(f"{where}.course_candidates: must be odd (the preferred course is the middle one), "
                          f"got {show(options.course_candidates)}")
