"""The README's code runs from any folder (issue 8: self-contained docs).

Every ``python`` block compiles and runs in an empty temporary folder (the README keeps its
examples short: a 10 s scenario, a two-run campaign of 5 s runs, 10 s of bare physics). Every
``mjasc …`` line of a ``bash`` block parses with the real command line, and a scenario or campaign
it names is a bundled name, not a path into the repository (which would work only from its root).
No file of the repository names a machine path or links outside the repository.
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from mjasc.cli import build_parser
from mjasc.core.resources import resolve_bundled

ROOT = Path(__file__).resolve().parent.parent
README = (ROOT / "README.md").read_text()


def _blocks(language: str) -> list[str]:
    return re.findall(rf"^```{language}\n(.*?)^```", README, flags=re.S | re.M)


PYTHON = _blocks("python")
COMMANDS = [line.split("#", 1)[0].strip() for block in _blocks("bash") for line in block.splitlines()
            if line.strip().startswith(("mjasc ", ".venv/bin/mjasc "))]


def test_the_readme_has_code_to_check():
    assert len(PYTHON) >= 2 and any("mjasc.load_scenario(" in b for b in PYTHON)
    assert any(c.split()[1:2] == ["run"] for c in COMMANDS) and any(c.split()[1:2] == ["list"] for c in COMMANDS)


@pytest.mark.parametrize("index", range(len(PYTHON)))
def test_python_block_runs_in_an_empty_folder(index, tmp_path, monkeypatch, capsys):
    code = compile(PYTHON[index], f"README.md python block {index + 1}", "exec")
    monkeypatch.chdir(tmp_path)
    exec(code, {"__name__": f"readme_block_{index + 1}"})


@pytest.mark.parametrize("command", COMMANDS)
def test_command_parses_and_names_bundled_files(command, tmp_path, monkeypatch):
    argv = shlex.split(command)[1:]
    args = build_parser().parse_args(argv)  # SystemExit on a stale option or sub-command
    monkeypatch.chdir(tmp_path)
    for attr, kind in (("scenario", "scenario"), ("campaign", "campaign")):
        ref = getattr(args, attr, None)
        if ref is None:
            continue
        assert not (ROOT / ref).exists(), f"{command!r}: {ref} is a repository path; use its bundled name"
        if not ref.endswith(".toml"):  # a file name stands for the reader's own file
            assert resolve_bundled(ref, kind).is_file(), f"{command!r}: no bundled {kind} {ref!r}"


# ------------------------------------------------------------------ nothing outside the repository
def _text_files() -> list[Path]:
    """The repository's own text files (build products such as ``*.egg-info/`` excluded)."""
    skip = {".git", ".venv", "runs", "build", "dist", "__pycache__", ".pytest_cache"}
    suffixes = {".md", ".py", ".toml", ".xml", ".sh", ".txt", ".cfg", ".yml", ".yaml", ".lock", ""}
    return [p for p in ROOT.rglob("*") if p.is_file() and p.suffix in suffixes
            and not skip & set(p.relative_to(ROOT).parts)
            and not any(part.endswith(".egg-info") for part in p.relative_to(ROOT).parts)
            and p != Path(__file__).resolve()]


MACHINE_PATHS = re.compile(r"(?<![\w.])(/work/|/root/|/home/|\.\./shared/|shared/reference/)")


def test_no_file_names_a_path_outside_the_repository():
    hits = []
    for p in _text_files():
        try:
            text = p.read_text()
        except UnicodeDecodeError:
            continue
        for n, line in enumerate(text.splitlines(), 1):
            if MACHINE_PATHS.search(line):
                hits.append(f"{p.relative_to(ROOT)}:{n}: {line.strip()}")
    assert hits == []


def test_markdown_links_stay_inside_the_repository():
    outside = []
    for p in ROOT.rglob("*.md"):
        if {".git", ".venv", "runs"} & set(p.relative_to(ROOT).parts):
            continue
        for target in re.findall(r"\]\(([^)\s]+)\)", p.read_text()):
            if re.match(r"[a-z]+:", target) or target.startswith("#"):
                continue  # a URL or an anchor
            resolved = (p.parent / target.split("#", 1)[0]).resolve()
            if not resolved.is_relative_to(ROOT):
                outside.append(f"{p.relative_to(ROOT)}: {target}")
    assert outside == []


def test_code_and_data_paths_named_in_the_readme_exist():
    """Module, scenario and script paths in backticks (the ones a refactor moves) exist."""
    named = set(re.findall(r"`((?:mjasc|tasks|assets|tests|benchmarks|scripts)/[^`\s]*)`", README))
    assert any(n.startswith("mjasc/") for n in named)
    missing = sorted(n for n in named if not any(ROOT.glob(n.rstrip("/"))))
    assert missing == []
