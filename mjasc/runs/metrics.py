"""Run metrics accumulated during a run and written as ``summary.json``.

Per vessel: distance travelled, mean and max |cross-track error| while a path is followed
(:class:`CrossTrackGate`: not past a finished path's end, nor on the approach to a mission leg
that begins away from the vessel), minimum clearance to every
obstacle (static: distance from the hull's bounding circle to the polygon/circle; moving and other
vessels: centre distance minus both radii), collisions (MuJoCo hull contacts, or clearance below
zero). Per run: wall time, simulated time and real-time factor.

A record tick is folded in at once (:meth:`RunMetrics.update`, given the traffic's state) or later
(:meth:`RunMetrics.defer`: its time, positions and cross-track errors kept, the traffic evaluated at
the kept times and the ticks folded in one compiled call per chunk of ticks; a run without a target
judge, which needs the traffic at every tick anyway): the same numbers.
"""

from __future__ import annotations

import numpy as np

from mjasc.evaluation.traffic_truth import traffic_at
from mjasc.physics.obstacles import PolygonObstacle
from mjasc.runs.metrics_kernels import update_metrics, update_metrics_ticks

__all__ = ["RunMetrics", "CrossTrackGate", "APPROACH_JUMP_M", "ON_PATH_BAND_M"]

#: [m] A new mission leg that puts the vessel this much farther off its line than it was the
#: tick before (a new phase's line, 9–45 m away in the chained mission) starts an approach: its
#: ticks measure the transit onto the line, not how well a line is followed, and are left out of
#: the cross-track statistics until the vessel first comes within :data:`ON_PATH_BAND_M` of its
#: leg (the recording's cross-track plot still shows them). Legs re-drawn a little way on (a
#: target-tracking station's line every few seconds: the error changes by < 5 m) count: their
#: error is how far the vessel lags its moving line.
APPROACH_JUMP_M = 5.0
#: [m] An approach ends when the vessel first comes this close to its leg.
ON_PATH_BAND_M = 1.0


#: Deferred record ticks folded in at once (:meth:`RunMetrics.defer`): bounds what is kept.
DEFER_TICKS = 512


class CrossTrackGate:
    """Which |cross-track errors| a record tick adds to the run's statistics, per vessel: the path
    follower's, except NaN (not counted) where no path is followed — before the first control
    tick, past a finished path's end (a vessel drifting there is off no path; the error kept
    growing with the drift) — and while a vessel approaches a mission leg that put it
    :data:`APPROACH_JUMP_M` or more farther off its line, until it first comes within
    :data:`ON_PATH_BAND_M` of its leg (at a phase change the error jumps to the distance to the
    new line: 9, 27 and 45 m in the chained mission). Paths that begin where the vessel is — the
    scenario's path from its start, a Dubins transit, avoidance's re-plans — and legs re-drawn a
    little way on (a station's moving line) count from their first tick."""

    def __init__(self, n_vessels: int):
        self._legs: list = [None] * n_vessels  # the mission leg path each vessel was last seen on
        self._last_abs_m = [0.0] * n_vessels  # its |error| [m] then
        self._approaching = [False] * n_vessels

    def counted(self, outputs, agents) -> list[float]:
        """The errors [m] (signed, NaN: not counted) of one record tick; ``outputs``: each vessel's
        last control output (None before the first), ``agents``: the vessels (their ``mission``)."""
        out = []
        legs, last, approaching = self._legs, self._last_abs_m, self._approaching
        for i, o in enumerate(outputs):
            st = o.status if o is not None else None
            if st is None or st.finished:
                out.append(np.nan)
                continue
            e = st.cross_track_m
            mission = agents[i].mission
            if mission is not None:
                leg, a = mission.leg_path, abs(e)
                if leg is not legs[i] and a - last[i] >= APPROACH_JUMP_M:  # a new line far off: the transit
                    approaching[i] = True
                elif approaching[i] and a <= ON_PATH_BAND_M:
                    approaching[i] = False
                legs[i], last[i] = leg, a
                if approaching[i]:
                    out.append(np.nan)
                    continue
            out.append(e)
        return out


