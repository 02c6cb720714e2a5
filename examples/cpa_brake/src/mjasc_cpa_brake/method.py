"""``cpa_brake``: a speed-only collision-avoidance method, the example of an mjasc plugin.

Every control tick it computes, for each confirmed moving track, the closest point of approach
under constant velocities (own velocity from the vessel's own navigation, the track's from its
course and speed)::

    r = p_track − p_own,  w = v_track − v_own
    t_cpa = clamp(−(r·w) / |w|², 0, horizon)        d_cpa = |r + w t_cpa|

and when some track comes closer than ``safety_distance_m`` (plus both radii) within the horizon it
slows the vessel to ``slow_factor`` × the mission speed (or stops it when the CPA is within
``stop_within_s``), keeping its path: the other vessel passes ahead. It reads only what the
plugin interface hands it (its own navigation, its guidance state, its perception's tracks).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mjasc.avoidance.request import AvoidanceRequest
from mjasc.core.config_tables import param
from mjasc.plugins import AvoidanceMethod


@dataclass(frozen=True)
class CPABrakeOptions:
    safety_distance_m: float = param(5.0, positive=True, unit="m", doc="clearance kept between hull circles")
    horizon_s: float = param(40.0, positive=True, unit="s", doc="how far ahead a CPA is considered")
    slow_factor: float = param(0.3, minimum=0.0, maximum=1.0, doc="speed while braking, fraction of the mission's")
    stop_within_s: float = param(10.0, nonneg=True, unit="s", doc="stop when the conflict's CPA is this close in time")


class CPABrake(AvoidanceMethod):
    """Slow down (or stop) for a predicted close approach; never leaves the path."""

    method = "cpa_brake"
    Options = CPABrakeOptions

    def __init__(self, context, options):
        super().__init__(context, options)
        self.radius_m = float(context.vessel.radius_m)
        self.brakes = 0
        self._braking = False

    def control(self, t, nav, guidance, report, team=None):
        o = self.options
        moving = [tr for tr in report.tracks if not tr.is_static] if report is not None else []
        if not moving or guidance is None:
            self._braking = False
            return AvoidanceRequest()
        p = np.array([tr.position_m for tr in moving], dtype=float)
        v = np.array([[tr.speed_m_s * np.cos(tr.heading_rad), tr.speed_m_s * np.sin(tr.heading_rad)]
                      for tr in moving])
        radii = np.array([tr.radius_m for tr in moving])
        r = p - nav.position_m
        w = v - nav.velocity_m_s
        ww = np.einsum("ij,ij->i", w, w)
        t_cpa = np.clip(-np.einsum("ij,ij->i", r, w) / np.maximum(ww, 1e-12), 0.0, o.horizon_s)
        d_cpa = np.linalg.norm(r + w * t_cpa[:, None], axis=1)
        conflict = d_cpa < o.safety_distance_m + self.radius_m + radii
        if not conflict.any():
            self._braking = False
            return AvoidanceRequest()
        if not self._braking:
            self.brakes += 1
            self._braking = True
        factor = 0.0 if t_cpa[conflict].min() <= o.stop_within_s else o.slow_factor
        return AvoidanceRequest("avoidance:yield", factor * guidance.mission_speed_m_s)

    def summary(self) -> dict:
        return {"method": self.method, "brakes": self.brakes}
