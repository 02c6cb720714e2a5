"""Team mates as collision avoidance sees them: predicted from their own broadcasts.

The team exchanges its navigation and plans over the link (docs/thesis.md §6;
:class:`~mjasc.cooperation.messages.TeamPicture`). A track matched to a team mate with a fresh
message (at most ``team_broadcast_max_age_s`` old) is replaced by that team mate's intention: its
plan — the path it follows, a detour included, at its planned speed (:class:`PlannedTrack`) — or,
without a plan, its broadcast velocity and the heading rate of successive messages. A team mate
with a fresh message but no track (not yet matched, or lost by the tracker) is added from the
message. Why: the IMM's ω̂ of a vessel on a straight leg wanders by ±0.01 rad/s, which over a 30 s
window bends the prediction by metres (phantom collisions between parallel lanes 10 m apart); a
team mate's re-planned detour or speed correction shows in its track only after it has begun;
and a team mate that brakes hard can be lost by the tracker for seconds. Team mates without a
fresh message keep their IMM track.

An unmatched track that, followed back along its own motion, lay on a team mate's broadcast
position at one of its messages of the last :data:`TEAM_HISTORY_S` seconds is that team mate (a
stale copy the tracker kept coasting): it is dropped (:meth:`TeamMates.is_ghost`).

World frame ENU, SI units, absolute simulation times [s].
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from mjasc.avoidance.plan_deviation import plans_deviate
from mjasc.avoidance.prediction.motion import TrackMotions
from mjasc.core.estimates import PlannedTrack, TrackEstimate, estimate_as_track, estimate_of

__all__ = ["TEAM_HISTORY_S", "PlannedTrack", "TeamMates"]

#: How far back [s] the team mates' broadcast positions are kept to recognise their stale tracks.
TEAM_HISTORY_S = 20.0

#: Every receiver's estimate of a team mate from one message (a TeamIntention, the same object for
#: every receiver of the broadcast) at one heading rate ω (``ω.hex()``: −0.0 kept apart): what the
#: message alone gives, made once for the fleet. id(message) → (message, {ω: estimate}); the
#: message is held so that its id stays its own; emptied when it holds :data:`_PROTOS_MAX` messages.
_PROTOS: dict[int, tuple] = {}
_PROTOS_MAX = 4096
#: The track of a team mate made of one message estimate alone (no track of it: :meth:`TeamMates._alone`),
#: shared by every receiver that gives it the same id and radius: id(message estimate) → (message
#: estimate, {(id, radius.hex()): track}); emptied when it holds :data:`_PROTOS_MAX` estimates.
_ALONE: dict[int, tuple] = {}


def _message_estimate(it, w: float) -> TrackEstimate:
    """The estimate of team mate ``it.name`` from message ``it`` at heading rate ``w`` [rad/s], without
    its id, radius and covariance (:meth:`TeamMates.tracks`): made once per (message, ω)
    for every receiver."""
    entry = _PROTOS.get(id(it))
    if entry is None or entry[0] is not it:
        if len(_PROTOS) >= _PROTOS_MAX:
            _PROTOS.clear()
        entry = _PROTOS[id(it)] = (it, {})
    by_rate = entry[1]
    key = w.hex() if isinstance(w, float) else float(w).hex()
    proto = by_rate.get(key)
    if proto is None:
        direction, speed = it.velocity_polar()
        course = direction if speed > 0.05 else it.heading_rad
        position = np.asarray(it.position_m, dtype=float).copy()
        if it.has_plan:
            proto = estimate_of(PlannedTrack, -1, it.sent_time_s, position, course, max(it.max_speed_m_s(), 1e-3),
                                w, 0.0, None, False, it.name, None, None, it)
        else:
            proto = estimate_of(TrackEstimate, -1, it.sent_time_s, position, course, speed, w, 0.0, None, False,
                                it.name, None, None)
        by_rate[key] = proto
    return proto


_NO_NAV = (None, None, 0.0)  # a team mate not heard twice: ω = 0


def _turn_rate(dh, dt: float) -> float:
    """ω = wrap(Δψ) / Δt [rad/s] as ``np.angle(np.exp(1j * Δψ)) / Δt`` gives it, in plain floats:
    ``1j * Δψ`` is (±0, 0 + Δψ), whose exp is (cos, sin) of 0 + Δψ (exp(±0) = 1), and ``np.angle``
    is ``arctan2`` of them — math's sin, cos and atan2 equal numpy's on x86-64 without AVX-512
    (:mod:`mjasc.core.portable_math`), the same bits; numpy's form for a Δψ that is not finite."""
    d = 0.0 + float(dh)
    if -math.inf < d < math.inf:
        return math.atan2(math.sin(d), math.cos(d)) / dt
    z = np.exp(1j * np.array([dh]))
    return (np.arctan2(z.imag, z.real) / np.array([dt])).tolist()[0]


