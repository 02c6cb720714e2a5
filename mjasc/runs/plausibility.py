"""Plausibility of a scenario at its start: what the field readers cannot see one value at a time.

A scenario whose every value is in bounds can still describe a run that is absurd from t = 0;
:func:`check_plausible` rejects it when the scenario loads (ScenarioError naming the field, the
reason and the distance), before any model is built:

* **names** — vessel and obstacle names are ASCII letters, digits, ``_`` or ``-`` (at most
  :data:`MAX_NAME_CHARS`); a vessel's name does not start with ``obstacle`` (the model's own
  bodies). They become MuJoCo body names and Rerun entity paths.
* **start clearance** — no vessel hull overlaps another vessel's hull, a static obstacle or a
  moving obstacle's disc at t = 0 (else the run reports collisions from its first step). The hull
  is the pentagon of :func:`mjasc.core.geometry.hull_outline` (length × beam of the vessel type,
  pointed bow) at the start pose; two shapes overlap when an edge of one crosses an edge of the
  other or one lies inside the other. The error gives the centre distance.
* **path ends** — a path-following vessel's hull at its path's end (its destination) and, with a
  go-to-formation phase, at its path's start (its formation pose), on the path's course there,
  overlaps no static obstacle: it could never get there. (Waypoints between may lie in one: going
  around is the collision avoidance's business.)
* **the team's link** (:func:`check_team_link`, once the vessels are read) — one coordination
  leader; a neighbour timeout longer than the comms period; vessels on one path apart along it by
  their leads (``formation_offset_m``) more than their hulls' radii.
* **current** — the water speed ``|V(p, t)|`` at every vessel's start, every waypoint and every
  obstacle centre, at t = 0 and t = duration, is at most :data:`Bounds.current_speed_m_s`
  (evaluated on a copy of the field: a seeded field's own random state is not advanced).
* **duration** — at least one control period ``1 / rates.control_hz`` (a shorter run never ticks).
* **traffic through structures** — moving obstacles are scripted (kinematic: they follow their
  constant-turn motion or path and avoid nothing), so one whose disc would enter a static obstacle
  during the run describes a ferry sailing through a pontoon: the vessels would meet it emerging
  from inside the structure, hidden until it does. :func:`traffic_through_structure` samples the
  motion every :data:`TRAFFIC_SAMPLE_FRACTION` of the smallest radius of travel (at most every
  :data:`TRAFFIC_SAMPLE_MAX_S`) and the error names the obstacle, the structure and the time.
* **transit turns** — a go-to-formation mission's ``turn_radius_m`` is at least the tightest
  steady turn each team vessel's hull sails at its cruise speed in still water (one propeller at
  its limit, :mod:`mjasc.physics.steady_turn`): a Dubins transit with tighter arcs is a plan the hull
  cannot keep, and the team's arrival time would be planned on it.

The bounds of single values (|coordinate| ≤ :data:`mjasc.core.frames.WORLD_LIMIT_M`, the physics
rate, speeds) are declared on the fields themselves with :func:`mjasc.core.config_tables.param`;
the bounds here are declared once in :class:`Bounds`.
"""

from __future__ import annotations

import copy
import re
from dataclasses import dataclass

import numpy as np

from mjasc.core.config_tables import ConfigError, param, show
from mjasc.core.geometry import (distance_to_polygon, hull_outline, point_in_polygon, points_near_polygon,
                                 polygons_overlap)
from mjasc.physics.obstacles import MovingObstacleSet, PolygonObstacle

__all__ = ["Bounds", "BOUNDS", "MAX_NAME_CHARS", "check_name", "file_name", "check_duration", "check_plausible",
           "check_team_link",
           "hulls_overlap", "traffic_through_structure", "TRAFFIC_SAMPLE_FRACTION", "TRAFFIC_SAMPLE_MAX_S"]

MAX_NAME_CHARS = 64
"""Longest vessel or obstacle name (it becomes a MuJoCo body name and a Rerun entity path)."""
TRAFFIC_SAMPLE_FRACTION = 0.25
"""Traffic is sampled every time it moves this fraction of its radius (the fastest, smallest one)."""
TRAFFIC_SAMPLE_MAX_S = 1.0
"""Longest sampling interval [s] of the traffic-through-structures check."""

_NAME = re.compile(r"[A-Za-z0-9_-]+")


@dataclass(frozen=True)
class Bounds:
    """The scenario-wide plausibility bounds (see the module docstring)."""

    current_speed_m_s: float = param(10.0, positive=True, unit="m/s",
                                     doc="fastest water current anywhere the run goes (the strongest tidal "
                                         "streams are ~5 m/s)")


