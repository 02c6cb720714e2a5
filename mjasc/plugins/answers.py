"""A plugin method's answers checked where the pipeline takes them: a wrong answer is one error
naming the method, the vessel and what is wrong, at the call — not a silent default (a forgotten
``return`` taken as "no request"), a value MuJoCo clamps without a word (commands of 5), or a
failure deep inside the perception, the control pass or the recording. The built-in methods'
answers (:func:`~mjasc.plugins.registry.builtin_method`) are not checked: they are theirs, and the control tick is hot.

* :func:`avoidance_answers` — ``control_many``'s answers: one
  :class:`~mjasc.avoidance.request.AvoidanceRequest` per call (the request's own constructor
  checks its mode and overrides);
* :func:`tracks_answer` — a tracker's ``tracks()``: TrackEstimate values with a finite (2,) position;
* :func:`steer_answer` — a control method's ``steer()``: ``(commands (2,) in [−1, 1],
  PathFollowingStatus)``.
"""

from __future__ import annotations

import numpy as np

from mjasc.avoidance.request import AvoidanceRequest
from mjasc.core.estimates import TrackEstimate
from mjasc.guidance.path_following import PathFollowingStatus
from mjasc.plugins.registry import builtin_method

__all__ = ["avoidance_answers", "tracks_answer", "steer_answer"]


def avoidance_answers(cls: type, calls: list) -> list:
    """``cls.control_many(calls)`` (each call ``(method, t, nav, ...)``), a plugin's checked: as many
    answers as calls, each an AvoidanceRequest."""
    answers = cls.control_many(calls)
    if builtin_method(cls):
        return answers
    answers = list(answers)
    if len(answers) != len(calls):
        raise TypeError(f"avoidance method {cls.__qualname__}: control_many returned {len(answers)} answer(s) for "
                        f"{len(calls)} vessel(s)")
    for call, answer in zip(calls, answers):
        if not isinstance(answer, AvoidanceRequest):
            vessel = getattr(getattr(call[0], "context", None), "vessel_name", "?")
            raise TypeError(f"avoidance method {cls.__qualname__} ({getattr(call[0], 'method', '?')}) returned "
                            f"{type(answer).__name__} for vessel {vessel!r}, expected an AvoidanceRequest "
                            f"(AvoidanceRequest() keeps the mission)")
    return answers


def tracks_answer(method, vessel_name: str) -> tuple:
    """``method.tracks()`` of a plugin tracker as a tuple, checked."""
    got = method.tracks()
    where = f"tracking method {getattr(method, 'method', type(method).__name__)!r} of vessel {vessel_name!r}"
    try:
        tracks = tuple(got)
    except TypeError:
        raise TypeError(f"{where}: tracks() returned {type(got).__name__}, expected a tuple of TrackEstimate") from None
    for k, e in enumerate(tracks):
        if not isinstance(e, TrackEstimate):
            raise TypeError(f"{where}: tracks()[{k}] is a {type(e).__name__}, expected a TrackEstimate")
        p = np.asarray(e.position_m)
        if p.shape != (2,) or not np.all(np.isfinite(p)):
            raise ValueError(f"{where}: tracks()[{k}].position_m must be a finite (2,) world x, y [m], got "
                             f"{np.array2string(p, threshold=6)}")
    return tracks


def steer_answer(method, vessel_name: str, answer) -> tuple:
    """A plugin control method's ``steer()`` answer ``(commands, status)``, checked; the commands as
    a float array."""
    where = f"control method {getattr(method, 'method', '?')!r} of vessel {vessel_name!r}"
    if not (isinstance(answer, (tuple, list)) and len(answer) == 2):
        raise TypeError(f"{where}: steer() returned {type(answer).__name__}, expected (commands (2,), "
                        f"PathFollowingStatus)")
    cmd, status = answer
    try:
        cmd = np.asarray(cmd, dtype=float)
    except (TypeError, ValueError):
        cmd = np.full(1, np.nan)
    if cmd.shape != (2,) or not np.all(np.abs(cmd) <= 1.0):
        raise ValueError(f"{where}: steer()'s commands must be (port, starboard), each in [-1, 1], got "
                         f"{np.array2string(cmd, threshold=6)}")
    if not isinstance(status, PathFollowingStatus):
        raise TypeError(f"{where}: steer()'s status is a {type(status).__name__}, expected a PathFollowingStatus")
    return cmd, status