class RunMetrics:
    def __init__(self, world, scenario, traffic=None):
        """``traffic``: the run's :class:`~mjasc.physics.obstacles.MovingObstacleSet` (the
        simulation's), needed by :meth:`defer` when the world has moving obstacles."""
        self.world = world
        self.names = list(world.vessel_names)
        n = len(self.names)
        self.radii = np.array([t.radius_m for t in world.vessel_types])
        self._distance = np.zeros(n)
        self._last_pos: np.ndarray | None = None
        self._xte_sum = np.zeros(n)
        self._xte_max = np.zeros(n)
        self._xte_count = np.zeros(n, dtype=int)
        self.static = list(world.static_obstacles)
        # Static obstacle j as the compiled update takes it (mjasc.runs.metrics_kernels): a polygon
        # is vertices[offsets[j]:offsets[j + 1]]; an empty range is a circle, circles[j] = (x, y, radius).
        polys = [np.asarray(o.vertices, dtype=float).reshape(-1, 2) if isinstance(o, PolygonObstacle)
                 else np.zeros((0, 2)) for o in self.static]
        self._vertices = np.ascontiguousarray(np.concatenate(polys)) if polys else np.zeros((0, 2))
        self._offsets = np.cumsum([0] + [len(v) for v in polys]).astype(np.int64)
        self._circles = np.array([[np.nan] * 3 if isinstance(o, PolygonObstacle)
                                  else [o.centre[0], o.centre[1], o.radius_m] for o in self.static],
                                 dtype=float).reshape(-1, 3)
        self._no_traffic = np.zeros((0, 2))
        # Minimum clearance per (vessel, object): columns are the static obstacles, the moving
        # obstacles, then the vessels (the diagonal stays +inf: no clearance to oneself).
        self._objects = [o.name for o in self.static] + [o.name for o in world.moving_obstacles] + self.names
        self._traffic_radii = np.array([o.radius_m for o in world.moving_obstacles], dtype=float)
        self._min_clear = np.full((n, len(self._objects)), np.inf)
        self.collisions: list[dict] = []
        self._in_contact: set[tuple[str, str]] = set()
        self._geom_owner = dict(enumerate(world.geom_owner))
        self._traffic_set = traffic
        self._pending: tuple[list, list, list] = ([], [], [])  # deferred ticks: times, positions, xte

    @property
    def distance(self) -> np.ndarray:
        """Distance travelled per vessel so far [m] (deferred ticks folded in first)."""
        self.flush()
        return self._distance

    def update(self, states, cross_track_m: np.ndarray, traffic) -> None:
        """Called at the record rate with the true states, each vessel's |xte| (nan = no path).
        Each block of the clearance matrix (a static obstacle's column, the moving obstacles', the
        vessels') is folded into the running minimum in place: the same numbers as one stacked
        matrix, without building it, in one compiled pass (:mod:`mjasc.runs.metrics_kernels`)."""
        if self._pending[0]:
            self.flush()
        pos = states.position_m
        has_last = self._last_pos is not None
        if not has_last:
            self._last_pos = np.empty_like(pos, dtype=float)
        tpos = traffic[0]
        update_metrics(pos, self._last_pos, has_last, np.asarray(cross_track_m, dtype=float), self._distance,
                       self._xte_sum, self._xte_count, self._xte_max, self._vertices, self._offsets, self._circles,
                       self.radii, tpos if tpos.shape[0] else self._no_traffic, self._traffic_radii, self._min_clear)

    def defer(self, states, cross_track_m) -> None:
        """:meth:`update` of this record tick later (module docstring): keeps its time, the true
        positions (``states.position_m``, a new array each tick: kept, not copied) and the |xte|
        values (a sequence, nan = no path); the traffic's state is evaluated at the kept times
        (:func:`~mjasc.evaluation.traffic_truth.traffic_at`: ``Simulation.traffic_state``'s
        numbers) when they are folded in — every :data:`DEFER_TICKS` ticks and by :meth:`flush`."""
        times, positions, xte = self._pending
        times.append(states.time_s)
        positions.append(states.position_m)
        xte.append(cross_track_m)
        if len(times) >= DEFER_TICKS:
            self.flush()

    def flush(self) -> None:
        """Fold the deferred ticks in (:meth:`defer`), in one compiled call."""
        times, positions, xte = self._pending
        if not times:
            return
        self._pending = ([], [], [])
        n = len(self.names)
        pos = np.array(positions, dtype=float).reshape(len(times), n, 2)
        if self._last_pos is None:
            self._last_pos = np.empty((n, 2))
            has_last = False
        else:
            has_last = True
        if len(self._traffic_radii):
            tpos = np.ascontiguousarray(traffic_at(self._traffic_set, times)[:, :, 0:2])
        else:
            tpos = np.zeros((len(times), 0, 2))
        update_metrics_ticks(pos, self._last_pos, has_last, np.array(xte, dtype=float).reshape(len(times), n),
                             self._distance, self._xte_sum, self._xte_count, self._xte_max, self._vertices,
                             self._offsets, self._circles, self.radii, tpos, self._traffic_radii, self._min_clear)

    def check_contacts(self, touches: dict) -> list[tuple[str, str]]:
        """New hull contacts since the last call (pairs of owner names); records them, each at the
        first physics step it touched. ``touches``: the geom pairs in contact at any physics step
        since the last call, with that step's time (:meth:`~mjasc.physics.simulation.Simulation.drain_touches`).
        A pair touching in two consecutive record periods is one contact. (Until 2026-12-07 only the
        contacts at the record tick's instant were seen: a bump of a step or two between two ticks —
        MuJoCo's contacts are instants — went uncounted.)"""
        if not touches and not self._in_contact:
            return []
        now: dict[tuple[str, str], float] = {}
        owner = self._geom_owner
        for (g1, g2), t in touches.items():
            a, b = owner.get(g1), owner.get(g2)
            if a and b and a != b and (a in self.names or b in self.names):
                pair = (a, b) if a < b else (b, a)
                now[pair] = min(t, now.get(pair, t))
        new = sorted(set(now) - self._in_contact, key=lambda p: (now[p], p))
        for pair in new:
            self.collisions.append({"time_s": round(now[pair], 3), "between": list(pair)})
        self._in_contact = set(now)
        return new

    def summary(self, wall_time_s: float, sim_time_s: float, per_vessel=None) -> dict:
        """The run's metrics for summary.json; ``per_vessel(i)`` (optional): more keys of vessel i's
        entry, after its cross-track statistics (the runner's mission offsets)."""
        self.flush()
        vessels = {}
        for i, name in enumerate(self.names):
            count = max(int(self._xte_count[i]), 1)
            clear = {k: round(float(self._min_clear[i, c]), 3) for c, k in sorted(enumerate(self._objects), key=lambda e: e[1])
                     if k != name and np.isfinite(self._min_clear[i, c])}
            vessels[name] = {
                "type": self.world.vessel_types[i].name,
                "distance_m": round(float(self._distance[i]), 3),
                "mean_cross_track_m": round(float(self._xte_sum[i] / count), 4) if self._xte_count[i] else None,
                "max_cross_track_m": round(float(self._xte_max[i]), 4) if self._xte_count[i] else None,
                **(per_vessel(i) if per_vessel is not None else {}),
                "min_clearance_m": clear,
                "min_clearance_to_any_m": round(min(clear.values()), 3) if clear else None,
                "collisions": [c for c in self.collisions if name in c["between"]],
            }
        return {
            "vessels": vessels,
            "collisions": self.collisions,
            "any_collision": bool(self.collisions),
            "sim_time_s": round(sim_time_s, 3),
            "wall_time_s": round(wall_time_s, 3),
            "real_time_factor": round(sim_time_s / wall_time_s, 2) if wall_time_s > 0 else None,
        }
