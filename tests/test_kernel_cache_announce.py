"""A partly filled kernel cache: the CLI says so when the first of mjasc's kernels compiles instead
of loading (a reviewer's first run took 56 s in silence: another process had cached only some of
the kernels, so the cache did not count as cold)."""

import io

import numba
from numba.core import event

from mjasc.core.kernel_cache import PARTLY_COLD_HINT, announce_compiles


def _fresh(module: str):
    def twice(x):
        return 2.0 * x
    twice.__module__ = module
    return numba.njit(cache=False)(twice)


def test_the_first_compile_of_an_mjasc_kernel_is_announced_once():
    out = io.StringIO()
    listener = announce_compiles(out)
    try:
        _fresh("somebody_else.kernels")(1.0)  # another package's kernel: nothing said
        assert out.getvalue() == ""
        _fresh("mjasc.probe_kernels")(1.0)
        _fresh("mjasc.probe_kernels")(2.0)
        assert out.getvalue() == PARTLY_COLD_HINT + "\n"
    finally:
        event.unregister("numba:compile", listener)


def test_a_kernel_loaded_from_the_cache_is_not_announced(tmp_path, monkeypatch):
    """numba raises its compile event only when it compiles, not when the cache answers."""
    import importlib
    import sys

    src = tmp_path / "mjasc_probe_cached.py"
    src.write_text("import numba\n\n@numba.njit(cache=True)\ndef f(x):\n    return x + 1.0\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    mod = importlib.import_module("mjasc_probe_cached")
    mod.f(1.0)  # compiled and cached
    del sys.modules["mjasc_probe_cached"]
    mod = importlib.import_module("mjasc_probe_cached")
    mod.f.py_func.__module__ = "mjasc.probe_cached"
    out = io.StringIO()
    listener = announce_compiles(out)
    try:
        assert mod.f(1.0) == 2.0  # loaded from the cache
        assert out.getvalue() == ""
    finally:
        event.unregister("numba:compile", listener)
        del sys.modules["mjasc_probe_cached"]
