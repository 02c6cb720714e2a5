"""The first run in a fresh checkout compiles the kernels (minutes): mjasc.core.kernel_cache tells
when numba's cache is empty, the CLI says so in one line, and a campaign waits long enough for its
first run child's warm-up."""

import pytest

from mjasc.core import kernel_cache
from mjasc.core.kernel_cache import COLD_HINT, cache_is_cold


@pytest.fixture(autouse=True)
def _fresh(monkeypatch):
    monkeypatch.setattr(kernel_cache, "_FIRST", {})
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)


def test_an_empty_cache_is_cold_and_one_index_file_makes_it_warm(tmp_path):
    pkg = tmp_path / "pkg"
    (pkg / "sub" / "__pycache__").mkdir(parents=True)
    (pkg / "sub" / "__pycache__" / "mod.cpython-311.pyc").write_bytes(b"")
    assert cache_is_cold(pkg)
    (pkg / "sub" / "__pycache__" / "mod.kernel-12.py311.nbi").write_bytes(b"")
    assert cache_is_cold(pkg)  # the first answer of the process is kept
    kernel_cache._FIRST.clear()
    assert not cache_is_cold(pkg)


def test_numba_cache_dir_is_where_the_kernels_are_looked_for(tmp_path, monkeypatch):
    pkg, cache = tmp_path / "pkg", tmp_path / "cache"
    (pkg / "__pycache__").mkdir(parents=True)
    (pkg / "__pycache__" / "a.k-1.py311.nbi").write_bytes(b"")  # (not where numba looks now)
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(cache))
    assert cache_is_cold(pkg)
    (cache / "pkg").mkdir(parents=True)
    (cache / "pkg" / "a.k-1.py311.nbi").write_bytes(b"")
    kernel_cache._FIRST.clear()
    assert not cache_is_cold(pkg)


def test_this_checkout_is_warm_after_the_tests_ran_a_kernel():
    from mjasc.core.compiled import maximum

    assert maximum(1.0, 2.0) == 2.0  # (compiled and cached, if it was not)
    assert not cache_is_cold()


@pytest.mark.parametrize("cold", [True, False])
def test_the_cli_says_once_that_the_first_run_compiles(cold, monkeypatch, capsys):
    from mjasc.cli import main

    monkeypatch.setattr(kernel_cache, "_FIRST", {(kernel_cache._PACKAGE, None): cold})
    monkeypatch.setenv("MJASC_COMPILE_HINTS", "1")  # (the suite silences them: tests/conftest.py)
    assert main(["run", "no_such_scenario_here"]) == 2
    err = capsys.readouterr().err
    assert (COLD_HINT in err) is cold and err.count("compiling") == (1 if cold else 0)
    main(["list"])  # (a command that does not simulate says nothing)
    assert COLD_HINT not in capsys.readouterr().err
    monkeypatch.setenv("MJASC_COMPILE_HINTS", "0")  # (and none when told so)
    assert main(["run", "no_such_scenario_here"]) == 2
    assert "compiling" not in capsys.readouterr().err
