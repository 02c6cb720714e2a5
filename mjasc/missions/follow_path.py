"""Cooperative path following as a mission phase: the thesis's primitive along the formation path.

Each vessel follows its formation path (its ``controller`` path) at its cruise speed; the γ/L
consensus (:mod:`mjasc.cooperation.coordination`) keeps the team abreast. The phase joins the path
at the vessel's projection and ends ``end_band_m`` before its end.
"""

from __future__ import annotations

from mjasc.guidance.paths import Path
from mjasc.missions.legs import MissionBroadcast, MissionLeg, PhaseInputs

__all__ = ["FollowPath"]


class FollowPath:
    """The path-following phase of one vessel."""

    name = "follow_path"

    def __init__(self, index: int, end_band_m: float, formation_path: Path, cruise_speed_m_s: float):
        self.index = index
        self.end_band_m = end_band_m
        self.path = formation_path
        self.cruise_m_s = float(cruise_speed_m_s)
        self.events: list[tuple[float, str]] = []
        self._ended = False

    def begin(self, t_s: float, nav) -> MissionLeg:
        g0 = float(self.path.project(nav.position_m, 0.0, search_window_m=max(50.0, 0.25 * self.path.length)))
        return MissionLeg(self.name, self.index, self.path, g0, self.cruise_m_s, True)

    def step(self, x: PhaseInputs) -> tuple[MissionLeg | None, bool]:
        self._ended = x.gamma_m >= self.path.length - self.end_band_m
        return None, self._ended

    def broadcast(self) -> MissionBroadcast:
        return MissionBroadcast(self.index)

    def result(self) -> dict:
        return {"completed": self._ended}