class TeamMates:
    """What one vessel's avoidance remembers of its team mates' broadcasts.

    name: the vessel's own name; team: the other team members' names; radius_m: the own radius
    (the default radius of a team mate that sends none); max_age_s: ``team_broadcast_max_age_s``;
    deviation_m: ``track_deviation_m`` (a changed plan); horizon_s: the window over which plans are
    compared."""

    def __init__(self, name: str, team: set[str], radius_m: float, max_age_s: float, deviation_m: float,
                 horizon_s: float):
        self.name, self.team, self.radius_m = name, set(team), float(radius_m)
        self.max_age_s, self.deviation_m, self.horizon_s = float(max_age_s), float(deviation_m), float(horizon_s)
        self._window_grid = np.linspace(0.0, self.horizon_s, 16)  # the plan comparison's times after now [s]
        self._nav: dict[str, tuple] = {}  # name → (sent t, heading, ω) from successive broadcasts
        self._predicted: dict = {}  # name → TeamIntention the last prediction used
        self._clearance: dict[str, float] = {}  # name → the last prediction's clearance to it [m] (> 0)
        self.clearance_changes = 0  # plans found changed only against a clearance below deviation_m
        self._history = _BroadcastHistory()  # every team mate's broadcast positions over TEAM_HISTORY_S
        self._plan_checked: dict[str, float] = {}  # name → sent time of the last message compared
        self._ghosts: set[int] = set()  # track ids found to be a team mate's stale copy (reported once)
        self._mate_id = {n: -1 - k for k, n in enumerate(sorted(self.team))}  # a team mate's id without a track
        self._unmatched: dict[str, tuple] = {}  # name → (message estimate, the track made of it alone)
        # What the team picture held (names and send times) at the last poll and at the last
        # complete plan comparison: an unchanged picture has nothing new for either.
        self._key_of: tuple = (None, None)  # (a picture's intentions mapping, its key)
        self._polled_key = self._compared_key = None
        # The intentions mappings last polled and last compared in full: the same (read-only) mapping
        # has the same key, so :meth:`poll` and :meth:`plans_changed` (False) have nothing new in it
        # and the control tick does not call them for it.
        self.polled_intentions = self.compared_intentions = None

    # ------------------------------------------------------------------ broadcasts
    def fresh(self, picture, t: float) -> dict:
        """The team mates' fresh intentions, at most ``max_age_s`` old; empty without a team
        picture or when that age is 0."""
        if picture is None or self.max_age_s <= 0.0:
            return {}
        return {n: i for n, i in picture.fresh(t, self.max_age_s).items() if n in self.team}

    def _key(self, picture) -> tuple:
        """The names and send times of a team picture's intentions (equal keys: nothing new).
        Worked out once per intentions mapping: the coordination layer hands the same read-only
        mapping in every picture until a message arrives (a new picture each control tick)."""
        its = picture.intentions
        if self._key_of[0] is not its:
            self._key_of = (its, (tuple(its), tuple([it.sent_time_s for it in its.values()])))
        return self._key_of[1]

    def poll(self, picture) -> None:
        """Heading rate ω of each team mate from two successive broadcasts [rad/s] (used when a
        team mate sends no plan), and the history of their positions."""
        if picture is None:
            return
        key_of = self._key_of  # (_key without its call when the mapping is the last one seen)
        key = key_of[1] if key_of[0] is picture.intentions else self._key(picture)
        self.polled_intentions = picture.intentions
        if key == self._polled_key:
            return  # the same messages as at the last poll
        self._polled_key = key
        # the new messages: (name, intention, Δψ, Δt), Δψ None unless 0 < Δt ≤ 3 s after the last
        new, nav, team, history = [], self._nav, self.team, self._history
        for name, it in picture.intentions.items():
            if name not in team:
                continue
            old = nav.get(name)
            if old is not None and it.sent_time_s <= old[0]:
                continue
            history.add(name, it.sent_time_s, it.position_m, float(it.radius_m) if it.radius_m else self.radius_m)
            if old is not None and 0.0 < it.sent_time_s - old[0] <= 3.0:
                new.append((name, it, it.heading_rad - old[1], it.sent_time_s - old[0]))
            else:
                new.append((name, it, None, None))
        for name, it, dh, dt in new:
            nav[name] = (it.sent_time_s, it.heading_rad, 0.0 if dh is None else _turn_rate(dh, dt))

    def heading_rate(self, name: str) -> float:
        """ω of team mate ``name`` from its last two broadcasts [rad/s] (0 when unknown)."""
        return self._nav.get(name, _NO_NAV)[2]

    def broadcast_based(self, track, fresh: dict) -> bool:
        """The track is a team mate predicted from its fresh broadcast (its speed is measured, not
        IMM noise: a slow team mate is not taken as static)."""
        return track.team_member in self.team and track.team_member in fresh

    # ------------------------------------------------------------------ tracks
    def _alone(self, it, proto, track_id: int) -> TrackEstimate:
        """The track of team mate ``it.name`` made of its message estimate ``proto`` alone (no track
        of it): id ``track_id``, its broadcast radius (the own one when it sends none), no
        covariance. One object per (message estimate, id, radius) for the whole fleet
        (:data:`_ALONE`; every receiver ranks the team mate alike but for its own name's place):
        kept by this receiver until the team mate's next message."""
        made = self._unmatched.get(it.name)
        if made is not None and made[0] is proto:
            return made[1]
        radius = float(it.radius_m if it.radius_m else self.radius_m)
        entry = _ALONE.get(id(proto))
        if entry is None or entry[0] is not proto:
            if len(_ALONE) >= _PROTOS_MAX:
                _ALONE.clear()
            entry = _ALONE[id(proto)] = (proto, {})
        key = (track_id, radius.hex())
        alone = entry[1].get(key)
        if alone is None:  # (its covariance read-only: receivers share the object)
            none = np.zeros((2, 2))
            none.flags.writeable = False
            alone = entry[1][key] = estimate_as_track(proto, track_id, radius, none)
        self._unmatched[it.name] = (proto, alone)
        return alone

    def tracks(self, tracks, t: float, picture, emit: Callable[[float, str], None]) -> list:
        """The tracks with team mates predicted from their fresh broadcasts (module docstring),
        stale copies of team mates dropped.

        A team mate's track from its broadcast: along its plan when it sent one
        (:class:`PlannedTrack`), else constant velocity and the heading rate of successive
        messages. What depends on the message alone (position, course, speed, the plan's largest
        speed, and with the heading rate the whole estimate but its id, radius and covariance) is
        worked out once per message for every receiver (:func:`_message_estimate`); a matched
        track's estimate is that one's fields with the track's id, radius and covariance
        (:func:`~mjasc.core.estimates.estimate_as_track`: ~26 a prediction of the 50-vessel fleet);
        a team mate without a track (~20 more) is :meth:`_alone`."""
        self.poll(picture)
        intents = self.fresh(picture, t)
        if not intents:
            out = list(tracks)
        else:
            out, seen, rate = [], set(), self.heading_rate
            for tr in tracks:
                it = intents.get(tr.team_member)  # (intents holds team mates' names only)
                if it is None:
                    out.append(tr)
                    continue
                name = tr.team_member
                if name in seen:
                    continue
                seen.add(name)
                out.append(estimate_as_track(_message_estimate(it, rate(it.name)), tr.track_id, float(tr.radius_m),
                                             tr.position_covariance))
            mate_id = self._mate_id
            for name, it in intents.items():
                if name not in seen:
                    out.append(self._alone(it, _message_estimate(it, rate(it.name)), mate_id[name]))
        unmatched = [k for k, tr in enumerate(out) if tr.team_member is None]
        if not unmatched:
            return out
        ghost = self.ghosts([out[k] for k in unmatched], t, emit)
        if not ghost.any():
            return out
        drop = {unmatched[k] for k in np.flatnonzero(ghost)}
        return [tr for k, tr in enumerate(out) if k not in drop]

    def ghosts(self, tracks, t: float, emit: Callable[[float, str], None]) -> np.ndarray:
        """:meth:`is_ghost` for many unmatched tracks at once: a bool mask (k,). All tracks'
        positions followed back to every kept broadcast time in one array operation
        (:class:`~mjasc.avoidance.prediction.motion.TrackMotions`)."""
        out = np.zeros(len(tracks), dtype=bool)
        if not self._history.names or not tracks:
            return out
        tb, pb, rb, who, names, newest = self._history.arrays()
        live = t - newest <= TEAM_HISTORY_S  # team mates heard within the kept history
        if tb.size == 0 or not live.any():
            return out
        keep = live[who]
        if not keep.all():
            tb, pb, rb, who = tb[keep], pb[keep], rb[keep], who[keep]
        # every track followed back to every kept broadcast: (k, H) within the larger radius
        hit = TrackMotions(tracks).within(tb, pb, rb)
        out = hit.any(axis=1)
        for k in np.flatnonzero(out):
            track = tracks[k]
            if track.track_id not in self._ghosts:
                self._ghosts.add(track.track_id)
                name = names[int(who[hit[k]].min())]  # the first team mate heard that it retraces
                emit(t, f"track {track.track_id} retraces team mate {name}'s broadcast positions: "
                        f"it is {name} (stale copy), ignored")
        return out

    def is_ghost(self, track, t: float, emit: Callable[[float, str], None]) -> bool:
        """An unmatched track that, followed back along its own motion, lay on a team mate's
        broadcast position (closer than the larger of the two radii: the discs deeply overlap) at
        one of that team mate's messages of the last ``TEAM_HISTORY_S`` is that team mate: a copy
        the tracker kept coasting at the old velocity when the team mate braked, or a second
        track of it. Anything else that close to a team mate would have been in collision with it."""
        return bool(self.ghosts([track], t, emit)[0])

    # ------------------------------------------------------------------ plans
    def remember_prediction(self, fresh: dict) -> None:
        """The intentions the prediction just made used (compared by :meth:`plans_changed`)."""
        self._predicted = fresh

    def remember_clearances(self, clearances: dict) -> None:
        """Each team mate's clearance in the last prediction (its closest predicted distance less
        the collision distance [m]; those with a predicted collision left out). While the own plan
        stands, a new plan that moves less than this cannot bring a collision the prediction did
        not see (the distance at each time changes by at most the move; checked at the
        comparison's times, not the prediction's finer grid); one that moves more may, and is
        compared against it instead of ``deviation_m`` when it is the smaller."""
        self._clearance = clearances

    def predicted_names(self) -> set:
        """Team mates the last prediction took from their fresh broadcasts."""
        return set(self._predicted)

    def plans_changed(self, t: float, picture) -> bool:
        """A team mate's newest plan differs by more than ``deviation_m`` — or than the last
        prediction's clearance to it, when that is smaller (:meth:`remember_clearances`) — from
        the one the last prediction used, within the prediction window (it re-planned, changed its
        speed or stopped). Each message is compared once; all new messages are compared in one
        array operation."""
        if picture is None:
            return False
        key_of = self._key_of  # (_key without its call when the mapping is the last one seen)
        key = key_of[1] if key_of[0] is picture.intentions else self._key(picture)
        if key == self._compared_key:
            self.compared_intentions = picture.intentions
            return False  # every message still fresh was compared at the last call
        intents = self.fresh(picture, t)
        pairs, limits = [], []
        for name, it in intents.items():
            if self._plan_checked.get(name) == it.sent_time_s:
                continue  # this message was compared already
            self._plan_checked[name] = it.sent_time_s
            old = self._predicted.get(name)
            if old is None:
                if it.has_plan:
                    return True
                continue
            if it.sent_time_s <= old.sent_time_s:
                continue
            pairs.append((it, old))
            limits.append(min(self.deviation_m, self._clearance.get(name, math.inf)))
        self._compared_key, self.compared_intentions = key, picture.intentions
        if not pairs:
            return False
        times = t + self._window_grid
        changed = plans_deviate(pairs, times, limits)  # (new plan, old) pairs
        if changed and min(limits) < self.deviation_m and not plans_deviate(pairs, times, self.deviation_m):
            self.clearance_changes += 1  # (counted: the summary's predictions_on_team_clearance)
        return changed


