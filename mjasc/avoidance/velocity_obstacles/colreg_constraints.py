"""COLREG roles and the velocities they forbid, over arrays (Kuwata, Wolf, Zarzhitsky & Huntsberger
2014, "Safe maritime autonomous navigation with COLREGS, using velocity obstacles", IEEE JOE 39(1)).

World frame ENU (z up), headings CCW from east. For the own vessel A and an obstacle B with
r = p_B − p_A and a candidate's relative velocity w = v_A − v_B (:mod:`.cones`), the sign of the
cross product

    s(w) = (r × w)_z = r_x w_y − r_y w_x

tells on which side of the line of sight A's relative motion passes B: s > 0 turns w
counter-clockwise from r, so A passes B's left in the relative frame — B stays on A's **starboard**
side while they pass. Kuwata et al. split the velocities outside the VO into those passing on one
side (their V_1), on the other (V_2) and those moving away (V_3, r·w < 0). Written in ENU:

* **head-on** (rule 14: both alter to starboard, pass port to port) and **crossing, give way**
  (rule 15: B on A's starboard side; A keeps out of the way and does not cross ahead of B, it
  passes astern) forbid the closing velocities passing on the wrong side, the half-plane

      V_forbidden = { v_A : r·w > 0 and (r × w)_z > 0 }

  Head-on these are the velocities that pass B starboard to starboard (turning to port); crossing
  from starboard they are the velocities that cross ahead of B: A reaches B's track when the
  relative position along w has turned past r, and s > 0 ⇔ A is then on B's bow side
  (tests/test_velocity_obstacles.py checks both against the straight-line geometry); and, as the
  alteration of a give-way vessel is to starboard (rules 14, 16; Kuwata et al. prefer starboard
  manoeuvres), courses more than 5° to port of the preferred course are penalized like forbidden
  ones (option ``give_way_starboard``, :func:`port_turn`);
* **overtaking** (rule 13: A keeps out of the way, either side): no side constraint, B's VO alone;
* **stand on** (crossing with B on A's port side, being overtaken; rule 17): A keeps course and
  speed — B's VO is not applied — until keeping the preferred velocity would collide within
  ``stand_on_ttc_s`` (rule 17 (a)(ii)/(b): action when collision cannot be avoided by the
  give-way vessel alone); then B's VO applies and, crossing, a turn to port is penalized
  (rule 17 (c): not to port for a vessel on her own port side).

The roles are those of :func:`mjasc.evaluation.colreg.role_from_geometry` (a pure function of the
relative bearing and course; the same :class:`~mjasc.evaluation.colreg.ColregConfig` thresholds),
computed here over arrays of tracks from the own navigation and the tracks' estimates only.

**Role persistence** (Kuwata's hysteresis): a track's role is fixed when it first comes into
conflict and kept while it stays in conflict and for ``hold_s`` after (:class:`RoleMemory`): as the
geometry changes during the manoeuvre (A turning to starboard changes the bearing of B), a role
recomputed each tick would flip between head-on and crossing and the allowed side with it.

**Departure, committed** (rule 2 (b): departing from the rules to avoid immediate danger; rule 17
(b)). When no candidate is admissible — every velocity the rules allow collides within the horizon
(in a gap, the side they ask for is out of the hull's reach) — and the cheapest is collision-free
but passes a head-on or give-way track on the forbidden side, the vessel departs from the rule for
that track and **commits** to the side it now takes: for that track the forbidden half-plane is
the other one, (r × w)_z < 0, while its role is remembered (:class:`Departures`;
``forbidden_side(..., departed)``). Without the commitment the choice flipped across the target's
line and back: once across, a crawl towards the rule's side was admissible again a moment later,
then not, and the hull, turning back and forth ahead of the target, met it.

A departure must be **within the hull's reach** (:func:`departure_reachable`): the candidate is a
velocity, the hull a vessel that turns at a finite rate. A collision-free candidate that passes a
track on the forbidden side counts as a departure only if it still clears that track when it begins
only once the hull has come round onto its course — |Δψ| / ``turn_rate_deg_s`` later, the hull
holding its position meanwhile — through the turn and the horizon after it; one the hull cannot
reach in time is as good as a collision (τ_c = 0 in the cost). Without that test a vessel 3–4 m
on the rule's side, 17–22 m from the target, turned across its bow (a 156° turn sweeping the bow
through the target's bearing), found nothing admissible half-way round and turned back: 0.6 m
clear with a departure, and in another draw −0.24 m (contact) without departures.
"""

