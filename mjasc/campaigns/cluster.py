"""The Dask side of a campaign (:mod:`mjasc.campaigns.engine`): open a client — an own
``LocalCluster`` of single-threaded workers (threads of this process when the runs execute in child
processes of their own, processes otherwise), an existing scheduler by its address, or a given
``distributed.Client`` — warm its workers up, and close what was opened."""

from __future__ import annotations

import functools
import os

__all__ = ["open_client", "close_client", "local_workers", "quiet_shutdown", "scheduler_problem", "warm_up_worker",
           "worker_thread_key", "workers_problem", "WORKER_WAIT_S", "code_digest", "code_identity",
           "workers_code_problem", "math_digest", "worker_math", "workers_math_problem",
           "MathDigestError"]

#: How long a campaign waits for the first worker of a cluster [s].
WORKER_WAIT_S = 120.0


def warm_up_worker(dask_worker=None) -> str:
    """Run on every worker before the tasks: import mjasc once, start the worker's run process
    (it imports while the other workers come up; a worker of several threads starts one per thread
    with its thread's first run, :func:`worker_thread_key`), report mjasc's version and
    :func:`code_digest` (``"<version> <digest>"``). (Its name, arguments and answer stay as they
    were: a worker on an older mjasc must be told apart by its answer, not fail to be asked.)"""
    from mjasc.campaigns.executor import start_isolated

    if _nthreads(dask_worker) <= 1:
        start_isolated()
    return code_identity()


def worker_math(isolate: bool = True) -> dict:
    """Run on every worker once its code is known to be this process's: ``{"digest": …}`` where its
    runs compute (:func:`math_digest`), or ``{"error": …}`` when it could not be computed."""
    try:
        return {"digest": math_digest(isolate)}
    except MathDigestError as exc:
        return {"error": str(exc)}


def code_identity() -> str:
    """``"<mjasc version> <code digest>"`` of this process (:func:`code_digest`)."""
    import mjasc

    return f"{getattr(mjasc, '__version__', 'unknown')} {code_digest()}"


