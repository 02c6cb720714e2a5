"""Where the shipped scenarios and hulls are read from: the checkout mjasc is imported from.

A second checkout put first on ``PYTHONPATH`` (its code imported) read the scenarios, campaigns and
hulls of the checkout installed in the environment: the editable install maps the data packages
``mjasc.tasks`` and ``mjasc.assets`` to its own folders (a reviewer's find)."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_a_second_checkout_reads_its_own_tasks_and_assets(tmp_path):
    clone = tmp_path / "clone"
    shutil.copytree(ROOT / "mjasc", clone / "mjasc", ignore=shutil.ignore_patterns("__pycache__"))
    (clone / "pyproject.toml").write_text("[project]\nname = \"mjasc\"\n")
    (clone / "tasks").mkdir()
    (clone / "tasks" / "only_in_the_clone.toml").write_text("name = \"x\"\n")
    (clone / "assets").mkdir()
    code = ("import mjasc\nfrom mjasc.core.resources import assets_dir, bundled_scenarios\n"
            "print(mjasc.__file__)\nprint(assets_dir())\nprint(sorted(bundled_scenarios()))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=tmp_path,
                         env={**os.environ, "PYTHONPATH": str(clone)}).stdout.splitlines()
    assert out[0] == str(clone / "mjasc" / "__init__.py")
    assert out[1] == str(clone / "assets")
    assert out[2] == "['only_in_the_clone']"


def test_the_installed_checkout_reads_its_own():
    from mjasc.core.resources import assets_dir, tasks_dir

    assert tasks_dir() == ROOT / "tasks" and assets_dir() == ROOT / "assets"
