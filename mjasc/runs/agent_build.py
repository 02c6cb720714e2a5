"""How a vessel's agent is assembled from its scenario table: :func:`build_agent` attaches the
components the vessel's tables ask for (perception, coordination on the team's link, collision
avoidance, the mission), each with its own random stream (:mod:`mjasc.runs.agent` runs them)."""

from __future__ import annotations

import math

import numpy as np

from mjasc.plugins.context import StageContext
from mjasc.runs.agent import VesselAgent
from mjasc.runs.scenario import VesselConfig

__all__ = ["build_agent"]


def build_agent(config: VesselConfig, index: int, world, total_mass: np.ndarray, team_names, network,
                seed_key, mission=None, mission_members=None) -> VesselAgent:
    """The vessel agent of scenario vessel ``config`` (index ``index`` in ``world``) with the
    components its tables ask for: perception (``sensor`` / ``tracking``), coordination (``comms``,
    on ``network``, the team's link), collision avoidance (``avoidance``). Every component gets its
    own random stream ``default_rng([*seed_key, k])`` (k = 1 perception, 2 coordination, 3
    avoidance, 4 a plugin tracker, 5 the control method), so adding a sensor to one vessel does not change another
    vessel's noise; the runner uses ``seed_key = [scenario seed, vessel index]``. ``mission``: the
    scenario's :class:`~mjasc.missions.config.MissionConfig` (None: the controller's path is the
    whole mission); a vessel with a path follower then runs it, its first leg applied here;
    ``mission_members``: the names of the vessels that run it (default: the whole team)."""
    vessel = world.vessel_types[index]
    rng = lambda k: np.random.default_rng([*seed_key, k])  # noqa: E731
    lateral_m = float(world.propeller_lateral_m[index, 0])
    agent = VesselAgent(config, vessel, total_mass, lateral_m, rng(5), tuple(team_names))
    opts = config.options
    mission_path = config.path if config.path is not None else (agent.follower.path if agent.follower else None)

    def context(k: int, link=None) -> StageContext:  # (every stage's the same fields: docs/plugins.md)
        return StageContext(config.name, vessel, mission_path, agent.team_names, opts.get("sensor"), rng(k),
                            agent.mission_speed_m_s, link, total_mass, lateral_m)

    if "sensor" in opts or "tracking" in opts:
        from mjasc.perception.pipeline import Perception

        agent.perception = Perception(world, index, opts.get("sensor"), opts.get("tracking"), rng(1),
                                      context=context(4))
    if "comms" in opts:
        from mjasc.cooperation.link import LinkEndpoint

        agent.coordination = opts["comms"].build(context(2, LinkEndpoint(network, config.name)
                                                         if network is not None else None))
    if "avoidance" in opts:
        agent.avoidance = opts["avoidance"].build(context(3))
    if mission is not None and agent.follower is not None:
        mission_team = set(mission_members) if mission_members is not None else set(team_names)
        from mjasc.core.navigation import OwnNavigation
        from mjasc.missions.sequencer import MissionSequencer

        agent.mission = MissionSequencer(mission, config.name, config.path, config.cruise_speed_m_s,
                                         vessel.top_speed_m_s, opts.get("mission"),
                                         team_size=sum(1 for n in team_names if n in mission_team))
        c, s = math.cos(config.heading_rad), math.sin(config.heading_rad)
        u = config.speed_m_s
        start = OwnNavigation(0.0, np.array(config.position_m, dtype=float), float(config.heading_rad),
                              np.array([u * c, u * s]), np.array([u, 0.0, 0.0]))
        agent.apply_leg(0.0, agent.mission.begin(0.0, start))
    return agent
