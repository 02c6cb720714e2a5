"""The project's tracker as the ``imm`` tracking method (the default of ``[vessels.tracking]``).

:class:`IMMMethod` is a :class:`~mjasc.plugins.stages.TrackingMethod` whose ``Options`` is
:class:`~mjasc.perception.tracking.config.TrackingConfig`. Inside a vessel's
:class:`~mjasc.perception.pipeline.Perception` it is never built: the perception recognises the
choice and runs the fleet path (every vessel's tracks in one batched IMM bank,
:class:`~mjasc.perception.tracking.fleet.FleetTracker`), exactly as without a method name. Built on
its own (``MethodChoice("tracking", "imm", config).build(context)``) it is a
:class:`~mjasc.perception.tracking.tracker.MultiTargetTracker` behind the plugin interface, a
fleet of one (the same tracks).
"""

from __future__ import annotations

import math

from mjasc.perception.tracking.config import TrackingConfig, check_tracking
from mjasc.perception.tracking.tracker import MultiTargetTracker
from mjasc.plugins.stages import TrackingMethod

__all__ = ["IMMMethod"]


class IMMMethod(TrackingMethod):
    """The built-in tracker (gated GNN, one batched IMM bank, M-of-N, manoeuvre detector, static
    flag, outlines, team mates: docs/perception.md) as a tracking method."""

    method = "imm"
    Options = TrackingConfig
    check_options = staticmethod(check_tracking)

    def __init__(self, context=None, options: TrackingConfig | None = None):
        super().__init__(context, options)
        self.tracker = MultiTargetTracker(self.options, context.sensor_range_m if context is not None else math.inf)

    def __len__(self) -> int:
        """Tracks held now, tentative ones included."""
        return len(self.tracker)

    def update(self, t_s: float, nav, detections) -> None:
        self.tracker.step(t_s, detections, None if detections is None else detections.origin_m)

    def tracks(self) -> tuple:
        return tuple(self.tracker.estimates())

    def drain_events(self) -> list[tuple[float, str]]:
        return [(e.time_s, e.text) for e in self.tracker.drain_events() if e.kind != "born"]

    def summary(self) -> dict:
        return {"method": self.method, **self.tracker.counts}
