"""One onboard slot for a whole fleet: the tick the runner and the suite's CAS baseline share.

:func:`run_onboard_slot` runs one slot of :data:`ONBOARD_SLOTS` for every vessel agent, in vessel
order (the order matters: the team's link draws its random numbers in the order of the calls).
With the thesis coordination the link is decided for the whole fleet in one pass
(:meth:`~mjasc.cooperation.coordination.Coordination.decide_link`, the same draws in the same
order): in the comms slot after every vessel has sent (each receiver up to its own message), in
the control slot before the vessels' coordination reads it.
The prediction slot predicts every vessel's (vessel, track) pairs in one batched call
(:func:`~mjasc.avoidance.fleet_slots.predict_slot`). The control slot runs each agent's
:meth:`~mjasc.runs.agent.VesselAgent.control_request` (coordination factor, avoidance request and
path switch): the coordination in vessel order (with the thesis coordination: every vessel's
mission first, then the fleet's speed law in one call,
:meth:`~mjasc.cooperation.coordination.Coordination.speed_correction_many`), then the avoidance
methods of every vessel at once
per method (``control_many``: the thesis method predicts what the tick triggers for all vessels in
one batched call, :func:`~mjasc.avoidance.fleet_slots.control_slot`), then the path
following of all vessels in one batched call (speeds and course overrides as arrays over vessels,
NaN = no course override) (:class:`~mjasc.guidance.path_following.FleetPathFollower`:
the agents' followers are gathered into one fleet at the first control tick and stay its rows).
The runner calls it for each due slot of a physics step (:class:`~mjasc.runs.schedule.Schedule`),
then records; :class:`mjasc.suite.baselines.CASPolicy` calls it inside a dm_control environment.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from mjasc.cooperation.coordination import Coordination
from mjasc.core.navigation import OwnNavigation
from mjasc.guidance.path_following import FleetPathFollower, PathFollower
from mjasc.plugins.answers import avoidance_answer, avoidance_answers
from mjasc.runs.fleet_control import ask_avoidance, control_fleet, fleet_control_applies

__all__ = ["ONBOARD_SLOTS", "run_onboard_slot", "SlotEvent"]

#: The slots the vessels' own pipelines run (the runner adds "record" and "video").
ONBOARD_SLOTS = ("sensing", "tracking", "comms", "prediction", "control")


def run_onboard_slot(slot: str, agents: Sequence, navs: Sequence[OwnNavigation], control_dt_s: float):
    """Run ``slot`` for each agent with its own navigation ``navs[i]``. Returns the agents'
    :class:`~mjasc.runs.agent.ControlOutput` list for ``"control"``, else None."""
    if slot == "sensing":
        for agent, nav in zip(agents, navs):
            agent.on_sensing(nav)
    elif slot == "tracking":
        for agent, nav in zip(agents, navs):
            agent.on_tracking(nav)
    elif slot == "comms":
        _comms(agents, navs)
    elif slot == "prediction":
        _prediction(agents, navs)
    elif slot == "control":
        return _control(agents, navs, control_dt_s)
    else:
        raise ValueError(f"slot: not an onboard slot: {slot!r} (known: {', '.join(ONBOARD_SLOTS)})")
    return None


def _thesis_link(agents: Sequence, navs: Sequence[OwnNavigation]) -> bool:
    """Whether the link can be decided for the whole fleet at once: every vessel's coordination
    (if any) is the thesis method and the navigations share one time."""
    coordinated = False
    for agent in agents:
        c = agent.coordination
        if c is not None:
            if type(c) is not Coordination:
                return False
            coordinated = True
    if not coordinated:
        return False
    t = navs[0].time_s
    for nav in navs:
        if not nav.time_s == t:
            return False
    return True


def _fleet_pass(agents: Sequence, navs: Sequence[OwnNavigation]) -> bool:
    """Whether the control slot runs as :func:`~mjasc.runs.fleet_control.control_fleet`: every
    vessel's coordination (if any) the thesis method — or none coordinated at all —, the
    navigations at one time and :func:`~mjasc.runs.fleet_control.fleet_control_applies`."""
    for agent in agents:
        c = agent.coordination
        if c is not None and type(c) is not Coordination:
            return False
    t = navs[0].time_s if navs else None
    for nav in navs:
        if not nav.time_s == t:
            return False
    return fleet_control_applies(agents)


def _comms(agents: Sequence, navs: Sequence[OwnNavigation]) -> None:
    """The comms slot: each vessel broadcasts, then reads what has arrived, in vessel order. With
    the thesis coordination: every vessel's message is sent first, the link is decided for all
    receivers in one pass (each up to its own message, as when it read right after sending), then
    each takes in its arrivals — the same draws and the same result."""
    if not _thesis_link(agents, navs):
        for agent, nav in zip(agents, navs):
            agent.on_comms(nav)
        return
    sent = [(k, agents[k].comms_send(navs[k])) for k in range(len(agents)) if agents[k].coordination is not None]
    Coordination.take_in_fleet([agents[k].coordination for k, _ in sent], navs[0].time_s,
                               [navs[k].position_m for k, _ in sent], [s[1] for _, s in sent],
                               [s[0] + 1 for _, s in sent])
    for k, s in sent:
        agents[k].comms_receive(navs[k], s, taken_in=True)


def _prediction(agents: Sequence, navs: Sequence[OwnNavigation]) -> None:
    """The prediction slot: the vessels using one avoidance method predict in one call of the
    method's ``predict_many`` (the thesis method batches every (vessel, track) pair:
    :func:`~mjasc.avoidance.fleet_slots.predict_slot`; the same requests as vessel by vessel: the
    methods share no state), then each request is applied in vessel order."""
    calls = [(agent, agent.prediction_call(nav)) for agent, nav in zip(agents, navs)]
    live = [(agent, call) for agent, call in calls if call is not None]
    if len(live) == 1:
        agent, call = live[0]
        agent.apply_request(avoidance_answer(call, "predict"))
        return
    groups: dict[type, list] = {}
    for k, (_, call) in enumerate(live):
        groups.setdefault(type(call[0]), []).append(k)
    requests = [None] * len(live)
    for cls, ks in groups.items():
        for k, request in zip(ks, avoidance_answers(cls, [live[k][1] for k in ks], "predict")):
            requests[k] = request
    for (agent, _), request in zip(live, requests):
        agent.apply_request(request)


def _control(agents: Sequence, navs: Sequence[OwnNavigation], control_dt_s: float) -> list:
    """The control slot: per-vessel requests in vessel order, then one batched call for the built-in
    path followers (other control methods steer one vessel at a time, right after its request).
    With the thesis coordination or none, and the built-in followers: the fleet in one pass
    (:func:`~mjasc.runs.fleet_control.control_fleet`, the same values)."""
    if _fleet_pass(agents, navs):
        return control_fleet(agents, navs, control_dt_s)
    outputs = [None] * len(agents)
    asked = []  # (vessel, speed after coordination, avoidance call or None)
    if _thesis_link(agents, navs):
        # Every vessel's mission first, then the coordination of all of them (the link decided once,
        # then each reads its arrivals: one tanh for the fleet), then each one's avoidance call. The
        # same as vessel by vessel: a vessel's mission and coordination read only its own state.
        steered = [i for i, agent in enumerate(agents) if agent.follower is not None]
        for i in steered:
            agents[i].control_mission(navs[i])
        polled = [i for i in steered if agents[i].coordination is not None]
        Coordination.decide_link([agents[i].coordination for i in polled], navs[0].time_s,
                                 [navs[i].position_m for i in polled])
        factors = dict(zip(polled, Coordination.speed_correction_many(
            [(agents[i].coordination, navs[i].time_s, navs[i], agents[i].mission_gamma_m()) for i in polled])))
        for i, (agent, nav) in enumerate(zip(agents, navs)):
            if agent.follower is None:
                outputs[i] = agent.control(nav, control_dt_s)  # open loop
            else:
                asked.append((i, *agent.avoidance_call(nav, factors.get(i))))
    else:
        for i, (agent, nav) in enumerate(zip(agents, navs)):
            if agent.follower is None:
                outputs[i] = agent.control(nav, control_dt_s)  # open loop
                continue
            asked.append((i, *agent.control_call(nav)))
    requests = ask_avoidance([call for _, _, call in asked])  # the avoidance methods, each for its vessels at once
    rows, speeds, modes, courses = [], [], [], []  # the built-in followers, commanded together
    for (i, speed, _), request in zip(asked, requests):
        agent, nav = agents[i], navs[i]
        speed, mode, course = agent.control_answer(speed, request)
        if type(agent.follower) is PathFollower:
            rows.append(i)
            speeds.append(speed)
            modes.append(mode)
            courses.append(course)
        else:
            cmd, st = agent.steered(agent.follower.steer(nav, agent.guidance_state(), speed,
                                                         None if math.isnan(course) else course, control_dt_s))
            outputs[i] = agent.control_output(cmd, st, mode)
    if rows:
        fleet = FleetPathFollower.of([agents[i].follower for i in rows])
        own = [navs[i] for i in rows]
        cmds, statuses = fleet.command(np.array([n.position_m for n in own]), np.array([n.heading_rad for n in own]),
                                       np.array([n.body_velocity for n in own]), np.array(speeds, dtype=float),
                                       control_dt_s, course_override_rad=np.array(courses, dtype=float))
        for k, (i, st) in enumerate(zip(rows, statuses)):
            outputs[i] = agents[i].control_output(cmds[k], st, modes[k])
    return outputs


@dataclass(frozen=True)
class SlotEvent:
    """What a runner observer receives after a slot ran: the slot, the time [s], the true vessel
    states (:class:`~mjasc.physics.simulation.VesselStates`), the vessels' own navigation, and the
    runner (read its public attributes: ``agents``, ``last_outputs``, ``sim``, ``world``,
    ``scenario``; do not change them)."""

    slot: str
    time_s: float
    states: Any
    navs: tuple
    runner: Any
