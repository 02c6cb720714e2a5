"""A campaign's runs on Dask: an own ``LocalCluster``, a scheduler's address or a given client.

:func:`run_on_dask` submits every run as a task (:func:`run_task`), stores each result the moment it
arrives, resubmits a run whose status asks for a retry (up to ``max_attempts``) and, interrupted or
failed, cancels the queued runs before it closes the cluster (docs/campaigns.md, "On a cluster").
On an own cluster with isolated runs the workers are threads of this process, each handing its runs
to its own run child (:mod:`mjasc.campaigns.executor`, forked from one warmed-up server:
:mod:`mjasc.campaigns.forked`); on any other cluster each worker thread has its own child
(:func:`mjasc.campaigns.cluster.worker_thread_key`). A lost scheduler stops the campaign (its runs
still out are not recorded: the same command does them). The driver's side is
:mod:`mjasc.campaigns.engine`.
"""

from __future__ import annotations

import os
import time
from concurrent.futures import ThreadPoolExecutor

from mjasc.campaigns.cluster import (WORKER_WAIT_S, MathDigestError, close_client, local_workers, math_digest,
                                    open_client, quiet_shutdown, warm_up_worker, worker_math, worker_thread_key,
                                    workers_code_problem, workers_math_problem)
from mjasc.campaigns.executor import adopt_isolated, execute_in_process, release_isolated, run_isolated, take_prestarted
from mjasc.campaigns.hull_shipping import hold_hull_root, localise, release_hull_root, ship_to_cluster
from mjasc.campaigns.run_request import request_of
from mjasc.campaigns.store import RETRY_STATUSES, record_result
from mjasc.core.kernel_cache import COLD_START_WAIT_S, cache_is_cold
from mjasc.runs.interrupts import raise_pending

__all__ = ["run_on_dask", "run_task"]


def run_task(request: dict, time_limit_s: float | None, isolate: bool, threaded: bool = False,
             hulls: dict | None = None) -> dict:
    """The Dask task: run one request in the worker's persistent child process (``threaded``: the
    workers are threads of one process, each with its own child, keyed by the worker's id;
    ``hulls``: the shipped vessel folders, written here once and handed to the child as paths)."""
    if hulls:
        request = localise({**request, "hulls": hulls})
    if not isolate:
        return execute_in_process(request)
    if threaded:
        from distributed import get_worker

        return run_isolated(request, time_limit_s, key=get_worker().id)
    return run_isolated(request, time_limit_s, key=worker_thread_key())


