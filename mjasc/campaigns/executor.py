"""Run campaign runs in a child process, so that a run that crashes its process (a segfault in a
native library), hangs, or exceeds its time limit costs only itself.

:class:`IsolatedExecutor` keeps one persistent child Python process (``python -m
mjasc.campaigns.executor``) and hands it one run at a time over a pipe (one JSON line per request
and per result, after one ``{"ready": pid}`` line once its imports are done,
:meth:`IsolatedExecutor.wait_ready`): the interpreter, MuJoCo and mjasc load once per child, not
once per run. When a run exceeds its time limit the child is killed (``timeout``); when the child
dies (``crashed``, with its exit code or signal) the next run starts a new one. Plain ``subprocess`` is used rather than
``multiprocessing``: Dask's worker processes are daemonic and may not start multiprocessing
children.

A request and its result are :mod:`mjasc.campaigns.run_request`'s; :func:`execute_in_process` (the
child's code path) is re-exported here.
"""

from __future__ import annotations

import atexit
import json
import os
import select
import subprocess
import sys
import threading
import time

from mjasc.campaigns.run_request import execute_in_process

__all__ = ["IsolatedExecutor", "execute_in_process", "run_isolated", "start_isolated", "adopt_isolated",
           "release_isolated", "prestart_isolated", "take_prestarted", "close_prestarted"]


def child_environment() -> dict:
    """What a run child's environment sets over this process's: ``PYTHONPATH`` (the same mjasc as
    this process) and ``MUJOCO_GL=disable`` (a campaign run never renders: no OpenGL back-end to
    load; MuJoCo and dm_control skip it, ~0.3 s of the child's start-up)."""
    return {"PYTHONPATH": os.pathsep.join(p for p in sys.path if p), "MUJOCO_GL": "disable"}


class IsolatedExecutor:
    """A persistent child process that runs one request at a time (module docstring)."""

    def __init__(self, python: str | None = None, warm: bool = False):
        self.python = python or sys.executable
        self.warm = warm  # the child warms up numba's kernels when no run waits (_serve)
        self._proc: subprocess.Popen | None = None
        self._buf = b""
        self._starting = False  # the child's "ready" line (imports done) is still to be read
        self._exit: int | None = None  # the exit code of a child that died
        # release(): for good — its worker is shutting down; a run that a worker's thread began
        # before it (the campaign's Ctrl-C) must not start a child that nothing would close
        self._released = False
        self._state = threading.Lock()  # guards the child's reference against release()

    def _start(self) -> None:
        env = {**os.environ, **child_environment()}
        proc = subprocess.Popen([self.python, "-m", "mjasc.campaigns.executor", *(["--warm"] if self.warm else [])],
                                stdin=subprocess.PIPE,
                                stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, env=env, bufsize=0)
        with self._state:
            released = self._released
            if not released:
                self._proc, self._buf, self._starting = proc, b"", True
        if released:  # (by another thread while the child started: it has not begun anything)
            proc.kill()
            proc.wait()

    @staticmethod
    def _stop(proc: subprocess.Popen) -> None:
        """Kill ``proc`` and reap it (whatever state another thread left it in)."""
        try:
            proc.kill()
            proc.wait(timeout=10)
        except Exception:  # noqa: BLE001
            pass

    def _kill(self) -> None:
        proc = self._proc
        if proc is not None:
            self._stop(proc)
        self._proc = None

    def release(self) -> None:
        """Close the child for good: its worker is shutting down (a local cluster's, on a Ctrl-C).
        A run a worker's thread began before this, or begins after, starts no new child: it ends
        ``crashed`` (closed only, :meth:`close`, the next run starts a new child)."""
        with self._state:
            self._released = True
        self.close()

    def _released_run(self, t0: float) -> dict:
        return self._failure("crashed", "the run's worker is shutting down (its run process was released)", t0)

    def close(self) -> None:
        """End the child: it leaves at the end of its input (every result it wrote is complete)."""
        with self._state:
            proc = self._proc  # (a run's thread may drop it meanwhile: the campaign's Ctrl-C)
        if proc is not None and proc.poll() is None:
            try:
                proc.stdin.close()
                proc.wait(timeout=5)
            except Exception:  # noqa: BLE001
                self._stop(proc)
        self._proc = None

    def start(self) -> None:
        """Start the child now (if it is not running), so it imports while the caller does other
        work: a child takes ~2 s to import MuJoCo and mjasc, once per worker and campaign."""
        if self._released:
            return
        proc = self._proc
        if proc is None or proc.poll() is not None:
            self._start()

    def wait_ready(self, timeout_s: float | None = None) -> bool:
        """Start the child if needed and wait until it has imported what runs need (its first line);
        False if it died or is not ready within ``timeout_s`` (it is then killed: the next run
        starts a new one)."""
        self.start()
        if self._released:
            return False
        if not self._starting:
            return True
        deadline = None if timeout_s is None else time.monotonic() + float(timeout_s)
        if self._line(deadline) is None:
            self._kill()
            return False
        self._starting = False
        return True

    def _line(self, deadline: float | None) -> bytes | None:
        """The child's next output line; None at the deadline or when the child died (then reaped,
        its exit code in ``self._exit``)."""
        proc = self._proc
        if proc is None:  # (released by another thread)
            self._exit = None
            return None
        fd = proc.stdout.fileno()
        while b"\n" not in self._buf:
            wait = None if deadline is None else max(0.0, deadline - time.monotonic())
            ready, _, _ = select.select([fd], [], [], wait)
            if not ready:
                self._exit = None
                return None
            chunk = os.read(fd, 1 << 20)
            if not chunk:
                self._exit = proc.wait()
                self._proc = None
                return None
            self._buf += chunk
        line, self._buf = self._buf.split(b"\n", 1)
        return line

    def run(self, request: dict, time_limit_s: float | None = None) -> dict:
        """The result of one request (module docstring); ``time_limit_s`` None: no limit. The limit
        counts from the request (and the child's start-up when this request starts it)."""
        t0 = time.perf_counter()
        self.start()
        proc = self._proc
        if proc is None:  # (released, by another thread)
            return self._released_run(t0)
        try:
            proc.stdin.write((json.dumps(request) + "\n").encode())
        except (BrokenPipeError, OSError, ValueError):  # (ValueError: closed by close() meanwhile)
            self._kill()
            return self._failure("crashed", "the run's process could not be started", t0)
        deadline = None if time_limit_s is None else time.monotonic() + float(time_limit_s)
        for _ in range(2 if self._starting else 1):  # the "ready" line first, if not read yet
            line = self._line(deadline)
            if line is None:
                if self._proc is not None:
                    self._kill()
                    return self._timed_out(time_limit_s, t0)
                return self._died(t0)
        self._starting = False
        return json.loads(line)

    def _timed_out(self, time_limit_s: float, t0: float) -> dict:
        return self._failure("timeout", f"the run exceeded its time limit of {time_limit_s:g} s", t0)

    def _died(self, t0: float) -> dict:
        """The result of a run whose child died (its exit code or signal in ``self._exit``; none
        known: killed)."""
        code = self._exit if self._exit is not None else -9
        what = f"signal {-code}" if code < 0 else f"exit code {code}"
        return self._failure("crashed", f"the run's process died ({what})", t0)

    @staticmethod
    def _failure(status: str, error: str, t0: float) -> dict:
        return {"status": status, "error": error, "summary": None, "wall_time_s": round(time.perf_counter() - t0, 3),
                "cpu_time_s": None, "worker": f"{os.uname().nodename}:{os.getpid()}"}


