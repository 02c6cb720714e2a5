"""The ``[outputs]`` and ``[evaluation]`` tables of a campaign file: what a campaign keeps besides its
results, and how it judges its runs beyond their own summary (:mod:`mjasc.campaigns.spec` reads them)."""

from __future__ import annotations

from dataclasses import dataclass

from mjasc.core.config_tables import check_params, param

__all__ = ["CampaignOutputs", "CampaignEvaluation"]


@dataclass(frozen=True)
class CampaignOutputs:
    """What a campaign keeps besides its results (the ``[outputs]`` table)."""

    recordings: bool = param(False, doc="keep each run's recording.rrd and summary.json in runs/<k>/")

    def __post_init__(self):
        check_params(self, "outputs")


@dataclass(frozen=True)
class CampaignEvaluation:
    """How a campaign judges its runs beyond their own summary (the ``[evaluation]`` table)."""

    mission_cost: bool = param(True, doc="run each run that has traffic again without its [[moving_obstacles]] "
                                         "(same seed, no recording) and report each vessel's path-length and time "
                                         "cost against it (mjasc.evaluation.mission_cost); costs up to one more "
                                         "run per run")
    gospa_cutoff_m: float = param(10.0, positive=True, maximum=1000.0, unit="m",
                                  doc="GOSPA's cut-off c of the tracking score: a track farther than this from a "
                                      "truth object is not its estimate (docs/campaigns.md, \"Outputs and metrics\")")
    gospa_order: float = param(2.0, minimum=1.0, maximum=10.0, doc="GOSPA's order p of the tracking score")

    def __post_init__(self):
        check_params(self, "evaluation")
