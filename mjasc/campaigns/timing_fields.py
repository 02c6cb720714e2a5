"""The fields of a campaign run's result that depend on the machine, not on the run (wall and CPU
times, the worker, per-component timers): what two executions of the same run may differ in.
:func:`without_timing` drops them — what must be identical whatever the workers, their number, the
completion order and (on pinned x86-64 machines) the machine."""

from __future__ import annotations

from typing import Any

__all__ = ["TIMING_KEYS", "is_timing_key", "without_timing"]

#: Fields of a result that depend on the machine, not on the run; besides these, every key ending
#: in ``_us`` (components report their wall-clock cost in microseconds).
TIMING_KEYS = frozenset({"wall_time_s", "cpu_time_s", "real_time_factor", "worker", "run_wall_time_s",
                         "run_cpu_time_s", "throughput_runs_per_hour", "startup_s", "timing_s"})


def is_timing_key(key: str) -> bool:
    """True for a machine-dependent field: one of :data:`TIMING_KEYS` or a ``*_us`` wall-clock cost."""
    return key in TIMING_KEYS or key.endswith("_us")


def without_timing(obj: Any) -> Any:
    """A summary (or any nested dict) without its machine-dependent fields (:func:`is_timing_key`):
    what must be identical whatever the workers, their number and the completion order."""
    if isinstance(obj, dict):
        return {k: without_timing(v) for k, v in obj.items() if not is_timing_key(k)}
    if isinstance(obj, list):
        return [without_timing(v) for v in obj]
    return obj
