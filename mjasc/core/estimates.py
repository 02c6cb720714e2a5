"""Typed values that flow between a vessel's perception and its collision avoidance.

A :class:`TrackEstimate` is what the tracker (``tracking``/``imm``) hands to collision
prediction: everything a vessel believes about one object around it. A :class:`SharedTrack` is
an own track as a vessel broadcasts it to its team. A :class:`PlannedTrack` is
a team mate that collision avoidance predicts along its own broadcast plan instead.
:func:`predicted_to` moves estimates on to a later time along their velocity (what a run's
evaluation scores at a record tick). World frame ENU, SI units.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, fields
from typing import Any, Callable

import numpy as np


class Pending:
    """A value not made yet: ``make(*args)`` on first read of the field that holds it (a
    :class:`TrackEstimate`'s ``outline_m``: the tracker hands one on for every slow track, only a
    prediction reads them). ``make`` is a module-level function and ``args`` values that do not
    change afterwards, so the value is the same whenever it is made (and the object pickles)."""

    __slots__ = ("make", "args")

    def __init__(self, make: Callable, *args):
        self.make, self.args = make, args


class _MadeOnRead:
    """A dataclass field's descriptor: the value in the instance's ``__dict__``, or — when that is a
    :class:`Pending` — the value it makes, kept in its place on first read. The default is None."""

    def __set_name__(self, owner, name: str) -> None:
        self.name = name

    def __get__(self, obj, cls=None):
        if obj is None:
            return None  # the field's default
        d = obj.__dict__
        v = d[self.name]
        if type(v) is Pending:
            v = d[self.name] = v.make(*v.args)
        return v

    def __set__(self, obj, value) -> None:  # (the frozen dataclass's __init__ sets fields through object.__setattr__)
        obj.__dict__[self.name] = value


@dataclass(frozen=True)
class TrackEstimate:
    """One tracked object as estimated by one vessel at time ``time_s``.

    position_m: (2,) world-frame x, y of the object's centre [m].
    heading_rad: course over ground, CCW from east [rad].
    speed_m_s: speed over ground [m/s] (≥ 0).
    turn_rate_rad_s: estimated turn rate ω̂ = Σ μ_j ω_j [rad/s], CCW positive.
    radius_m: radius of the circle bounding the object [m] (estimated from sensor returns).
    position_covariance: (2, 2) covariance of position_m [m²].
    is_static: True for objects that do not move (docks, islands, moored buoys).
    team_member: name of the team mate this track was matched to, or None.
    outline_m: (k, 2) world-frame polygon of a static object's extent, or None (the tracker may
        hand on a :class:`Pending` outline: it is made on first read).
    source: None for the vessel's own track (its sensor; possibly fused with team tracks), or
        ``"team:<sender>"`` for a track only a team mate saw (team-shared perception,
        :mod:`mjasc.perception.track_fusion`).
    """

    track_id: int
    time_s: float
    position_m: np.ndarray
    heading_rad: float
    speed_m_s: float
    turn_rate_rad_s: float
    radius_m: float
    position_covariance: np.ndarray = field(default_factory=lambda: np.zeros((2, 2)))
    is_static: bool = False
    team_member: str | None = None
    outline_m: np.ndarray | None = _MadeOnRead()  # (None by default; a Pending is made on first read)
    source: str | None = None

    def predict_positions(self, times_s: np.ndarray) -> np.ndarray:
        """Positions (n, 2) at absolute times ``times_s`` under constant speed and turn rate
        (the constant-turn motion of thesis eq. 3.2 without noise; straight line when ω̂ ≈ 0)."""
        tau = np.asarray(times_s, dtype=float) - self.time_s
        x0, y0 = float(self.position_m[0]), float(self.position_m[1])
        v, th, w = self.speed_m_s, self.heading_rad, self.turn_rate_rad_s
        if self.is_static or v == 0.0:
            return np.tile([x0, y0], (tau.size, 1))
        if abs(w) < 1e-9:
            return np.stack([x0 + v * tau * np.cos(th), y0 + v * tau * np.sin(th)], axis=-1)
        th_t = th + w * tau
        return np.stack(
            [x0 + v / w * (np.sin(th_t) - np.sin(th)), y0 - v / w * (np.cos(th_t) - np.cos(th))],
            axis=-1,
        )


_FIELDS_OF: dict = {}  # class → its field names in order


def _field_names(cls) -> tuple:
    """The dataclass ``cls``'s field names in order (looked up once per class)."""
    names = _FIELDS_OF.get(cls)
    if names is None:
        names = _FIELDS_OF[cls] = tuple(f.name for f in fields(cls))
    return names


