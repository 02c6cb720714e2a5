"""A campaign's ``[evaluation]`` sets GOSPA's cut-off and order of its runs' tracking score: the runs
(in their child process) are scored with them, each summary says which, and the report labels its
table with them; bounds are one-line errors naming the field."""

from __future__ import annotations

import pytest

from mjasc.campaigns.engine import run_campaign
from mjasc.campaigns.perturbation import CampaignError
from mjasc.campaigns.report import format_report, report_data
from mjasc.campaigns.spec import parse_campaign_spec

FAMILY = {"kind": "head_on", "runs_per_point": 1, "duration_s": 6.0}


def _run(tmp_path, name, evaluation):
    spec = parse_campaign_spec({"name": name, "evaluation": {"mission_cost": False, **evaluation},
                                "families": [FAMILY]})
    res = run_campaign(spec, tmp_path / name, workers=0, progress=False)
    assert [r.status for r in res.runs] == ["completed"]
    return res.runs[0].metrics["evaluation"]["tracking"]["own"], format_report(report_data(tmp_path / name))


def test_the_campaign_sets_gospa_cutoff_and_order(tmp_path):
    default, md_default = _run(tmp_path, "default", {})
    custom, md_custom = _run(tmp_path, "custom", {"gospa_cutoff_m": 5.0, "gospa_order": 1.0})
    assert (default["gospa_cutoff_m"], default["gospa_order"]) == (10.0, 2.0)
    assert (custom["gospa_cutoff_m"], custom["gospa_order"]) == (5.0, 1.0)
    assert "c = 10 m, p = 2" in md_default and "c = 5 m, p = 1" in md_custom
    # the same run, the same ticks missed (the target before its track is confirmed; the track within
    # 5 m afterwards): the missed part scales with c^p / 2 (2.5 m against 50 m²)
    assert default["gospa_missed_mean"] > 0
    assert custom["gospa_missed_mean"] == pytest.approx(default["gospa_missed_mean"] * 2.5 / 50.0, rel=1e-3)


@pytest.mark.parametrize("evaluation, message", [
    ({"gospa_cutoff_m": 0.0}, r"evaluation\.gospa_cutoff_m: must be > 0"),
    ({"gospa_order": 0.5}, r"evaluation\.gospa_order: must be ≥ 1"),
])
def test_bad_gospa_settings_are_one_line_errors(evaluation, message):
    with pytest.raises((CampaignError, ValueError), match=message) as info:
        parse_campaign_spec({"name": "bad", "evaluation": evaluation, "families": [FAMILY]})
    assert "\n" not in str(info.value)