class _BroadcastHistory:
    """The team mates' broadcast positions of the last :data:`TEAM_HISTORY_S` seconds before each
    one's newest message, as one table (rows in no particular order; the ghost check does not
    depend on it): new rows are queued by :meth:`add` and joined, and the old ones dropped, when
    the table is next read."""

    def __init__(self):
        self.names: list[str] = []  # in the order first heard
        self._index: dict[str, int] = {}
        self._queued: list[tuple] = []  # (sent t, x, y, radius, team mate index)
        self._newest = np.zeros(0)
        self._rows = (np.zeros(0), np.zeros((0, 2)), np.zeros(0), np.zeros(0, dtype=np.intp))

    def add(self, name: str, sent_time_s: float, position_m, radius_m: float) -> None:
        i = self._index.get(name)
        if i is None:
            i = self._index[name] = len(self.names)
            self.names.append(name)
        p = position_m  # (a float vector as it is)
        if not (type(p) is np.ndarray and p.ndim == 1 and p.dtype == np.float64):
            p = np.asarray(position_m, dtype=float).reshape(-1)
        self._queued.append((float(sent_time_s), float(p[0]), float(p[1]), float(radius_m), i))

    def arrays(self) -> tuple:
        """(sent t (H,) [s], position (H, 2) [m], radius (H,) [m], team mate index (H,), names,
        each name's newest sent time [s])."""
        if self._queued:
            q = np.array(self._queued, dtype=float)
            self._queued = []
            newest = np.full(len(self.names), -np.inf)
            newest[: self._newest.size] = self._newest
            np.maximum.at(newest, q[:, 4].astype(np.intp), q[:, 0])
            t, p, r, who = self._rows
            t = np.concatenate([t, q[:, 0]])
            p = np.concatenate([p, q[:, 1:3]])
            r = np.concatenate([r, q[:, 3]])
            who = np.concatenate([who, q[:, 4].astype(np.intp)])
            keep = t >= newest[who] - TEAM_HISTORY_S
            self._rows = (t[keep], p[keep], r[keep], who[keep])
            self._newest = newest
        return (*self._rows, self.names, self._newest)