BOUNDS = Bounds()


def check_name(name: str, where: str, *, vessel: bool) -> str:
    """``name`` if it follows the naming rule (module docstring), else ConfigError at ``where``."""
    if len(name) > MAX_NAME_CHARS:
        raise ConfigError(f"{where}: must be at most {MAX_NAME_CHARS} characters, got {show(name)}")
    if not _NAME.fullmatch(name):
        raise ConfigError(f"{where}: must be ASCII letters, digits, '_' or '-', got {show(name)}")
    if vessel and name.startswith("obstacle"):
        raise ConfigError(f"{where}: must not start with 'obstacle', got {show(name)}")
    return name


def file_name(data: dict, source, where: str = "name") -> str:
    """A scenario's or campaign's ``name`` (it names the output folder and the recording): the
    table's own, which must follow the naming rule, else the file's name made to follow it."""
    from pathlib import Path

    from mjasc.core.config_tables import string

    if where in data:
        return check_name(string(data[where], where), where, vessel=False)
    return re.sub(r"[^A-Za-z0-9_-]", "_", Path(str(source)).stem)[:MAX_NAME_CHARS] or "unnamed"


def hulls_overlap(hull: np.ndarray, shape) -> bool:
    """Does the hull polygon (k, 2) overlap ``shape``: a polygon (m, 2) or a disc ``(centre, radius)``?"""
    if isinstance(shape, tuple):
        centre, radius = shape
        return points_near_polygon(np.asarray(centre, dtype=float)[None], hull, radius)
    return polygons_overlap(hull, shape)


def _check_clearance(scenario, types: dict) -> None:
    hulls, radii = [], []
    for v in scenario.vessels:
        vt = types[v.type]
        hulls.append(hull_outline(vt.length_m, vt.beam_m, v.position_m, v.heading_rad)[:-1])
        radii.append(vt.radius_m)
    pos = np.array([v.position_m for v in scenario.vessels])
    radii = np.array(radii)
    # Vessel pairs: only those whose bounding circles meet can overlap.
    dist = np.linalg.norm(pos[:, None] - pos[None], axis=-1)
    for i, j in zip(*np.nonzero(np.triu(dist < radii[:, None] + radii[None], 1))):
        if polygons_overlap(hulls[i], hulls[j]):
            raise ConfigError(f"vessels[{j}].position_m: the hull overlaps vessel {scenario.vessels[i].name!r} "
                              f"at the start (centres {dist[i, j]:.2f} m apart)")
    for i, v in enumerate(scenario.vessels):
        for k, o in enumerate(scenario.static_obstacles):
            if isinstance(o, PolygonObstacle):
                d = float(distance_to_polygon(v.position_m[None], o.vertices)[0])
                if d < radii[i] or point_in_polygon(v.position_m[None], o.vertices)[0]:
                    if hulls_overlap(hulls[i], o.vertices):
                        inside = "inside" if point_in_polygon(v.position_m[None], o.vertices)[0] else "from"
                        raise ConfigError(f"vessels[{i}].position_m: the hull overlaps static obstacle {o.name!r} at "
                                          f"the start (its centre {d:.2f} m {inside} the obstacle's edge)")
            elif hulls_overlap(hulls[i], (o.centre, o.radius_m)):
                raise ConfigError(f"vessels[{i}].position_m: the hull overlaps static obstacle {o.name!r} at the "
                                  f"start (centres {np.linalg.norm(v.position_m - o.centre):.2f} m apart, "
                                  f"radius {o.radius_m:g} m)")
        for k, o in enumerate(scenario.moving_obstacles):
            if hulls_overlap(hulls[i], (o.position_m, o.radius_m)):
                raise ConfigError(f"vessels[{i}].position_m: the hull overlaps moving obstacle {o.name!r} at the "
                                  f"start (centres {np.linalg.norm(v.position_m - o.position_m):.2f} m apart, "
                                  f"radius {o.radius_m:g} m)")


