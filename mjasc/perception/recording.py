"""How one vessel's perception draws itself in the Rerun recording (docs/perception.md, "Recording").

Every entity is one batch per vessel (all its tracks, all its returns), never one entity per track,
except the per-track time series of ``full`` detail. World frame ENU, metres, z only lifts layers
apart in the top-down view.

Standard detail (``[outputs] recording_detail = "standard"``, the default):

    world/vessels/<v>/tracks/positions   confirmed tracks, written at each tracker update; labels
                                         ``<v>:T<id>[ (<team mate>)][ static]`` in the same row
                                         whenever they change (rows without labels keep the latest)
    world/vessels/<v>/static_map         the mapped polygons the avoidance built last (what it
                                         planned around) when newer than the drawing, at most every
                                         ``MAP_LOG_PERIOD_S``; a changed map that nobody built is
                                         built for the drawing every ``MAP_BUILD_PERIOD_S``

The body-frame sensor view (``sensor/<v>``, FLU: x forward, y to port, metres from the sensor
mount; a static ``ViewCoordinates``): the fan's outline ``sensor/<v>/fan`` (its range and field of
view, static) and a bow arrow ``sensor/<v>/bow`` (static), the returns ``sensor/<v>/hits_body``
(every ``BODY_HITS_PERIOD_S``) and the detections ``sensor/<v>/detections_body`` (every
``BODY_DETECTIONS_PERIOD_S``; full detail: every scan).

Full detail (``"full"``) writes the tracks at every record tick and adds: returns in the world
(``world/vessels/<v>/sensor/hits``, every ``HITS_LOG_PERIOD_S``, as the body-frame returns),
detections and their discs (each new scan), the 2-σ position ellipses, the track discs and velocity
arrows, ``tracks/labels`` (every ``LABEL_LOG_PERIOD_S``), the time series
``plots/tracking/<v>/{omega,speed}/T<id>`` and ``.../modes/T<id>/w<j>``, the map at every change and
the track events (births included) in ``tracking_events/<v>``.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import rerun as rr

from mjasc.perception.detection import centres_body
from mjasc.perception.scan_batch import scan_time

__all__ = ["PerceptionLog", "HITS_LOG_PERIOD_S", "BODY_HITS_PERIOD_S", "LABEL_LOG_PERIOD_S", "MAP_LOG_PERIOD_S",
           "BODY_DETECTIONS_PERIOD_S", "MAP_BUILD_PERIOD_S", "ARROW_HORIZON_S", "fan_outline_body"]

#: Full detail: returns are written to the recording at most this often (a 720-beam fan is heavy) [s].
HITS_LOG_PERIOD_S = 0.5
#: Standard detail: the body-frame returns and detections are written at most this often [s] (the
#: returns at 1 s would add ~15 % to the demo's recording).
BODY_HITS_PERIOD_S = 2.0
BODY_DETECTIONS_PERIOD_S = 1.0
#: Full detail: the separate track labels are written this often [s].
LABEL_LOG_PERIOD_S = 1.0
#: Standard detail: the mapped polygons are written at most this often [s]: those the avoidance last
#: planned around (:meth:`~mjasc.perception.static_map.StaticMap.built_polygons`, built already) when
#: they are newer than the drawing.
MAP_LOG_PERIOD_S = 5.0
#: Standard detail: a map that changed but that the avoidance has not asked for is built for the
#: drawing at most this often [s] (a build costs ~1 ms in a run; building every changed map for
#: the drawing was ~3 % of the §6.4.3 bottleneck run).
MAP_BUILD_PERIOD_S = 30.0
#: Velocity arrows show where a track will be this many seconds ahead [s].
ARROW_HORIZON_S = 5.0

_CIRCLE_24 = np.linspace(0.0, 2.0 * np.pi, 25)
_CIRCLE_16 = np.linspace(0.0, 2.0 * np.pi, 17)
_ELLIPSE_33 = np.linspace(0.0, 2.0 * np.pi, 33)


def _circles(centres: np.ndarray, radii: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Closed inscribed polygons (k, m, 2) of discs (centres (k, 2), radii (k,)) with vertices at
    ``angles`` (the same points as :func:`mjasc.core.geometry.circle_polygon`, closed, inscribed)."""
    unit = np.stack([np.cos(angles), np.sin(angles)], axis=-1)
    return centres[:, None, :] + radii[:, None, None] * unit[None]


