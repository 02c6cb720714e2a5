"""``python -m mjasc``: the command line (:func:`mjasc.cli.main`).

A ``campaign`` command leaves without the interpreter's final clean-up (module teardown and the
last garbage collection of MuJoCo, numba, SciPy and Dask: ~0.4–0.6 s of wall time after the
command's work, measured): once every exit handler has run — the one below is registered first,
so it runs last, after logging's flush, multiprocessing's and Dask's handlers and every
``weakref.finalize`` — it flushes stdout and stderr and ends the process with the command's exit
status. By then the campaign has closed everything it wrote (the store, the exports,
``campaign.json``, the runs' children, the cluster). Other commands exit as usual; so does a
command that raised (its traceback is printed as usual).
"""

import atexit
import os
import sys

_FAST_EXIT_COMMANDS = ("campaign",)
_status = None  # the exit status to leave with, once the command has returned (None: the usual exit)


def _leave() -> None:
    if _status is None:
        return
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except Exception:  # noqa: BLE001 — a closed pipe: nothing more to say, leave all the same
        pass
    os._exit(_status)


atexit.register(_leave)  # (first registered: the last exit handler to run)

from mjasc.cli import main  # noqa: E402  (after the exit handler)

_code = main()
if sys.argv[1:2] and sys.argv[1] in _FAST_EXIT_COMMANDS and isinstance(_code, int) and 0 <= _code <= 255:
    _status = _code
raise SystemExit(_code)
