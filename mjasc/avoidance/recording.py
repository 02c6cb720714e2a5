"""How one vessel's collision avoidance draws itself in the Rerun recording.

Time series ``plots/mode/<vessel>`` (the mode code of :data:`~mjasc.avoidance.request.MODES`),
the virtual target's speed and γ; in the world view under ``world/vessels/<vessel>/avoidance``:
the virtual target, the predicted own and track motions of the latest prediction, the predicted
collision points with their obstruction interval, the obstructed stretches, the SVOs, and while a
detour runs its streamline, the field's obstacles and a grid of the field's flow directions.
"""

from __future__ import annotations

import numpy as np
import rerun as rr

from mjasc.avoidance.request import MODES

__all__ = ["AvoidanceLog"]


def _xyz(p, z):
    p = np.asarray(p, dtype=float).reshape(-1, 2)
    return np.column_stack([p, np.full(len(p), z)])


def _closed(p):
    p = np.asarray(p, dtype=float)
    return np.vstack([p, p[:1]])


class AvoidanceLog:
    """Logging state of one vessel's avoidance: styles logged once, the latest prediction and
    detour logged once each (when :meth:`prediction_pending` was called since the last log)."""

    def __init__(self):
        self._styled = False
        self._pending = False

    def prediction_pending(self) -> None:
        """A new prediction or detour is to be drawn at the next :meth:`log`."""
        self._pending = True

    def log(self, recorder, t, vessel_name, mode, correction, guidance, last, detour) -> None:
        base = f"world/vessels/{vessel_name}/avoidance"
        if not self._styled:
            recorder.series_style(f"plots/speed/{vessel_name}/virtual_target", f"{vessel_name} virtual target",
                                  (230, 60, 60), 1.0)
            recorder.series_style(f"plots/mode/{vessel_name}", f"{vessel_name} mode (0 mission, 1 yield, 2 pass, "
                                  f"3 detour)", (200, 200, 200), 1.5)
            recorder.static(f"{base}/virtual_target", rr.Points3D.from_fields(colors=[(230, 60, 60)], radii=[0.4]))
            self._styled = True
        recorder.scalar(f"plots/mode/{vessel_name}", t, MODES[mode])
        c = correction
        if c is not None and guidance is not None:
            g_d = c.law.gamma_desired(t) - c.gamma_offset_m
            recorder.scalar(f"plots/speed/{vessel_name}/virtual_target", t, c.law.desired_speed)
            recorder.scalar(f"plots/gamma/{vessel_name}/virtual_target", t, c.law.gamma_desired(t))
            recorder.scalar(f"plots/gamma/{vessel_name}/actual", t, guidance.gamma_m + c.gamma_offset_m)
            recorder.points(f"{base}/virtual_target", t, guidance.path.point(float(np.clip(g_d, 0, guidance.path.length))),
                            z=0.4)
        if self._pending:
            self._log_prediction(recorder, t, base, last, detour)
            self._pending = False

    @staticmethod
    def _log_prediction(recorder, t, base, last, detour) -> None:
        if last is not None and last.time_s <= t:
            conflicts, statics = last.conflicts, last.statics
            own = last.all[0].vessel_positions if last.all else None
            if own is not None:
                recorder.log(f"{base}/predicted_own", rr.LineStrips3D([_xyz(own, 0.3)], colors=[(120, 220, 120)],
                                                                      radii=[0.08]), t)
                recorder.log(f"{base}/predicted_tracks", rr.LineStrips3D(
                    [_xyz(c.obstacle_positions, 0.3) for c in last.all],
                    colors=[(230, 80, 80) if c.collision else (230, 160, 160) for c in last.all], radii=[0.08]), t)
            pts, labels = [], []
            for c in conflicts:
                k = int(np.argmin(np.abs(c.times - c.t_closest_s)))
                pts.append(c.vessel_positions[k])
                tf = "inf" if not np.isfinite(c.t_f) else f"{c.t_f:.0f}"
                labels.append(f"t_c {c.t_closest_s:.0f}s [{c.t_i:.0f}, {tf}] s")
            recorder.log(f"{base}/collision_points", rr.Points3D(_xyz(np.array(pts).reshape(-1, 2), 0.5),
                                                                 colors=[(255, 0, 0)], radii=[0.6], labels=labels), t)
            stretches = [_xyz(last.path.point(np.linspace(s.gamma_a, s.gamma_b, 30)), 0.35)
                         for s in list(conflicts) + list(statics) if s.gamma_b > s.gamma_a]
            recorder.log(f"{base}/obstructed", rr.LineStrips3D(stretches, colors=[(255, 140, 0)], radii=[0.3]), t)
            svos = [_xyz(_closed(c.svo_polygon), 0.3) for c in conflicts if c.svo_polygon is not None]
            recorder.log(f"{base}/svo", rr.LineStrips3D(svos, colors=[(255, 200, 0)], radii=[0.12]), t)
        d = detour
        if d is not None:
            recorder.log(f"{base}/detour", rr.LineStrips3D([_xyz(d.streamline, 0.25)], colors=[(0, 220, 255)],
                                                           radii=[0.15]), t)
            recorder.log(f"{base}/field_obstacles", rr.LineStrips3D([_xyz(_closed(p), 0.25) for p in d.obstacles],
                                                                    colors=[(200, 120, 255)], radii=[0.1]), t)
            lo = np.min(np.vstack([d.streamline, *d.obstacles]), axis=0) - 5.0
            hi = np.max(np.vstack([d.streamline, *d.obstacles]), axis=0) + 5.0
            gx, gy = np.meshgrid(np.linspace(lo[0], hi[0], 15), np.linspace(lo[1], hi[1], 15))
            grid = np.column_stack([gx.ravel(), gy.ravel()])
            outside = np.array([d.field.obstacle_containing(p) is None for p in grid])
            grid = grid[outside]
            u = d.field.velocity(grid)
            n = np.hypot(*u.T)
            ok = np.isfinite(n) & (n > 0)
            scale = 0.6 * float(np.min(hi - lo)) / 15.0
            recorder.log(f"{base}/field", rr.Arrows3D(origins=_xyz(grid[ok], 0.2),
                                                      vectors=_xyz(scale * u[ok] / n[ok, None], 0.0),
                                                      colors=[(160, 160, 255, 150)], radii=[0.04]), t)
        else:
            for e in ("detour", "field_obstacles", "field"):
                recorder.log(f"{base}/{e}", rr.Clear(recursive=False), t)
