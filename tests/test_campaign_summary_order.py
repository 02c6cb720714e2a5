"""The campaign's printed summary and report list families in the file's order (they were sorted
by name, so crossing_give_way came before head_on against the docs), and a negative median cost
prints as −, not as "+-0.1 %"."""

from types import SimpleNamespace

import mjasc.campaigns.statistics as statistics


def test_families_come_in_the_campaign_file_s_order(monkeypatch):
    monkeypatch.setattr(statistics, "_group", lambda rs, near_miss_m: sorted(r.index for r in rs))
    runs = [SimpleNamespace(family=f, index=i) for f, i in
            [("head_on", 0), ("head_on", 1), ("crossing_give_way", 2), ("crossing_give_way", 3), ("bottleneck", 4)]]
    by_family = statistics._by_family(list(reversed(runs)), 1.0)
    assert list(by_family) == ["head_on", "crossing_give_way", "bottleneck"]
    assert by_family["crossing_give_way"] == [2, 3]


def test_a_negative_median_cost_has_one_sign():
    rate = {"rate": None}
    group = {"completed": 1, "collision": rate, "near_miss": rate, "min_separation_m": None,
             "per_vessel": {"path_cost": {"p50": -0.001}, "time_cost_s": {"p50": -0.4}}}
    agg = {"runs_recorded": 1, "runs_defined": 1, "runs_failed": 0, "families": {"f": group}, **group}
    text = statistics.format_aggregate(agg, "c")
    assert "-0.1 % / -0.4 s" in text and "+-" not in text


def test_the_paired_comparison_lists_families_in_the_file_s_order(monkeypatch):
    """The paired table (each method against the first on the same runs) sorted its families by name
    while every other table kept the file's order (a user-style review)."""
    monkeypatch.setattr(statistics, "run_outcome", lambda metrics, near_miss_m: metrics)
    runs = [SimpleNamespace(family=f, index=i, method=m, status="completed",
                            metrics={"collision": False, "min_separation_m": 5.0 + i + (m == "b")})
            for f, i in [("head_on", 0), ("crossing_give_way", 1), ("bottleneck", 2)] for m in ("a", "b")]
    table = statistics.paired(list(reversed(runs)), ["a", "b"])["b"]
    assert list(table) == ["baseline", "head_on", "crossing_give_way", "bottleneck", "all"]
    assert table["all"]["pairs"] == 3 and table["all"]["separation_larger"] == 3