_EXECUTORS: dict = {}  # key (a Dask worker's id; None: this process) → its IsolatedExecutor


def _executor(key: str | None = None) -> IsolatedExecutor:
    ex = _EXECUTORS.get(key)
    if ex is None:
        if key in _RELEASED:  # (a task its worker's shutdown left queued: no new child for it)
            raise RuntimeError(f"worker {key}: shutting down, its run child released")
        ex = _EXECUTORS[key] = IsolatedExecutor()
    return ex


def run_isolated(request: dict, time_limit_s: float | None = None, key: str | None = None) -> dict:
    """Run ``request`` in the persistent child of ``key`` (created on first use): the Dask task.
    ``key``: the worker's id when several workers share this process (threads of a local cluster),
    so that each has its own child; None: one child per process."""
    return _executor(key).run(request, time_limit_s)


def start_isolated(key: str | None = None) -> None:
    """Start the persistent child of ``key`` now (a Dask worker's warm-up)."""
    _executor(key).start()


def adopt_isolated(key: str, executor: IsolatedExecutor) -> None:
    """Make ``executor`` (started by the caller, e.g. before the cluster) the child of ``key``."""
    _EXECUTORS[key] = executor


def release_isolated(key: str) -> None:
    """Close and forget the child of ``key`` (a worker of a local cluster that is shutting down);
    a task of ``key`` that starts after this fails at once instead of starting a new child (a
    worker id is never reused)."""
    _RELEASED.add(key)
    ex = _EXECUTORS.pop(key, None)
    if ex is not None:
        ex.release()  # (a task that took the child before this starts none either)


_RELEASED: set = set()  # the keys release_isolated closed


_PRESTARTED: list = []  # children started before their campaign was read (prestart_isolated)


def prestart_isolated(workers: int | None) -> int:
    """Start run children now, before the caller has read its campaign (the ``campaign`` command):
    they import MuJoCo and mjasc (~2 s each) while the driver parses the campaign, which keeps one
    core busy — children forked from one warmed-up server (:mod:`mjasc.campaigns.forked`, which
    then imports once for all) where forking is safe, new interpreters otherwise. As many as the cores the driver leaves idle (CPU count − 1, at least one), at most
    ``workers`` (None: one per core); :func:`take_prestarted` hands them to the campaign, and any
    left untaken are killed at exit. Returns how many were started."""
    from mjasc.campaigns.forked import ForkedExecutor, forking_safe

    cores = os.cpu_count() or 1
    n = max(0, min(workers if workers is not None else cores, max(1, cores - 1)))
    fork = forking_safe()
    for _ in range(n):
        ex = ForkedExecutor() if fork else IsolatedExecutor(warm=True)
        ex.start()
        _PRESTARTED.append(ex)
    return n