def track_estimate_rows(*columns) -> list[TrackEstimate]:
    """One :class:`TrackEstimate` per row of ``columns``, equal-length sequences of every field's
    values in field order (track_id … source): the same objects as ``TrackEstimate(*row)``. The
    frozen dataclass's ``__init__`` sets each of the twelve fields through ``object.__setattr__``
    (~2 µs a track; a fleet's tracker hands on ~10⁴ tracks a second); here each instance's
    ``__dict__`` is filled at once. Values are taken as given (the tracker's own, already typed)."""
    names = _field_names(TrackEstimate)
    if len(columns) != len(names):
        raise ValueError(f"columns: expected {len(names)} (one per field), got {len(columns)}")
    new, cls = object.__new__, TrackEstimate
    out = []
    for row in zip(*columns):
        e = new(cls)
        e.__dict__.update(zip(names, row))
        out.append(e)
    return out


_N_TRACK_FIELDS = len(_field_names(TrackEstimate))


class TrackRows(Sequence):
    """A read-only sequence of :class:`TrackEstimate` kept as columns: the objects are made on the
    first read of an item (:func:`track_estimate_rows` of the columns, then kept), while the
    columns a control tick checks are read without them: ``track_ids`` (list of int), ``times_s``
    (list of float) and ``positions_m`` ((k, 2) array [m]; item k's ``position_m`` is its row k).
    ``columns``: every field's values in field order (track_id … source), equal lengths, not
    changed afterwards. A tracker hands one per vessel and step to the perception report: a
    vessel's control tick reads its tracks' ids, times and positions ~10 times a second, a
    prediction reads the objects every few seconds. ``id_array`` (k,) int64 and ``time_array``
    (k,) float64 [s]: the ids and times as arrays (a tracker's report: the compiled deviation
    check reads them without converting the lists), else None. A tracker's report is a span of
    columns shared by the fleet's vessels (:meth:`of_span`): a vessel's slices of the fields a
    prediction reads are made with its objects, not with the report."""

    __slots__ = ("_columns", "_span", "_items", "track_ids", "times_s", "positions_m", "id_array", "time_array")

    def __init__(self, columns: Sequence):
        if len(columns) != _N_TRACK_FIELDS:
            raise ValueError(f"columns: expected {_N_TRACK_FIELDS} (one per field), got {len(columns)}")
        self._columns, self._span, self._items = tuple(columns), None, None
        self.track_ids, self.times_s, self.positions_m = columns[0], columns[1], columns[2]
        self.id_array = self.time_array = None

    @classmethod
    def of_columns(cls, columns: tuple, id_array=None, time_array=None) -> "TrackRows":
        """``TrackRows(columns)`` for a caller whose ``columns`` is a tuple of one value per field
        already (a tracker's report: no check, no copy); ``id_array`` and ``time_array`` the
        ids (k,) int64 and times (k,) float64 as arrays, equal to ``columns[0]`` and
        ``columns[1]``, not changed afterwards (or None), with ``columns[2]`` a (k, 2) float64 array."""
        rows = object.__new__(cls)
        rows._columns, rows._span, rows._items = columns, None, None
        rows.track_ids, rows.times_s, rows.positions_m = columns[0], columns[1], columns[2]
        rows.id_array, rows.time_array = id_array, time_array
        return rows

    @classmethod
    def of_span(cls, columns: tuple, first: int, end: int, id_array, time_array) -> "TrackRows":
        """The rows ``first … end − 1`` of ``columns``, a tuple of every field's values in field order
        but ``source`` (track_id … outline_m, equal lengths; each row's source is None), as
        :meth:`of_columns` of those slices would make them: a fleet tracker's report, whose vessels
        share its columns (in the usual control tick only the ids, times and positions are read:
        the other fields are sliced when the objects are made). ``columns`` with ``columns[2]`` a
        (n, 2) float64 array, ``id_array`` (n,) int64 and ``time_array`` (n,) float64 as for
        :meth:`of_columns`; none of them changed afterwards."""
        rows = object.__new__(cls)
        rows._columns, rows._span, rows._items = columns, (first, end), None
        rows.track_ids, rows.times_s = columns[0][first:end], columns[1][first:end]
        rows.positions_m = columns[2][first:end]
        rows.id_array, rows.time_array = id_array[first:end], time_array[first:end]
        return rows

    def _get(self) -> tuple:
        items = self._items
        if items is None:
            columns, span = self._columns, self._span
            if span is not None:  # (a span of shared columns: this one's slices, source None)
                a, b = span
                columns = [c[a:b] for c in columns]
                columns.append((None,) * (b - a))
            items = self._items = tuple(track_estimate_rows(*columns))
            self._columns = self._span = None
        return items

    def __getitem__(self, k):
        return self._get()[k]

    def __len__(self) -> int:
        return len(self.track_ids)

    def __iter__(self):
        return iter(self._get())

    def __eq__(self, other) -> bool:
        """Equal to a sequence of the same estimates in the same order (a tuple, a list, other rows)."""
        if not isinstance(other, (TrackRows, tuple, list)):
            return NotImplemented
        return self._get() == tuple(other)

    __hash__ = None

    def __repr__(self) -> str:
        return f"TrackRows(track_ids={list(self.track_ids)!r})"


