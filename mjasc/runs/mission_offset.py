"""How far each vessel sailed from its mission path: the summary's ``mean_mission_offset_m`` and
``max_mission_offset_m``.

The cross-track statistics measure path following: the distance to the path the follower follows
at that moment, which is a detour while the thesis method avoids (a re-planned path is followed
like any other). So they cannot compare avoidance methods — a detour's excursion is not in them, a
course override's (the velocity obstacles steer off the path) is. The mission offset is the
distance to the *mission* path — the current mission leg with a ``[mission]``, else the vessel's
scenario path — whatever avoidance does: the same measure for every method.

It is taken once a simulated second (every ``every``-th record tick: the largest excursion is
missed by at most the distance a hull sails in a second) at the record ticks the cross-track
statistics count (:class:`~mjasc.runs.metrics.CrossTrackGate`: a path followed, not past its end,
not approaching a far mission leg), the samples folded in chunks, one
:meth:`~mjasc.guidance.paths.Path.closest_points` call per path (world frame, metres).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["MissionOffset"]

#: Samples kept before they are folded into the statistics (bounded memory on long runs).
CHUNK = 512


class MissionOffset:
    """The mission offsets of ``n_vessels``, sampled every ``every`` record ticks."""

    def __init__(self, n_vessels: int, every: int):
        self.every = max(1, int(every))
        self._tick = 0
        self._sum = np.zeros(n_vessels)
        self._max = np.zeros(n_vessels)
        self._count = np.zeros(n_vessels, dtype=int)
        self._samples: list[tuple[int, object, float, float]] = []  # (vessel, path, x, y)

    def sample(self, positions_m: np.ndarray, counted, agents) -> None:
        """One record tick: ``positions_m`` (n, 2) world [m] of the vessels, ``counted`` each one's
        cross-track value as the statistics take it (NaN: not counted), ``agents`` the vessels
        (their mission leg or scenario path)."""
        tick, self._tick = self._tick, self._tick + 1
        if tick % self.every:
            return
        for i, e in enumerate(counted):
            if e == e:  # (counted: not NaN)
                agent = agents[i]
                path = agent.mission.leg_path if agent.mission is not None else agent.config.path
                if path is not None:
                    self._samples.append((i, path, float(positions_m[i][0]), float(positions_m[i][1])))
        if len(self._samples) >= CHUNK:
            self.flush()

    def flush(self) -> None:
        """Fold the kept samples into the statistics: one closest-point pass per path."""
        samples, self._samples = self._samples, []
        by_path: dict[int, list] = {}
        for s in samples:
            by_path.setdefault(id(s[1]), []).append(s)
        for group in by_path.values():
            path = group[0][1]
            vessels = np.array([s[0] for s in group], dtype=np.intp)
            _, d = path.closest_points(np.array([(s[2], s[3]) for s in group], dtype=float))
            np.add.at(self._sum, vessels, d)
            np.add.at(self._count, vessels, 1)
            np.maximum.at(self._max, vessels, d)

    def summary(self, i: int) -> dict:
        """Vessel i's ``mean_mission_offset_m`` and ``max_mission_offset_m`` [m] (None: no sample)."""
        self.flush()
        n = int(self._count[i])
        if not n:
            return {"mean_mission_offset_m": None, "max_mission_offset_m": None}
        mean = float(self._sum[i] / n)
        return {"mean_mission_offset_m": round(mean, 4) if math.isfinite(mean) else None,
                "max_mission_offset_m": round(float(self._max[i]), 4)}
