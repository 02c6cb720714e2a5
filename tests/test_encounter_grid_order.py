"""Which grid varies fastest in an encounter family: the last in mjasc's declaration of the
family's parameters (docs/campaigns.md's parameter table, in that order), not the file's order —
a reviewer mapped run indices to grid points from the file's order and got them wrong."""

import re
from dataclasses import fields
from pathlib import Path

from mjasc.campaigns.encounter_parameters import Bottleneck, Conditions, TargetParameters, Team
from mjasc.campaigns.spec import load_campaign_spec

DOCS = Path(__file__).resolve().parents[1] / "docs" / "campaigns.md"


def _family(tmp_path, parameters: str):
    path = tmp_path / "grid.toml"
    path.write_text(f"""
name = "grid"
[[families]]
kind = "head_on"
runs_per_point = 1
[families.parameters]
{parameters}
""")
    return load_campaign_spec(path)


def test_the_declared_order_not_the_file_s_sets_the_fastest_grid(tmp_path):
    """docs/campaigns.md's example: dcpa written first and current last, or the other way round,
    give the same runs in the same order, dcpa fastest."""
    expected = [(-1.0, 0.0), (1.0, 0.0), (-1.0, 0.1), (1.0, 0.1)]
    for text in ("dcpa_m = { grid = [-1.0, 1.0] }\ncurrent_m_s = { grid = [0.0, 0.1] }",
                 "current_m_s = { grid = [0.0, 0.1] }\ndcpa_m = { grid = [-1.0, 1.0] }"):
        spec = _family(tmp_path, text)
        got = [(spec.run(k).parameters["dcpa_m"], spec.run(k).parameters["current_m_s"]) for k in range(4)]
        assert got == expected, text


def test_the_docs_table_lists_the_parameters_in_declared_order():
    """The table whose order the text says decides: the conditions, a team's, a bottleneck's, then
    a target's, each group in its dataclass's field order."""
    declared = [f.name for cls in (Conditions, Team, Bottleneck, TargetParameters) for f in fields(cls)]
    text = DOCS.read_text()
    table = text[text.index("| parameter (in declared order) |"):]
    table = table[:table.index("\n\n")]
    listed = [name for row in table.splitlines()[2:] for name in re.findall(r"`([a-z_0-9]+)`", row.split("|")[1])]
    assert listed == declared