@functools.lru_cache(maxsize=1)
def code_digest() -> str:
    """The first 16 hex digits of the SHA-256 of every Python source of the mjasc package this
    process imported (relative paths and contents, in path order): two processes that give the same
    digest run the same code. The version string does not change with each commit, so a worker
    started on another checkout or an older install reports the same version and other results."""
    import hashlib
    from pathlib import Path

    import mjasc

    root = Path(mjasc.__file__).resolve().parent
    h = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        h.update(path.relative_to(root).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
    return h.hexdigest()[:16]


class MathDigestError(RuntimeError):
    """The math fingerprint could not be computed (its process failed or timed out)."""


_MATH_DIGESTS: dict[bool, str] = {}  # fresh → the digest (successes only: a failure is asked again)


def math_digest(fresh: bool = True) -> str:
    """The digest of :func:`mjasc.core.math_fingerprint.fingerprint` where this machine's runs
    compute: ``fresh``, a new process started as a run child is (``python -m
    mjasc.core.math_fingerprint`` with the children's environment: it imports mjasc first, so numpy
    and OpenBLAS are pinned whatever this process imported before); else this process (runs in
    the worker's own process). Machines with the same digest compute the sampled operations — the
    ones a run rests on — bit for bit alike; a different digest means a run there would not replay
    here. Raises :class:`MathDigestError` when it cannot be computed."""
    if fresh in _MATH_DIGESTS:
        return _MATH_DIGESTS[fresh]
    if not fresh:
        from mjasc.core.math_fingerprint import digest

        _MATH_DIGESTS[fresh] = value = digest()
        return value
    import subprocess
    import sys

    from mjasc.campaigns.executor import child_environment

    try:
        done = subprocess.run([sys.executable, "-m", "mjasc.core.math_fingerprint"], capture_output=True, text=True,
                              env={**os.environ, **child_environment()}, timeout=WORKER_WAIT_S)
    except (OSError, subprocess.TimeoutExpired) as exc:
        raise MathDigestError(f"python -m mjasc.core.math_fingerprint: {type(exc).__name__}: {exc}") from None
    first = done.stdout.split("\n", 1)[0].split()
    if done.returncode or len(first) != 2 or first[0] != "digest":
        tail = (done.stderr.strip().splitlines() or ["no output"])[-1]
        raise MathDigestError(f"python -m mjasc.core.math_fingerprint exited with status {done.returncode}: {tail}")
    _MATH_DIGESTS[fresh] = first[1]
    return first[1]


def workers_code_problem(reports: dict) -> str:
    """What is wrong with the workers' :func:`warm_up_worker` reports (worker address → report)
    against this process's code ('' if every worker runs it)."""
    own = code_identity()
    other = {w: r for w, r in reports.items() if r != own}
    if not other:
        return ""
    w, r = sorted(other.items())[0]
    return (f"{len(other)} of {len(reports)} Dask worker(s) run other mjasc code than this process (worker {w}: "
            f"version and code digest {r!r}, here {own!r}); install the same mjasc on every worker (a worker "
            f"started on another checkout or PYTHONPATH gives other results)")


def workers_math_problem(reports: dict, own: str | MathDigestError) -> str:
    """What is wrong with the workers' :func:`worker_math` reports (worker address → report)
    against this machine's math digest ``own`` (or the error computing it): '' if every worker
    computes the same bits — a run gives the same result wherever it runs, and ``mjasc extract``
    replays it here."""
    if isinstance(own, MathDigestError):
        return f"could not compute this machine's math digest ({own}), to compare the workers' with"
    failed = {w: r["error"] for w, r in reports.items() if "error" in r}
    if failed:
        w, error = sorted(failed.items())[0]
        return f"could not compute the math digest on {len(failed)} Dask worker(s) (worker {w}: {error})"
    other = {w: r["digest"] for w, r in reports.items() if r["digest"] != own}
    if not other:
        return ""
    w, r = sorted(other.items())[0]
    return (f"{len(other)} of {len(reports)} Dask worker(s) compute other floating-point bits than this machine "
            f"(worker {w}: math digest {r}, here {own}): a run there would not replay here; use machines whose "
            f"'python -m mjasc.core.math_fingerprint' digests agree (the same CPU architecture, x86-64 with AVX2, "
            f"the same locked packages, no NPY_DISABLE_CPU_FEATURES, OPENBLAS_CORETYPE or OPENBLAS_NUM_THREADS of "
            f"their own)")


def _nthreads(worker) -> int:
    state = getattr(worker, "state", None)
    return int(getattr(state, "nthreads", 1) or 1)


def worker_thread_key() -> str | None:
    """Whose run child a task of a worker process uses (:func:`mjasc.campaigns.executor.run_isolated`):
    None, the process's one child, on a single-threaded worker; on a worker of several threads
    (``dask worker --nthreads 2``) the child of the task's thread, so that two runs at once never
    share one child's pipe (they swapped results, lost one and hung the worker)."""
    import threading

    try:
        from distributed import get_worker

        worker = get_worker()
    except (ImportError, ValueError):  # (not in a Dask worker)
        return None
    if _nthreads(worker) <= 1:
        return None
    return f"{worker.id}-thread-{threading.get_ident()}"


#: Dask settings of an own threaded cluster, whose event loop shares this process's core with the
#: runs' children: no profiler; the event-loop tick measured every 1 s instead of 20 ms and the
#: system monitor (CPU, memory, network counters for the dashboard) every 10 s instead of 0.5 s;
#: no work stealing (with worker-saturation 1.0 the scheduler queues the tasks itself: there is
#: nothing to steal). Together ~0.03 s of CPU per second of campaign less (measured: an idle
#: 2-worker cluster 0.029 → 0.005 s/s, 40 tasks 9.5 → 4.6 ms of CPU each).
_THREADED_CONFIG = {"distributed.worker.profile.enabled": False, "distributed.admin.tick.interval": "1s",
                    "distributed.admin.system-monitor.interval": "10s", "distributed.scheduler.work-stealing": False}


class _InterruptedSyncFilter:
    """A logging filter for ``tornado.application``: drops the traceback Dask's ``sync`` logs when
    Ctrl-C lands before its coroutine has made the future it would cancel (its ``cancel`` callback
    then raises NameError on the event loop's thread: there was nothing to cancel). Every other
    record passes. (Seen with distributed 2026.8: ``mjasc campaign`` interrupted printed that
    traceback before its one line.)"""

    @staticmethod
    def filter(record) -> bool:
        exc = record.exc_info[1] if record.exc_info else None
        return not (isinstance(exc, NameError) and "sync.<locals>.cancel" in record.getMessage())


def _quiet_interrupted_sync() -> None:
    """Install :class:`_InterruptedSyncFilter` on ``tornado.application`` (once)."""
    import logging

    log = logging.getLogger("tornado.application")
    if not any(isinstance(f, _InterruptedSyncFilter) for f in log.filters):
        log.addFilter(_InterruptedSyncFilter())


def open_client(scheduler, workers: int | None, threaded: bool = False):
    """(client, closers): a Client instance is used as is; None/"local" starts a LocalCluster of
    ``workers`` single-threaded processes (``threaded``: single-threaded workers in this process,
    for runs that execute in child processes of their own — module docstring); any other string is
    an existing scheduler's address (the client connected to it is closed with the closers; the
    cluster is left as it is)."""
    import dask
    from distributed import Client, LocalCluster

    _quiet_interrupted_sync()
    if isinstance(scheduler, Client):
        return scheduler, []
    if scheduler in (None, "local"):
        import logging

        logging.getLogger("distributed").setLevel(logging.WARNING)  # no INFO chatter from the scheduler
        n = local_workers(workers)
        # A threaded worker only waits on its run's child process: no stack sampling of it (Dask's
        # profiler would cost CPU that the runs need) and no memory limit (the runs' memory is
        # their children's).
        with dask.config.set({"distributed.scheduler.worker-saturation": 1.0,
                              **(_THREADED_CONFIG if threaded else {})}):
            # dashboard_address ":0": the scheduler's HTTP server takes a free port (8787 may be in use).
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=not threaded, dashboard_address=":0",
                                   **({"memory_limit": 0} if threaded else {}))
        client = Client(cluster)
        return client, [client, cluster]
    if not isinstance(scheduler, str):
        raise ValueError(f"scheduler: must be None, 'local', 'synchronous', an address or a distributed.Client, "
                         f"got {scheduler!r}")
    if problem := workers_problem(scheduler, workers):
        raise ValueError(f"workers: {problem}")
    client = Client(scheduler)  # ours to close (not the cluster's workers and scheduler)
    return client, [client]


