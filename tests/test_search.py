"""Failure search: the cross-entropy sampler concentrates on a known minimum where uniform sampling
does not; a real search over an encounter family stores its runs and writes replayable failures."""

from pathlib import Path

import numpy as np
import pytest

from mjasc.campaigns.search import CrossEntropySampler, SearchConfig, search_failures
from mjasc.campaigns.spec import parse_campaign_spec


def _run_sampler(method, budget=120, batch=12, seed=0):
    """A 'separation' with a narrow failure region around u* = (0.8, 0.15): below 0 within 0.05 of it."""
    target = np.array([0.8, 0.15])
    s = CrossEntropySampler(2, SearchConfig(method=method, budget=budget, batch=batch, seed=seed))
    found, best = 0, np.inf
    for _ in range(budget // batch):
        pts = np.array([s.ask() for _ in range(batch)])
        sep = np.hypot(*(pts - target).T) - 0.05
        found += int((sep < 0).sum())
        best = min(best, float(sep.min()))
        s.tell(pts, sep)
    return found, best


def test_cross_entropy_finds_more_failures_than_uniform_at_the_same_budget():
    ce = [_run_sampler("cross_entropy", seed=k) for k in range(5)]
    un = [_run_sampler("uniform", seed=k) for k in range(5)]
    assert sum(f for f, _ in ce) > 3 * sum(f for f, _ in un)
    assert np.median([b for _, b in ce]) < np.median([b for _, b in un])


def test_a_search_over_an_encounter_family_stores_runs_and_replayable_failures(tmp_path):
    spec = parse_campaign_spec({"name": "s", "families": [{
        "kind": "head_on", "duration_s": 6.0, "parameters": {
            "dcpa_m": {"uniform": [-5.0, 5.0]}, "speed_ratio": {"uniform": [0.8, 1.2]}}}]})
    cfg = SearchConfig(budget=4, batch=2, failure_separation_m=1e9)  # every run counts as a "failure" here
    res = search_failures(spec, "head_on", tmp_path, cfg, workers=0)
    assert len(res.runs) == 4 and len(res.failures) == 4
    assert all(r["min_separation_m"] is not None for r in res.runs)
    assert res.failures[0].read_text().startswith("#") and "seed = " in res.failures[0].read_text()
    again = search_failures(spec, "head_on", tmp_path, cfg, workers=0)  # resumes from the store
    assert [r["min_separation_m"] for r in again.runs] == [r["min_separation_m"] for r in res.runs]
    with pytest.raises(ValueError, match="no encounter family"):
        search_failures(spec, "nope", tmp_path, cfg)


def test_a_search_over_a_perturbation_family_says_why_it_cannot(tmp_path):
    # It said "no encounter family 'demo' in c (have: demo)".
    spec = parse_campaign_spec({"name": "c", "families": [{"kind": "perturbation", "name": "demo",
                                                           "scenario": "demo.toml", "duration_s": 5.0}]},
                               base_dir=Path(__file__).resolve().parents[1] / "tasks")
    with pytest.raises(ValueError, match="'demo' is a family of kind 'perturbation', which has no parameter laws"):
        search_failures(spec, "demo", tmp_path, SearchConfig(budget=2, batch=2))
