"""How one vessel's collision avoidance draws itself in the Rerun recording.

The mode as a state (``StateChange`` at ``modes/<vessel>``, one lane per vessel in a state timeline,
styled by a static ``StateConfiguration``: names and colours of
:data:`~mjasc.runs.blueprint.MODE_STATES`) written when it changes; the threat panel
(:mod:`mjasc.avoidance.threat_panel`, markdown at ``threats/<vessel>``) written when its text
changes — at once when the mode, the running correction or the set of conflicts changed, else at
most every ``THREAT_PERIOD_S`` (a new prediction's CPA and TCPA); the virtual target's speed (and,
``full`` detail only, its γ and the vessel's: no view of the default blueprint shows them); in the world view under ``world/vessels/<vessel>/avoidance``:
the virtual target, the predicted own motion and the predicted motions of the tracks in conflict
(every ``_PREDICTION_STEP_S``) of the latest prediction, the predicted collision points with their
obstruction interval, the obstructed stretches, the SVOs, and while a detour runs its streamline
and the field's obstacles. ``full`` detail (``[outputs] recording_detail``) draws every predicted
track (the clear ones pale) at the prediction's own time step and a grid of the detour field's
flow directions. Everything goes through the recorder's buffers (written column-wise); a row with
no strips empties an entity when the detour ends. Overlays use the legend's classes and colours
(:data:`~mjasc.runs.blueprint.LEGEND_CLASSES`); the collision points' labels (t_c and the
obstruction interval) show on hover or selection only.
"""

from __future__ import annotations

import functools

from typing import TYPE_CHECKING

import numpy as np

from mjasc.avoidance.threat_panel import threat_markdown

if TYPE_CHECKING:  # rerun loads when a recording is made (a run without one never imports it)
    import rerun as rr

__all__ = ["AvoidanceLog", "THREAT_PERIOD_S"]

#: Standard detail: predicted trajectories are drawn with a point about this often [s of prediction].
_PREDICTION_STEP_S = 2.0
#: The threat panel's text is re-written for new CPA/TCPA values at most this often [s] (in a
#: 50-vessel fleet, predictions every second or two made the panels 10 % of the recording).
THREAT_PERIOD_S = 2.0
#: Legend classes (:data:`mjasc.runs.blueprint.LEGEND_CLASSES`) of the overlays.
_CONFLICT, _OBSTRUCTED, _SVO, _DETOUR, _FIELD_OBSTACLE, _VIRTUAL_TARGET, _OWN = 103, 104, 105, 106, 107, 108, 117
#: The virtual target's speed beside the vessel's (the vessels without views share one entity,
#: :meth:`mjasc.runs.recording.Recorder.vessel_scalar`).
_TARGET_SPEED = "plots/speed/{}/virtual_target"


def _closed(p):
    p = np.asarray(p, dtype=float)
    return np.vstack([p, p[:1]])


def _thin(times, points, step_s: float):
    """Every k-th of the (n, 2) points, k so that they are about ``step_s`` apart in time, with the last."""
    n = len(points)
    if n < 3 or len(times) != n:
        return points
    k = max(1, int(round(step_s / max(float(times[1] - times[0]), 1e-9))))
    idx = np.arange(0, n, k)
    if idx[-1] != n - 1:
        idx = np.append(idx, n - 1)
    return np.asarray(points)[idx]


@functools.cache
def _mode_states() -> rr.StateConfiguration:
    """The mode lane's states: names and colours of :data:`~mjasc.runs.blueprint.MODE_STATES`."""
    import rerun as rr

    from mjasc.runs.blueprint import MODE_STATES

    return rr.StateConfiguration(values=list(MODE_STATES), labels=[label for label, _ in MODE_STATES.values()],
                                 colors=[(*rgb, 255) for _, rgb in MODE_STATES.values()])