from __future__ import annotations

import numpy as np

from mjasc.avoidance.velocity_obstacles.cones import time_to_collision
from mjasc.evaluation.colreg import ColregConfig

__all__ = ["ROLE_NAMES", "NONE", "HEAD_ON", "GIVE_WAY", "STAND_ON", "OVERTAKING", "OVERTAKEN", "roles",
           "side_of_passing", "forbidden_side", "port_turn", "departure_reachable", "RoleMemory", "Departures"]

#: Role codes (index into :data:`ROLE_NAMES`; the names of mjasc.evaluation.colreg.ROLES).
ROLE_NAMES = ("none", "head_on", "crossing_give_way", "crossing_stand_on", "overtaking", "overtaken")
NONE, HEAD_ON, GIVE_WAY, STAND_ON, OVERTAKING, OVERTAKEN = range(6)


def _wrap_deg(a: np.ndarray) -> np.ndarray:
    """Degrees wrapped to (−180, 180] (as :func:`mjasc.evaluation.colreg.wrap_deg`)."""
    w = (np.asarray(a, dtype=float) + 180.0) % 360.0 - 180.0
    return np.where(w == -180.0, 180.0, w)


def roles(own_position_m, own_heading_rad: float, target_position_m, target_course_rad,
          config: ColregConfig = ColregConfig()) -> np.ndarray:
    """The own vessel's role code (t,) towards each target (positions (t, 2), courses (t,) [rad]),
    as :func:`mjasc.evaluation.colreg.role_from_geometry` of the relative bearing β (clockwise from
    the own bow) and relative course c (clockwise), checked in its order: overtaking (|β_t| > abaft),
    overtaken (|β| > abaft), head-on (|β| ≤ 15°, courses reciprocal within 15°), else crossing —
    give way with B to starboard (β ≥ 0), stand on to port."""
    d = np.asarray(target_position_m, dtype=float).reshape(-1, 2) - np.asarray(own_position_m, dtype=float)[:2]
    beta = _wrap_deg(np.degrees(own_heading_rad - np.arctan2(d[:, 1], d[:, 0])))
    c = _wrap_deg(-np.degrees(np.asarray(target_course_rad, dtype=float) - own_heading_rad))
    beta_t = _wrap_deg(beta + 180.0 - c)
    abaft = config.abaft_beam_deg
    head_on = (np.abs(beta) <= config.head_on_bearing_deg) & (np.abs(180.0 - np.abs(c)) <= config.head_on_course_deg)
    return np.select([np.abs(beta_t) > abaft, np.abs(beta) > abaft, head_on, beta >= 0.0],
                     [OVERTAKING, OVERTAKEN, HEAD_ON, GIVE_WAY], STAND_ON)


def side_of_passing(relative_position_m, w) -> np.ndarray:
    """s = (r × w)_z (c, t) for relative positions r (t, 2) and relative velocities w (c, t, 2):
    > 0 when A's relative motion passes with B on A's starboard side (module docstring)."""
    r = np.asarray(relative_position_m, dtype=float)[None, :, :]
    return r[..., 0] * w[..., 1] - r[..., 1] * w[..., 0]


def forbidden_side(relative_position_m, w, role_codes, departed=None) -> np.ndarray:
    """(c, t) bool: the candidate's relative velocity closes on a head-on or give-way target (r·w > 0)
    on the forbidden side ((r × w)_z > 0: passing it starboard to starboard, crossing ahead of it);
    for a target the vessel departed from the rule for (``departed`` (t,) bool, module docstring)
    the other side, (r × w)_z < 0: the side committed to is kept."""
    r = np.asarray(relative_position_m, dtype=float)[None, :, :]
    closing = np.sum(r * w, axis=-1) > 0.0
    bound = np.isin(np.asarray(role_codes), (HEAD_ON, GIVE_WAY))[None, :]
    s = side_of_passing(relative_position_m, w)
    if departed is None:
        return bound & closing & (s > 0.0)
    departed = np.asarray(departed, dtype=bool)[None, :]
    return bound & closing & np.where(departed, s < 0.0, s > 0.0)