def run_on_dask(runs, store, out_dir, scheduler, workers, max_attempts, time_limit_s, isolate, recordings,
                reference, bar, info, plugins=None, hulls=None, colreg=None, gospa=None) -> None:
    """Execute ``runs`` on Dask (module docstring), storing each result in ``store`` as it arrives;
    ``info`` gets the scheduler, its address, the workers and the start-up time."""
    from concurrent.futures import CancelledError

    from distributed import as_completed

    t_start = time.perf_counter()
    local = scheduler in (None, "local")
    # A local cluster for isolated runs: its workers are threads of this process, each handing
    # its runs to its own child process (which does all the work and gives the isolation; worker
    # processes would only add their start-up, shutdown and traffic). The children start first,
    # so that they import MuJoCo and mjasc while Dask starts: forks of one server that imports
    # and warms up once for all of them (mjasc.campaigns.forked).
    threaded = local and isolate
    cold = cache_is_cold()  # (before any child compiles: its warm-up then takes minutes)
    n_children = local_workers(workers) if threaded else 0
    children = take_prestarted(n_children)  # (started before the campaign was read, if any)
    if n_children > len(children):
        from mjasc.campaigns.forked import ForkedExecutor  # (a new interpreter where forking is not safe)

        children += [ForkedExecutor() for _ in range(n_children - len(children))]
    for child in children:
        child.start()
    client, closers = None, []
    keys: list = []
    pending: dict = {}  # future → its run, while it is out
    lost = False  # the scheduler went away: its client's reconnection, cut short by the close, is not news
    held = False  # the workers hold their copies of the shipped hulls for this campaign
    try:
        client, closers = open_client(scheduler, workers, threaded)
        try:
            client.wait_for_workers(1, timeout=WORKER_WAIT_S)
        except TimeoutError:
            raise RuntimeError(f"no Dask worker joined the scheduler at {client.scheduler.address} "
                               f"within {WORKER_WAIT_S:.0f} s") from None
        if threaded:
            import mjasc

            cluster = closers[-1]
            for w, child in zip(cluster.workers.values(), children):
                keys.append(w.id)
                adopt_isolated(w.id, child)
            # Start-up ends when the first child (pre-started, if any) has imported what runs need:
            # the runs go out then, and each other child's first run reads its ready line, its
            # imports overlapping the first child's runs. A first child that cannot start stops
            # the campaign before any run.
            # (a cold kernel cache: the child's warm-up compiles them, minutes: kernel_cache)
            wait_s = COLD_START_WAIT_S if cold else WORKER_WAIT_S
            if children and not children[0].wait_ready(wait_s):
                raise RuntimeError(f"a run's child process (python -m mjasc.campaigns.executor) did not start "
                                   f"within {wait_s:.0f} s; no run was done")
            versions = {k: getattr(mjasc, "__version__", "unknown") for k in keys}
        else:
            try:
                versions = client.run(warm_up_worker)
            except Exception as exc:  # noqa: BLE001
                raise RuntimeError(f"the Dask workers cannot import mjasc ({type(exc).__name__}: {exc}); "
                                   f"install mjasc on every worker") from None
            if problem := workers_code_problem(versions):  # (before any run: the results would differ)
                raise RuntimeError(f"{problem}; no run was done")
            # The same code: the same floating-point bits too? (this machine's digest meanwhile)
            with ThreadPoolExecutor(1) as pool:
                own = pool.submit(math_digest, isolate)
                maths = client.run(worker_math, isolate)
                try:
                    own = own.result()
                except MathDigestError as exc:
                    own = exc
            if problem := workers_math_problem(maths, own):
                raise RuntimeError(f"{problem}; no run was done")
        info.update(scheduler="local" if local else scheduler if isinstance(scheduler, str) else "client",
                    address=client.scheduler.address, workers=len(versions),
                    startup_s=round(time.perf_counter() - t_start, 3))
        tag = f"{store.digest[:10]}-{os.getpid()}-{time.time_ns()}"
        attempts = {(i, m): n for m in dict.fromkeys(getattr(r, "method", "") for r in runs)
                    for i, n in store.attempts(m).items()}

        if hulls:  # (to each worker once: a future its tasks share, computed again if a worker is lost with it)
            hulls = ship_to_cluster(client, hulls, tag)
            if not threaded:  # (a worker's copies stay while any campaign sailing them runs there)
                held = client.run(hold_hull_root) is not None

        def key(run) -> tuple:
            return run.index, getattr(run, "method", "")

        def submit(run) -> None:
            method = f"-{run.method}" if getattr(run, "method", "") else ""
            request = request_of(run, out_dir, recordings, reference, plugins, colreg, gospa)
            fut = client.submit(run_task, request, time_limit_s, isolate, threaded, hulls or None, pure=False,
                                key=f"mjasc-run-{tag}-{run.index}{method}-{attempts.get(key(run), 0)}")
            pending[fut] = run

        for run in runs:
            submit(run)
        queue = as_completed(list(pending))
        for fut in queue:
            raise_pending()  # (an interrupt that arrived inside a finalizer: mjasc.runs.interrupts)
            run = pending.pop(fut)
            try:
                result = fut.result()
            except CancelledError:  # the scheduler went away (the client cancels every future): not the run's
                lost = True
                raise RuntimeError(f"lost the Dask scheduler at {info['address']}: {len(pending) + 1} run(s) not "
                                   f"done (every finished run is stored; the same command does the rest)") from None
            except Exception as exc:  # noqa: BLE001 — a lost worker, a task that could not run
                result = {"status": "crashed", "error": f"{type(exc).__name__}: {exc}", "summary": None,
                          "wall_time_s": None, "worker": None}
            fut.release()
            attempts[key(run)] = record_result(store, run, result)
            if result["status"] in RETRY_STATUSES and attempts[key(run)] < max_attempts:
                submit(run)
                queue.add(next(f for f, r in pending.items() if key(r) == key(run)))
                continue
            if bar is not None:
                bar.update(1)
    finally:
        # Interrupted (Ctrl-C) or failed: the queued runs are cancelled first, so that no worker
        # starts one while the cluster closes; then the children, so that a run still waiting on
        # one ends with it (its task fails: a local cluster's shutdown logs nothing of it).
        quiet = quiet_shutdown(local or lost)
        try:
            if client is not None and pending:
                try:
                    client.cancel(list(pending), force=True)
                except Exception:  # noqa: BLE001 — a scheduler already gone: nothing queued to cancel
                    pass
            for k in keys:
                release_isolated(k)
            for child in children:  # also those never adopted (the cluster failed to start)
                child.close()
            if held:  # (the workers' copies of the shipped hulls: removed with the last campaign using them)
                try:
                    client.run(release_hull_root)
                except Exception:  # noqa: BLE001 — a worker gone: its temporary folder goes at its exit
                    pass
        finally:
            try:
                close_client(closers, local)
            finally:
                quiet()
