"""The control slot of a fleet in one pass (:func:`mjasc.runs.tick.run_onboard_slot`).

When every vessel's coordination (if any) is the thesis method and every vessel that steers does so
with the built-in path follower, the tick hands the fleet's values over once instead of asking
each agent piece by piece: the followers' paths and γ are read once from their
:class:`~mjasc.guidance.path_following.FleetPathFollower` (γ on the mission path from them — an
avoidance method other than the thesis's is asked with a
:class:`~mjasc.guidance.state.GuidanceState` with the previous coordination factor —, and each
vessel's guidance state with the new factor for its avoidance method), the link decides and
delivers for every vessel and the speed law runs for all of them in one call
(:func:`~mjasc.cooperation.fleet_speed_law.speed_correction_fleet`), the avoidance
methods are asked per method for their vessels at once, and the fleet's navigation arrays go to
the followers' command as they are when the navigations are the fleet's rows
(:class:`~mjasc.core.navigation.NavigationList`).

The same values, in the same order, as the agents' own calls (:meth:`~mjasc.runs.agent.VesselAgent.control_call`
and :meth:`~mjasc.runs.agent.VesselAgent.control_answer`): between a vessel's mission update and its
avoidance call nothing changes its follower's path or γ (the coordination reads and writes only its
own state), so one reading serves both. ``tests/test_fleet_control.py`` compares with the per-agent
form.

Written out with few Python calls (the slot runs every 0.1 s for every vessel): the agents'
``control_answer``, ``control_output`` and ``guidance_of``, the coordination's ``team_picture`` and
the thesis method's ``mission_gamma_m`` as their bodies (the same operations in the same order;
a class that changes one of them is called as it is); each vessel's perception report from its
agent (``perception_report``); per-vessel lists filled by index.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from mjasc.avoidance.system import CollisionAvoidance
from mjasc.cooperation import fleet_speed_law
from mjasc.cooperation.messages import TeamPicture
from mjasc.cooperation.team_knowledge import TeamKnowledge
from mjasc.core.navigation import NavigationList
from mjasc.guidance.path_following import FleetPathFollower, PathFollower
from mjasc.guidance.state import GuidanceState
from mjasc.plugins.answers import avoidance_answers
from mjasc.runs.agent import ControlOutput, VesselAgent

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
    cls = None
    for call in calls:  # (one method for every vessel: most fleets)
        if call is None or (cls is not None and type(call[0]) is not cls):
            break
        cls = type(call[0])
    else:
        if cls is not None:
            return avoidance_answers(cls, calls)
    groups: dict[type, list] = {}
    for k, call in enumerate(calls):
        if call is not None:
            groups.setdefault(type(call[0]), []).append(k)
    requests = [None] * len(calls)
    for cls, ks in groups.items():
        for k, request in zip(ks, avoidance_answers(cls, [calls[k] for k in ks])):
            requests[k] = request
    return requests


_THESIS_GAMMA = CollisionAvoidance.mission_gamma_m
#: The agent's and the coordination's read-outs whose bodies control_fleet writes out (a class that
#: changes them is called as it is).
_GUIDANCE_OF, _TEAM_PICTURE = VesselAgent.guidance_of, TeamKnowledge.team_picture
_new = object.__new__


def control_fleet(agents: Sequence, navs: Sequence, control_dt_s: float) -> list:
    """The control slot's outputs (:class:`~mjasc.runs.agent.ControlOutput` per agent), for a fleet
    that :func:`fleet_control_applies` to, whose navigations share one time."""
    outputs = [None] * len(agents)
    # One pass over the fleet (no comprehension per list): the open-loop vessels, the steered ones,
    # each one's mission (in vessel order; a mission reads and writes only its own vessel's state),
    # its follower and whether it is coordinated (laws: indices into steered)
    steered, followers, laws, open_loop = [], [], [], []
    for i, agent in enumerate(agents):
        if agent.follower is None:
            open_loop.append(i)
            continue
        if agent.mission is not None:
            agent.control_mission(navs[i])
        if agent.coordination is not None:
            laws.append(len(steered))
        steered.append(i)
        followers.append(agent.follower)
    fleet = FleetPathFollower.of(followers)
    paths, gammas = fleet.guidance_rows()
    t = navs[0].time_s
    m = len(steered)
    # γ on the mission path of every coordinated steered vessel (with its guidance before the new
    # factor): the avoidance method's mission_gamma_m (the thesis method's written out)
    n_laws = len(laws)
    coords, positions, mission_gammas = [None] * n_laws, [None] * n_laws, [None] * n_laws
    for j, k in enumerate(laws):
        i = steered[k]
        agent = agents[i]
        coords[j], positions[j] = agent.coordination, navs[i].position_m
        avoidance = agent.avoidance
        if avoidance is None:
            mission_gammas[j] = gammas[k]
        elif type(avoidance).mission_gamma_m is _THESIS_GAMMA:
            d = avoidance.detour
            mission_gammas[j] = (d.mission_gamma(gammas[k]) if d is not None and paths[k] is d.path
                                 else float(gammas[k]))
        else:
            mission_gammas[j] = avoidance.mission_gamma_m(agent.guidance_of(paths[k], gammas[k]))
    factors = fleet_speed_law.speed_correction_fleet(coords, t, positions, mission_gammas) if coords else ()
    speeds, courses = fleet.reference_arrays()  # (m,) each, filled by row: what command_all reads
    calls = [None] * m
    j = 0
    for k in range(m):
        agent = agents[steered[k]]
        speed = agent.mission_speed_m_s
        c = agent.coordination
        if c is not None:
            speed *= factors[j]
            j += 1
        speeds[k] = speed
        avoidance = agent.avoidance
        if avoidance is not None:
            if type(agent).guidance_of is _GUIDANCE_OF:  # agent.guidance_of(paths[k], gammas[k]) written out
                factor = c.last_factor if c is not None else 1.0
                if not (type(factor) is float and -math.inf < factor < math.inf):
                    factor = float(factor) if math.isfinite(factor) else 1.0
                v = agent.mission_speed_m_s
                guidance = _new(GuidanceState)  # GuidanceState.of
                guidance.__dict__.update(path=paths[k], gamma_m=gammas[k],
                                         mission_speed_m_s=(v if type(v) is float else float(v)) * factor)
            else:
                guidance = agent.guidance_of(paths[k], gammas[k])
            if c is None:
                picture = None
            elif type(c).team_picture is _TEAM_PICTURE:  # c.team_picture(t) written out
                intentions = c._intentions
                if intentions is None:
                    intentions = c._intentions = c.team_intentions()
                picture = _new(TeamPicture)
                picture.__dict__.update(time_s=float(t), intentions=intentions, speed_factor=c.last_factor)
            else:
                picture = c.team_picture(t)
            calls[k] = (avoidance, t, navs[steered[k]], guidance, agent.perception_report(t), picture)
    for i in open_loop:
        outputs[i] = agents[i].control(navs[i], control_dt_s)  # open loop
    requests = ask_avoidance(calls)
    modes = [None] * m
    for k in range(m):  # each agent's control_answer(speeds[k], requests[k])
        agent, req = agents[steered[k]], requests[k]
        mode, course = "mission", math.nan
        if req is not None:
            sw = req.path_switch  # (apply_request)
            if sw is not None:
                agent.follower.set_path(sw.path, sw.gamma_m)
            mode = req.mode
            if req.speed_override_m_s is not None:
                speeds[k] = req.speed_override_m_s
            if req.course_override_rad is not None:
                course = float(req.course_override_rad)
        agent.mode = modes[k] = mode
        courses[k] = course
    own = navs.fleet if type(navs) is NavigationList else None  # the fleet's arrays, the navigations its rows
    if own is not None and m == own.heading_rad.shape[0]:
        pos, heading, body = own.position_m, own.heading_rad, own.body_velocity
    elif own is not None:  # (some vessel in open loop: the steered rows, copied as stacking them would)
        pos, heading, body = own.position_m[steered], own.heading_rad[steered], own.body_velocity[steered]
    else:
        rows = [navs[i] for i in steered]
        pos, heading = np.array([n.position_m for n in rows], dtype=float), np.array([n.heading_rad for n in rows],
                                                                                   dtype=float)
        body = np.array([n.body_velocity for n in rows], dtype=float)
    cmds, statuses = fleet.command_all(pos, heading, body, speeds, courses, control_dt_s)
    for k in range(m):  # each agent's control_output(cmds[k], statuses[k], modes[k])
        st = statuses[k]
        outputs[steered[k]] = out = _new(ControlOutput)
        out.__dict__.update(commands=cmds[k], status=st, speed_ref_m_s=st.speed_ref_m_s, mode=modes[k])
    return outputs
