"""A plugin method's answers checked where the pipeline takes them: a wrong answer is one error
naming the method, the vessel and what is wrong, at the call — not a silent default (a forgotten
``return`` taken as "no request"), a value MuJoCo clamps without a word (commands of 5), or a
failure deep inside the perception, the control pass or the recording. The built-in methods'
answers (:func:`~mjasc.plugins.registry.builtin_method`) are not checked: they are theirs, and the control tick is hot.

* :func:`avoidance_answers` — ``control_many``'s and ``predict_many``'s answers: one
  :class:`~mjasc.avoidance.request.AvoidanceRequest` per call (the request's own constructor
  checks its mode and overrides; here: a speed override within :data:`SPEED_LIMIT_FACTOR` × the
  hull's top speed, a path switch's γ on its path and its reason "detour" or "mission");
* :func:`tracks_answer` — a tracker's ``tracks()``: TrackEstimate values, every number finite, the
  speed and the radius ≥ 0, the time in [0, the scan's], the position a (2,) world x, y, the
  covariance a symmetric positive semi-definite (2, 2), each id once;
* :func:`steer_answer` — a control method's ``steer()``: ``(commands (2,) in [−1, 1],
  PathFollowingStatus)`` with a finite γ;
* :func:`factor_answer` and :func:`team_picture_answer` — a coordination method's
  ``speed_correction()`` (a finite factor ≥ 0, the speed it asks within :data:`SPEED_LIMIT_FACTOR`
  × the hull's top speed) and ``team_picture()`` (a TeamPicture or None);
* :func:`events_answer` — any method's ``drain_events()``: a list of ``(t [s], text)``;
* :func:`plugin_at_fault` — which plugin method (and vessel) an exception that ends a run came
  from, for the run's one-line error.
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.avoidance.request import AvoidanceRequest
from mjasc.cooperation.messages import TeamPicture
from mjasc.core.estimates import TrackEstimate
from mjasc.guidance.path_following import PathFollowingStatus
from mjasc.plugins.registry import builtin_method

__all__ = ["avoidance_answers", "avoidance_answer", "tracks_answer", "steer_answer", "factor_answer",
           "team_picture_answer", "events_answer", "plugin_at_fault", "where"]


def where(method, vessel_name: str | None = None) -> str:
    """``"<stage> method 'name' of vessel 'v'"`` for a method (its context's vessel by default)."""
    if vessel_name is None:
        vessel_name = getattr(getattr(method, "context", None), "vessel_name", "?")
    return f"{getattr(method, 'stage', '') or 'stage'} method {getattr(method, 'method', type(method).__name__)!r} " \
           f"of vessel {vessel_name!r}"


def avoidance_answers(cls: type, calls: list, slot: str = "control") -> list:
    """``cls.control_many(calls)`` (``slot`` "control") or ``cls.predict_many(calls)`` ("predict"),
    each call ``(method, t, nav, ...)``; a plugin's answers checked: as many answers as calls, each
    an AvoidanceRequest."""
    answers = (cls.control_many if slot == "control" else cls.predict_many)(calls)
    if builtin_method(cls):
        return answers
    try:
        answers = list(answers)
    except TypeError:
        raise TypeError(f"avoidance method {cls.__qualname__}: {slot}_many returned {type(answers).__name__}, "
                        f"expected a list of AvoidanceRequest (one per vessel)") from None
    if len(answers) != len(calls):
        raise TypeError(f"avoidance method {cls.__qualname__}: {slot}_many returned {len(answers)} answer(s) for "
                        f"{len(calls)} vessel(s)")
    for call, answer in zip(calls, answers):
        _request(call[0], answer, slot)
    return answers


def avoidance_answer(call: tuple, slot: str) -> object:
    """One vessel's ``control`` (``slot`` "control") or ``predict`` ("predict") call ``(method, t,
    nav, ...)`` answered; a plugin's answer checked as :func:`avoidance_answers` checks it."""
    method = call[0]
    answer = (method.control if slot == "control" else method.predict)(*call[1:])
    return answer if builtin_method(type(method)) else _request(method, answer, slot)


#: A plugin's speed (an avoidance speed override, the speed a coordination factor asks) above this
#: many times its hull's top speed is refused: no hull sails it, and it is likely a unit mistake
#: (knots, km/h) — the hull would saturate without a word (a review: 1e6 m/s sailed at top speed).
SPEED_LIMIT_FACTOR = 1.5


def _top_speed(method) -> float:
    return float(getattr(getattr(getattr(method, "context", None), "vessel", None), "top_speed_m_s", math.inf))


def _request(method, answer, slot: str):
    if not isinstance(answer, AvoidanceRequest):
        raise TypeError(f"{where(method)}: {slot}() returned {type(answer).__name__}, expected an "
                        f"AvoidanceRequest (AvoidanceRequest() keeps the mission)")
    top = _top_speed(method)
    if answer.speed_override_m_s is not None and answer.speed_override_m_s > SPEED_LIMIT_FACTOR * top:
        raise ValueError(f"{where(method)}: {slot}()'s speed_override_m_s {answer.speed_override_m_s:g} m/s is more "
                         f"than {SPEED_LIMIT_FACTOR:g} × the hull's top speed ({top:g} m/s): a speed in m/s is "
                         f"expected (not knots or km/h)")
    switch = answer.path_switch
    if switch is not None:
        g, length = switch.gamma_m, float(getattr(switch.path, "length", math.inf))
        if not (isinstance(g, (int, float, np.integer, np.floating)) and math.isfinite(g) and 0.0 <= g <= length):
            raise ValueError(f"{where(method)}: {slot}()'s path_switch.gamma_m must be a finite γ in [0, the path's "
                             f"length {length:g}] m, got {g!r}")
        if switch.reason not in ("detour", "mission"):
            raise ValueError(f"{where(method)}: {slot}()'s path_switch.reason must be \"detour\" or \"mission\", "
                             f"got {switch.reason!r}")
    return answer


#: A track's numbers a tracker must give finite, and those that must also be ≥ 0 (TrackEstimate).
_FINITE = ("time_s", "heading_rad", "speed_m_s", "turn_rate_rad_s", "radius_m")
_NON_NEGATIVE = ("speed_m_s", "radius_m")


def tracks_answer(method, vessel_name: str, t_s: float = math.inf) -> tuple:
    """``method.tracks()`` of a tracker as a tuple, checked when it is a plugin's: TrackEstimates with
    finite numbers, ``time_s`` in [0, t_s] (the scan's time [s]: an estimate is of the past, and a
    stamp of −1e9 s made the avoidance predict every track a billion seconds ahead — no decision at
    all), distinct ids, and a position covariance that is a covariance (symmetric, positive
    semi-definite: an asymmetric one changed the velocity obstacles' answers)."""
    got = method.tracks()
    if builtin_method(type(method)):  # (filterpy_imm: its answers are its own)
        return tuple(got)
    at = where(method, vessel_name)
    try:
        tracks = tuple(got)
    except TypeError:
        raise TypeError(f"{at}: tracks() returned {type(got).__name__}, expected a tuple of TrackEstimate") from None
    for k, e in enumerate(tracks):
        if not isinstance(e, TrackEstimate):
            raise TypeError(f"{at}: tracks()[{k}] is a {type(e).__name__}, expected a TrackEstimate")
        p = np.asarray(e.position_m)
        if p.shape != (2,) or not np.all(np.isfinite(p)):
            raise ValueError(f"{at}: tracks()[{k}].position_m must be a finite (2,) world x, y [m], got "
                             f"{np.array2string(p, threshold=6)}")
        for name in _FINITE:
            v = getattr(e, name)
            if not (isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)
                    and math.isfinite(v) and (v >= 0.0 or name not in _NON_NEGATIVE)):
                bound = "a finite number ≥ 0" if name in _NON_NEGATIVE else "a finite number"
                raise ValueError(f"{at}: tracks()[{k}].{name} (track {e.track_id}) must be {bound}, got {v!r}")
        if not 0.0 <= e.time_s <= t_s + 1e-9:
            raise ValueError(f"{at}: tracks()[{k}].time_s (track {e.track_id}) must be in [0, {t_s:g}] s (the run's "
                             f"start to the scan's time: when the estimate was made), got {e.time_s!r}")
        c = np.asarray(e.position_covariance)
        if c.shape != (2, 2) or not np.all(np.isfinite(c)):
            raise ValueError(f"{at}: tracks()[{k}].position_covariance (track {e.track_id}) must be a finite (2, 2) "
                             f"[m²], got {np.array2string(c, threshold=6)}")
        scale = max(abs(float(c[0, 0])), abs(float(c[1, 1])), 1e-300)
        if abs(float(c[0, 1]) - float(c[1, 0])) > 1e-9 * scale or c[0, 0] < 0.0 or c[1, 1] < 0.0 or \
                float(c[0, 0] * c[1, 1] - c[0, 1] * c[1, 0]) < -1e-9 * scale * scale:
            raise ValueError(f"{at}: tracks()[{k}].position_covariance (track {e.track_id}) must be symmetric and "
                             f"positive semi-definite [m²], got {c.tolist()}")
    ids = [e.track_id for e in tracks]
    if len(set(ids)) != len(ids):
        dup = next(i for i in ids if ids.count(i) > 1)
        raise ValueError(f"{at}: tracks() holds track id {dup!r} twice (each track once, by its id)")
    return tracks


