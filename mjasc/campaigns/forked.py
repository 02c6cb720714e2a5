"""Run children forked from one warmed-up server process: the runs' children of a campaign whose
workers are threads of the driver (the local cluster, the ``campaign`` command).

A child of :class:`~mjasc.campaigns.executor.IsolatedExecutor` is a new interpreter: each imports
MuJoCo and mjasc (~1.6 s of CPU) and pays numba's first calls (its target, then loading the cached
kernels as the first run meets them: ~1.5–2 s more), once per worker and campaign. A
:class:`ForkedExecutor`'s child is a fork of a server process (multiprocessing's ``forkserver``)
that did all of that once (:mod:`mjasc.campaigns.fork_warm`: the imports and one simulated second
of the demo, as a warm-up): it is ready in milliseconds with the kernels loaded, and the server
starts at :func:`start_server` — the ``campaign`` command calls it first, so the server imports
while the driver reads the campaign.

The child is still a process of its own, with the same protocol and statuses as a new
interpreter: one JSON request and one JSON result per message (over a ``multiprocessing`` pipe),
a run over its time limit is killed (``timeout``), a child that dies is ``crashed`` with its exit
code or signal and the next run forks a new one; everything a run prints goes to /dev/null. The
server's warm-up leaves nothing but loaded modules and kernels (a run is a function of its own
text). When no child can be forked (the server failed to start), the executor falls back to a new
interpreter (its base class) for good. Only for children of a non-daemonic process: a Dask worker
process is daemonic and may not start multiprocessing children (it uses the base class).
"""

from __future__ import annotations

import json
import os
import sys
import threading
import time

from mjasc.campaigns.executor import IsolatedExecutor, child_environment

__all__ = ["ForkedExecutor", "start_server"]

#: What the server imports before its first fork (module docstring).
PRELOAD = "mjasc.campaigns.fork_warm"
_LOCK = threading.Lock()


def _context():
    import multiprocessing

    return multiprocessing.get_context("forkserver")


def start_server() -> None:
    """Start the fork server now if it is not running (it imports and warms up, ~3 s of CPU, while
    the caller goes on): with this process's module path, and no OpenGL back-end (a campaign run
    never renders; as for a new interpreter's child). Idempotent; a server that some other code of
    this process started first is used as it is (its children then import what they need)."""
    from multiprocessing import forkserver

    with _LOCK:
        overrides = child_environment()
        saved = {k: os.environ.get(k) for k in overrides}
        os.environ.update(overrides)
        try:
            _context().set_forkserver_preload([PRELOAD])
            forkserver.ensure_running()
        finally:
            for k, v in saved.items():
                if v is None:
                    os.environ.pop(k, None)
                else:
                    os.environ[k] = v


def forking_safe() -> bool:
    """Whether a forked child leaves this process's main module alone: multiprocessing re-imports a
    main *script* in every child (as ``__mp_main__``), which is only harmless under an ``if
    __name__ == "__main__"`` guard; it skips a package's ``__main__`` (``python -m mjasc``,
    ``python -m pytest``) and an interactive session. A script is trusted only when it is
    ``mjasc``'s console script (guarded by its generator); any other script gets new interpreters."""
    main = sys.modules.get("__main__")
    if main is None or getattr(main, "__file__", None) is None:
        return True
    name = getattr(getattr(main, "__spec__", None), "name", None)
    if name is not None:
        return name == "__main__" or name.endswith(".__main__")
    from mjasc.cli import main as cli_main

    return getattr(main, "main", None) is cli_main


def _serve(conn) -> None:
    """The forked child's loop: one JSON request per message, one JSON result per message."""
    from mjasc.campaigns.executor import _prepare, answer, leave_when_closed

    leave_when_closed(conn.fileno())  # (not the fork server's exit: the server waits for its children)
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)  # what runs and libraries print goes nowhere, as from a new interpreter's child
    os.dup2(devnull, 2)
    _prepare()  # (done by the server: nothing left to import unless the server could not preload)
    conn.send_bytes(json.dumps({"ready": os.getpid()}).encode())
    while True:
        try:
            msg = conn.recv_bytes()
        except (EOFError, OSError):  # the driver closed its end: leave
            break
        conn.send_bytes(answer(msg).encode())
    os._exit(0)  # without the interpreter's clean-up (every result is sent, every run closed its files)


