"""Whether numba's cache of mjasc's compiled kernels is empty: the first run in a fresh checkout
(or after the cache was deleted) compiles every kernel it meets, which takes minutes instead of
the ~1 s of loading them, and nothing else says why that run is slow.

numba keeps a kernel's machine code next to its module (``__pycache__/*.nbi`` and ``*.nbc``), or
under ``NUMBA_CACHE_DIR`` when that is set (:mod:`mjasc.core.compiled`). :func:`cache_is_cold`
looks for any index file there; :data:`COLD_HINT` is the one line the CLI prints then, and a
campaign waits :data:`COLD_START_WAIT_S` instead of its usual limit for its first run child (whose
warm-up compiles them).
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["cache_is_cold", "COLD_HINT", "COLD_START_WAIT_S"]

#: What the CLI says when the cache is cold (printed once, to stderr).
COLD_HINT = ("mjasc: compiling mjasc's kernels (numba) once for this checkout — the first run takes a few "
             "minutes; later runs load them in about a second")

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
