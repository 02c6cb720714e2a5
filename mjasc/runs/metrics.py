"""Run metrics accumulated during a run and written as ``summary.json``.

Per vessel: distance travelled, mean and max |cross-track error|, minimum clearance to every
obstacle (static: distance from the hull's bounding circle to the polygon/circle; moving and other
vessels: centre distance minus both radii), collisions (MuJoCo hull contacts, or clearance below
zero). Per run: wall time, simulated time and real-time factor.
"""

from __future__ import annotations

import numpy as np

from mjasc.core.polygon_kernels import boundary_distance, inside_even_odd
from mjasc.physics.obstacles import PolygonObstacle

__all__ = ["RunMetrics"]


def _norm(d: np.ndarray) -> np.ndarray:
    """‖d‖ over the last axis (2) of d: √(x² + y²), the numbers of ``np.linalg.norm(d, axis=-1)``."""
    x, y = d[..., 0], d[..., 1]
    return np.sqrt(x * x + y * y)


class RunMetrics:
    def __init__(self, world, scenario):
        self.world = world
        self.names = list(world.vessel_names)
        n = len(self.names)
        self.radii = np.array([t.radius_m for t in world.vessel_types])
        self.distance = np.zeros(n)
        self._last_pos: np.ndarray | None = None
        self._xte_sum = np.zeros(n)
        self._xte_max = np.zeros(n)
        self._xte_count = np.zeros(n, dtype=int)
        self.static = list(world.static_obstacles)
        # Per static obstacle: (vertices as the compiled kernels take them, None) for a polygon,
        # (None, centre, radius) for a circle.
        self._static_shapes = [(np.ascontiguousarray(np.asarray(o.vertices, dtype=float).reshape(-1, 2)), None, None)
                               if isinstance(o, PolygonObstacle)
                               else (None, o.centre, o.radius_m) for o in self.static]
        # Minimum clearance per (vessel, object): columns are the static obstacles, the moving
        # obstacles, then the vessels (the diagonal stays +inf: no clearance to oneself).
        self._objects = [o.name for o in self.static] + [o.name for o in world.moving_obstacles] + self.names
        self._traffic_radii = np.array([o.radius_m for o in world.moving_obstacles])
        self._min_clear = np.full((n, len(self._objects)), np.inf)
        self.collisions: list[dict] = []
        self._in_contact: set[tuple[str, str]] = set()
        self._geom_owner = dict(enumerate(world.geom_owner))

    def update(self, states, cross_track_m: np.ndarray, traffic) -> None:
        """Called at the record rate with the true states, each vessel's |xte| (nan = no path).
        Each block of the clearance matrix (a static obstacle's column, the moving obstacles', the
        vessels') is folded into the running minimum in place: the same numbers as one stacked
        matrix, without building it (this runs at every record tick)."""
        pos = states.position_m
        if self._last_pos is not None:
            self.distance += np.hypot(*(pos - self._last_pos).T)
        self._last_pos = pos.copy()
        ok = np.isfinite(cross_track_m)
        a = np.abs(np.where(ok, cross_track_m, 0.0))
        self._xte_sum += a
        self._xte_count += ok
        np.maximum(self._xte_max, a, out=self._xte_max)
        mc, radii = self._min_clear, self.radii
        if self._static_shapes:
            p = np.ascontiguousarray(pos, dtype=float)  # (the kernels' layout: core.geometry's distance and inside)
            for j, (vertices, centre, radius) in enumerate(self._static_shapes):
                if vertices is not None:
                    d = boundary_distance(p, vertices)
                    d = np.where(inside_even_odd(p, vertices), -d, d)
                else:
                    d = np.hypot(*(pos - centre).T) - radius
                np.minimum(mc[:, j], d - radii, out=mc[:, j])
        j = len(self._static_shapes)
        tpos = traffic[0]
        if len(tpos):
            k = len(tpos)
            block = _norm(pos[:, None] - tpos[None]) - radii[:, None] - self._traffic_radii[None]
            np.minimum(mc[:, j:j + k], block, out=mc[:, j:j + k])
            j += k
        pair = _norm(pos[:, None] - pos[None]) - radii[:, None] - radii[None]
        np.fill_diagonal(pair, np.inf)
        np.minimum(mc[:, j:], pair, out=mc[:, j:])

    def check_contacts(self, t_s: float) -> list[tuple[str, str]]:
        """New hull contacts since the last call (pairs of owner names); records them."""
        d = self.world.data
        now = set()
        if not d.ncon and not self._in_contact:
            return []  # (``d.contact`` costs ~0.5 ms to wrap even when empty: most calls stop here)
        for c in d.contact[: d.ncon]:
            a, b = self._geom_owner.get(c.geom1), self._geom_owner.get(c.geom2)
            if a and b and a != b and (a in self.names or b in self.names):
                now.add(tuple(sorted((a, b))))
        new = sorted(now - self._in_contact)
        for pair in new:
            self.collisions.append({"time_s": round(t_s, 3), "between": list(pair)})
        self._in_contact = now
        return new

    def summary(self, wall_time_s: float, sim_time_s: float) -> dict:
        vessels = {}
        for i, name in enumerate(self.names):
            count = max(int(self._xte_count[i]), 1)
            clear = {k: round(float(self._min_clear[i, c]), 3) for c, k in sorted(enumerate(self._objects), key=lambda e: e[1])
                     if k != name and np.isfinite(self._min_clear[i, c])}
            vessels[name] = {
                "type": self.world.vessel_types[i].name,
                "distance_m": round(float(self.distance[i]), 3),
                "mean_cross_track_m": round(float(self._xte_sum[i] / count), 4) if self._xte_count[i] else None,
                "max_cross_track_m": round(float(self._xte_max[i]), 4) if self._xte_count[i] else None,
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
