"""The values collision prediction takes and returns (:mod:`~mjasc.avoidance.prediction.conflicts`
computes them): one vessel's :class:`PredictionQuery`, the :class:`PredictedConflict` of each
(vessel, track) pair with its decision σ (:class:`Decision`, thesis eq. 3.17), and
:class:`ConflictList`, a query's conflicts in order with the clear pairs made on first read. World
frame ENU, SI units, absolute simulation times [s]."""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from mjasc.avoidance.prediction.config import CollisionPredictionConfig
from mjasc.avoidance.prediction.timing import SpeedProfile
from mjasc.core.estimates import TrackEstimate
from mjasc.guidance.paths import Path

__all__ = ["ConflictList", "Decision", "PredictedConflict", "PredictionQuery"]


class Decision(enum.Enum):
    """σ(Δt_o) of thesis eq. 3.17 (NONE when no collision is predicted)."""

    NONE = "none"
    VELOCITY_CORRECTION = "velocity_correction"
    REPLAN = "replan"


@dataclass(frozen=True, eq=False)
class PredictedConflict:
    """The outcome of collision prediction for one track.

    t_closest_s: t_c, the chosen local minimum of d(t) [s]; min_distance_m: d(t_c) [m].
    collision: d(t_c) ≤ R_vh + R_ob + safety. When False the spatial fields are NaN/None.
    t_i, t_f: obstruction interval [s] (t_f = inf for a static obstacle).
    gamma_a, gamma_b: the obstructed stretch of the vessel's path [m]; point_a, point_b: (2,) its ends.
    decision: σ(Δt_o). svo_polygon: (k, 2) CCW polygon of the static virtual obstacle when
    decision is REPLAN, else None.
    obstruction_truncated: the obstruction was still going on at the end of the searched span,
    so t_f is a lower bound.
    times, vessel_positions, obstacle_positions: the grid (n,) and both predictions on it (n, 2).
    """

    track_id: int
    t_closest_s: float
    min_distance_m: float
    collision: bool
    t_i: float
    t_f: float
    gamma_a: float
    gamma_b: float
    point_a: np.ndarray | None
    point_b: np.ndarray | None
    decision: Decision
    svo_polygon: np.ndarray | None
    vessel_positions: np.ndarray
    obstacle_positions: np.ndarray
    times: np.ndarray
    collision_distance_m: float = float("nan")
    is_static: bool = False
    obstruction_truncated: bool = False

    @property
    def obstruction_s(self) -> float:
        """Δt_o = t_f − t_i [s] (inf for static obstacles, NaN without a collision)."""
        return self.t_f - self.t_i


@dataclass(frozen=True)
class PredictionQuery:
    """One vessel's prediction (the arguments of :func:`predict_conflicts`)."""

    vessel_path: Path
    gamma_now: float
    t_now: float
    speed_profile: SpeedProfile
    vessel_radius_m: float
    tracks: Sequence[TrackEstimate]
    config: CollisionPredictionConfig = CollisionPredictionConfig()
    include_clear: bool = False


class ConflictList(Sequence):
    """One query's result of :func:`predict_fleet_lazy`: the :class:`PredictedConflict` of every
    checked pair sorted by t_c (as :func:`predict_fleet`'s list), the clear ones made on first
    use (a fleet's predictions read only the collisions and the smallest distance; the recording
    and the threat panel read the rest). ``collisions``: the collisions in order;
    ``min_distances``: every pair's d(t_c) [m] in order; ``track_ids`` and
    ``collision_distances`` (R_vh + R_ob + safety [m]): every pair's, in the same order."""

    __slots__ = ("_items", "_make", "collisions", "min_distances", "track_ids", "collision_distances")

    def __init__(self, items: list, make, collisions: list, min_distances: list, track_ids: list,
                 collision_distances: list):
        self._items, self._make, self.collisions, self.min_distances = items, make, collisions, min_distances
        self.track_ids, self.collision_distances = track_ids, collision_distances

    def __len__(self) -> int:
        return len(self._items)

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self[j] for j in range(*i.indices(len(self._items)))]
        c = self._items[i]
        if type(c) is int:  # a clear pair not made yet
            c = self._items[i] = self._make(c)
        return c

    def __iter__(self):
        for i in range(len(self._items)):
            yield self[i]
