"""What a video frame shows of a run's sensing and decisions, and how it is drawn into MuJoCo's scene.

:func:`frame_view` reads only what a runner observer may read (a
:class:`~mjasc.runs.tick.SlotEvent`: the true states, ``runner.agents``, ``runner.last_outputs``,
``runner.sim.current``, ``runner.scenario``; per agent the public ``perception.scan`` and
``perception.tracks()``, ``avoidance.last_prediction``, ``avoidance.detour`` and the latest entry of
``avoidance.conflict_log``, the decision taken) into a
:class:`FrameView`. :func:`add_scene_geoms` draws it as user geoms of the ``mjvScene`` (after
``update_scene``, before rendering), all in the world frame (ENU, metres), a few centimetres above
the water so that MuJoCo's own geoms (hulls, obstacles) stay visible:

- mission paths (white, faint) and each vessel's trail (its colour);
- the sensor fan: the outline of what the latest scan saw (range ``ρ_k`` along beam ``k`` at world
  angle ``ψ + a_k``; the maximum range where there was no return), decimated to every 6th beam
  except where returns are, and the returns as small dots, in the vessel's colour;
- each confirmed track as a disc of its estimated radius, its 2σ position ellipse and its velocity
  vector (the distance covered in :data:`VELOCITY_ARROW_S` seconds), in the tracking vessel's colour;
- the latest prediction's conflicts: own position at the closest approach ``t_c`` (red) joined to
  the obstacle's predicted position then (the predicted miss distance), and the static virtual
  obstacle of a conflict that asked for a re-plan (black outline);
- the detour streamline (cyan) and the potential field's obstacle polygons (deep purple);
- a map-symbol arrow per vessel (a 2 m hull is a few pixels in a 200 m view), ``marker_m`` long.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np

from mjasc.core.geometry import covariance_ellipse
from mjasc.runs.recording import vessel_colour

__all__ = ["FrameView", "VesselView", "frame_view", "add_scene_geoms", "VELOCITY_ARROW_S", "COLOURS"]

#: A track's velocity vector is drawn as the distance it covers in this time [s].
VELOCITY_ARROW_S = 10.0
#: Overlay colours (RGBA 0–1) shared by the scene and the legend. None equals a vessel colour
#: (:data:`mjasc.runs.blueprint.PALETTE`: gold, pink, lime, orange, violet, white, …) and each stands
#: out on the blue water: light blue paths (not the white of vessel 5), cyan detours, red
#: conflicts, black static virtual obstacles (not vessel 0's gold nor vessel 3's orange) and deep
#: purple potential-field obstacles (not vessel 4's light violet).
COLOURS = {"path": (0.45, 0.6, 1.0, 0.5), "detour": (0.0, 0.9, 1.0, 1.0), "conflict": (1.0, 0.15, 0.15, 1.0),
           "svo": (0.02, 0.02, 0.02, 0.9), "field": (0.45, 0.0, 0.55, 0.95), "fan_alpha": 0.3, "track_alpha": 0.35}
#: The sensor fan keeps every FAN_DECIMATION-th beam without a return (all beams with one).
FAN_DECIMATION = 6


#: How long after it a conflict's decision stays in the video's HUD while the vessel is back on its
#: mission [s] (while it avoids, the latest decision stays).
DECISION_SHOWN_S = 30.0


@dataclass
class VesselView:
    """One vessel as the frame shows it: true pose [m, rad], its colour (RGB 0–255), its mode."""

    name: str
    colour: tuple
    position_m: np.ndarray
    heading_rad: float
    mode: str = ""
    decision: str = ""  # the latest conflict's decision, e.g. "velocity_correction for T112 at 41 s"
    fan: np.ndarray | None = None  # (k, 2) closed outline of the latest scan [m]
    returns: np.ndarray | None = None  # (m, 2) world returns of the latest scan [m]
    tracks: list = field(default_factory=list)  # TrackEstimate
    conflicts: list = field(default_factory=list)  # (own (2,), obstacle (2,)) at t_c [m]
    svos: list = field(default_factory=list)  # (k, 2) polygons [m]
    detour: np.ndarray | None = None  # (k, 2) streamline [m]
    field_obstacles: list = field(default_factory=list)  # (k, 2) polygons [m]
    mission_phase: str = ""  # the chained mission's phase ("go to formation" …; "" without a mission)
    leg: np.ndarray | None = None  # (k, 2) the mission leg's path when it is not the formation path [m]


@dataclass
class FrameView:
    time_s: float
    vessels: list
    current_m_s: np.ndarray  # (2,) the current at the view's centre [m/s]
    #: Text rows under the title (a suite episode: policy, reward, return, the task's state).
    lines: list = field(default_factory=list)
    #: The legend's rows (kind, RGBA 0–1, text) as :data:`mjasc.runs.video_hud.LEGEND_ITEMS`
    #: (None: those, a run's overlays; empty: no legend).
    legend: tuple | None = None
    #: The moving obstacles' true positions (k, 2) world [m] (None: none), which the legend keeps clear of.
    traffic_m: np.ndarray | None = None


def frame_view(event, centre_xy) -> FrameView:
    """The :class:`FrameView` of a :class:`~mjasc.runs.tick.SlotEvent` (public attributes only)."""
    runner, st = event.runner, event.states
    outputs = getattr(runner, "last_outputs", [None] * len(runner.agents))
    vessels = []
    for i, agent in enumerate(runner.agents):
        out = outputs[i] if i < len(outputs) else None
        v = VesselView(agent.name, vessel_colour(i), np.asarray(st.position_m[i], float), float(st.heading_rad[i]),
                       out.mode if out is not None else getattr(agent, "mode", ""))
        p = agent.perception
        if p is not None:
            scan = p.scan
            if scan is not None:
                v.fan, v.returns = scan_outline(scan), scan.hit_points_world
            v.tracks = [tr for tr in p.tracks() if not tr.is_static]
        m = getattr(agent, "mission", None)
        if m is not None:
            from mjasc.missions.sequencer import PHASE_STATES

            v.mission_phase = PHASE_STATES[m.phase_name][0]
            leg = m.leg_path
            if leg is not None and leg is not agent.config.path:
                v.leg = leg.sample(max(0.5, leg.length / 100.0))
        a = agent.avoidance
        if a is not None:
            log = getattr(a, "conflict_log", None)
            c = getattr(a, "last_conflict", None) or (log[-1] if log else None)  # (a plugin may keep only a log)
            corr = getattr(a, "correction", None)  # (the thesis method's running yield or pass: its track's decision)
            if corr is not None and (c is None or c.get("track_id") != corr.track_id):
                c = next((e for e in reversed(log or ()) if e.get("track_id") == corr.track_id), None) or \
                    {"time_s": float(event.time_s), "track_id": corr.track_id,
                     "decision": "emergency stop" if corr.emergency else corr.kind}
            # the latest decision, while the vessel avoids or for DECISION_SHOWN_S after it (not a
            # decision from the run's first second still shown at its end); what it did (the
            # triage's answer) where the method says it, else the prediction's σ
            recent = c is not None and float(event.time_s) - c["time_s"] <= DECISION_SHOWN_S
            if c is not None and ((v.mode or "").startswith("avoidance") or recent):
                what = "a static obstacle" if c.get("static") else f"T{c['track_id']}"
                v.decision = f"{c.get('action') or c['decision']} for {what} at {c['time_s']:.1f} s"
            last = a.last_prediction
            if last is not None:
                for c in last.conflicts:
                    k = int(np.argmin(np.abs(c.times - c.t_closest_s)))
                    v.conflicts.append((c.vessel_positions[k], c.obstacle_positions[k]))
                    if c.svo_polygon is not None:
                        v.svos.append(np.asarray(c.svo_polygon, float))
            if a.detour is not None:
                v.detour = np.asarray(a.detour.streamline, float)
                v.field_obstacles = [np.asarray(o, float) for o in a.detour.obstacles]
        vessels.append(v)
    current = np.asarray(runner.sim.current.velocity(np.asarray(centre_xy, float).reshape(1, 2), event.time_s),
                         float).reshape(-1)[:2]
    traffic_state = getattr(runner.sim, "traffic_state", None)
    traffic = np.asarray(traffic_state()[0], float).reshape(-1, 2) if traffic_state is not None else None
    return FrameView(float(event.time_s), vessels, current, traffic_m=traffic if traffic is not None and len(traffic)
                     else None)


def scan_outline(scan) -> np.ndarray:
    """Closed world outline (k, 2) [m] of a scan's fan: the sensor origin, then the beam ends
    ``o + ρ_k (cos(ψ + a_k), sin(ψ + a_k))`` of the kept beams (every :data:`FAN_DECIMATION`-th,
    the first and last, and all with a return), then the origin again (a full circle closes on its
    first beam end instead)."""
    n = len(scan.angles_body)
    keep = scan.hit.copy()
    keep[::FAN_DECIMATION] = True
    keep[[0, n - 1]] = True
    ang = scan.heading_rad + scan.angles_body[keep]
    ends = scan.origin_m + scan.ranges[keep, None] * np.column_stack([np.cos(ang), np.sin(ang)])
    o = np.asarray(scan.origin_m, float)[None, :]
    return np.vstack([ends, ends[:1]]) if scan.full_circle else np.vstack([o, ends, o])


# ---------------------------------------------------------------------------------- geoms
_EYE3 = np.eye(3).ravel()
_ZERO3 = np.zeros(3)


def _free(scn) -> bool:
    return scn.ngeom < scn.maxgeom


_UNKNOWN, _DECOR = int(mujoco.mjtObj.mjOBJ_UNKNOWN), int(mujoco.mjtCatBit.mjCAT_DECOR)


def _init_geom(g, kind, size, pos, mat, rgba) -> None:
    """``mujoco.mjv_initGeom``, and the fields it leaves as the scene's slot held them: the object
    (unknown, none), the category (decoration) and the segmentation id (none). A slot holds what an
    earlier frame or the scene's uninitialised memory left there, and ``mjr_render`` reads the
    object type: a transparent geom whose stale ``objtype`` says "model geom" takes the model's
    bounding radius (0, as initialised) instead of its own size for its distance to the camera, so
    the back-to-front order of crossing semi-transparent lines — the colour where two trails cross
    — depended on the process's heap (the same seed gave other video bytes now and then)."""
    mujoco.mjv_initGeom(g, kind, size, pos, mat, rgba)
    g.objtype, g.objid, g.category, g.segid = _UNKNOWN, -1, _DECOR, -1