def _ellipses(centres: np.ndarray, covariances: np.ndarray, n_sigma: float = 2.0) -> np.ndarray:
    """Closed n-σ contours (k, 33, 2) of 2×2 covariances (k, 2, 2) (the batch form of
    :func:`mjasc.core.geometry.covariance_ellipse`: centre + n·V·√Λ·[cos t, sin t])."""
    lam, vec = np.linalg.eigh(covariances)
    scaled = vec * np.sqrt(np.maximum(lam, 0.0))[:, None, :]
    circle = np.stack([np.cos(_ELLIPSE_33), np.sin(_ELLIPSE_33)], axis=0)
    return centres[:, None, :] + n_sigma * np.einsum("kij,jm->kmi", scaled, circle)


def fan_outline_body(fov_deg: float, max_range_m: float, min_range_m: float = 0.0) -> list[np.ndarray]:
    """The sensor fan's outline in the body frame (FLU, x forward, y to port) [m]: closed strips
    (m, 2) — the outer arc at ``max_range_m`` from −fov/2 to +fov/2 (a full circle for 360°), the
    blind zone's arc at ``min_range_m`` and, for a sector, its two edges."""
    half = 0.5 * math.radians(fov_deg)
    arc = np.linspace(-half, half, max(8, int(round(fov_deg / 5.0)) + 1))
    unit = np.column_stack([np.cos(arc), np.sin(arc)])
    out = [max_range_m * unit]
    if min_range_m > 0.0:
        out.append(min_range_m * unit)
    if fov_deg < 360.0 - 1e-9:
        out += [np.array([min_range_m * unit[0], max_range_m * unit[0]]),
                np.array([min_range_m * unit[-1], max_range_m * unit[-1]])]
    return out


def _labels(vessel_name: str, ids, team, static) -> list[str]:
    """``<vessel>:T<id>[ (<team mate>)][ static]`` per confirmed track (ids, team mates and static
    flags of the confirmed tracks)."""
    return [f"{vessel_name}:T{i}" + (f" ({m})" if m else "") + (" static" if st else "")
            for i, m, st in zip(ids, team, static)]


def _as_list(values) -> list:
    """A list of the values (a list as it is; an array's as Python numbers)."""
    return values if type(values) is list else values.tolist()


@functools.lru_cache(maxsize=64)
def _track_style(colour: tuple) -> rr.Points3D:
    """The confirmed tracks' style in the vessel's colour (vessels share the palette's colours)."""
    return rr.Points3D.from_fields(colors=[(*colour, 255)], radii=[0.25], show_labels=[False], class_ids=[102])


@functools.lru_cache(maxsize=4)
def _map_style(colour: tuple) -> rr.LineStrips3D:
    return rr.LineStrips3D.from_fields(colors=[colour], radii=[0.1], class_ids=[111], show_labels=[False])


