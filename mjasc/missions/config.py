"""The scenario's mission: which primitives the team chains, and each one's parameters.

A scenario without a ``[mission]`` table runs the thesis's cooperative path following alone (each
vessel's ``controller`` path, coordinated over comms) exactly as before. With one, the vessels with
a path-following controller run its ``phases`` in order (``tasks/README.md``, docs/missions.md)::

    [mission]
    phases = ["go_to_formation", "follow_path", "track_target"]
    [mission.go_to_formation]            # every key optional
    turn_radius_m = 10.0
    [mission.track_target]
    leader = "alpha"                     # estimates the target with its own sensor, broadcasts it
    target_hint_m = [300.0, 40.0]        # where the target is expected when the phase starts
    duration_s = 300.0
    target = "buoy"                      # the moving obstacle that is the target: for judging only

    [[vessels]]  ...
    mission = { target_offset_m = [-30.0, 15.0] }   # this vessel's station in the target's frame

The formation path of ``go_to_formation`` and ``follow_path`` is each vessel's ``controller``
path (its start pose is the formation pose). Parameters are declared once below (type, bound,
unit, doc); ``describe_params`` lists them for the docs.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mjasc.core.config_tables import (ConfigError, check_keys, check_params, dataclass_from_table, param, point,
                                      string, table)
from mjasc.core.frames import WORLD_LIMIT_M

__all__ = ["PHASES", "GoToFormationOptions", "FollowPathOptions", "TrackTargetOptions", "MissionConfig",
           "VesselMissionOptions", "parse_mission", "parse_vessel_mission"]

PHASES = ("go_to_formation", "follow_path", "track_target")
"""The mission primitives a chain is made of, in the thesis's words (docs/missions.md)."""


@dataclass(frozen=True)
class GoToFormationOptions:
    """``[mission.go_to_formation]``: every vessel from wherever it is to its formation pose — the
    start of its formation path, on the path's course, at its cruise speed — all at one time."""

    turn_radius_m: float = param(10.0, positive=True, maximum=500.0, unit="m",
                                 doc="turn radius of the transit paths (Dubins curves); at least each team "
                                     "vessel's tightest steady turn at its cruise speed (checked at load)")
    lead_in_m: float = param(15.0, nonneg=True, maximum=500.0, unit="m",
                             doc="the transit's last metres are straight on the formation course, to settle")
    arrival_band_m: float = param(1.0, positive=True, maximum=50.0, unit="m",
                                  doc="the phase ends this far before the transit's end (the formation pose)")
    agree_s: float = param(3.0, positive=True, maximum=60.0, unit="s",
                           doc="the team's arrival time is fixed once every team mate's earliest arrival is heard, "
                               "or this long after the phase starts")
    min_speed_fraction: float = param(0.3, positive=True, maximum=1.0,
                                      doc="no vessel is planned slower than this fraction of its cruise speed")


@dataclass(frozen=True)
class FollowPathOptions:
    """``[mission.follow_path]``: cooperative path following along each vessel's controller path."""

    end_band_m: float = param(1.0, positive=True, maximum=50.0, unit="m",
                              doc="the phase ends this far before the end of the formation path")


@dataclass(frozen=True)
class TrackTargetOptions:
    """``[mission.track_target]``: the team keeps stations around a moving target that the leader
    estimates with its own range sensor and shares over the link."""

    leader: str = param(doc="the vessel whose sensor estimates the target (it broadcasts the estimate)")
    target_hint_m: np.ndarray = param(reader=point, minimum=-WORLD_LIMIT_M, maximum=WORLD_LIMIT_M, unit="m",
                                      doc="where the target is expected when the phase starts: the leader "
                                          "designates the confirmed track nearest to it")
    duration_s: float = param(positive=True, unit="s", doc="how long the team tracks the target")
    target: str | None = param(None, doc="the moving obstacle that is the target, for judging the run only "
                                         "(the vessels never read it; absent: the run is not judged)")
    speed_gain_1_s: float = param(0.05, positive=True, maximum=2.0, unit="1/s",
                                  doc="speed correction per metre of along-course station error")
    line_ahead_s: float = param(10.0, positive=True, maximum=120.0, unit="s",
                                doc="each station line ends this long ahead of the station at the target's speed "
                                    "(+ 5 m): short of the target when the station is astern of it")
    replan_period_s: float = param(2.0, positive=True, unit="s", doc="how often the station line is re-drawn")
    designation_gate_m: float = param(60.0, positive=True, unit="m",
                                      doc="the target is designated only among tracks this close to target_hint_m "
                                          "(until then the leader heads for the hint)")
    reacquire_gate_m: float = param(15.0, positive=True, unit="m",
                                    doc="a lost target track is replaced by the nearest track within this "
                                        "distance of the predicted target")
    max_estimate_age_s: float = param(5.0, positive=True, unit="s",
                                      doc="an estimate older than this counts as the target out of track")
    min_in_track_fraction: float = param(0.95, positive=True, maximum=1.0,
                                         doc="the phase is completed when the target was in track at least this "
                                             "fraction of it (before the first designation it is not)")
    settle_s: float = param(60.0, nonneg=True, unit="s",
                            doc="station errors are judged from this long after the phase starts")