def take_prestarted(n: int) -> list:
    """Up to ``n`` children that :func:`prestart_isolated` started (now the caller's to close)."""
    taken = _PRESTARTED[:n]
    del _PRESTARTED[:n]
    return taken


def close_prestarted() -> None:
    """Kill the children :func:`prestart_isolated` started that no campaign took (never given a run:
    nothing to finish): at exit, and when the ``campaign`` command ends without running (an
    invalid campaign file), so that a process calling the command leaves no child behind."""
    while _PRESTARTED:
        _PRESTARTED.pop()._kill()


atexit.register(close_prestarted)


def _warm_up() -> None:
    """Load numba's cached kernels before the first run asks for them (~1 s): one simulated second
    of the bundled demo, evaluated, in the child's own time (a pre-started child waits for the
    driver to read its campaign). Nothing of it stays but the loaded kernels: a run is a function
    of its own text."""
    from mjasc.core.resources import bundled_scenarios

    demo = bundled_scenarios().get("demo")
    if demo is not None:
        body = "\n".join("duration_s = 1.0" if ln.startswith("duration_s") else ln
                         for ln in demo.read_text().splitlines())
        execute_in_process({"index": -1, "scenario_toml": body, "run_dir": None, "evaluate": True})


#: Whether this run child is in a run (set by its loop around each request; read by the watcher of
#: :func:`leave_when_closed`).
RUNNING = [False]


def leave_when_closed(fd: int) -> None:
    """Leave this run child as soon as the other end of ``fd`` (its requests: stdin, or the pipe to
    the driver of a forked child) is closed — its worker or driver was killed (SIGKILL, the machine
    lost) or closed it — instead of finishing a run nobody will read (a hung one: never); the run is
    done again elsewhere. Status 0 between runs (a driver's close: nothing is cut short, as when the
    loop reads the end of its input), 1 in a run (:data:`RUNNING`). A daemon thread blocked in
    ``poll`` for the hang-up (it costs nothing while it waits; a request arriving is not a
    hang-up). Where ``poll`` is missing, nothing is watched."""
    if not hasattr(select, "poll"):
        return
    watched = select.POLLHUP | getattr(select, "POLLRDHUP", 0)

    def watch() -> None:
        poller = select.poll()
        poller.register(fd, watched)
        poller.poll()  # (returns on a hang-up or an error only: no read event is asked for)
        os._exit(1 if RUNNING[0] else 0)

    threading.Thread(target=watch, name="mjasc-leave-when-closed", daemon=True).start()


def answer(message: str | bytes) -> str:
    """A run child's answer to one request (its JSON text): the result's JSON text, the child
    marked as in a run meanwhile (:data:`RUNNING`)."""
    RUNNING[0] = True
    try:
        return json.dumps(execute_in_process(json.loads(message)))
    finally:
        RUNNING[0] = False


def _serve() -> None:
    """The child's loop: one JSON request per line on stdin, one JSON result per line on the
    original stdout (everything else the run prints goes to stderr)."""
    leave_when_closed(sys.stdin.fileno())
    out = os.fdopen(os.dup(1), "w", buffering=1)
    os.dup2(2, 1)  # stray prints of libraries must not corrupt the result stream
    sys.stdout = sys.stderr
    _prepare()
    out.write(json.dumps({"ready": os.getpid()}) + "\n")  # IsolatedExecutor.wait_ready
    out.flush()
    if "--warm" in sys.argv[1:] and not select.select([sys.stdin], [], [], 0.0)[0]:
        _warm_up()
    for line in sys.stdin:
        if not line.strip():
            continue
        out.write(answer(line) + "\n")
        out.flush()
    # Every result is written and every run closed its files: leave without the interpreter's
    # clean-up of MuJoCo, numba and the rest (~0.5 s that the driver would wait for).
    os._exit(0)


def _prepare() -> None:
    """Import what every run imports and set up numba's compiler target, before the first request
    instead of during it (a child's start-up: ~1.5–2 s of CPU)."""
    import mjasc  # noqa: F401  (MUJOCO_GL before mujoco)

    import mjasc.avoidance.system  # noqa: F401
    import mjasc.cooperation.coordination  # noqa: F401
    import mjasc.evaluation.mission_cost  # noqa: F401
    import mjasc.evaluation.run_evaluation  # noqa: F401
    import mjasc.perception.pipeline  # noqa: F401
    import mjasc.runs.runner  # noqa: F401
    from mjasc.core.compiled import maximum

    # numba sets up its compiler target (registries, BLAS, typed containers: ~1 s) at the first
    # kernel call of a process: here, before the ready line, not inside the first run.
    maximum(0.0, 1.0)


if __name__ == "__main__":
    _serve()
