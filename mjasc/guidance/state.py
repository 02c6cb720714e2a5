"""What a vessel's guidance is doing now: the typed value the path follower hands to collision
avoidance and coordination each tick (they never hold the follower itself)."""

from __future__ import annotations

from dataclasses import dataclass

from mjasc.guidance.paths import Path

__all__ = ["GuidanceState"]


@dataclass(frozen=True)
class GuidanceState:
    """A vessel's guidance at one moment.

    path: the path it follows now (its mission path, or a detour that avoidance spliced in);
    gamma_m: its progress γ along that path [m] (the follower's projection);
    mission_speed_m_s: the speed its mission asks for now [m/s] — the mission's cruise speed times
    the coordination layer's latest correction factor (1 without coordination).
    """

    path: Path
    gamma_m: float
    mission_speed_m_s: float

    @classmethod
    def of(cls, path: Path, gamma_m: float, mission_speed_m_s: float) -> "GuidanceState":
        """The same value as ``GuidanceState(path, gamma_m, mission_speed_m_s)``, without the frozen
        dataclass's ``__init__`` (the agent makes a few per vessel and control tick); values taken
        as given."""
        state = object.__new__(cls)
        state.__dict__.update(path=path, gamma_m=gamma_m, mission_speed_m_s=mission_speed_m_s)
        return state
