"""The thesis coordination's options (``[vessels.comms]``): gains, formation role, the broadcast
plan and team-shared perception (:class:`CoordinationConfig`), as the scenario table declares them."""

from __future__ import annotations

from dataclasses import dataclass

from mjasc.core.config_tables import ConfigError, check_params, dataclass_from_table, param, show

__all__ = ["CoordinationConfig", "parse_coordination_options"]


@dataclass(frozen=True)
class CoordinationConfig:
    """Gains and formation role of one vessel (``[vessels.comms]``). The broadcast period is the
    runner's comms slot, ``rates.comms_hz``."""

    max_speed_correction: float = param(0.5, doc="k ∈ (0, 1): the consensus term moves the speed within "
                                                 "[(1 − k), (1 + k)] × nominal")
    error_scale_m: float = param(10.0, positive=True, unit="m", doc="e_s: tanh(e / e_s); linear gain k / e_s per "
                                                                   "metre of error")
    formation_offset_m: float = param(0.0, unit="m", doc="o_i: desired lead along the own path over the formation "
                                                         "reference")
    role: str = param("peer", choices=("leader", "peer"), doc="peer (consensus) or leader (keeps its nominal speed)")
    neighbour_timeout_s: float = param(5.0, positive=True, unit="s", doc="a neighbour whose latest message is older "
                                                                         "is dropped from N_i")
    extrapolate: bool = param(True, doc="extrapolate neighbours: ξ̂_j = ξ_j + ξ̇_j (t − t_j)")
    formation_tolerance_m: float = param(1.0, positive=True, unit="m", doc="formation spread below this counts as "
                                                                          "in formation (summary only)")
    intent_horizon_s: float = param(60.0, nonneg=True, unit="s", doc="the broadcast plan covers this far ahead "
                                                                     "(0: no plan, pose only)")
    intent_step_s: float = param(1.0, positive=True, unit="s", doc="spacing of the plan's samples")
    share_tracks: bool = param(False, doc="team-shared perception: broadcast the own confirmed tracks and fuse "
                                          "the team's with the own (covariance intersection, "
                                          "mjasc.perception.track_fusion)")
    share_max_tracks: int = param(8, minimum=1, maximum=64, doc="at most this many tracks per message, nearest "
                                                                "first")
    share_max_age_s: float = param(3.0, positive=True, unit="s", doc="a team track estimated longer ago is not "
                                                                     "used")
    share_gate: float = param(9.21, positive=True, doc="gate on the Mahalanobis d² between a team and an own "
                                                       "track's positions (χ²₂ 99 %: 9.21)")

    def __post_init__(self):
        check_params(self, "comms")
        _validate(self, "comms")


def _validate(cfg: CoordinationConfig, where: str) -> None:
    """Cross-field and open-interval checks of a :class:`CoordinationConfig` (the declared bounds
    are checked by :func:`~mjasc.core.config_tables.check_params`)."""
    if not 0.0 < cfg.max_speed_correction < 1.0:
        raise ConfigError(f"{where}.max_speed_correction: must be in (0, 1) so that the speed stays positive, "
                          f"got {show(cfg.max_speed_correction)}")


def parse_coordination_options(table: dict, where: str = "comms") -> CoordinationConfig:
    """A ``[vessels.comms]`` table → :class:`CoordinationConfig` (ValueError names ``where.<key>``)."""
    return dataclass_from_table(CoordinationConfig, table, where, check=_validate)
