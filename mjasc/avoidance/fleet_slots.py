"""The thesis method's two slots for many vessels at once (:meth:`CollisionAvoidance.predict_many
<mjasc.avoidance.system.CollisionAvoidance.predict_many>` and ``control_many``): each system
prepares its query, every vessel's (vessel, track) pairs are predicted in one
:func:`~mjasc.avoidance.prediction.predict_fleet` call, then each system acts on its own result —
the same requests as vessel by vessel (the systems share no state;
``tests/test_prediction_fleet.py``, ``tests/test_fleet_following.py``).

World frame ENU, SI units, absolute simulation times [s].
"""

from __future__ import annotations

from mjasc.avoidance.control_tick import ControlTick
from mjasc.avoidance.prediction.conflicts import predict_fleet_lazy
from mjasc.avoidance.request import AvoidanceRequest

__all__ = ["predict_slot", "control_slot"]


def predict_slot(calls) -> list[AvoidanceRequest]:
    """The prediction slot of many vessels at once: ``calls`` is a sequence of (system, t, nav,
    guidance, perceived, team), the arguments of :meth:`~mjasc.avoidance.system.CollisionAvoidance.predict` per vessel.
    Returns each vessel's request — the same as calling ``predict`` vessel by vessel (the systems
    share no state) — with every vessel's (vessel, track) pairs predicted in one
    :func:`~mjasc.avoidance.prediction.predict_fleet` call. Predictions a decision triggers
    (after a re-plan) run per vessel."""
    pending = []
    for system, t, nav, guidance, perceived, team in calls:
        system._begin(guidance, perceived, team)
        pending.append(system._prediction_query(float(t), list(perceived.tracks)))
    results = iter(predict_fleet_lazy([p.query for p in pending if p.query is not None]))
    out = []
    for (system, t, nav, guidance, perceived, team), p in zip(calls, pending):
        system._begin(guidance, perceived, team)
        all_c = next(results) if p.query is not None else []
        conflicts = system._act_on_prediction(float(t), nav, p, all_c, list(perceived.static_polygons))
        out.append(AvoidanceRequest.of(system.mode, None, system._switch, tuple(conflicts), None))
    return out


#: The control tick's request on the mission without a manoeuvre or a path switch (frozen: shared).
_MISSION = AvoidanceRequest.of("mission", None, None, (), None)


#: The control tick's methods whose bodies :func:`control_slot` writes out (a class that changes
#: them, or a test's reference form, is called as it is).
_CONTROL_QUERY, _CONTROL_REST = ControlTick._control_query, ControlTick._control_rest


def control_slot(calls) -> list[AvoidanceRequest]:
    """The control tick of many vessels at once: ``calls`` is a sequence of (system, t, nav,
    guidance, perceived, team), the arguments of :meth:`~mjasc.avoidance.system.CollisionAvoidance.control` per vessel.
    Returns each vessel's request — the same as calling ``control`` vessel by vessel (the systems
    share no state) — with the predictions the tick triggers (a new track, a deviating track or
    team plan, a changed mission speed, an emergency) of every vessel in one
    :func:`~mjasc.avoidance.prediction.predict_fleet` call. Predictions a decision triggers (after a
    re-plan, a finished velocity correction) run per vessel."""
    pending, queries = [None] * len(calls), []  # (lists filled by index: the tick runs for every vessel)
    for k, (system, t, nav, guidance, perceived, team) in enumerate(calls):
        system._guidance, system._switch, system._perceived, system._team = guidance, None, perceived, team  # _begin
        t = float(t)
        if type(system)._control_query is not _CONTROL_QUERY:  # (a changed form: as it is)
            pending[k] = p = system._control_query(t)
            if p is not None and p[0].query is not None:
                queries.append(p[0].query)
            continue
        # system._control_query(t) written out: the team polled, then _prediction_due (its first
        # answer read here when the tracks hold nothing new and the last prediction is recent)
        mates = system.team_mates
        if team is not None and team.intentions is not mates.polled_intentions:
            mates.poll(team)  # (the mapping polled last holds nothing new)
        if perceived is None or (perceived.tracks is system._no_new_in and t - system._last_predict_t < 1.0):
            continue  # no prediction due
        new = system._prediction_due(t)
        if new is None:
            continue
        pending[k] = p = system._prediction_query(t, list(perceived.tracks)), new
        if p[0].query is not None:
            queries.append(p[0].query)
    results = iter(predict_fleet_lazy(queries) if queries else ())  # (most ticks predict nothing)
    out = [None] * len(calls)
    for k, ((system, t, nav, _, _, _), p) in enumerate(zip(calls, pending)):
        t = float(t)
        if p is not None:
            system._control_predict(t, nav, p, next(results) if p[0].query is not None else [])
        if system.detour is None and system.correction is None and system._sharp_turn is None and \
                type(system)._control_rest is _CONTROL_REST:
            override = course = None  # (_control_rest on the mission: the mode noted only)
            mode = system._note_mode(t)
        else:
            override, mode, course = system._control_rest(t, nav)
        switch = system._switch
        out[k] = (_MISSION if override is None and course is None and switch is None and mode == "mission"
                  else AvoidanceRequest.of(mode, override, switch, (), course))
    return out
