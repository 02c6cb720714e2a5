"""The control slot of a coordinated fleet in one pass (:func:`mjasc.runs.tick.run_onboard_slot`).

When every vessel's coordination (if any) is the thesis method and every vessel that steers does so
with the built-in path follower, the tick hands the fleet's values over once instead of asking
each agent piece by piece: the followers' paths and γ are read once from their
:class:`~mjasc.guidance.path_following.FleetPathFollower` (each vessel's
:class:`~mjasc.guidance.state.GuidanceState` built from them: once with the previous coordination
factor for γ on the mission path, once with the new one for the avoidance method), the link
decides and delivers for every vessel and the speed law runs for all of them in one call
(:meth:`~mjasc.cooperation.coordination.Coordination.speed_correction_fleet`), the avoidance
methods are asked per method for their vessels at once, and the fleet's navigation arrays go to
the followers' command as they are when the navigations are the fleet's rows
(:class:`~mjasc.core.navigation.NavigationList`).

The same values, in the same order, as the agents' own calls (:meth:`~mjasc.runs.agent.VesselAgent.control_call`
and :meth:`~mjasc.runs.agent.VesselAgent.control_answer`): between a vessel's mission update and its
avoidance call nothing changes its follower's path or γ (the coordination reads and writes only its
own state), so one reading serves both. ``tests/test_fleet_control.py`` compares with the per-agent
form.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from mjasc.cooperation.coordination import Coordination
from mjasc.guidance.path_following import FleetPathFollower, PathFollower

__all__ = ["fleet_control_applies", "control_fleet", "ask_avoidance"]


def fleet_control_applies(agents: Sequence) -> bool:
    """Whether :func:`control_fleet` can run the slot: every follower the built-in path follower
    and at least one vessel steered (the caller checks the thesis link)."""
    steered = False
    for agent in agents:
        f = agent.follower
        if f is not None:
            if type(f) is not PathFollower:
                return False
            steered = True
    return steered


def ask_avoidance(calls: list) -> list:
    """Each avoidance call's request (None where the call is None): the vessels of one avoidance
    method at once, in one ``control_many`` call per method."""
    groups: dict[type, list] = {}
    for k, call in enumerate(calls):
        if call is not None:
            groups.setdefault(type(call[0]), []).append(k)
    requests = [None] * len(calls)
    for cls, ks in groups.items():
        for k, request in zip(ks, cls.control_many([calls[k] for k in ks])):
            requests[k] = request
    return requests


def control_fleet(agents: Sequence, navs: Sequence, control_dt_s: float) -> list:
    """The control slot's outputs (:class:`~mjasc.runs.agent.ControlOutput` per agent), for a fleet
    that :func:`fleet_control_applies` to, whose navigations share one time."""
    outputs = [None] * len(agents)
    steered = [i for i, agent in enumerate(agents) if agent.follower is not None]
    for i in steered:
        if agents[i].mission is not None:
            agents[i].control_mission(navs[i])
    fleet = FleetPathFollower.of([agents[i].follower for i in steered])
    paths, gammas = fleet.guidance_rows()
    t = navs[0].time_s
    # γ on the mission path of every steered vessel (with its guidance before the new factor)
    coords, positions, mission_gammas = [], [], []
    for k, i in enumerate(steered):
        agent = agents[i]
        if agent.coordination is None:
            continue
        avoidance = agent.avoidance
        coords.append(agent.coordination)
        positions.append(navs[i].position_m)
        mission_gammas.append(gammas[k] if avoidance is None else
                              avoidance.mission_gamma_m(agent.guidance_of(paths[k], gammas[k])))
    factors = iter(Coordination.speed_correction_fleet(coords, t, positions, mission_gammas) if coords else ())
    speeds, calls = [], []
    for k, i in enumerate(steered):
        agent, nav = agents[i], navs[i]
        speed = agent.mission_speed_m_s
        c = agent.coordination
        if c is not None:
            speed *= next(factors)
        speeds.append(speed)
        avoidance = agent.avoidance
        calls.append(None if avoidance is None else
                     (avoidance, t, nav, agent.guidance_of(paths[k], gammas[k]), agent.perception_report(t),
                      None if c is None else c.team_picture(t)))
    for i, agent in enumerate(agents):
        if agent.follower is None:
            outputs[i] = agent.control(navs[i], control_dt_s)  # open loop
    requests = ask_avoidance(calls)
    modes, courses = [], []
    for k, (i, request) in enumerate(zip(steered, requests)):
        speeds[k], mode, course = agents[i].control_answer(speeds[k], request)
        modes.append(mode)
        courses.append(course)
    own = getattr(navs, "fleet", None)  # the fleet's arrays as they are when the navigations are its rows
    if own is not None and len(steered) == len(own):
        pos, heading, body = own.position_m, own.heading_rad, own.body_velocity
    else:
        rows = [navs[i] for i in steered]
        pos, heading = np.array([n.position_m for n in rows]), np.array([n.heading_rad for n in rows])
        body = np.array([n.body_velocity for n in rows])
    cmds, statuses = fleet.command(pos, heading, body, np.array(speeds, dtype=float), control_dt_s,
                                   course_override_rad=np.array(courses, dtype=float))
    for k, (i, st) in enumerate(zip(steered, statuses)):
        outputs[i] = agents[i].control_output(cmds[k], st, modes[k])
    return outputs