@functools.cache
def _overlay_styles(full: bool) -> dict:
    """Overlay entity (under ``world/vessels/<v>/avoidance``) → its style, in the legend's classes
    and colours (the same for every vessel: built once)."""
    import rerun as rr

    from mjasc.runs.blueprint import legend_colour as c

    styles = {"virtual_target": rr.Points3D.from_fields(colors=[c(_VIRTUAL_TARGET)], radii=[0.4],
                                                        class_ids=[_VIRTUAL_TARGET], show_labels=[False]),
              "predicted_own": rr.LineStrips3D.from_fields(colors=[c(_OWN)], radii=[0.08], class_ids=[_OWN],
                                                           show_labels=[False]),
              "predicted_tracks": rr.LineStrips3D.from_fields(colors=[c(_CONFLICT)], radii=[0.08],
                                                              class_ids=[_CONFLICT], show_labels=[False]),
              "collision_points": rr.Points3D.from_fields(colors=[c(_CONFLICT)], radii=[0.6], show_labels=[False],
                                                          class_ids=[_CONFLICT]),
              "obstructed": rr.LineStrips3D.from_fields(colors=[c(_OBSTRUCTED)], radii=[0.3],
                                                        class_ids=[_OBSTRUCTED], show_labels=[False]),
              "svo": rr.LineStrips3D.from_fields(colors=[c(_SVO)], radii=[0.12], class_ids=[_SVO], show_labels=[False]),
              "detour": rr.LineStrips3D.from_fields(colors=[c(_DETOUR)], radii=[0.15], class_ids=[_DETOUR],
                                                    show_labels=[False]),
              "field_obstacles": rr.LineStrips3D.from_fields(colors=[c(_FIELD_OBSTACLE)], radii=[0.1],
                                                             class_ids=[_FIELD_OBSTACLE], show_labels=[False])}
    if full:
        styles["field"] = rr.Arrows3D.from_fields(colors=[(160, 160, 255, 150)], radii=[0.04])
    return styles