def track_columns(tracks) -> tuple:
    """(ids, times [s], positions (k, 2) or a list of (2,) [m]) of a sequence of tracks: the
    columns of a :class:`TrackRows` as they are, else read from the objects."""
    if type(tracks) is TrackRows:
        return tracks.track_ids, tracks.times_s, tracks.positions_m
    return ([tr.track_id for tr in tracks], [tr.time_s for tr in tracks], [tr.position_m for tr in tracks])


def estimate_of(cls, *values):
    """One ``cls`` — a frozen dataclass without ``__post_init__``: :class:`TrackEstimate`,
    :class:`PlannedTrack`, collision prediction's ``PredictedConflict`` — from every field's value in
    field order: the same object as ``cls(*values)``, its ``__dict__`` filled at once (as
    :func:`track_estimate_rows`; collision avoidance makes ~10⁵ team-mate tracks and clear
    conflicts a minute in a fleet of fifty). Values are taken as given."""
    try:
        names = _FIELDS_OF[cls]  # (_field_names without its call once the class is known)
    except KeyError:
        names = _field_names(cls)
    e = object.__new__(cls)
    try:
        e.__dict__.update(zip(names, values, strict=True))  # (the count checked by the zip: no len calls)
    except ValueError:
        if len(values) != len(names):
            raise ValueError(f"values: expected {len(names)} (one per field of {cls.__name__}), "
                             f"got {len(values)}") from None
        raise
    return e


def estimate_replace(proto, **changes):
    """``dataclasses.replace(proto, **changes)`` for a :class:`TrackEstimate` or
    :class:`PlannedTrack` (``changes`` are field names): the same object, made as a copy of
    ``proto``'s fields with ``changes`` (no constructor; values taken as given). Collision avoidance
    makes every track of a team mate from one message this way, only the track's id, radius and
    covariance differing."""
    cls = type(proto)
    names = _FIELD_SETS.get(cls)
    if names is None:
        names = _FIELD_SETS[cls] = frozenset(_field_names(cls))
    if not changes.keys() <= names:
        raise TypeError(f"estimate_replace: {sorted(set(changes) - names)} are not fields of {cls.__name__}")
    e = object.__new__(cls)
    d = proto.__dict__.copy()
    d.update(changes)
    object.__setattr__(e, "__dict__", d)
    return e


_FIELD_SETS: dict = {}  # class → its field names as a set (estimate_replace's check)