def add_line(scn, a, b, rgba, width: float = 2.0, z: float = 0.05) -> None:
    """A line from world xy ``a`` to ``b`` [m] at height z, ``width`` pixels."""
    add_lines(scn, np.asarray(a, float).reshape(1, 2), np.asarray(b, float).reshape(1, 2), rgba, width, z)


def add_strip(scn, points, rgba, width: float = 2.0, z: float = 0.05) -> None:
    """The polyline through world xy ``points`` (k, 2) [m] at height z, ``width`` pixels."""
    pts = np.asarray(points, float)
    if len(pts) > 1:
        add_lines(scn, pts[:-1], pts[1:], rgba, width, z)


def add_lines(scn, starts, ends, rgba, width: float = 2.0, z: float = 0.05) -> None:
    """Lines from world xy ``starts[i]`` to ``ends[i]`` (n, 2) [m] at height z, ``width`` pixels, in
    order, as many as the scene has room for. One geom per line (MuJoCo's ``mjv_connector``); the
    colour and the end points are converted once for all of them (a frame draws ~1,000 lines)."""
    k0 = scn.ngeom
    n = min(len(starts), scn.maxgeom - k0)
    if n <= 0:
        return
    a, b = np.empty((n, 3)), np.empty((n, 3))
    a[:, :2], a[:, 2] = np.asarray(starts, float)[:n], z
    b[:, :2], b[:, 2] = np.asarray(ends, float)[:n], z
    colour = np.asarray(rgba, np.float32)
    geoms, connect, line = scn.geoms, mujoco.mjv_connector, mujoco.mjtGeom.mjGEOM_LINE
    for i in range(n):
        g = geoms[k0 + i]
        _init_geom(g, line, _ZERO3, _ZERO3, _EYE3, colour)
        connect(g, line, width, a[i], b[i])
    scn.ngeom = k0 + n