@dataclass(frozen=True)
class VesselMissionOptions:
    """``[vessels.mission]``: this vessel's part of the mission."""

    target_offset_m: np.ndarray = param(default_factory=lambda: np.array([-30.0, 0.0]), reader=point,
                                        minimum=-500.0, maximum=500.0, unit="m",
                                        doc="station in the target's frame: [ahead along its course, to port]")

    def __post_init__(self):
        check_params(self, "mission")


@dataclass(frozen=True)
class MissionConfig:
    """The scenario's ``[mission]``: the phases in order and each one's options."""

    phases: tuple[str, ...]
    go_to_formation: GoToFormationOptions = field(default_factory=GoToFormationOptions)
    follow_path: FollowPathOptions = field(default_factory=FollowPathOptions)
    track_target: TrackTargetOptions | None = None


def parse_mission(data, where: str = "mission") -> MissionConfig:
    """The ``[mission]`` table → :class:`MissionConfig` (ConfigError naming ``where.<key>``)."""
    t = table(data, where)
    check_keys(t, {"phases", *PHASES}, where)
    raw = t.get("phases")
    if not isinstance(raw, list) or not raw:
        raise ConfigError(f"{where}.phases: must be a non-empty list of {', '.join(PHASES)}, got {raw!r}")
    phases = tuple(string(p, f"{where}.phases[{k}]", choices=PHASES) for k, p in enumerate(raw))
    for k, p in enumerate(phases):
        if phases.index(p) != k:
            raise ConfigError(f"{where}.phases[{k}]: {p!r} appears twice (each primitive runs once)")
    if "go_to_formation" in phases and phases.index("go_to_formation") != 0:
        raise ConfigError(f"{where}.phases: go_to_formation must come first (it starts from the deployment poses)")
    for p in PHASES:
        if p in t and p not in phases:
            raise ConfigError(f"{where}.{p}: options for a phase not in {where}.phases")
    kw = {}
    if "go_to_formation" in t:
        kw["go_to_formation"] = dataclass_from_table(GoToFormationOptions, t["go_to_formation"],
                                                     f"{where}.go_to_formation")
    if "follow_path" in t:
        kw["follow_path"] = dataclass_from_table(FollowPathOptions, t["follow_path"], f"{where}.follow_path")
    if "track_target" in phases:
        if "track_target" not in t:
            raise ConfigError(f"{where}.track_target: missing (the phase needs leader, target_hint_m, duration_s)")
        kw["track_target"] = dataclass_from_table(TrackTargetOptions, t["track_target"], f"{where}.track_target")
    return MissionConfig(phases, **kw)


def parse_vessel_mission(data, where: str) -> VesselMissionOptions:
    """A vessel's ``mission`` table → :class:`VesselMissionOptions`."""
    return dataclass_from_table(VesselMissionOptions, data, where)