def steer_answer(method, vessel_name: str, answer) -> tuple:
    """A plugin control method's ``steer()`` answer ``(commands, status)``, checked; the commands as
    a float array."""
    at = where(method, vessel_name)
    if not (isinstance(answer, (tuple, list)) and len(answer) == 2):
        raise TypeError(f"{at}: steer() returned {type(answer).__name__}, expected (commands (2,), "
                        f"PathFollowingStatus)")
    cmd, status = answer
    try:
        cmd = np.asarray(cmd, dtype=float)
    except (TypeError, ValueError):
        cmd = np.full(1, np.nan)
    if cmd.shape != (2,) or not np.all(np.abs(cmd) <= 1.0):
        raise ValueError(f"{at}: steer()'s commands must be (port, starboard), each in [-1, 1], got "
                         f"{np.array2string(cmd, threshold=6)}")
    if not isinstance(status, PathFollowingStatus):
        raise TypeError(f"{at}: steer()'s status is a {type(status).__name__}, expected a PathFollowingStatus")
    for name in ("gamma_m", "cross_track_m", "speed_ref_m_s"):
        v = getattr(status, name)
        if not (isinstance(v, (int, float, np.integer, np.floating)) and math.isfinite(v)):
            raise ValueError(f"{at}: steer()'s status.{name} must be a finite number, got {v!r}")
    return cmd, status


