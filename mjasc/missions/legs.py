"""The typed values of the mission layer.

* :class:`MissionLeg` — what the mission asks of the vessel now: a path to follow from a given γ,
  a speed, and whether the team coordinates its progress along that path (the γ/L consensus of
  :mod:`mjasc.cooperation.coordination`). The agent hands it to the path follower, to collision
  avoidance and to coordination (``set_mission``): none of them holds the mission.
* :class:`TargetEstimate` — a moving target's estimated state (world ENU, SI, absolute time).
* :class:`PhaseInputs` — what a phase reads at a control tick (typed values only).
* :class:`MissionBroadcast` — the mission's part of a vessel's team message: its phase, its
  earliest arrival at the formation pose (go-to-formation), its target estimate (the leader of
  target tracking).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from mjasc.guidance.paths import Path

__all__ = ["MissionLeg", "TargetEstimate", "MissionBroadcast", "PhaseInputs"]


@dataclass(frozen=True, eq=False)
class MissionLeg:
    """phase: the primitive (``go_to_formation``, ``follow_path``, ``track_target``); index: its place
    in the chain (0 first) — team mates coordinate only with mates in the same phase; path: the path
    to follow; gamma_m: where to join it [m]; speed_m_s: the mission speed along it [m/s];
    coordinated: the team keeps γ/L equal along its paths (False: the phase sets the speed itself);
    new_path: the path changed (False: only the speed did); station_keeping: the path is a line
    through a moving station (target tracking): its end is no destination — the station moves on
    along it — so collision avoidance may hold a lane change past it."""

    phase: str
    index: int
    path: Path
    gamma_m: float
    speed_m_s: float
    coordinated: bool = True
    new_path: bool = True
    station_keeping: bool = False


@dataclass(frozen=True, eq=False)
class TargetEstimate:
    """A target's state as estimated at ``time_s`` [s] by ``source`` (a vessel's name) from its track
    ``track_id``: position_m (2,) and velocity_m_s (2,), world ENU; turn_rate_rad_s its course rate
    (CCW positive; the IMM's ω̂)."""

    time_s: float
    position_m: np.ndarray
    velocity_m_s: np.ndarray
    track_id: int
    source: str
    turn_rate_rad_s: float = 0.0

    def position_at(self, t_s: float) -> np.ndarray:
        """The position extrapolated at constant velocity to ``t_s`` [m]."""
        return self.position_m + (float(t_s) - self.time_s) * self.velocity_m_s

    @property
    def speed_m_s(self) -> float:
        return float(math.hypot(*self.velocity_m_s))


@dataclass(frozen=True, eq=False)
class MissionBroadcast:
    """phase_index: the sender's phase in the chain; arrival_time_s: its earliest arrival at its
    formation pose at its cruise speed [s, absolute] (go-to-formation; None otherwise); target: its
    own estimate of the tracked target (the leader; None otherwise)."""

    phase_index: int
    arrival_time_s: float | None = None
    target: TargetEstimate | None = None


@dataclass(frozen=True, eq=False)
class PhaseInputs:
    """What a mission phase reads at one control tick: t_s [s]; nav the vessel's own
    :class:`~mjasc.core.navigation.OwnNavigation`; gamma_m its progress along the leg's path [m]
    (mapped back from a detour by avoidance); report its
    :class:`~mjasc.core.estimates.PerceptionReport` (None without perception); mates: team mate
    name → the :class:`MissionBroadcast` last heard from it; in_mission: avoidance is not acting
    (a phase re-draws its path and hands over only then); mate_plans: team mate name → the plan
    its last message carried, (times (k,) [s, absolute], world points (k, 2) [m]) (only mates whose
    message had one)."""

    t_s: float
    nav: object
    gamma_m: float
    report: object
    mates: dict
    in_mission: bool
    mate_plans: dict = field(default_factory=dict)
