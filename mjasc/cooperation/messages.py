"""The typed values of the team's link: what a vessel broadcasts, and what it knows of its team.

* :class:`TeamMessage` — one broadcast: the sender's own navigation, its progress along its
  mission path (the coordination state ξ = (γ − o)/L and its rate), its radius and its plan (where
  it intends to be over the next seconds). Sent over :class:`~mjasc.cooperation.comms.CommsNetwork`.
* :class:`TeamIntention` — a team mate's newest message as collision avoidance uses it
  (:meth:`TeamIntention.positions` samples the plan).
* :class:`TeamPicture` — what the coordination layer hands to the rest of the vessel each tick:
  the newest intention of every team mate heard, and its factor on the mission speed.

World frame ENU, SI units, absolute simulation times [s].
"""

from __future__ import annotations

import math
from bisect import bisect_right
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from mjasc.core.compiled import kernel

__all__ = ["TeamMessage", "TeamIntention", "TeamPicture"]


@kernel
def _plan_max_speed(ts, pts):
    """The largest speed along a plan of at least two points [m/s]: numpy's
    ``(np.hypot(*np.diff(pts, axis=0).T) / np.maximum(np.diff(ts), 1e-9)).max()`` in one pass —
    the same differences, the C library's ``hypot`` (numpy's), the same division, NaN propagating
    as ``max`` does."""
    best = -math.inf
    for i in range(ts.size - 1):
        dt = ts[i + 1] - ts[i]
        if dt < 1e-9:  # (np.maximum: a NaN stays NaN)
            dt = 1e-9
        v = math.hypot(pts[i + 1, 0] - pts[i, 0], pts[i + 1, 1] - pts[i, 1]) / dt
        if v != v:
            return v
        if v > best:
            best = v
    return best


@dataclass(frozen=True, eq=False)
class TeamMessage:
    """One broadcast of ``sender`` (its own values at the send time).

    position_m (2,), heading_rad, velocity_m_s (2,): its navigation; mission_speed_m_s: its mission's
    cruise speed; radius_m: its bounding radius [m] (None: not sent); plan_times_s (k,),
    plan_points_m (k, 2): its plan (k = 0: none). Progress along its mission path (all None for a
    vessel without one): gamma_m γ [m], path_length_m L [m], xi ξ = (γ − o)/L, xi_rate_1_s ξ̇ [1/s]
    (its along-path speed / L), offset_m its formation offset o [m]. tracks: the sender's confirmed
    own tracks (:class:`~mjasc.core.estimates.SharedTrack`, nearest first, capped) when it shares
    its perception (``share_tracks``; empty otherwise). phase: the index of its mission phase
    (0 without a chained mission: team mates coordinate with mates in their own phase only);
    mission: its :class:`~mjasc.missions.legs.MissionBroadcast` (None without a ``[mission]``).
    gives_way_to: the team mates the sender is giving way to at the send time (a running yield or
    stop for their track; empty otherwise): a team mate named here is the stand-on vessel toward
    the sender and does not yield to it in turn (:mod:`~mjasc.avoidance.triage`). stands_on_to: the
    team mates toward which the sender's latest prediction made it the stand-on vessel; a team mate
    that stands on toward it too gives way if its name sorts after the sender's.
    """

    sender: str
    position_m: np.ndarray
    heading_rad: float
    velocity_m_s: np.ndarray
    mission_speed_m_s: float
    radius_m: float | None = None
    plan_times_s: np.ndarray = field(default_factory=lambda: np.zeros(0))
    plan_points_m: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    gamma_m: float | None = None
    path_length_m: float | None = None
    xi: float | None = None
    xi_rate_1_s: float | None = None
    offset_m: float | None = None
    tracks: tuple = ()
    phase: int = 0
    mission: object = None
    gives_way_to: tuple = ()
    stands_on_to: tuple = ()

    @property
    def has_path(self) -> bool:
        """The sender follows a mission path (its coordination state ξ is in the message)."""
        return self.xi is not None