def scheduler_problem(scheduler) -> str:
    """Why ``scheduler`` is not one run_campaign takes ('' if it is): None, "local", "synchronous",
    a ``distributed.Client`` or a scheduler's address with its port (``tcp://host:8786``)."""
    import re

    if scheduler is None or scheduler in ("local", "synchronous") or type(scheduler).__name__ == "Client":
        return ""
    if isinstance(scheduler, str) and (re.fullmatch(r"(?:[a-z]+://)?[^\s/:\[\]]+:\d{1,5}", scheduler) or
                                       re.fullmatch(r"(?:[a-z]+://)?\[[0-9A-Fa-f:.]+\]:\d{1,5}", scheduler)):
        return ""
    return (f"must be 'synchronous', 'local', a distributed.Client or a scheduler address with its port "
            f"(tcp://host:8786), got {scheduler!r}")


def workers_problem(scheduler, workers: int | None) -> str:
    """Why ``workers`` does not go with ``scheduler`` ('' if it does): an existing cluster's address
    has its own workers (and ``workers = 0``, this process, would ignore the cluster)."""
    if workers is not None and isinstance(scheduler, str) and scheduler not in ("local", "synchronous"):
        return f"only for a local cluster; the cluster at {scheduler} has its own workers"
    if workers and scheduler == "synchronous":  # (workers = 0 is this process: what synchronous means)
        return "only for a local cluster; the synchronous scheduler runs every run in this process"
    return ""


def local_workers(workers: int | None) -> int:
    """The number of workers of a local cluster: ``workers``, default one per core."""
    return workers if workers is not None else (os.cpu_count() or 1)


def quiet_shutdown(local: bool):
    """Silence Dask's loggers while a local cluster of ours shuts down (the runs' tasks it cancels
    or whose children it closes log errors that are not the user's) — or a client whose scheduler
    went away closes (its reconnection, cut short, logs a traceback); returns the function that
    restores them. Otherwise nothing changes. (``distributed.client`` has a level of its own in
    Dask's logging configuration: ``distributed``'s does not reach it.)"""
    import logging

    if not local:
        return lambda: None
    logs = [logging.getLogger(name) for name in ("distributed", "distributed.client")]
    levels = [log.level for log in logs]
    for log in logs:
        log.setLevel(logging.CRITICAL)

    def restore() -> None:
        for log, level in zip(logs, levels):
            log.setLevel(level)

    return restore


def close_client(closers, local: bool) -> None:
    import logging

    nanny_log = logging.getLogger("distributed.nanny")
    level = nanny_log.level
    if closers and local:  # our own workers: no shutdown chatter
        nanny_log.setLevel(logging.ERROR)
    try:
        for c in closers:
            c.close()
    finally:
        nanny_log.setLevel(level)