def factor_answer(method, factor) -> float:
    """A plugin coordination method's ``speed_correction()`` answer: a finite factor ≥ 0 on the
    mission speed (1: none)."""
    if not (isinstance(factor, (int, float, np.integer, np.floating)) and not isinstance(factor, bool)
            and math.isfinite(factor) and factor >= 0.0):
        raise ValueError(f"{where(method)}: speed_correction() returned {factor!r}, expected a finite factor ≥ 0 on "
                         f"the mission speed (1: none)")
    top = _top_speed(method)
    cruise = float(getattr(getattr(method, "context", None), "mission_speed_m_s", 0.0) or 0.0)
    if factor * cruise > SPEED_LIMIT_FACTOR * top:
        raise ValueError(f"{where(method)}: speed_correction() returned {factor!r}: {factor:g} × the mission speed "
                         f"{cruise:g} m/s is more than {SPEED_LIMIT_FACTOR:g} × the hull's top speed ({top:g} m/s)")
    return float(factor)


def team_picture_answer(method, picture):
    """A plugin coordination method's ``team_picture()`` answer: a TeamPicture or None."""
    if picture is not None and not isinstance(picture, TeamPicture):
        raise TypeError(f"{where(method)}: team_picture() returned {type(picture).__name__}, expected a TeamPicture "
                        f"(mjasc.cooperation.messages) or None")
    return picture


def events_answer(method, events) -> list:
    """A plugin method's ``drain_events()`` answer: a list of ``(t [s], text)``."""
    if events is None or isinstance(events, (str, bytes)):
        raise TypeError(f"{where(method)}: drain_events() returned {type(events).__name__}, expected a list of "
                        f"(t [s], text) ([] for none)")
    events = list(events)
    for k, ev in enumerate(events):
        if not (isinstance(ev, (tuple, list)) and len(ev) == 2 and isinstance(ev[1], str)
                and isinstance(ev[0], (int, float, np.integer, np.floating)) and math.isfinite(ev[0])):
            raise TypeError(f"{where(method)}: drain_events()[{k}] is {ev!r}, expected a (t [s], text) pair")
        events[k] = (ev[0], ev[1])
    return events


def plugin_at_fault(exc: BaseException, methods) -> str | None:
    """Which plugin method an exception came from, as :func:`where` says it, or None: the innermost
    frame of the traceback that runs a method of ``methods`` (the run's stage methods; built-ins
    are left out); else the failing frame itself when it holds one in a local (a call that failed
    before the method ran, e.g. with the wrong arguments); else the method whose class the message
    names (``Class.method() takes …``). mjasc's own frames that merely hold a plugin while they
    fail elsewhere blame no one."""
    plugins = [m for m in methods if m is not None and not builtin_method(type(m))]
    if not plugins:
        return None
    ids = {id(m): m for m in plugins}
    found = None
    tb = exc.__traceback__
    while tb is not None:  # (the innermost frame that runs a plugin's method)
        local = tb.tb_frame.f_locals
        owner = local.get("self")
        if owner is not None and id(owner) in ids:
            found = owner
        elif tb.tb_next is None and found is None:  # (the failing frame holds the plugin it was calling:
            held = {id(v) for v in local.values() if id(v) in ids}  # a call the method cannot take)
            if len(held) == 1:
                found = ids[held.pop()]
        tb = tb.tb_next
    if found is not None:
        return where(found)
    text = str(exc)
    named = [m for m in plugins if text.startswith(f"{type(m).__qualname__}.")]
    if not named:
        return None
    vessels = sorted({getattr(getattr(m, "context", None), "vessel_name", "?") for m in named})
    m = named[0]
    return where(m, vessels[0]) if len(vessels) == 1 else \
        f"{m.stage} method {m.method!r} of vessels {', '.join(map(repr, vessels))}"