def _check_path_ends(scenario, types: dict) -> None:
    """A path-following vessel's destination (its path's end) — and, with a go-to-formation phase,
    its formation pose (the path's start) — leaves its hull clear of every static obstacle: a hull
    there overlapping an island could never reach it (a user's formation pose inside an island ran
    the vessel into it)."""
    mission = getattr(scenario, "mission", None)
    to_formation = mission is not None and "go_to_formation" in mission.phases
    for i, v in enumerate(scenario.vessels):
        if v.controller == "none" or v.path is None:
            continue
        vt = types[v.type]
        ends = [("ends", v.path.length)] + ([("starts (its formation pose)", 0.0)] if to_formation else [])
        for what, g in ends:
            p = np.asarray(v.path.point(g), dtype=float)
            hull = hull_outline(vt.length_m, vt.beam_m, p, float(v.path.tangent_angle(g)))[:-1]
            for o in scenario.static_obstacles:
                shape = o.vertices if isinstance(o, PolygonObstacle) else (o.centre, o.radius_m)
                if hulls_overlap(hull, shape):
                    raise ConfigError(f"vessels[{i}].controller.waypoints: the path {what} at "
                                      f"{np.round(p, 1).tolist()} m, where the hull overlaps static obstacle "
                                      f"{o.name!r}: it could never get there")


def check_team_link(vessels, rates) -> None:
    """The team's coordination settings against each other and the rates: one leader (two keep
    their own speeds and the consensus can never close the gap between them: a spread held for
    good); a neighbour heard at least once within its timeout (a timeout under the comms period
    drops every neighbour between two messages: no consensus at all); vessels on one path apart
    along it."""
    from mjasc.physics.vessels import load_vessel_type

    def option(v, name, default=None):  # (a built-in coordination's option; a plugin's may not have it)
        return getattr(getattr(v.options.get("comms"), "options", None), name, default)

    leaders = [i for i, v in enumerate(vessels) if option(v, "role") == "leader"]
    if len(leaders) > 1:
        raise ConfigError(f"vessels[{leaders[1]}].comms.role: a second leader (vessels[{leaders[0]}] is one): a "
                          f"leader keeps its own speed, and two never close the gap between them")
    period = 1.0 / rates.comms_hz
    for i, v in enumerate(vessels):
        timeout = option(v, "neighbour_timeout_s")
        if timeout is not None and timeout <= period:
            raise ConfigError(f"vessels[{i}].comms.neighbour_timeout_s: must be > the comms period 1/rates.comms_hz "
                              f"= {period:g} s (a neighbour is heard once a period at best), got {timeout:g}")
    # a column on one path: its vessels' leads along it (formation_offset_m) apart by more than two hulls' radii,
    # else the consensus draws them onto one point (a review: two vessels on one path without offsets touched)
    column = [(i, v) for i, v in enumerate(vessels) if v.path is not None and "comms" in v.options]
    samples = {i: v.path.point(np.linspace(0.0, v.path.length, 9)) for i, v in column}
    for a, (i, u) in enumerate(column):
        for j, v in column[a + 1:]:
            if abs(u.path.length - v.path.length) > 1e-6 or \
                    not np.allclose(samples[i], samples[j], rtol=0.0, atol=1e-6):
                continue
            leads = [option(w, "formation_offset_m", 0.0) for w in (u, v)]
            need = load_vessel_type(u.type).radius_m + load_vessel_type(v.type).radius_m
            if abs(leads[0] - leads[1]) < need:
                raise ConfigError(f"vessels[{j}].comms.formation_offset_m: {v.name!r} sails the same path as "
                                  f"vessels[{i}] ({u.name}) with leads {leads[1]:g} and {leads[0]:g} m, closer "
                                  f"than their hulls' radii ({need:.1f} m): the formation puts both on one point")


def _check_current(scenario) -> None:
    pts = [v.position_m for v in scenario.vessels]
    for v in scenario.vessels:
        if v.path is not None:  # nine points along the path, its ends included
            pts.extend(np.asarray(v.path.point(g), dtype=float) for g in np.linspace(0.0, v.path.length, 9))
    pts += [o.centre for o in scenario.static_obstacles] + [o.position_m for o in scenario.moving_obstacles]
    pts = np.array(pts, dtype=float).reshape(-1, 2)
    field = copy.deepcopy(scenario.current)
    limit = BOUNDS.current_speed_m_s
    for t in (0.0, scenario.duration_s):
        with np.errstate(all="ignore"):
            speed = np.linalg.norm(field.velocity(pts.copy(), t), axis=1)
        worst = int(np.argmax(np.where(np.isfinite(speed), speed, np.inf)))
        if not speed[worst] <= limit:
            raise ConfigError(f"current: the water speed at {np.round(pts[worst], 1).tolist()} m, t = {t:g} s is "
                              f"{speed[worst]:.3g} m/s, must be ≤ {limit} m/s")


