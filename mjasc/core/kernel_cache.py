"""Whether numba's cache of mjasc's compiled kernels is empty: the first run in a fresh checkout
(or after the cache was deleted) compiles every kernel it meets, which takes minutes instead of
the ~1 s of loading them, and nothing else says why that run is slow.

numba keeps a kernel's machine code next to its module (``__pycache__/*.nbi`` and ``*.nbc``), or
under ``NUMBA_CACHE_DIR`` when that is set (:mod:`mjasc.core.compiled`). :func:`cache_is_cold`
looks for any index file there; :data:`COLD_HINT` is the one line the CLI prints then, and a
campaign waits :data:`COLD_START_WAIT_S` instead of its usual limit for its first run child (whose
warm-up compiles them). A cache only partly filled (another process compiling the rest, a kernel
whose source changed) is not cold, but its first run compiles the missing kernels all the same:
:func:`announce_compiles` prints :data:`PARTLY_COLD_HINT` when the first of mjasc's kernels is
compiled rather than loaded (numba's ``numba:compile`` event, which a cache hit does not raise).
``MJASC_COMPILE_HINTS=0`` in the environment silences both (a program that reads the CLI's error
lines; the test suite, whose tests meet the cache in any state).
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["cache_is_cold", "announce_compiles", "COLD_HINT", "PARTLY_COLD_HINT", "COLD_START_WAIT_S"]

#: What the CLI says when the cache is cold (printed once, to stderr).
COLD_HINT = ("mjasc: compiling mjasc's kernels (numba) once for this checkout — the first run takes a few "
             "minutes; later runs load them in about a second")

#: What the CLI says when a kernel compiles although the cache was not empty (once, to stderr).
PARTLY_COLD_HINT = ("mjasc: compiling mjasc kernels that numba had not cached yet (a partly filled cache, or changed "
                    "sources) — this run is slower and its timing includes it; later runs load them")

#: How long a campaign waits for its first run child when the cache is cold [s]: its warm-up
#: compiles the kernels (~3–6 min on a busy 2-core machine).
COLD_START_WAIT_S = 1800.0

_PACKAGE = Path(__file__).resolve().parent.parent


_FIRST: dict = {}  # (folder, NUMBA_CACHE_DIR) → the first answer in this process


def cache_is_cold(package: Path | None = None) -> bool:
    """True when no kernel of ``package`` (default: mjasc) had been cached when this process first
    asked: no ``*.nbi`` index under its folders' ``__pycache__``, or under ``NUMBA_CACHE_DIR`` when
    that is set. The first answer is kept (the kernels this process's children compile meanwhile do
    not make it warm: a campaign asks after its first children started). False when unsure (a
    package folder numba cannot write to caches elsewhere: nothing to say then)."""
    root = Path(package) if package is not None else _PACKAGE
    key = (root, os.environ.get("NUMBA_CACHE_DIR"))
    if key not in _FIRST:
        _FIRST[key] = _cold(*key)
    return _FIRST[key]


def _cold(root: Path, custom: str | None) -> bool:
    if custom:
        base = Path(custom)
        return not base.is_dir() or not any(True for _ in base.rglob("*.nbi"))
    if not os.access(root, os.W_OK):
        return False
    for folder, dirs, files in os.walk(root):
        dirs[:] = [d for d in dirs if not d.startswith(".")]
        if folder.endswith("__pycache__") and any(f.endswith(".nbi") for f in files):
            return False
    return True


def announce_compiles(stream):
    """Print :data:`PARTLY_COLD_HINT` to ``stream`` when the first of mjasc's kernels is compiled in
    this process rather than loaded from numba's cache (once; kernels of other packages are left
    out), as a listener of numba's ``numba:compile`` event. Returns the listener: the caller removes
    it (``numba.core.event.unregister("numba:compile", it)``) when its command ends — the CLI does."""
    from numba.core import event

    class _FirstCompile(event.Listener):
        said = False

        def on_start(self, ev):
            dispatcher = (ev.data or {}).get("dispatcher")
            module = getattr(getattr(dispatcher, "py_func", None), "__module__", "") or ""
            if not self.said and module.startswith("mjasc."):
                self.said = True
                try:
                    print(PARTLY_COLD_HINT, file=stream, flush=True)
                except (OSError, ValueError):  # (a closed or gone stream: a hint, never an error)
                    pass

        def on_end(self, ev):
            pass

    listener = _FirstCompile()
    event.register("numba:compile", listener)
    return listener
