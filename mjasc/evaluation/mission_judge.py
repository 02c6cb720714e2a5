"""Judging a target-tracking mission against the truth (the vessels never see it).

While a vessel is in its ``track_target`` phase — until the phase ends, not until the vessel (maybe
still avoiding) hands over to its next phase — at every record tick from ``settle_s`` after the
phase began: its true station s = p_T + R(ψ_T) o_i (the target's true position and heading, the
vessel's offset o_i = [ahead, to port]) and the errors

    station error  |s − p_i|          standoff  |p_T − p_i|

summarized per vessel (RMS, max, mean, min) in summary.json under ``mission.track_target_truth``,
with the number of record ticks judged and their first and last time (``samples``,
``judged_from_s``, ``judged_to_s``: a phase that ended just after settling rests on one sample;
one that ended before has ``samples`` 0 and no numbers).
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.missions.config import VesselMissionOptions
from mjasc.missions.target_tracking import station

__all__ = ["TargetJudge"]


class TargetJudge:
    """Record-slot judge of the team's stations around the named target (a moving obstacle).

    ``rows``: vessel name → [(t [s], station error [m], stand-off [m])] at every record tick the
    vessel spent in its ``track_target`` phase (observers draw them: mjasc.figures.missions); the
    summary judges those from ``settle_s`` after the phase began."""

    def __init__(self, scenario, world):
        tt = scenario.mission.track_target
        names = [o.name for o in world.moving_obstacles]
        self.index = names.index(tt.target)
        self.settle_s = tt.settle_s
        self.offsets = {v.name: (v.options.get("mission") or VesselMissionOptions()).target_offset_m
                        for v in scenario.vessels if v.controller != "none"}
        self.rows: dict[str, list[tuple[float, float, float]]] = {n: [] for n in self.offsets}
        self._settled: dict[str, int] = {n: 0 for n in self.offsets}  # rows before settling, per vessel

    def update(self, states, traffic, agents) -> None:
        """One record tick: states (true :class:`~mjasc.physics.simulation.VesselStates`), traffic
        (positions (M, 2), headings (M,), velocities (M, 2)), the agents (their mission phase)."""
        pos_t, head_t = traffic[0][self.index], float(traffic[1][self.index])
        for i, agent in enumerate(agents):
            m = agent.mission
            if m is None or m.phase_name != "track_target" or agent.name not in self.offsets or \
                    m.timeline[-1]["end_s"] is not None:  # (ended: the vessel is not yet back in mission mode)
                continue
            st = station(pos_t, head_t, self.offsets[agent.name])
            p = states.position_m[i]
            self.rows[agent.name].append((float(states.time_s), math.hypot(st[0] - p[0], st[1] - p[1]),
                                          math.hypot(pos_t[0] - p[0], pos_t[1] - p[1])))
            if states.time_s - m.timeline[-1]["start_s"] < self.settle_s:
                self._settled[agent.name] = len(self.rows[agent.name])

    def summary(self) -> dict:
        out = {}
        for name, rows in self.rows.items():
            rows = rows[self._settled[name]:]
            entry = dict.fromkeys(("station_error_rms_m", "station_error_max_m", "standoff_mean_m",
                                   "standoff_min_m"))  # (None: the phase ended before settle_s)
            if rows:
                e = np.array(rows)[:, 1:]
                entry.update(station_error_rms_m=round(float(np.sqrt(np.mean(e[:, 0] ** 2))), 3),
                             station_error_max_m=round(float(e[:, 0].max()), 3),
                             standoff_mean_m=round(float(e[:, 1].mean()), 3),
                             standoff_min_m=round(float(e[:, 1].min()), 3))
            # what the numbers rest on: a phase that ended just after settling is one sample
            entry.update(standoff_nominal_m=round(float(math.hypot(*self.offsets[name])), 3), samples=len(rows),
                         judged_from_s=round(rows[0][0], 3) if rows else None,
                         judged_to_s=round(rows[-1][0], 3) if rows else None)
            out[name] = entry
        return out
