"""The option tables of the docs list every option a scenario table accepts: a user who writes a
scenario from docs/ finds each key there (the avoidance table had lost the sharp-turn and two
prediction keys that the validator's "allowed" list names)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from mjasc.core.config_tables import describe_params
from mjasc.perception.range_sensor import parse_sensor_options
from mjasc.plugins.registry import parse_avoidance_table, parse_coordination_table, parse_tracking_table

DOCS = Path(__file__).resolve().parent.parent / "docs"


def _table_keys(page: str, start: str, end: str) -> set[str]:
    """The backticked keys of the first column of the tables between two headings."""
    text = (DOCS / page).read_text().split(start, 1)[1].split(end, 1)[0]
    return {k for line in text.splitlines() if line.startswith("| `")
            for k in re.findall(r"`([a-z_0-9]+)`", line.split("|")[1])}


def _options(parse):
    options = parse({}, "x")
    return getattr(options, "options", options)


@pytest.mark.parametrize("page, start, end, parse", [
    ("avoidance.md", "## Configuration (`[vessels.avoidance]`", "## Recording", parse_avoidance_table),
    ("perception.md", "## Tracking (`[vessels.tracking]`)", "## Tracking methods", parse_tracking_table),
    ("perception.md", "## Range sensor (`[vessels.sensor]`)", "## Detections", parse_sensor_options),
    ("coordination.md", "## The speed law (`[vessels.comms]`)", "## Results", parse_coordination_table),
], ids=["avoidance", "tracking", "sensor", "comms"])
def test_every_option_is_in_its_docs_table(page, start, end, parse):
    declared = {r["name"] for r in describe_params(type(_options(parse))) if "." not in r["name"]}
    assert declared, "no declared options"
    assert sorted(declared - _table_keys(page, start, end)) == []