class PerceptionLog:
    """Logging state of one vessel's perception; :meth:`log` at every record tick."""

    def __init__(self):
        self._styled = False
        self._last_hits_log = -math.inf
        self._last_body_hits_log = -math.inf
        self._last_body_det_log = -math.inf
        self._last_label_log = -math.inf
        self._last_map_log = -math.inf
        self._logged_scan_t = -math.inf
        self._seen_scan = None  # the latest scan log() looked at
        self._logged_update = -1
        self._logged_map_version = 0
        self._label_key: tuple | None = None  # what the latest logged labels say
        self._series: set[int] = set()
        self._base_of: str | None = None  # the vessel whose world entity _base is
        self._base = ""
        self._views = False  # does the vessel have per-vessel views (Recorder.has_views; set by _style)

    def _style(self, rec, base: str, name: str, colour, sensor_config) -> None:
        # Track labels show on hover or selection, not over the boats (show_labels False). A vessel
        # without views has its styles written with the entity's first rows (Recorder.vessel_style).
        rec.vessel_style(name, f"{base}/tracks/positions", _track_style(tuple(colour)))
        rec.vessel_style(name, f"{base}/static_map", _map_style(rec.legend_colour(111)))
        self._styled = True  # (set before the early return: a vessel without views was styled at every tick)
        self._views = rec.has_views(name)  # (the recorder's views are set before the first record tick)
        if not self._views:
            return
        det = rec.legend_colour(116)
        body = f"sensor/{name}"
        rec.static(body, rr.ViewCoordinates.RIGHT_HAND_Z_UP)
        cfg = sensor_config
        fan = fan_outline_body(cfg.fov_deg, cfg.max_range_m, cfg.min_range_m)
        rec.static(f"{body}/fan", rr.LineStrips3D([np.column_stack([f, np.zeros(len(f))]) for f in fan],
                                                  colors=[rec.legend_colour(115)], radii=[-1.0], class_ids=[115],
                                                  show_labels=[False]))
        rec.static(f"{body}/bow", rr.Arrows3D(origins=[[0.0, 0.0, 0.0]], vectors=[[0.1 * cfg.max_range_m, 0.0, 0.0]],
                                              colors=[colour], radii=[-2.0], labels=[f"{name} bow (x)"],
                                              show_labels=[True]))
        # Sizes in UI points (negative radii): the view spans the whole fan, hundreds of metres.
        rec.static(f"{body}/hits_body", rr.Points3D.from_fields(colors=[(*colour, 220)], radii=[-1.5]))
        rec.static(f"{body}/detections_body", rr.Points3D.from_fields(colors=[det], radii=[-4.0], class_ids=[116],
                                                                      show_labels=[False]))
        if rec.full:
            rec.static(f"{base}/sensor/hits", rr.Points3D.from_fields(colors=[(*colour, 150)], radii=[0.12]))
            rec.static(f"{base}/sensor/detections", rr.Points3D.from_fields(colors=[det], radii=[0.35],
                                                                            class_ids=[116], show_labels=[False]))
            rec.static(f"{base}/sensor/detection_discs", rr.LineStrips3D.from_fields(colors=[(*det, 160)],
                                                                                     radii=[0.04]))
            rec.static(f"{base}/tracks/ellipses", rr.LineStrips3D.from_fields(colors=[(*colour, 255)], radii=[0.07]))
            rec.static(f"{base}/tracks/discs", rr.LineStrips3D.from_fields(colors=[(*colour, 110)], radii=[0.05]))
            rec.static(f"{base}/tracks/velocity", rr.Arrows3D.from_fields(colors=[(*colour, 255)], radii=[0.08]))
            rec.static(f"{base}/tracks/labels", rr.Points3D.from_fields(radii=[0.01], show_labels=[False]))

    def log(self, rec, t_s: float, perception, vessel_name: str) -> None:
        """Log ``perception`` (a :class:`mjasc.perception.pipeline.Perception`) at time t_s."""
        p, full = perception, rec.full
        base = self._base if self._base_of == vessel_name else self._name(vessel_name)
        if not self._styled:
            from mjasc.runs.recording import vessel_colour

            self._style(rec, base, vessel_name, vessel_colour(p.vessel_index), p.sensor_config)
        scan = p.scan
        # (a record tick without a new scan: no call; the scan's time read without filling in its
        # other fields, which only a due drawing reads: scan_batch.scan_time; a scan seen before —
        # scans are frozen, a new one a new object — was logged or had the time logged then)
        if scan is not None and scan is not self._seen_scan:
            self._seen_scan = scan
            if (scan_t := scan_time(scan)) != self._logged_scan_t:
                self._logged_scan_t = scan_t
                if full or self._views and (t_s - self._last_body_det_log >= BODY_DETECTIONS_PERIOD_S - 1e-9 or
                                            t_s - self._last_body_hits_log >= BODY_HITS_PERIOD_S - 1e-9):
                    self._log_scan(rec, t_s, p, scan, base, vessel_name, full)  # (a drawing is due)
        update = p._stats["track_updates"]
        if full or update != self._logged_update:
            self._logged_update = update
            self._log_tracks(rec, t_s, p, base, vessel_name, full)
        if full:
            for ev in p._log_events:
                rec.event(ev.time_s, ev.text, "DEBUG" if ev.kind == "born" else "INFO",
                          entity=f"tracking_events/{vessel_name}")
        if p._log_events:
            p._log_events = []
        # (the period first: the map's version read only when a drawing is due)
        if full or t_s - self._last_map_log >= MAP_LOG_PERIOD_S - 1e-9:
            self._log_map(rec, t_s, p.map, base, full)

    def _log_map(self, rec, t_s: float, static_map, base: str, full: bool) -> None:
        """The mapped polygons, when a drawing is due: full detail, the map at every change; standard,
        the polygons the avoidance built last if newer than the drawing, else the map itself (built
        now) if it changed and the drawing is :data:`MAP_BUILD_PERIOD_S` old."""
        built, polygons = static_map.built_version, None  # (the polygons' list copied only when drawn)
        if full or (built == self._logged_map_version and t_s - self._last_map_log >= MAP_BUILD_PERIOD_S - 1e-9):
            built = static_map.version
        elif built != self._logged_map_version:
            built, polygons = static_map.built_polygons()
        if built == self._logged_map_version:
            return
        self._logged_map_version, self._last_map_log = built, t_s
        if polygons is None:  # (the map now; built polygons may be none at all: an empty map drawn as such)
            polygons = static_map.polygons()
        rec.strips(f"{base}/static_map", t_s, [np.vstack([q, q[:1]]) for q in polygons], z=0.4)

    def _name(self, vessel_name: str) -> str:
        """The vessel's world entity (kept: :meth:`log` runs at every record tick)."""
        self._base_of, self._base = vessel_name, f"world/vessels/{vessel_name}"
        return self._base

    def _log_scan(self, rec, t_s, p, scan, base, vessel_name, full) -> None:
        """The new ``scan``'s returns and detections (:meth:`log` calls it once per scan, when a
        drawing is due); the detections are read only when drawn."""
        views = self._views
        if views and t_s - self._last_body_hits_log >= (HITS_LOG_PERIOD_S if full else BODY_HITS_PERIOD_S) - 1e-9:
            self._last_body_hits_log = t_s
            rec.points(f"sensor/{vessel_name}/hits_body", t_s, scan.hit_points_body, z=0.1)
        if views and (full or t_s - self._last_body_det_log >= BODY_DETECTIONS_PERIOD_S - 1e-9):
            self._last_body_det_log = t_s
            rec.points(f"sensor/{vessel_name}/detections_body", t_s, centres_body(p.detections), z=0.15)
        if not full:
            return
        det = p.detections
        if t_s - self._last_hits_log >= HITS_LOG_PERIOD_S - 1e-9:
            self._last_hits_log = t_s
            rec.points(f"{base}/sensor/hits", t_s, scan.hit_points_world, z=0.1)
        rec.points(f"{base}/sensor/detections", t_s, det.centres_m, z=0.15)
        rec.strips(f"{base}/sensor/detection_discs", t_s, list(_circles(det.centres_m, det.radii_m, _CIRCLE_16)),
                   z=0.15)

    def _log_tracks(self, rec, t_s, p, base, vessel_name, full) -> None:
        tr = p.tracker
        if not full:  # labels only when they change (the strings are built only then)
            ids, xy, static, team = tr.confirmed_points(t_s)  # (the fleet's read once per record tick)
            key = (_as_list(ids), _as_list(static), team)  # (arrays or lists: the same key)
            labels = None
            if key != self._label_key:
                self._label_key = key
                labels = _labels(vessel_name, ids, team, static)
            elif not len(ids):
                return  # nothing tracked, nothing was
            rec.points(f"{base}/tracks/positions", t_s, xy, z=0.3, labels=labels)
            return
        conf, ids, x, static, team = tr.confirmed_fields()  # (the vessel's confirmed rows only)
        bank = tr.bank
        labels = None
        if t_s - self._last_label_log >= LABEL_LOG_PERIOD_S - 1e-9:
            labels = _labels(vessel_name, ids, team, static)
        rec.points(f"{base}/tracks/positions", t_s, x[:, :2], z=0.3)
        rec.strips(f"{base}/tracks/ellipses", t_s, list(_ellipses(x[:, :2], bank.position_covariances[conf])), z=0.3)
        rec.strips(f"{base}/tracks/discs", t_s, list(_circles(x[:, :2], tr.radii_m[conf], _CIRCLE_24)), z=0.3)
        vel = ARROW_HORIZON_S * x[:, 3, None] * np.stack([np.cos(x[:, 2]), np.sin(x[:, 2])], axis=-1)
        rec.arrows(f"{base}/tracks/velocity", t_s, x[:, :2], vel, z=0.3)
        if labels is not None:
            self._last_label_log = t_s
            rec.points(f"{base}/tracks/labels", t_s, x[:, :2], z=1.0, labels=labels)
        omega = bank.turn_rates[conf]
        mu = bank.mode_probabilities[conf]
        plot = f"plots/tracking/{vessel_name}"
        for k, tid in enumerate(ids):
            rec.scalar(f"{plot}/omega/T{tid}", t_s, omega[k])
            rec.scalar(f"{plot}/speed/T{tid}", t_s, x[k, 3])
            for j in range(mu.shape[1]):
                rec.scalar(f"{plot}/modes/T{tid}/w{j}", t_s, mu[k, j])
            if tid not in self._series:
                self._series.add(tid)
                col = rec.colour(vessel_name)
                rec.series_style(f"{plot}/omega/T{tid}", f"{vessel_name} T{tid} ω̂ [rad/s]", col)
                rec.series_style(f"{plot}/speed/T{tid}", f"{vessel_name} T{tid} V̂ [m/s]", col)
                for j, wj in enumerate(p.config.imm.turn_rates_rad_s):
                    rec.series_style(f"{plot}/modes/T{tid}/w{j}", f"{vessel_name} T{tid} μ(ω={wj:+.2f} rad/s)",
                                     (*col, 140))