def traffic_through_structure(moving_obstacles, static_obstacles, duration_s: float) -> str | None:
    """The first moving obstacle whose disc enters a static obstacle during ``[0, duration_s]``, as
    a one-line reason naming both and the time (``None`` when every track stays clear). Sampled
    every :data:`TRAFFIC_SAMPLE_FRACTION` radii of travel (module docstring); the disc enters a
    polygon when its centre is inside or nearer than its radius to an edge, a circle when the
    centres are nearer than the radii's sum."""
    moving, static = list(moving_obstacles), list(static_obstacles)
    if not moving or not static or duration_s <= 0:
        return None
    traffic = MovingObstacleSet(moving)
    speeds = np.array([o.speed_m_s for o in moving])
    step = float(np.min(np.where(speeds > 0, TRAFFIC_SAMPLE_FRACTION * traffic.radii_m / np.maximum(speeds, 1e-12),
                                 TRAFFIC_SAMPLE_MAX_S)))
    step = min(max(step, 1e-3), TRAFFIC_SAMPLE_MAX_S)
    times = np.append(np.arange(0.0, duration_s, step), duration_s)
    centres = np.array([traffic.state(float(t))[0] for t in times])  # (T, M, 2)
    flat = centres.reshape(-1, 2)
    radii = np.broadcast_to(traffic.radii_m, centres.shape[:2]).reshape(-1)
    first = None  # (time index, moving index, static obstacle)
    for o in static:
        if isinstance(o, PolygonObstacle):
            inside = point_in_polygon(flat, o.vertices) | (distance_to_polygon(flat, o.vertices) < radii)
        else:
            inside = np.linalg.norm(flat - o.centre, axis=1) < radii + o.radius_m
        hits = np.flatnonzero(inside)
        if hits.size and (first is None or hits[0] // len(moving) < first[0]):
            first = (int(hits[0] // len(moving)), int(hits[0] % len(moving)), o)
    if first is None:
        return None
    k, j, o = first
    return (f"moving_obstacles[{j}]: {moving[j].name!r} (a disc of radius {moving[j].radius_m:g} m) sails into static "
            f"obstacle {o.name!r} at t = {times[k]:.1f} s, near {np.round(centres[k, j], 1).tolist()} m; traffic "
            f"is scripted and avoids nothing, so its heading, speed or path must keep it clear")


def check_duration(scenario) -> None:
    """The run lasts at least one control period (``duration_s: must be at least ...``)."""
    period = 1.0 / scenario.rates.control_hz
    if scenario.duration_s < period:
        raise ConfigError(f"duration_s: must be at least one control period (1 / rates.control_hz = {period:g} s), "
                          f"got {scenario.duration_s:g}")


def check_plausible(scenario, types: dict) -> None:
    """Raise ConfigError (naming the field) when the scenario is absurd at its start (module
    docstring). ``types``: vessel type name → :class:`~mjasc.physics.vessels.VesselType`."""
    check_duration(scenario)
    _check_clearance(scenario, types)
    _check_path_ends(scenario, types)
    _check_current(scenario)
    reason = traffic_through_structure(scenario.moving_obstacles, scenario.static_obstacles, scenario.duration_s)
    if reason is not None:
        raise ConfigError(reason)
    _check_transit_turns(scenario, types)


def _check_transit_turns(scenario, types: dict) -> None:
    """go-to-formation's Dubins arcs are no tighter than each team vessel's hull can turn steadily
    at its cruise speed in still water (:func:`mjasc.physics.steady_turn.tightest_turn_of_type`)."""
    mission = getattr(scenario, "mission", None)
    if mission is None or "go_to_formation" not in mission.phases:
        return
    from mjasc.physics.steady_turn import smallest_turn_radius_m, tightest_turn_of_type

    radius = mission.go_to_formation.turn_radius_m
    where = "mission.go_to_formation.turn_radius_m"
    for i, v in enumerate(scenario.vessels):
        if v.controller == "none":
            continue
        turn = tightest_turn_of_type(types[v.type], v.cruise_speed_m_s)
        if turn is None:
            raise ConfigError(f"{where}: vessels[{i}] {v.name!r} ({types[v.type].name}) sails no steady turn at its "
                              f"cruise speed {v.cruise_speed_m_s:g} m/s (vessels[{i}].controller.speed_m_s), so "
                              f"it cannot sail the transit's arcs; got {radius:g}")
        if radius < turn.radius_m:
            limit = smallest_turn_radius_m(turn)  # rounded up: the value printed passes
            raise ConfigError(f"{where}: vessels[{i}] {v.name!r} ({types[v.type].name}) turns no tighter than "
                              f"{limit:.2f} m at its cruise speed {v.cruise_speed_m_s:g} m/s (one propeller at "
                              f"its limit, still water; 'mjasc trial tightest-turn' shows it), so its "
                              f"transit's arcs must be at least that; got {radius:g}")
