"""How a run that stopped early says why: :class:`RunFailed`, :class:`RunInterrupted`, and the
one-line error of a component that raised (:func:`component_error`).

A component's exception ends the run with status ``error`` and a line naming the exception, the
simulated time and where it was raised: the file and line, and when a plugin's method raised
(:func:`~mjasc.plugins.answers.plugin_at_fault`) the plugin too. A plugin's answer that failed
mjasc's checks already names the plugin in its message, so nothing is added; a ``TypeError`` raised
inside mjasc's own files while calling a plugin's method means the method's signature does not take
mjasc's call, and the line says so.
"""

from __future__ import annotations

import traceback
from pathlib import Path

from mjasc.plugins.answers import plugin_at_fault

__all__ = ["RunFailed", "RunInterrupted", "component_error"]

_PACKAGE = Path(__file__).resolve().parent.parent  # (mjasc's own files: a failing frame there is not a plugin's)


class RunFailed(RuntimeError):
    """A run stopped early; the message says why and where its partial outputs are. ``summary`` is
    the run's summary up to the stop (the same fields as a completed run's, ``status`` saying why:
    ``diverged``, ``error`` or ``interrupted``)."""

    def __init__(self, message: str, summary: dict | None = None):
        super().__init__(message)
        self.summary = summary


class RunInterrupted(RunFailed):
    """A run stopped by Ctrl-C or SIGTERM (:mod:`mjasc.runs.interrupts`); its recording was closed
    and its summary written (``status`` ``interrupted``)."""


def component_error(exc: Exception, time_s: float, agents) -> str:
    """The run's ``error`` for ``exc`` raised by a component at simulated ``time_s`` [s] in a run of
    ``agents`` (the vessels' :class:`~mjasc.runs.agent.VesselAgent`)."""
    tb = traceback.extract_tb(exc.__traceback__)
    place = f"{tb[-1].filename.rsplit('/', 1)[-1]}:{tb[-1].lineno}" if tb else ""
    fault = plugin_at_fault(exc, stage_methods(agents))  # (a plugin's bug: say whose, and where)
    if fault is not None and str(exc).startswith(fault):  # (a checked answer: the message says whose,
        fault = place = ""                                  # and the check's own line says nothing)
    elif fault is not None and isinstance(exc, TypeError) and tb and \
            Path(tb[-1].filename).resolve().is_relative_to(_PACKAGE):  # (a call the method cannot take)
        place = f"its signature does not take mjasc's call at {place}; docs/plugins.md lists each " \
                f"method's arguments"
    where = ": ".join(p for p in (fault, place) if p)
    where = f" ({where})" if where else ""
    return f"{type(exc).__name__} at t = {time_s:.3f} s: {exc}{where}"


def stage_methods(agents) -> list:
    """Every vessel's stage methods (built-in ones too), for naming a plugin at fault."""
    out = []
    for agent in agents:
        out += [agent.coordination, agent.avoidance, agent.control_plugin, getattr(agent.perception, "method", None)]
    return [m for m in out if m is not None]
