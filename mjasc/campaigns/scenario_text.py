"""A generated run as scenario text (TOML) and as a file that ``mjasc run`` replays.

Every run of a campaign is a normal scenario (tasks/README.md): :class:`~mjasc.campaigns.spec.RunSpec`
keeps it as TOML text, and nothing else about the run lives outside that text. :func:`scenario_toml`
writes a scenario document (the dict that :func:`mjasc.runs.scenario.parse_scenario` reads) in the
compact layout of the shipped task files — top-level keys, then ``[tables]``, then
``[[arrays of tables]]`` whose sub-tables are inline (``controller = { type = …, waypoints = […] }``)
— with an optional header of ``#`` comment lines. Floats are written with ``repr`` (shortest
round-trip form), so ``tomllib.loads(scenario_toml(doc)) == doc`` holds exactly for the documents
mjasc generates (str, bool, int, finite float, lists, tables); the tests check it. (``tomli_w``
writes every array one element per line, which makes a three-vessel scenario a few hundred lines.)

:func:`write_scenario` writes a run's text to a file; :func:`load_run_scenario` parses a run's
text into the :class:`~mjasc.runs.scenario.Scenario` the engine runs. ``mjasc run FILE`` on the
written file and running the parsed scenario give the same ``summary.json`` (timing fields aside).
"""

from __future__ import annotations

import json
import math
import re
import tomllib
from pathlib import Path
from typing import Any, Mapping

__all__ = ["scenario_toml", "write_scenario", "load_run_scenario"]

_BARE = re.compile(r"^[A-Za-z0-9_-]+$")


def _key(k: str) -> str:
    return k if _BARE.match(k) else json.dumps(k, ensure_ascii=False)


def _value(v: Any, where: str) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise ValueError(f"{where}: TOML scenario values must be finite, got {v}")
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False).replace("\x7f", "\\u007f")  # a TOML basic string
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x, f"{where}[{i}]") for i, x in enumerate(v)) + "]"
    if isinstance(v, Mapping):
        if not v:
            return "{}"
        return "{ " + ", ".join(f"{_key(k)} = {_value(x, f'{where}.{k}')}" for k, x in v.items()) + " }"
    if hasattr(v, "item"):  # a numpy scalar
        return _value(v.item(), where)
    raise TypeError(f"{where}: cannot write {type(v).__name__} as TOML")


def _is_table_array(v: Any) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(x, Mapping) for x in v)


def scenario_toml(doc: Mapping[str, Any], header: str = "") -> str:
    """The TOML text of a scenario document (module docstring). ``header``: lines written first as
    ``#`` comments."""
    lines = [f"# {line}".rstrip() for line in header.splitlines()] if header else []
    scalars = [(k, v) for k, v in doc.items() if not isinstance(v, Mapping) and not _is_table_array(v)]
    tables = [(k, v) for k, v in doc.items() if isinstance(v, Mapping)]
    arrays = [(k, v) for k, v in doc.items() if _is_table_array(v)]
    lines += [f"{_key(k)} = {_value(v, k)}" for k, v in scalars]
    for k, v in tables:
        lines += ["", f"[{_key(k)}]"] + [f"{_key(kk)} = {_value(vv, f'{k}.{kk}')}" for kk, vv in v.items()]
    for k, items in arrays:
        for i, item in enumerate(items):
            lines += ["", f"[[{_key(k)}]]"] + [f"{_key(kk)} = {_value(vv, f'{k}[{i}].{kk}')}"
                                               for kk, vv in item.items()]
    return "\n".join(lines) + "\n"


def load_run_scenario(text: str, source: str = "<run>"):
    """The :class:`~mjasc.runs.scenario.Scenario` of a run's TOML text (raises ScenarioError)."""
    from mjasc.runs.scenario import parse_scenario

    return parse_scenario(tomllib.loads(text), source)


def write_scenario(run, path: str | Path) -> Path:
    """Write a run's scenario (a :class:`~mjasc.campaigns.spec.RunSpec`, or its text) to ``path``
    (folders created): ``mjasc run PATH`` replays the run exactly. Returns the path."""
    text = run if isinstance(run, str) else run.scenario_toml
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path
