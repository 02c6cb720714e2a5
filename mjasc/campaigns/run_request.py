"""One campaign run in the calling process: its request in, its result out.

A request is ``{"index", "scenario_toml", "run_dir" (None: no files), "evaluate", "reference"}`` and
optionally ``"plugins"`` (``{stage: {name: "module:QualifiedName"}}``: methods registered in the
driver's process, imported and registered here before the run; :mod:`mjasc.campaigns.methods`),
``"hulls"`` / ``"vessel_paths"`` (shipped own hulls: :mod:`mjasc.campaigns.hull_shipping`) and
``"colreg"`` (the campaign's ``[colreg]`` thresholds that differ from the defaults: the evaluation's
COLREG roles and compliance use them) and ``"gospa"`` (its ``[evaluation]`` GOSPA cut-off and order
that differ from the defaults: the tracking score's); the result
``{"status": completed | diverged | error | timeout | crashed, "error", "summary", "wall_time_s",
"cpu_time_s", "worker"}``. :func:`execute_in_process` runs one request here: the code path of a run child
(:mod:`mjasc.campaigns.executor`, :mod:`mjasc.campaigns.forked`), and what ``workers = 0`` uses when
isolation is off.

With ``"reference": true`` (and evaluation on) a completed run with traffic is followed, in the
same process, by its reference — the same scenario text without its ``[[moving_obstacles]]``,
same seed, no recording, no video, no evaluation (:mod:`mjasc.evaluation.mission_cost`) — and
``summary["evaluation"]["cost"]`` holds each vessel's path-length and time cost against it;
``summary["evaluation"]["cost_reference"]`` says how the reference was made (``no_traffic``, or
``self`` for a run without traffic: a run is a pure function of its text, so it is its own
reference and costs nothing to compare) with its status and wall time. The reference's time
counts in the run's ``wall_time_s`` and time limit.
"""

from __future__ import annotations

import os
import time
import traceback
from pathlib import Path

__all__ = ["execute_in_process", "plain", "request_of"]


def execute_in_process(request: dict) -> dict:
    """Run one campaign run here: parse its scenario text, run it (recording into ``run_dir`` when
    given), evaluate it against the truth; never raises for a failed run."""
    from mjasc.campaigns.hull_shipping import run_document
    from mjasc.runs.runner import RunFailed, Runner

    t0, c0 = time.perf_counter(), time.process_time()
    out: dict = {"status": "completed", "error": None, "summary": None}
    try:
        from dataclasses import replace

        if request.get("plugins"):
            from mjasc.campaigns.methods import register_plugins

            register_plugins(request["plugins"])
        request, doc, sc = run_document(request)  # (shipped own hulls written here once and sailed from here)
        run_dir = request.get("run_dir")
        sc = replace(sc, outputs=replace(sc.outputs, recording=run_dir is not None, video=False))
        runner = Runner(sc, run_dir, progress=False)
        evaluator = None
        if request.get("evaluate", True):
            from mjasc.evaluation.run_evaluation import RunEvaluator

            config = None
            if request.get("colreg") or request.get("gospa"):  # (the campaign's settings; absent: the defaults)
                from mjasc.evaluation.colreg import ColregConfig
                from mjasc.evaluation.run_evaluation import EvaluationConfig

                config = EvaluationConfig(colreg=ColregConfig(**(request.get("colreg") or {})),
                                          **(request.get("gospa") or {}))
            evaluator = RunEvaluator(runner, config)
            runner.observe("record", evaluator)
            runner.add_summary("evaluation", evaluator.summary)  # (in the run's summary.json too)
        try:
            out["summary"] = runner.run().summary
        except RunFailed as exc:
            out["status"] = (exc.summary or {}).get("status", "diverged")  # diverged, error, interrupted
            out["error"] = str(exc).split("; partial outputs")[0]
            out["summary"] = exc.summary
        if evaluator is not None and out["summary"] is not None:
            if request.get("reference", False) and out["status"] == "completed":
                out["summary"]["evaluation"].update(_cost(doc, evaluator, request.get("index")))
    except Exception as exc:  # noqa: BLE001 — one failed run must not stop the campaign
        tb = traceback.extract_tb(exc.__traceback__)
        where = f" at {tb[-1].filename.rsplit('/', 1)[-1]}:{tb[-1].lineno}" if tb else ""
        out["status"], out["error"] = "error", f"{type(exc).__name__}: {exc}{where}"
    out["wall_time_s"] = round(time.perf_counter() - t0, 3)
    out["cpu_time_s"] = round(time.process_time() - c0, 3)
    out["worker"] = f"{os.uname().nodename}:{os.getpid()}"
    return plain(out)


def _cost(doc: dict, evaluator, index) -> dict:
    """``{"cost", "cost_reference"}`` of a completed run (module docstring): runs its reference."""
    from dataclasses import replace

    from mjasc.evaluation.mission_cost import ProgressTrace, reference_document
    from mjasc.runs.runner import RunFailed, Runner
    from mjasc.runs.scenario import parse_scenario

    ref_doc = reference_document(doc)
    if ref_doc is None:
        return {"cost": evaluator.cost(None), "cost_reference": {"kind": "self", "status": "completed"}}
    t0 = time.perf_counter()
    sc = parse_scenario(ref_doc, f"<reference of run {index}>")
    sc = replace(sc, outputs=replace(sc.outputs, recording=False, video=False))
    runner = Runner(sc, None, progress=False)
    trace = ProgressTrace(runner)
    runner.observe("record", trace)
    info = {"kind": "no_traffic", "status": "completed"}
    try:
        runner.run()
        cost = evaluator.cost(trace)
    except RunFailed as exc:
        info.update(status=(exc.summary or {}).get("status", "diverged"), error=str(exc).split("; partial outputs")[0])
        cost = {}
    info["wall_time_s"] = round(time.perf_counter() - t0, 3)
    return {"cost": cost, "cost_reference": info}


def plain(obj):
    """JSON-ready: numpy scalars → numbers, non-finite floats → None, tuples → lists."""
    import math

    import numpy as np

    if isinstance(obj, dict):
        return {str(k): plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [plain(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return plain(obj.tolist())
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def request_of(run, out_dir: Path, recordings: bool, reference: bool, plugins: dict | None = None,
               colreg: dict | None = None, gospa: dict | None = None) -> dict:
    """The request (module docstring) of ``run`` (:class:`~mjasc.campaigns.spec.RunSpec`): its files in
    ``out_dir``/runs/[<method>/]<index>/ with ``recordings``, else none; the mission-cost reference with
    ``reference``; ``plugins``, ``colreg`` and ``gospa`` when given."""
    method = getattr(run, "method", "")
    run_dir = str(out_dir / "runs" / method / str(run.index) if method else out_dir / "runs" / str(run.index)) \
        if recordings else None
    request = {"index": run.index, "scenario_toml": run.scenario_toml, "run_dir": run_dir, "evaluate": True,
               "reference": reference}
    if plugins:
        request["plugins"] = plugins
    if colreg:
        request["colreg"] = colreg
    if gospa:
        request["gospa"] = gospa
    return request