class ForkedExecutor(IsolatedExecutor):
    """An :class:`IsolatedExecutor` whose child is forked from the warmed-up server (module
    docstring); the same methods and results."""

    def __init__(self):
        super().__init__()
        self._process = None  # the forked child (multiprocessing.Process)
        self._conn = None  # this end of its pipe
        self._fallback = False  # no fork possible: a new interpreter's child (the base class)
        self.pid: int | None = None  # the current child's process id
        # Held for every call on a child's Process object (is_alive, join, kill, close): the run's
        # thread reaps a child that died while close() joins it from the driver's thread (the
        # campaign's Ctrl-C kills both at once); multiprocessing's Process is not thread-safe — a
        # close() in one thread between another's checks and its use of the process ends in
        # AssertionError or AttributeError there, not in the ValueError of a closed process.
        self._reaping = threading.RLock()

    def start(self) -> None:
        """Start the fork server if needed (the child itself forks when it is waited for or given
        its first run: in milliseconds once the server is up)."""
        if not self._fallback and not forking_safe():
            self._fallback = True
        if self._fallback:
            return super().start()
        try:
            start_server()
        except Exception:  # noqa: BLE001 — no server: new interpreters
            self._fallback = True
            super().start()

    def _fork(self, deadline: float | None) -> bool:
        """Fork the child and read its ready message; False when it is not ready by ``deadline``
        (then killed) — or when no child could be forked (then the fallback has started)."""
        if self._alive(self._process):
            return True
        self._drop()
        if self._released:  # (release(): no new child)
            self._exit = None
            return False
        ctx = _context()
        try:
            if not forking_safe():
                raise RuntimeError("the main module is a script")
            start_server()
            ours, theirs = ctx.Pipe(duplex=True)
            proc = ctx.Process(target=_serve, args=(theirs,), daemon=True, name="mjasc-run")
            proc.start()  # (waits for the server's warm-up the first time)
            theirs.close()
        except Exception:  # noqa: BLE001 — the server died or cannot fork: new interpreters from now on
            self._fallback = True
            super().start()
            return False
        with self._state:
            released = self._released
            if not released:
                self._process, self._conn, self.pid = proc, ours, proc.pid
        if released:  # (by another thread while the child forked: it ends before any run)
            ours.close()
            self._end(proc, 0.0)
            self._exit = None
            return False
        if self._recv(deadline) is None:
            self._kill()
            return False
        return True

    def _recv(self, deadline: float | None) -> bytes | None:
        """The child's next message; None at the deadline or when the child died (then reaped,
        its exit code in ``self._exit``) — or when :meth:`close` closed it from another thread
        meanwhile (a Ctrl-C on the campaign: the exit code is then unknown)."""
        conn, proc = self._conn, self._process  # (close() may drop them from another thread)
        wait = None if deadline is None else max(0.0, deadline - time.monotonic())
        try:
            if conn is None:
                raise OSError("the pipe was closed")
            if conn.poll(wait):
                return conn.recv_bytes()
            self._exit = None
            return None
        except (EOFError, OSError):
            self._exit = self._reaped(proc)
            self._drop()
            return None

    def wait_ready(self, timeout_s: float | None = None) -> bool:
        """Fork the child if there is none and wait for its ready message (module docstring)."""
        if self._fallback:
            return super().wait_ready(timeout_s)
        ok = self._fork(None if timeout_s is None else time.monotonic() + float(timeout_s))
        return super().wait_ready(timeout_s) if self._fallback else ok

    def run(self, request: dict, time_limit_s: float | None = None) -> dict:
        """The result of one request; ``time_limit_s`` counts from the request (and the fork, when
        this request needs a new child)."""
        if self._fallback:
            return super().run(request, time_limit_s)
        t0 = time.perf_counter()
        deadline = None if time_limit_s is None else time.monotonic() + float(time_limit_s)
        if not self._fork(deadline):
            if self._fallback:
                return super().run(request, time_limit_s)
            if self._released:
                return self._released_run(t0)
            if self._exit is None:  # (the child was killed: not ready in time)
                return self._timed_out(time_limit_s, t0)
            return self._died(t0)
        try:
            conn = self._conn
            if conn is None:  # (closed by another thread since the fork)
                raise OSError("the pipe was closed")
            conn.send_bytes(json.dumps(request).encode())
        except (BrokenPipeError, OSError):
            self._kill()
            return self._failure("crashed", "the run's process could not be started", t0)
        msg = self._recv(deadline)
        if msg is None:
            if self._process is not None:
                self._kill()
                return self._timed_out(time_limit_s, t0)
            return self._died(t0)
        return json.loads(msg)

    def _alive(self, proc) -> bool:
        """Whether ``proc`` (a child, or None) is running; a closed one has ended."""
        if proc is None:
            return False
        with self._reaping:
            try:
                return proc.is_alive()
            except ValueError:  # (closed by another thread)
                return False

    def _reaped(self, proc) -> int | None:
        """``proc``'s exit code once it has ended (waiting up to 10 s); None when there is no
        process or another thread closed it meanwhile."""
        if proc is None:
            return None
        with self._reaping:
            try:
                proc.join(10)
                return proc.exitcode
            except ValueError:
                return None

    def _drop(self) -> None:
        with self._state:
            conn, proc = self._conn, self._process
            self._conn = self._process = None
        if conn is not None:
            conn.close()
        self._end(proc, 0.0, kill=False)

    def _end(self, proc, wait_s: float, kill: bool = True) -> None:
        """Wait up to ``wait_s`` for ``proc`` (or None) to leave, kill it if it has not (``kill``),
        and close it once it has ended — under the lock of every call on a child's process."""
        if proc is None:
            return
        with self._reaping:
            try:
                if wait_s > 0:
                    proc.join(wait_s)
                if kill and proc.is_alive():
                    proc.kill()
                    proc.join(10)
                if not proc.is_alive():
                    proc.close()
            except ValueError:  # (closed by another thread meanwhile)
                pass

    def _kill(self) -> None:
        if self._fallback:
            return super()._kill()
        self._take_and_end(0.0)

    def close(self) -> None:
        """End the child: it leaves when its pipe closes (every result it sent is complete). Safe
        while another thread waits in :meth:`run` on this child (the campaign's Ctrl-C): that run
        then ends ``crashed``."""
        if self._fallback:
            return super().close()
        self._take_and_end(5.0)

    def _take_and_end(self, wait_s: float) -> None:
        """Take the child and its pipe (a run's thread then neither reaps nor closes the child),
        close the pipe, give the child ``wait_s`` to leave, kill it if it has not, close it."""
        with self._state:
            proc, conn = self._process, self._conn
            self._conn = self._process = None
        if conn is not None:
            conn.close()
        self._end(proc, wait_s)