def add_arrow(scn, tail, tip, rgba, width_m: float, z: float = 0.3) -> None:
    """A 3-D arrow from world xy ``tail`` to ``tip`` [m], shaft ``width_m`` wide."""
    if not _free(scn) or np.hypot(tip[0] - tail[0], tip[1] - tail[1]) < 1e-6:
        return
    g = scn.geoms[scn.ngeom]
    _init_geom(g, mujoco.mjtGeom.mjGEOM_ARROW, np.zeros(3), np.zeros(3), _EYE3, np.asarray(rgba, np.float32))
    mujoco.mjv_connector(g, mujoco.mjtGeom.mjGEOM_ARROW, width_m, np.array([tail[0], tail[1], z]),
                         np.array([tip[0], tip[1], z]))
    scn.ngeom += 1


def add_disc(scn, centre, radius_m: float, rgba, z: float = 0.04, kind=mujoco.mjtGeom.mjGEOM_CYLINDER) -> None:
    """A flat disc (cylinder 2 cm high) or, with ``kind`` sphere, a ball of ``radius_m`` [m]."""
    if not _free(scn):
        return
    g = scn.geoms[scn.ngeom]
    # mjv_initGeom takes a model geom's size: (radius, half-height) for a cylinder, (radius,) for a sphere.
    size = np.array([radius_m, 0.01, 0.0] if kind == mujoco.mjtGeom.mjGEOM_CYLINDER else [radius_m] * 3)
    _init_geom(g, kind, size, np.array([centre[0], centre[1], z]), _EYE3, np.asarray(rgba, np.float32))
    scn.ngeom += 1