def check_mission(mission: MissionConfig, vessels, moving_names, hears=None, moving=()) -> None:
    """Cross-checks against the scenario's vessels: every vessel in the mission has a path-following
    controller with a path; the leader exists, has a sensor and a link; every follower of a target
    hears the leader on the link (``hears``: receiver → the senders it hears,
    :meth:`~mjasc.cooperation.network_config.NetworkConfig.hears`; nothing relays the leader's
    estimate); the judged target is a moving obstacle; the stations around it are apart, off the
    target (``moving``: the scenario's moving obstacles); a vessel's station needs a
    ``track_target`` phase."""
    team = [v for v in vessels if v.controller != "none"]
    if not team:
        raise ConfigError("mission: no vessel has a controller to run it")
    for i, v in enumerate(vessels):
        if v.controller != "none" and v.path is None:
            raise ConfigError(f"vessels[{i}].controller.waypoints: missing (the mission's formation path)")
        if len(team) > 1 and v.controller != "none" and "comms" not in v.options:
            raise ConfigError(f"vessels[{i}].comms: missing (a team mission is coordinated over the link)")
    if "go_to_formation" in mission.phases:  # (every vessel to its path's start; follow_path joins where it is)
        _check_formation_poses(vessels)
    tt = mission.track_target
    if tt is None:
        for i, v in enumerate(vessels):
            if "mission" in v.options:  # (its only key is its station around a target)
                raise ConfigError(f"vessels[{i}].mission.target_offset_m: the mission has no track_target phase "
                                  f"(phases: {', '.join(mission.phases)}): the station would be ignored")
    else:
        names = [v.name for v in team]
        if tt.leader not in names:
            raise ConfigError(f"mission.track_target.leader: no vessel with a controller named {tt.leader!r} "
                              f"(vessels: {', '.join(names)})")
        leader = next(v for v in team if v.name == tt.leader)
        if "sensor" not in leader.options:
            raise ConfigError(f"mission.track_target.leader: {tt.leader!r} has no [vessels.sensor] (it estimates "
                              "the target with its own sensor)")
        if tt.target and tt.target not in moving_names:
            raise ConfigError(f"mission.track_target.target: no moving obstacle named {tt.target!r} "
                              f"(moving obstacles: {', '.join(moving_names) or 'none'})")
        if hears is not None:
            for i, v in enumerate(vessels):
                if v.controller != "none" and v.name != tt.leader and tt.leader not in hears.get(v.name, ()):
                    raise ConfigError(f"vessels[{i}].comms: {v.name!r} does not hear the track_target leader "
                                      f"{tt.leader!r} on the link (comms.topology), so it would never get the "
                                      f"target's estimate (nothing relays it)")
        target = next((o for o in moving if o.name == tt.target), None)
        _check_stations(vessels, target.radius_m if target is not None else 0.0)


def _check_stations(vessels, target_radius_m: float) -> None:
    """The team's stations around the target (``target_offset_m``, the default where a vessel gives
    none) are farther apart than two hulls' radii, and each off the target's disc by a hull's
    radius: two vessels on one station (or one on the target) can never both hold it."""
    team = [(i, v) for i, v in enumerate(vessels) if v.controller != "none"]
    offsets = [np.asarray((v.options.get("mission") or VesselMissionOptions()).target_offset_m, dtype=float)
               for _, v in team]
    radii = _hull_radii(team)
    for (i, u), o in zip(team, offsets):
        if float(np.hypot(*o)) < target_radius_m + radii[u.type]:
            raise ConfigError(f"vessels[{i}].mission.target_offset_m: the station {o.tolist()} m is on the target "
                              f"(closer to it than its radius and the hull's, {target_radius_m + radii[u.type]:.1f} m)")
    close = _closer_than_hulls(team, offsets, radii)
    if close is not None:
        i, u, j, d, need = close
        raise ConfigError(f"vessels[{j}].mission.target_offset_m: its station is {d:.1f} m from that of "
                          f"vessels[{i}] ({u.name}), closer than their hulls' radii ({need:.1f} m): both cannot hold it")


def _check_formation_poses(vessels) -> None:
    """Two team vessels whose formation poses (their paths' starts) are closer than their hulls'
    radii can never both reach them: the mission would stall, one yielding to the other for good."""
    team = [(i, v) for i, v in enumerate(vessels) if v.controller != "none" and v.path is not None]
    close = _closer_than_hulls(team, [np.asarray(v.path.start_point, dtype=float) for _, v in team], _hull_radii(team))
    if close is not None:
        i, u, j, d, need = close
        raise ConfigError(f"vessels[{j}].controller.waypoints: its formation pose (the path's start) is "
                          f"{d:.1f} m from that of vessels[{i}] ({u.name}), closer than their hulls' radii "
                          f"({need:.1f} m): both cannot hold it")


def _hull_radii(team) -> dict:
    """Vessel type → its hull's bounding radius [m], for the team's ``(index, vessel)`` pairs."""
    from mjasc.physics.vessels import load_vessel_type

    return {v.type: load_vessel_type(v.type).radius_m for _, v in team}


def _closer_than_hulls(team, points, radii):
    """The first pair of the team's ``(index, vessel)`` whose ``points`` (2,) [m] are closer than
    their hulls' radii: ``(i, vessel i, j, distance, radii's sum)``; None when every pair is apart."""
    for a, (i, u) in enumerate(team):
        for b in range(a + 1, len(team)):
            j, v = team[b]
            d = float(np.hypot(*(points[a] - points[b])))
            need = radii[u.type] + radii[v.type]
            if d < need:
                return i, u, j, d, need
    return None