class AvoidanceLog:
    """Logging state of one vessel's avoidance: styles logged once, the latest prediction and
    detour logged once each (when :meth:`prediction_pending` was called since the last log)."""

    def __init__(self):
        self._styled = False
        self._pending = False
        self._detour_shown = False
        self._mode: str | None = None  # the mode last written as a state
        self._threats: str | None = None  # the threat panel's text last written
        self._threats_key: tuple | None = None  # (mode, correction, conflicts) of that text
        self._threats_t = -np.inf  # when it was written [s]
        self._threats_due = True  # a prediction or the mode changed since
        self._shown = None  # the prediction whose conflicts _shown_ids names
        self._shown_ids: tuple = ()
        self._vessel: tuple = (None, "", False)  # (vessel name, its avoidance entity, has views): _entity

    def prediction_pending(self) -> None:
        """A new prediction or detour is to be drawn at the next :meth:`log`."""
        self._pending = True

    def _style(self, recorder, vessel_name: str, base: str) -> None:
        col = recorder.colour(vessel_name)
        c = recorder.legend_colour
        recorder.static(f"modes/{vessel_name}", _mode_states())
        recorder.vessel_series_style(_TARGET_SPEED, vessel_name, f"{vessel_name} virtual target", c(_VIRTUAL_TARGET),
                                     1.0)
        if recorder.full:  # no view of the default blueprint shows γ
            recorder.series_style(f"plots/gamma/{vessel_name}/virtual_target", f"{vessel_name} virtual target γ_d",
                                  c(_VIRTUAL_TARGET), 1.0)
            recorder.series_style(f"plots/gamma/{vessel_name}/actual", f"{vessel_name} γ", col, 2.0)
        for entity, style in _overlay_styles(recorder.full).items():  # without views: with the first rows
            recorder.vessel_style(vessel_name, f"{base}/{entity}", style)
        self._styled = True

    def _entity(self, recorder, vessel_name: str) -> tuple:
        """(vessel name, ``world/vessels/<vessel>/avoidance``, whether the vessel has per-vessel views),
        kept: :meth:`log` runs at every record tick (the recorder's views are set before the first)."""
        self._vessel = (vessel_name, f"world/vessels/{vessel_name}/avoidance", recorder.has_views(vessel_name))
        return self._vessel

    def log(self, recorder, t, vessel_name, mode, correction, guidance, last, detour, team=frozenset(),
            note: str | None = None) -> None:
        """``note``: for a method without predictions (the velocity obstacles), what the threat panel
        says instead of its table — its latest decision (:func:`~mjasc.avoidance.threat_panel.threat_markdown`)."""
        vessel = self._vessel if self._vessel[0] == vessel_name else self._entity(recorder, vessel_name)
        base = vessel[1]
        if not self._styled:
            self._style(recorder, vessel_name, base)
        if mode != self._mode:
            self._mode = mode
            recorder.state(f"modes/{vessel_name}", t, mode)
        if vessel[2]:  # (the threat panel: vessels with views only)
            self._log_threats(recorder, t, vessel_name, mode, correction, last, team, note)
        c = correction
        if c is not None and guidance is not None:
            g_d = c.law.gamma_desired(t) - c.gamma_offset_m
            recorder.vessel_scalar(_TARGET_SPEED, vessel_name, t, c.law.desired_speed)
            if recorder.full:
                recorder.scalar(f"plots/gamma/{vessel_name}/virtual_target", t, c.law.gamma_desired(t))
                recorder.scalar(f"plots/gamma/{vessel_name}/actual", t, guidance.gamma_m + c.gamma_offset_m)
            recorder.points(f"{base}/virtual_target", t, guidance.path.point(min(max(g_d, 0.0), guidance.path.length)),
                            z=0.4)
        if self._pending:
            self._log_prediction(recorder, t, base, last, detour)
            self._pending = False

    def _log_threats(self, recorder, t, vessel_name, mode, correction, last, team, note=None) -> None:
        shown = last if last is not None and last.time_s <= t else None
        if shown is not self._shown:  # (the conflicts' ids only change with the prediction)
            self._shown, self._shown_ids = shown, () if shown is None else (
                tuple(c.track_id for c in shown.conflicts), tuple(s.track_id for s in shown.statics))
        key = (mode, id(correction), self._shown_ids, note)
        self._threats_due |= self._pending or key != self._threats_key
        if not self._threats_due or (key == self._threats_key and t - self._threats_t < THREAT_PERIOD_S - 1e-9):
            return
        self._threats_due, self._threats_key = False, key
        text = threat_markdown(vessel_name, shown, team, mode, correction, note)
        if text != self._threats:
            self._threats, self._threats_t = text, t
            recorder.document(f"threats/{vessel_name}", t, text)

    def _log_prediction(self, recorder, t, base, last, detour) -> None:
        full = recorder.full
        if last is not None and last.time_s <= t:
            conflicts, statics = last.conflicts, last.statics
            if not last.all:
                recorder.strips(f"{base}/predicted_own", t, [], z=0.3)
                recorder.strips(f"{base}/predicted_tracks", t, [], z=0.3)
            else:
                own = last.all[0]
                recorder.strips(f"{base}/predicted_own", t, [own.vessel_positions if full else
                                                            _thin(own.times, own.vessel_positions, _PREDICTION_STEP_S)],
                                z=0.3)
                if full:
                    recorder.strips(f"{base}/predicted_tracks", t, [c.obstacle_positions for c in last.all], z=0.3,
                                    colours=[(*recorder.legend_colour(_CONFLICT), 255 if c.collision else 90)
                                             for c in last.all])
                else:
                    recorder.strips(f"{base}/predicted_tracks", t,  # the collisions of ``all``, in its order
                                    [_thin(c.times, c.obstacle_positions, _PREDICTION_STEP_S) for c in conflicts],
                                    z=0.3)
            pts, labels = [], []
            for c in conflicts:
                k = int(np.argmin(np.abs(c.times - c.t_closest_s)))
                pts.append(c.vessel_positions[k])
                tf = "inf" if not np.isfinite(c.t_f) else f"{c.t_f:.0f}"
                labels.append(f"t_c {c.t_closest_s:.0f}s [{c.t_i:.0f}, {tf}] s")
            recorder.points(f"{base}/collision_points", t, np.array(pts).reshape(-1, 2), z=0.5, labels=labels)
            stretches = [last.path.point(np.linspace(s.gamma_a, s.gamma_b, 30))
                         for s in list(conflicts) + list(statics) if s.gamma_b > s.gamma_a]
            recorder.strips(f"{base}/obstructed", t, stretches, z=0.35)
            recorder.strips(f"{base}/svo", t, [_closed(c.svo_polygon) for c in conflicts if c.svo_polygon is not None],
                            z=0.3)
        d = detour
        if d is not None:
            self._detour_shown = True
            recorder.strips(f"{base}/detour", t, [d.streamline], z=0.25)
            recorder.strips(f"{base}/field_obstacles", t, [_closed(p) for p in d.obstacles], z=0.25)
            if full and d.field is not None:
                self._log_field(recorder, t, base, d)
        elif self._detour_shown:  # the detour ended: empty rows clear it from the view
            self._detour_shown = False
            recorder.strips(f"{base}/detour", t, [], z=0.25)
            recorder.strips(f"{base}/field_obstacles", t, [], z=0.25)
            if full:
                recorder.arrows(f"{base}/field", t, np.zeros((0, 2)), np.zeros((0, 2)), z=0.2)

    @staticmethod
    def _log_field(recorder, t, base, d) -> None:
        """A 15 × 15 grid of the detour field's unit flow directions around the streamline."""
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
        recorder.arrows(f"{base}/field", t, grid[ok], scale * u[ok] / n[ok, None], z=0.2)
