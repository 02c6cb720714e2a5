"""mjasc installs as a wheel and runs outside the checkout (issue 8: packaging).

The packaging config must list every subpackage and ship every data file (vessel models, scene,
bundled scenarios); a wheel built with ``pip wheel . --no-deps`` from the repository's files,
installed into a fresh virtual environment with no checkout on ``sys.path``, must list and run a
bundled scenario from an unrelated folder.

Installing every dependency into a fresh venv takes minutes, so the temporary venv gets the
dependencies of the environment running the tests through a ``.pth`` line naming its
site-packages folder. ``.pth`` files inside a folder added that way are not processed, so the
checkout's editable-install finder (a ``.pth`` hook) does not load there; the test checks that
``mjasc`` is imported from the temporary venv.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import tomllib
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())
SETUPTOOLS = PYPROJECT["tool"]["setuptools"]
# Repository folder -> package it installs as (besides mjasc/ itself).
DATA_PACKAGES = {"assets": "mjasc.assets", "tasks": "mjasc.tasks"}


def _git(*args: str, input: str | None = None) -> subprocess.CompletedProcess | None:
    if shutil.which("git") is None:
        return None
    return subprocess.run(["git", "-C", str(ROOT), *args], input=input, capture_output=True, text=True)


def _repository_files() -> list[str]:
    """The files a clean checkout has: tracked or untracked but not ignored (git), else all files
    outside caches and build outputs."""
    proc = _git("ls-files", "--cached", "--others", "--exclude-standard", "-z")
    if proc is not None and proc.returncode == 0:
        return sorted({f for f in proc.stdout.split("\0") if f and (ROOT / f).is_file()})
    skip = {".git", ".venv", "runs", "build", "dist", "__pycache__", ".pytest_cache"}
    return sorted(p.relative_to(ROOT).as_posix() for p in ROOT.rglob("*")
                  if p.is_file() and not skip & set(p.relative_to(ROOT).parts)
                  and not p.name.endswith((".pyc", ".egg-info")))


def _python_package_dirs() -> set[str]:
    """Dotted names of every folder of mjasc/ holding Python code."""
    return {".".join(p.parent.relative_to(ROOT).parts) for p in (ROOT / "mjasc").rglob("*.py")
            if "__pycache__" not in p.parts}


def test_packaging_config_lists_every_subpackage():
    listed = set(SETUPTOOLS["packages"])
    found = _python_package_dirs()
    assert found - listed == set(), "subpackages missing from [tool.setuptools] packages in pyproject.toml"
    assert listed - found - set(DATA_PACKAGES.values()) == set(), "packages listed that do not exist"
    for folder, package in DATA_PACKAGES.items():
        assert package in listed and SETUPTOOLS["package-dir"][package] == folder
        assert (ROOT / folder / "__init__.py").is_file()
    for name in found:
        assert (ROOT.joinpath(*name.split(".")) / "__init__.py").is_file(), f"{name} has no __init__.py"


def test_no_package_file_is_git_ignored():
    """A clean checkout (CI, a wheel built from a clone) must have every file the package ships:
    no .gitignore pattern may match one (``runs/`` once hid ``mjasc/runs/__init__.py``)."""
    files = [p.relative_to(ROOT).as_posix() for folder in ("mjasc", *DATA_PACKAGES)
             for p in (ROOT / folder).rglob("*") if p.is_file() and "__pycache__" not in p.parts]
    proc = _git("check-ignore", "--no-index", "--stdin", input="\n".join(files))
    if proc is None or proc.returncode not in (0, 1):
        pytest.skip("not a git checkout")
    assert proc.stdout.split() == [], "package files matched by .gitignore"


def test_import_mjasc_is_cheap_and_the_top_level_api_resolves():
    code = ("import sys, mjasc\n"
            "heavy = sorted(m for m in ('mujoco', 'dm_control', 'numpy', 'scipy') if m in sys.modules)\n"
            "assert not heavy, heavy\n"
            "assert 'MUJOCO_GL' in __import__('os').environ\n"
            "from mjasc.runs.scenario import load_scenario\n"
            "from mjasc.runs.runner import run_scenario\n"
            "from mjasc.campaigns.spec import load_campaign_spec as load_campaign\n"
            "from mjasc.campaigns.engine import run_campaign\n"
            "assert (mjasc.load_scenario, mjasc.run_scenario, mjasc.load_campaign, mjasc.run_campaign) == "
            "(load_scenario, run_scenario, load_campaign, run_campaign)\n"
            "assert callable(mjasc.suite.load) and 'demo' in mjasc.bundled_scenarios()\n"
            "assert 'campaigns/demo_monte_carlo' in mjasc.bundled_campaigns()\n"
            "assert set(mjasc.__all__) <= set(dir(mjasc))\n"
            "try:\n    mjasc.no_such_name\nexcept AttributeError:\n    pass\nelse:\n    raise SystemExit('no error')\n")
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    env.pop("MUJOCO_GL", None)
    proc = subprocess.run([sys.executable, "-c", code], cwd=ROOT / "tests", env=env, capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr


# ----------------------------------------------------------------------------- the wheel
@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """``pip wheel . --no-deps`` of a copy of the repository's files (the build writes build/ and
    *.egg-info into its source folder; the copy keeps the checkout clean)."""
    tmp = tmp_path_factory.mktemp("wheel")
    src = tmp / "src"
    for rel in _repository_files():
        dest = src / rel
        dest.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(ROOT / rel, dest)
    proc = subprocess.run([sys.executable, "-m", "pip", "wheel", str(src), "--no-deps", "-q", "-w", str(tmp / "dist")],
                          capture_output=True, text=True, timeout=300)
    if proc.returncode != 0 and "satisfies the requirement setuptools" in proc.stderr:
        pytest.skip(f"no package index reachable for the build backend: {proc.stderr.strip()[-300:]}")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    (whl,) = (tmp / "dist").glob("mjasc-*.whl")
    return whl


def test_wheel_ships_every_module_and_data_file(wheel):
    names = set(zipfile.ZipFile(wheel).namelist())
    assert "mjasc/assets/vessels/otter/otter.xml" in names
    assert "mjasc/tasks/demo.toml" in names
    assert "mjasc/tasks/campaigns/demo_monte_carlo.toml" in names
    expected = set()
    for rel in _repository_files():
        top, _, rest = rel.partition("/")
        if top == "mjasc":
            expected.add(rel)
        elif top in DATA_PACKAGES and rest:
            expected.add(f"mjasc/{top}/{rest}")
    assert expected - names == set(), "files of the package folders missing from the wheel (package-data?)"


def _site_packages(python: Path) -> Path:
    out = subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                         capture_output=True, text=True, check=True).stdout.strip()
    return Path(out)


def test_installed_wheel_runs_a_bundled_scenario_from_another_folder(wheel, tmp_path):
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True, timeout=120)
    python = venv / "bin" / "python"
    site = _site_packages(python)
    # The dependencies: this environment's site-packages, appended to the new venv's sys.path.
    ours = {sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"]}
    (site / "mjasc_test_dependencies.pth").write_text("".join(f"{p}\n" for p in sorted(ours)))
    proc = subprocess.run([sys.executable, "-m", "pip", "--python", str(python), "install", "--no-deps",
                           "--no-index", "-q", str(wheel)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr

    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "PYTHONSTARTUP")}

    def run(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run(list(args), cwd=elsewhere, env=env, capture_output=True, text=True, timeout=300)

    where = run(str(python), "-c", "import sys, mjasc; print(mjasc.__file__); "
                                   "assert not [m for m in sys.modules if m.startswith('__editable__')]")
    assert where.returncode == 0, where.stderr
    assert Path(where.stdout.strip()).is_relative_to(site), f"mjasc imported from {where.stdout.strip()}"
    assert not Path(where.stdout.strip()).is_relative_to(ROOT)

    listing = run(str(venv / "bin" / "mjasc"), "list")
    assert listing.returncode == 0, listing.stderr
    for name in ("demo", "thesis_6_2_dock", "demo_monte_carlo", "otter", "delfim"):
        assert f"  {name} " in listing.stdout, listing.stdout
    assert "INVALID" not in listing.stdout

    done = run(str(venv / "bin" / "mjasc"), "run", "demo", "--duration", "2", "--out", "out", "--no-progress")
    assert done.returncode == 0, done.stdout + done.stderr
    summary = json.loads((elsewhere / "out" / "summary.json").read_text())
    assert summary["status"] == "completed"
    assert summary["sim_time_s"] == pytest.approx(2.0)
    assert sorted(summary["vessels"]) == ["alpha", "bravo", "charlie"]
    assert (elsewhere / "out" / "recording.rrd").is_file()
