"""A vessel's view of its formation over a run (:class:`~mjasc.cooperation.coordination.Coordination`):
at every exchange with at least one neighbour heard, its lead over the neighbours and the formation
spread, both in metres of path (:meth:`Coordination.coordination_error`), and the statistics of
those samples that a run's summary reports.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["FormationHistory"]


@dataclass
class FormationHistory:
    """The (time [s], lead [m], spread [m]) samples in the order taken."""

    samples: list = field(default_factory=list)

    def add(self, t_s: float, lead_m: float, spread_m: float) -> None:
        self.samples.append((float(t_s), lead_m, spread_m))

    def __len__(self) -> int:
        return len(self.samples)

    def statistics(self, tolerance_m: float) -> dict:
        """The lead's initial, final, largest absolute and mean absolute values, the spread's
        initial, final, largest and mean values (rounded to the millimetre), and
        ``in_formation_from_s``: the first sample time from which the spread stays below
        ``tolerance_m`` [m] to the end (None: it never does); {} without samples."""
        if not self.samples:
            return {}
        t, lead, spread = np.array(self.samples).T
        a = np.abs(lead)
        # (+ 0.0: a lead rounded to −0.0 is written as 0.0)
        out = dict(initial_error_m=round(float(lead[0]), 3) + 0.0, final_error_m=round(float(lead[-1]), 3) + 0.0,
                   max_abs_error_m=round(float(a.max()), 3), mean_abs_error_m=round(float(a.mean()), 3),
                   initial_spread_m=round(float(spread[0]), 3), final_spread_m=round(float(spread[-1]), 3),
                   max_spread_m=round(float(spread.max()), 3), mean_spread_m=round(float(spread.mean()), 3))
        outside = np.nonzero(spread >= tolerance_m)[0]
        if not len(outside):
            out["in_formation_from_s"] = round(float(t[0]), 3)
        elif outside[-1] + 1 < len(t):
            out["in_formation_from_s"] = round(float(t[outside[-1] + 1]), 3)
        else:
            out["in_formation_from_s"] = None
        return out
