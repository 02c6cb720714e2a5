"""One seed bound: a scenario file's seed and --seed take 0 … 2**32 − 1 (MAX_SEED, declared once)."""

import pytest

from mjasc.cli import main
from mjasc.runs.scenario import load_scenario


def test_a_scenario_seed_and_seed_option_share_one_bound(tmp_path, capsys):
    from mjasc.runs.scenario import ScenarioError
    from mjasc.runs.scenario_values import MAX_SEED

    assert load_scenario("demo", seed=MAX_SEED).seed == MAX_SEED
    with pytest.raises(ScenarioError, match="seed: must be ≤ 4294967295"):
        load_scenario("demo", seed=MAX_SEED + 1)
    with pytest.raises(SystemExit):
        main(["run", "demo", "--seed", str(MAX_SEED + 1)])
    assert "must be ≤ 4294967295" in capsys.readouterr().err