@dataclass(frozen=True, eq=False)
class TeamIntention:
    """A team mate's newest message about itself (world ENU, SI, absolute times).

    name, sent_time_s: who and when. position_m (2,), heading_rad, velocity_m_s (2,): its own
    navigation at ``sent_time_s``. radius_m: its bounding radius [m] (None if not sent).
    plan_times_s (k,), plan_points_m (k, 2): where it intends to be (k = 0: no plan; then
    :meth:`positions` extrapolates the velocity). mission: its mission broadcast
    (:class:`~mjasc.missions.legs.MissionBroadcast`, None without a chained mission). gives_way_to,
    stands_on_to: the team mates it was giving way to / standing on toward when it sent the message
    (:class:`TeamMessage`)."""

    name: str
    sent_time_s: float
    position_m: np.ndarray
    heading_rad: float
    velocity_m_s: np.ndarray
    radius_m: float | None = None
    plan_times_s: np.ndarray = field(default_factory=lambda: np.zeros(0))
    plan_points_m: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    mission: object = None
    gives_way_to: tuple = ()
    stands_on_to: tuple = ()

    @classmethod
    def from_message(cls, msg: TeamMessage, sent_time_s: float) -> "TeamIntention":
        """The intention a received message states (a plan whose sample counts disagree is dropped).

        Made once per message and shared by every receiver (a broadcast reaches each team mate as
        the same immutable object; the intention's arrays are views of the message's anyway): in a
        team of n, n − 1 receivers no longer each rebuild it and its :meth:`max_speed_m_s`."""
        t = float(sent_time_s)
        cached = msg.__dict__.get("_intention")
        if cached is not None and cached.sent_time_s == t:
            return cached
        typed = type(msg) is TeamMessage
        pos, vel = msg.position_m, msg.velocity_m_s
        plan_t, plan_xy = msg.plan_times_s, msg.plan_points_m
        nd, f8 = np.ndarray, np.float64
        if not (typed and type(pos) is nd and pos.ndim == 1 and pos.dtype == f8 and type(vel) is nd
                and vel.ndim == 1 and vel.dtype == f8 and type(plan_t) is nd and plan_t.ndim == 1
                and plan_t.dtype == f8 and type(plan_xy) is nd and plan_xy.ndim == 2 and plan_xy.shape[1] == 2
                and plan_xy.dtype == f8):  # (the conversions below do nothing to a typed message's float arrays)
            plan_t = np.asarray(plan_t, dtype=float).reshape(-1)
            plan_xy = np.asarray(plan_xy, dtype=float).reshape(-1, 2)
            pos, vel = np.asarray(pos, dtype=float), np.asarray(vel, dtype=float)
        if plan_t.size != plan_xy.shape[0]:
            plan_t, plan_xy = np.zeros(0), np.zeros((0, 2))
        out = cls(msg.sender, t, pos[:2], float(msg.heading_rad), vel[:2], msg.radius_m, plan_t, plan_xy,
                  msg.mission if typed else getattr(msg, "mission", None),
                  msg.gives_way_to if typed else tuple(getattr(msg, "gives_way_to", ())),
                  msg.stands_on_to if typed else tuple(getattr(msg, "stands_on_to", ())))
        if typed or isinstance(msg, TeamMessage):
            object.__setattr__(msg, "_intention", out)
        return out

    @property
    def has_plan(self) -> bool:
        return self.plan_times_s.size >= 2

    def positions(self, times_s) -> np.ndarray:
        """Intended positions (n, 2) at absolute ``times_s``: the plan, linearly interpolated;
        before its start along the broadcast velocity, after its end along its last segment."""
        if isinstance(times_s, (float, int, np.floating)) or (isinstance(times_s, np.ndarray) and times_s.size == 1):
            return np.array([self._position(float(np.asarray(times_s).reshape(-1)[0]) if isinstance(times_s, np.ndarray)
                                            else float(times_s))])
        t = np.atleast_1d(np.asarray(times_s, dtype=float))
        if not self.has_plan:
            return self.position_m + (t - self.sent_time_s)[:, None] * self.velocity_m_s
        ts, pts = self.plan_times_s, self.plan_points_m
        out = np.stack([np.interp(t, ts, pts[:, 0]), np.interp(t, ts, pts[:, 1])], axis=-1)
        lo, hi = t < ts[0], t > ts[-1]
        if lo.any():
            out[lo] = pts[0] + (t[lo] - ts[0])[:, None] * self.velocity_m_s
        if hi.any():
            v_end = (pts[-1] - pts[-2]) / max(ts[-1] - ts[-2], 1e-9)
            out[hi] = pts[-1] + (t[hi] - ts[-1])[:, None] * v_end
        return out

    def _position(self, t: float) -> tuple[float, float]:
        """:meth:`positions` at one time, in plain floats (``np.interp``'s formula and end rules)."""
        if not self.has_plan:
            dt = t - self.sent_time_s
            return self.position_m[0] + dt * self.velocity_m_s[0], self.position_m[1] + dt * self.velocity_m_s[1]
        ts, xs, ys = self._plan_lists()
        if t < ts[0]:
            dt = t - ts[0]
            return xs[0] + dt * float(self.velocity_m_s[0]), ys[0] + dt * float(self.velocity_m_s[1])
        if t > ts[-1]:
            span = max(ts[-1] - ts[-2], 1e-9)
            vx, vy = (xs[-1] - xs[-2]) / span, (ys[-1] - ys[-2]) / span
            dt = t - ts[-1]
            return xs[-1] + dt * vx, ys[-1] + dt * vy
        if t == ts[-1]:
            return xs[-1], ys[-1]
        j = bisect_right(ts, t) - 1
        h = ts[j + 1] - ts[j]
        return (xs[j + 1] - xs[j]) / h * (t - ts[j]) + xs[j], (ys[j + 1] - ys[j]) / h * (t - ts[j]) + ys[j]

    def _plan_lists(self):
        """The plan as plain-float lists (times, x, y), made once."""
        cached = self.__dict__.get("_lists")
        if cached is None:
            cached = (self.plan_times_s.tolist(), self.plan_points_m[:, 0].tolist(), self.plan_points_m[:, 1].tolist())
            object.__setattr__(self, "_lists", cached)
        return cached

    def velocity_polar(self) -> tuple[float, float]:
        """(direction [rad] CCW from east, magnitude [m/s]) of the broadcast velocity (computed once
        per intention: every receiver shares it)."""
        v = self.__dict__.get("_velocity_polar")
        if v is None:
            vel = self.velocity_m_s
            v = (float(np.arctan2(vel[1], vel[0])), float(np.hypot(*vel)))
            object.__setattr__(self, "_velocity_polar", v)
        return v

    def max_speed_m_s(self) -> float:
        """Largest speed along the plan (or the broadcast speed) [m/s] (computed once per intention)."""
        v = self.__dict__.get("_max_speed")
        if v is None:
            v = float(np.hypot(*self.velocity_m_s))
            if self.has_plan:
                ts, pts = self.plan_times_s, self.plan_points_m
                if ts.dtype == pts.dtype == np.float64 and ts.ndim == 1 and pts.ndim == 2 and pts.shape[1] == 2:
                    v = max(v, float(_plan_max_speed(ts, pts)))  # (the numpy form below in one compiled pass)
                else:
                    seg = np.hypot(*np.diff(pts, axis=0).T) / np.maximum(np.diff(ts), 1e-9)
                    v = max(v, float(seg.max()))
            object.__setattr__(self, "_max_speed", v)
        return v


@dataclass(frozen=True, eq=False)
class TeamPicture:
    """What a vessel knows of its team at ``time_s`` [s] from its link.

    intentions: name → the newest :class:`TeamIntention` heard from each team mate (any age; users
    filter by :meth:`fresh`); speed_factor: the coordination law's latest factor on the mission
    speed (1 when there is nothing to coordinate with)."""

    time_s: float
    intentions: Mapping[str, TeamIntention] = field(default_factory=dict)
    speed_factor: float = 1.0

    def fresh(self, t_s: float, max_age_s: float) -> dict[str, TeamIntention]:
        """The intentions sent at most ``max_age_s`` before ``t_s``."""
        return {n: it for n, it in self.intentions.items() if not t_s - it.sent_time_s > max_age_s}

    def positions(self) -> dict[str, tuple[float, np.ndarray]]:
        """name → (sent time [s], position (2,) world [m]) of every team mate heard."""
        return {n: (it.sent_time_s, it.position_m) for n, it in self.intentions.items()}