def port_turn(candidate_courses_rad, own_heading_rad: float, tolerance_rad: float) -> np.ndarray:
    """(c,) bool: the candidate course lies counter-clockwise (to port) of the own heading by more
    than ``tolerance_rad`` (rule 17 (c) for a stand-on vessel that must act)."""
    d = np.mod(np.asarray(candidate_courses_rad, dtype=float) - own_heading_rad + np.pi, 2 * np.pi) - np.pi
    return d > tolerance_rad


def departure_reachable(relative_position_m, target_velocity_m_s, radius_m, turn_s, velocities_m_s,
                        horizon_s: float) -> np.ndarray:
    """(c, t) bool: each departure velocity (c, 2), taken only after the hull has come round onto it
    — holding its position for its ``turn_s`` (c,) (no progress either way), then sailing it — keeps
    clear of each target (relative position r (t, 2), velocity (t, 2), combined radius R (t,))
    during the turn and the horizon after it (module docstring, "Departure, committed")."""
    r = np.asarray(relative_position_m, dtype=float).reshape(-1, 2)
    v_b = np.asarray(target_velocity_m_s, dtype=float).reshape(-1, 2)
    turn = np.asarray(turn_s, dtype=float).reshape(-1)
    hit_turning = time_to_collision(r, -v_b[None], radius_m)[0][None, :] <= turn[:, None]
    r_after = r[None, :, :] + turn[:, None, None] * v_b[None, :, :]  # (c, t, 2): the target when the turn ends
    w_after = np.asarray(velocities_m_s, dtype=float).reshape(-1, 2)[:, None, :] - v_b[None, :, :]
    hit_after = time_to_collision(r_after, w_after, radius_m)[0] <= float(horizon_s)
    return ~(hit_turning | hit_after)


class RoleMemory:
    """Roles kept per track id (module docstring): ``update(t, ids, fresh, engaged)`` returns the
    roles to use (t,) — a track's remembered role while it is remembered, else its fresh role; a
    track engaged now is (re)remembered with that role until ``hold_s`` after it was last engaged
    (``keep`` engages remembered tracks again without a fresh role)."""

    def __init__(self, hold_s: float):
        self.hold_s = float(hold_s)
        self._roles: dict[int, tuple[int, float]] = {}  # track id → (role, last engaged [s])

    def update(self, t_s: float, track_ids, fresh_roles, engaged) -> np.ndarray:
        self._roles = {k: v for k, v in self._roles.items() if t_s - v[1] <= self.hold_s}
        ids = [int(i) for i in np.asarray(track_ids).tolist()]
        out = np.asarray(fresh_roles, dtype=int).copy()
        for k, (i, e) in enumerate(zip(ids, np.asarray(engaged, dtype=bool).tolist())):
            if i in self._roles:
                out[k] = self._roles[i][0]
            if e:
                self._roles[i] = (int(out[k]), float(t_s))
        return out

    def keep(self, t_s: float, track_ids) -> None:
        """Count the remembered tracks among ``track_ids`` as engaged at ``t_s`` (their role is kept
        another ``hold_s``); ids not remembered are ignored."""
        for i in np.asarray(track_ids).tolist():
            if int(i) in self._roles:
                self._roles[int(i)] = (self._roles[int(i)][0], float(t_s))

    def role(self, track_id: int) -> int | None:
        """The remembered role of a track, or None."""
        v = self._roles.get(int(track_id))
        return None if v is None else v[0]


class Departures:
    """The tracks the vessel departed from the rule for (module docstring, "Departure, committed"):
    ``depart(ids)`` records them; ``of(ids, remembered)`` (t,) bool tells which of ``ids`` are
    departed, forgetting those whose role is no longer remembered (the target past and clear)."""

    def __init__(self):
        self._ids: set[int] = set()

    def depart(self, track_ids) -> list[int]:
        """Record ``track_ids``; returns those not departed before."""
        new = [int(i) for i in np.asarray(track_ids).tolist() if int(i) not in self._ids]
        self._ids.update(new)
        return new

    def of(self, track_ids, remembered) -> np.ndarray:
        ids = [int(i) for i in np.asarray(track_ids).tolist()]
        keep = {i for i, m in zip(ids, np.asarray(remembered, dtype=bool).tolist()) if m}
        self._ids = {i for i in self._ids if i in keep or i not in ids}
        return np.array([i in self._ids for i in ids], dtype=bool)