def _rgba(colour, alpha: float = 1.0) -> tuple:
    return (*(np.asarray(colour[:3], float) / 255.0), alpha)


def add_scene_geoms(scn, view: FrameView, marker_m: float, trails=(), paths=(), only: str | None = None) -> None:
    """Draw ``view`` into ``scn`` (see the module docstring). ``marker_m`` [m]: map-symbol size
    (0 draws no symbols: hulls are large enough, e.g. in a chase view); ``trails``: (k, 2) per
    vessel in vessel order; ``paths``: (k, 2) mission paths; ``only``: draw the sensing and the
    decisions of this vessel alone (a chase view: what that vessel sees), trails of all."""
    m = max(marker_m, 1.0)
    for line in paths:
        add_strip(scn, line, COLOURS["path"], 1.5, 0.02)
    for v in view.vessels:  # a mission leg (transit, station line) in the vessel's colour, faint
        if v.leg is not None and len(v.leg) > 1:
            add_strip(scn, v.leg, _rgba(v.colour, 0.45), 1.5, 0.03)
    for v, trail in zip(view.vessels, trails):
        if len(trail) > 1:
            add_strip(scn, trail, _rgba(v.colour, 0.9), 3.0, 0.06)
    for v in view.vessels:
        if only is not None and v.name != only:
            continue
        if v.fan is not None:
            add_strip(scn, v.fan, _rgba(v.colour, COLOURS["fan_alpha"]), 1.0, 0.03)
        if v.returns is not None:  # short lines: a disc per return costs ~0.2 ms of software rendering
            d = np.array([0.06 * m, 0.0])
            returns = np.asarray(v.returns, float).reshape(-1, 2)
            add_lines(scn, returns - d, returns + d, _rgba(v.colour), 4.0, 0.08)
        for tr in v.tracks:
            add_disc(scn, tr.position_m, max(float(tr.radius_m), 0.1 * m), _rgba(v.colour, COLOURS["track_alpha"]), 0.1)
            add_strip(scn, covariance_ellipse(tr.position_m, tr.position_covariance, 2.0, 17), _rgba(v.colour, 0.9), 1.5, 0.12)
            vel = tr.speed_m_s * VELOCITY_ARROW_S * np.array([np.cos(tr.heading_rad), np.sin(tr.heading_rad)])
            add_arrow(scn, tr.position_m, tr.position_m + vel, _rgba(v.colour, 0.95), 0.12 * m, 0.15)
        for own, other in v.conflicts:
            add_disc(scn, own, 0.18 * m, COLOURS["conflict"], 0.5, mujoco.mjtGeom.mjGEOM_SPHERE)
            add_disc(scn, other, 0.12 * m, COLOURS["conflict"], 0.5, mujoco.mjtGeom.mjGEOM_SPHERE)
            add_line(scn, own, other, COLOURS["conflict"], 2.0, 0.5)
        for poly in v.svos:
            add_strip(scn, np.vstack([poly, poly[:1]]), COLOURS["svo"], 2.0, 0.2)
        for poly in v.field_obstacles:
            add_strip(scn, np.vstack([poly, poly[:1]]), COLOURS["field"], 2.0, 0.19)
        if v.detour is not None:
            add_strip(scn, v.detour, COLOURS["detour"], 3.0, 0.25)
    if marker_m > 0:
        for v in view.vessels:
            d = np.array([np.cos(v.heading_rad), np.sin(v.heading_rad)])
            add_arrow(scn, v.position_m - 0.5 * marker_m * d, v.position_m + marker_m * d, _rgba(v.colour), 0.35 * marker_m,
                      0.6)