def estimate_as_track(proto, track_id: int, radius_m: float, position_covariance):
    """``estimate_replace(proto, track_id=…, radius_m=…, position_covariance=…)`` without the
    keyword check: the estimate of a team mate's message as one track of a receiver (every
    prediction of every vessel makes one per team mate: collision avoidance's ``TeamMates``)."""
    e = object.__new__(type(proto))
    d = proto.__dict__.copy()
    d["track_id"], d["radius_m"], d["position_covariance"] = track_id, radius_m, position_covariance
    object.__setattr__(e, "__dict__", d)
    return e


@dataclass(frozen=True, eq=False)
class SharedTrack:
    """One confirmed own track as a vessel broadcasts it to its team (team-shared perception,
    :mod:`mjasc.perception.track_fusion`): the sender's estimate, never the truth.

    track_id: the sender's id; time_s: the estimate's time [s]; position_m (2,) [m]; velocity_m_s
    (2,) over ground [m/s]; turn_rate_rad_s ω̂ [rad/s]; radius_m [m]; position_covariance (2, 2)
    [m²]; is_static."""

    track_id: int
    time_s: float
    position_m: np.ndarray
    velocity_m_s: np.ndarray
    turn_rate_rad_s: float
    radius_m: float
    position_covariance: np.ndarray
    is_static: bool = False


@dataclass(frozen=True, eq=False)
class PlannedTrack(TrackEstimate):
    """A team mate predicted from its own broadcast plan (``intention``, a
    :class:`~mjasc.cooperation.messages.TeamIntention`): ``predict_positions`` follows the plan (its
    path, a detour included, at its planned speed) instead of constant speed and turn rate.
    ``speed_m_s`` is the plan's largest speed (the prediction samples the swept stretch with it),
    position/heading/time are the broadcast's. Built by :mod:`mjasc.avoidance.team_mates`."""

    intention: Any = None

    def predict_positions(self, times_s: np.ndarray) -> np.ndarray:
        return self.intention.positions(times_s)


@dataclass(frozen=True)
class PerceptionReport:
    """What one vessel's perception hands onward at ``time_s`` [s]: its confirmed tracks (a
    read-only sequence of :class:`TrackEstimate`; the agent hands the built-in tracker's
    :class:`TrackRows`, whose estimates are made on first read) and the convex polygons (each
    (k, 2), world [m]) of the static structures it has mapped (a sequence; the agent hands a
    :class:`Deferred` one, computed on first use: only a prediction needs them)."""

    time_s: float
    tracks: Sequence[TrackEstimate] = ()
    static_polygons: Sequence[np.ndarray] = ()


class Deferred(Sequence):
    """A read-only sequence whose items are produced by ``make()`` on first use, then kept."""

    def __init__(self, make: Callable[[], Sequence]):
        self._make, self._items = make, None

    def _get(self) -> tuple:
        if self._items is None:
            self._items, self._make = tuple(self._make()), None
        return self._items

    def __getitem__(self, k):
        return self._get()[k]

    def __len__(self) -> int:
        return len(self._get())


def predicted_to(positions_m, times_s, headings_rad, speeds_m_s, t_s: float) -> np.ndarray:
    """Track positions (k, 2) [m] estimated at ``times_s`` (k,) predicted to the tick ``t_s`` along
    their velocity (heading [rad], speed [m/s]): what the evaluation compares with the truth at
    t_s. A track is last estimated at its tracker's latest update (5 Hz) and the record ticks come
    at 10 Hz: scored as estimated, the age of the estimate (up to a tracking period of the target's
    motion) counted as error — the §6.1 tracking scene's position RMSE 0.140 m instead of 0.073 m.
    A straight line, not :meth:`TrackEstimate.predict_positions`' constant turn: a tracking period
    ahead the turn is negligible, and the evaluation's compiled pass
    (:func:`mjasc.evaluation.track_samples.append_confirmed`) gives these bits."""
    dv = np.maximum(t_s - np.asarray(times_s, dtype=float), 0.0) * np.asarray(speeds_m_s, dtype=float)
    th = np.asarray(headings_rad, dtype=float)
    out = np.array(positions_m, dtype=float).reshape(-1, 2)
    out[:, 0] += dv * np.cos(th)
    out[:, 1] += dv * np.sin(th)
    return out
