"""Go-to-formation: from arbitrary deployment poses, every vessel at its formation pose at one time.

The formation pose of a vessel is the start of its formation path (its ``controller`` path): that
point, on the path's course, at its cruise speed. The plan (docs/missions.md):

1. **A feasible transit per hull.** Each vessel plans the shortest path its turn radius allows
   from its pose to its formation pose: a Dubins curve (:mod:`mjasc.missions.dubins`) to a point
   ``lead_in_m`` short of it, then straight on the formation course — length L_i.
2. **One arrival time, set by the slowest.** Each vessel's earliest arrival is
   t₀ + L_i / v_i (v_i its cruise speed); it broadcasts it, and once it has heard every team mate
   (or after ``agree_s``) takes the latest, T = max_j (t₀ + L_j / v_j). It then re-plans its transit
   to arrive at T at its cruise speed: a vessel that would be early lengthens its straight lead-in
   (the length found with scipy's ``brentq``). A lead-in moved back along the formation course
   adds no length until its entry passes behind the vessel, and then a whole turn at once: an
   extra length inside that jump is made by a **bump** — the transit's Dubins part through a
   waypoint pushed sideways from its midpoint (two Dubins curves; at no push, the shortest transit
   itself), pushed until the length is met. So the whole team reaches its formation poses at
   cruise speed; when neither gives the length it sails slower, L_i / (T − t) (not below
   ``min_speed_fraction`` of its cruise). A later arrival heard afterwards slows it down.
3. **Arriving together over the lossy link.** Along the transits the team runs the same γ/L
   consensus as in cooperative path following: equal normalized progress γ_i / L_i means equal
   time to go, so the consensus absorbs speed lag, currents and lost messages; with all transit
   speeds L_i / (T − t₀) its feed-forward is the common rate 1 / (T − t₀).

The phase ends for a vessel when its progress reaches ``arrival_band_m`` before the transit's end;
it records when (extrapolated to the pose), and its position, heading and speed errors there.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq

from mjasc.core.frames import wrap_angle
from mjasc.guidance.paths import LineSegment, Path
from mjasc.missions.config import GoToFormationOptions
from mjasc.missions.dubins import dubins_length, dubins_path
from mjasc.missions.legs import MissionBroadcast, MissionLeg, PhaseInputs

__all__ = ["plan_transit", "transit_length", "bumped_transit", "lead_in_for", "GoToFormation"]


def _lead_in(position_m, formation_path: Path, lead_in_m: float) -> tuple:
    """(the vessel's position (2,), the formation pose's point (2,) and course [rad], the lead-in's
    entry (2,), ``lead_in_m`` before the pose on its course) [m]."""
    goal = np.asarray(formation_path.point(0.0), dtype=float)
    course = float(formation_path.tangent_angle(0.0))
    entry = goal - lead_in_m * np.array([math.cos(course), math.sin(course)])
    return np.asarray(position_m, dtype=float)[:2], goal, course, entry


def plan_transit(position_m, heading_rad: float, formation_path: Path, turn_radius_m: float,
                 lead_in_m: float) -> Path:
    """The transit from a pose to the start of ``formation_path``: a Dubins curve to ``lead_in_m``
    before it, then straight along its start course (a straight line alone when the vessel is
    exactly at that entry on the course; a vessel already past the entry, on the lead-in, would get
    a Dubins loop back to it: the phase plans it with :func:`lead_in_for`'s shorter lead-in)."""
    p, goal, course, entry = _lead_in(position_m, formation_path, lead_in_m)
    try:
        head = dubins_path(p, heading_rad, entry, course, turn_radius_m)
    except ValueError:  # already at the entry on the formation course
        return Path.line(p, goal)
    if lead_in_m <= 0.0:
        return head
    return Path.from_segments([*head.segments, LineSegment(head.end_point, goal)])


def transit_length(position_m, heading_rad: float, formation_path: Path, turn_radius_m: float,
                   lead_in_m: float) -> float:
    """The length [m] of :func:`plan_transit`'s path, from the Dubins lengths alone (nothing built:
    the lead-in search evaluates it ~150 times)."""
    p, goal, course, entry = _lead_in(position_m, formation_path, lead_in_m)
    head = dubins_length(p, heading_rad, entry, course, turn_radius_m)
    if not math.isfinite(head):  # (at the entry on the formation course: the straight line alone)
        return float(math.hypot(*(goal - p)))
    return head + max(lead_in_m, 0.0)


def lead_in_for(position_m, heading_rad: float, formation_path: Path, turn_radius_m: float,
                lead_in_m: float) -> float:
    """The lead-in [m] a transit from this pose uses: ``lead_in_m``, unless the vessel is already on
    its lead-in — past the entry, short of the formation pose, within 2R of the course line and
    heading within 90° of it — where a Dubins curve to the entry behind it would loop back (a whole
    turn, > 2πR, for a few metres of straight). There it is the longest lead-in whose transit is
    still the shortest (within :data:`LENGTH_TOL_M`): the vessel sails on, with an S-bend onto the
    line if it is off it."""
    p, goal, course, _ = _lead_in(position_m, formation_path, lead_in_m)
    u = np.array([math.cos(course), math.sin(course)])
    d = float(np.dot(goal - p, u))  # along the course to the pose
    lateral = float(u[0] * (p[1] - goal[1]) - u[1] * (p[0] - goal[0]))
    if not (0.0 < d < lead_in_m and abs(lateral) <= 2.0 * turn_radius_m
            and abs(wrap_angle(float(heading_rad) - course)) < 0.5 * math.pi):
        return lead_in_m
    leads = np.linspace(0.0, lead_in_m, 61)
    lengths = np.array([transit_length(p, heading_rad, formation_path, turn_radius_m, x) for x in leads])
    shortest = float(np.min(lengths))
    if lengths[-1] <= shortest + LENGTH_TOL_M:  # (no loop: the entry is still reachable)
        return lead_in_m
    return float(leads[np.flatnonzero(lengths <= shortest + LENGTH_TOL_M)[-1]])


def _bump_geometry(position_m, heading_rad: float, formation_path: Path, turn_radius_m: float,
                   lead_in_m: float) -> tuple:
    """:func:`_lead_in`'s (start, goal, course, entry) and the plain transit's Dubins part, for a
    bump (ValueError: the vessel is at the entry)."""
    p, goal, course, entry = _lead_in(position_m, formation_path, lead_in_m)
    return p, goal, course, entry, dubins_path(p, heading_rad, entry, course, turn_radius_m)


def _waypoint(head: Path, push_m: float) -> tuple[np.ndarray, float]:
    """The bump's waypoint: ``push_m`` left of ``head``'s midpoint, and ``head``'s course there."""
    half = 0.5 * head.length
    c = float(head.tangent_angle(half))
    return np.asarray(head.point(half), dtype=float) + push_m * np.array([-math.sin(c), math.cos(c)]), c


def bumped_transit(position_m, heading_rad: float, formation_path: Path, turn_radius_m: float, lead_in_m: float,
                   push_m: float) -> Path:
    """:func:`plan_transit` made longer by a bump: its Dubins part runs through a waypoint ``push_m``
    to the left (negative: right) of its midpoint, on the course it has there — two shortest
    Dubins curves, then the straight lead-in. With ``push_m`` 0 it is the plain transit (a shortest
    Dubins curve's two halves are the shortest curves between their poses); its length grows
    continuously with the push while the two curves keep their words."""
    p, goal, course, entry, head = _bump_geometry(position_m, heading_rad, formation_path, turn_radius_m, lead_in_m)
    w, c = _waypoint(head, push_m)
    pieces = [*dubins_path(p, heading_rad, w, c, turn_radius_m).segments,
              *dubins_path(w, c, entry, course, turn_radius_m).segments]
    if lead_in_m > 0.0:
        pieces.append(LineSegment(entry, goal))
    return Path.from_segments(pieces)


#: A transit up to this much [m] longer than the need counts as meeting it; a longer one would
#: arrive late at cruise speed (and the consensus would hold the whole team back).
LENGTH_TOL_M = 1.0


def _shortfall_key(length_m: float, need_m: float) -> tuple[bool, float]:
    """Order of preference of a transit length for ``need_m``: not longer than the need (beyond
    :data:`LENGTH_TOL_M`: it would arrive late), then the closest. A shorter transit is sailed
    slower and still arrives at the agreed time."""
    return length_m > need_m + LENGTH_TOL_M, abs(length_m - need_m)


def _solve_length(length_of, upper: float, need_m: float) -> tuple[float, float]:
    """The argument x in [0, ``upper``] whose ``length_of(x)`` [m] comes closest to ``need_m``
    without exceeding it (:func:`_shortfall_key`), and that length: a grid finds the closest point,
    ``brentq`` refines a neighbouring sign change. The length jumps where a Dubins word changes:
    there ``brentq`` ends on the jump, not on the need, and its point is taken only if it comes
    closer than the grid's (a bump's length can also rise steeply, like √push, where it starts to
    grow: a slope bound would take that for a jump)."""
    f = lambda x: length_of(x) - need_m  # noqa: E731
    xs = np.linspace(0.0, upper, 121)
    fs = np.array([f(x) for x in xs])
    j = min(range(len(xs)), key=lambda i: _shortfall_key(fs[i] + need_m, need_m))
    x, fx = float(xs[j]), float(fs[j])
    for a, b in ((j - 1, j), (j, j + 1)):
        if 0 <= a and b < len(xs) and fs[a] * fs[b] < 0.0:
            r = float(brentq(f, xs[a], xs[b], xtol=0.05))
            fr = f(r)
            if _shortfall_key(fr + need_m, need_m) < _shortfall_key(fx + need_m, need_m):
                x, fx = r, fr
    return x, fx + need_m


#: Of two bump sides that both give the length, the one clearer of the team mates' plans wins,
#: counted up to this much [m]: both sides at least this clear of every mate are equal, and the
#: smaller push wins.
BUMP_CLEAR_M = 20.0


def _separation(path: Path, t_s: float, speed_m_s: float, mate_plans: dict) -> float:
    """The smallest distance [m] between ``path`` sailed at ``speed_m_s`` from ``t_s`` and each
    team mate's plan (times (k,) [s], points (k, 2) [m]) at equal times, over the times both cover;
    ``inf`` with no plan."""
    out = math.inf
    for times, points in mate_plans.values():
        times = np.asarray(times, dtype=float)
        t = times[(times >= t_s) & (times <= t_s + path.length / speed_m_s)]
        if t.size == 0:
            continue
        own = path.point((t - t_s) * speed_m_s)
        pts = np.asarray(points, dtype=float)
        mate = np.column_stack([np.interp(t, times, pts[:, 0]), np.interp(t, times, pts[:, 1])])
        out = min(out, float(np.min(np.hypot(*(own - mate).T))))
    return out


class GoToFormation:
    """The go-to-formation phase of one vessel (see the module docstring)."""

    name = "go_to_formation"

    def __init__(self, index: int, options: GoToFormationOptions, formation_path: Path, cruise_speed_m_s: float,
                 team_size: int = 1):
        self.index = index
        self.options = options
        self.formation_path = formation_path
        self.cruise_m_s = float(cruise_speed_m_s)
        self.mates = max(int(team_size) - 1, 0)
        self.path: Path | None = None
        self.t0_s = 0.0
        self.own_arrival_s = math.inf
        self.team_arrival_s = math.inf
        self.agreed = False
        self.lead_in_m = options.lead_in_m
        self.bump_m = 0.0  # the transit's sideways push [m] (left positive; 0: none)
        self.speed_m_s = self.cruise_m_s
        self.arrival: dict = {}  # the arrival's figures, once arrived
        self.events: list[tuple[float, str]] = []

    def _plan(self, nav, lead_in_m: float) -> Path:
        o = self.options
        return plan_transit(nav.position_m, nav.heading_rad, self.formation_path, o.turn_radius_m, lead_in_m)

    def _base_lead_in(self, nav) -> float:
        o = self.options
        return lead_in_for(nav.position_m, nav.heading_rad, self.formation_path, o.turn_radius_m, o.lead_in_m)

    def begin(self, t_s: float, nav) -> MissionLeg:
        self.lead_in_m = self._base_lead_in(nav)
        self.path = self._plan(nav, self.lead_in_m)
        self.t0_s = float(t_s)
        self.own_arrival_s = self.team_arrival_s = self.t0_s + self.path.length / self.cruise_m_s
        self.speed_m_s = self.cruise_m_s
        return MissionLeg(self.name, self.index, self.path, 0.0, self.speed_m_s, True)

    def broadcast(self) -> MissionBroadcast:
        """The arrival time this vessel states: its own earliest, or the team's once agreed."""
        return MissionBroadcast(self.index, arrival_time_s=self.team_arrival_s)

    def result(self) -> dict:
        """The arrival's figures; before the arrival (a run that ends in transit) the plan so far:
        when the team is due and the transit being sailed, so a short run says why it fell short."""
        if self.arrival or self.path is None:
            return {**self.arrival, "completed": bool(self.arrival)}
        due = round(self.team_arrival_s, 3) if math.isfinite(self.team_arrival_s) else None
        return {"planned_arrival_s": due, "transit_length_m": round(self.path.length, 3),
                "lead_in_m": round(self.lead_in_m, 3), "bump_m": round(self.bump_m, 3),
                "transit_speed_m_s": round(self.speed_m_s, 4), "completed": False}

    def _agree(self, t_s: float, nav, mate_plans=None) -> MissionLeg:
        """Fix the team's arrival time and re-plan the transit to arrive then at cruise speed: the
        lead-in lengthened (brentq on the path length) when the vessel would be early, else a bump
        pushed out of the transit's middle (to the side that gives the length and keeps clearer of
        the team mates' plans, ``mate_plans`` as :class:`~mjasc.missions.legs.PhaseInputs` has
        them), else slower; never a transit longer than the need (it would arrive late)."""
        self.agreed = True
        need_m = self.cruise_m_s * (self.team_arrival_s - t_s)
        o = self.options
        lead0 = self._base_lead_in(nav)
        base = self._plan(nav, lead0)
        path, lead, push = base, lead0, 0.0
        if math.isfinite(need_m) and base.length < need_m - LENGTH_TOL_M:
            # Path length against the lead-in's extension x: continuous but for jumps where the
            # shortest Dubins word changes
            x, length = _solve_length(lambda x: transit_length(nav.position_m, nav.heading_rad, self.formation_path,
                                                               o.turn_radius_m, lead0 + x), need_m, need_m)
            # (never a longer transit than the need: it would arrive late; a shorter one is sailed slower)
            if _shortfall_key(length, need_m) < _shortfall_key(base.length, need_m):
                lead = lead0 + x
                path = self._plan(nav, lead)
            if abs(path.length - need_m) > LENGTH_TOL_M:  # inside a jump: a bump
                # only a bump that gives the length: one that cannot is a detour sailed slower all the same
                got = self._bump(t_s, nav, need_m, mate_plans or {}, lead0)
                if got is not None and abs(got[0].length - need_m) <= LENGTH_TOL_M:
                    (path, push), lead = got, lead0
        self.path, self.lead_in_m, self.bump_m = path, lead, push
        self.speed_m_s = self._speed(t_s, path.length)
        return MissionLeg(self.name, self.index, path, 0.0, self.speed_m_s, True)

    def _bump(self, t_s: float, nav, need_m: float, mate_plans: dict, lead: float) -> tuple[Path, float] | None:
        """The transit with a bump (:func:`bumped_transit`) whose length comes closest to ``need_m``
        [m] without exceeding it, and its push [m] (left positive), with the lead-in ``lead`` [m];
        None when the vessel is at its entry already. Of the two sides, one whose bump gives the length (within
        :data:`LENGTH_TOL_M`), then the one whose transit, sailed at cruise speed from ``t_s``,
        passes the team mates' broadcast plans at the larger separation at equal times (counted up
        to :data:`BUMP_CLEAR_M`), then the one nearer the length, then the smaller push, then the
        left. The search reads the lengths only (:func:`~mjasc.missions.dubins.dubins_length`)."""
        r = self.options.turn_radius_m
        try:
            p, _, course, entry, head = _bump_geometry(nav.position_m, nav.heading_rad, self.formation_path, r, lead)
        except ValueError:
            return None
        hdg = float(nav.heading_rad)

        def length_of(push):
            w, c = _waypoint(head, push)
            return dubins_length(p, hdg, w, c, r) + dubins_length(w, c, entry, course, r) + lead

        best = None
        for side in (1.0, -1.0):
            h, length = _solve_length(lambda h, side=side: length_of(side * h), 0.5 * need_m, need_m)
            path = bumped_transit(nav.position_m, nav.heading_rad, self.formation_path, r, lead, side * h)
            clear = min(_separation(path, t_s, self.cruise_m_s, mate_plans), BUMP_CLEAR_M)
            # a side that gives the length first (the other's "bump" is a detour sailed slower or
            # late), then the clearer, then the one nearer the length, then the smaller push
            over, miss = _shortfall_key(length, need_m)
            short = over or miss > LENGTH_TOL_M
            key = (short, -clear, miss if short else 0.0, h)
            if best is None or key < best[0]:
                best = (key, path, side * h)
        return best[1], best[2]

    def _speed(self, t_s: float, remaining_m: float) -> float:
        v = remaining_m / max(self.team_arrival_s - t_s, 1e-6)
        return min(max(v, self.options.min_speed_fraction * self.cruise_m_s), self.cruise_m_s)

    def step(self, x: PhaseInputs) -> tuple[MissionLeg | None, bool]:
        """(a new leg — the agreed transit, or a new speed when a later arrival is heard —, whether
        the vessel has arrived)."""
        t_s, nav, gamma_m = x.t_s, x.nav, x.gamma_m
        # (a mate's non-finite arrival time is no time: T = inf would leave no length to search for)
        heard = [b.arrival_time_s for b in x.mates.values()
                 if b.phase_index == self.index and b.arrival_time_s and math.isfinite(b.arrival_time_s)]
        latest = max([self.team_arrival_s, *heard])
        leg = None
        if not self.agreed:
            self.team_arrival_s = latest
            if len(heard) >= self.mates or t_s - self.t0_s >= self.options.agree_s:
                leg = self._agree(t_s, nav, x.mate_plans)
                gamma_m = 0.0
        elif latest > self.team_arrival_s + 0.5:  # a mate that planned later, heard late: slow down
            self.team_arrival_s = latest
            speed = self._speed(t_s, self.path.length - gamma_m)
            if abs(speed - self.speed_m_s) > 1e-6:
                self.speed_m_s = speed
                leg = MissionLeg(self.name, self.index, self.path, float(gamma_m), speed, True, new_path=False)
        arrived = gamma_m >= self.path.length - self.options.arrival_band_m
        if arrived and not self.arrival:  # recorded once: the pose as the vessel reached it
            self._record(t_s, nav, gamma_m)
        return leg, arrived

    def _record(self, t_s: float, nav, gamma_m: float) -> None:
        g = float(self.path.project(nav.position_m, gamma_m, search_window_m=20.0))
        vel = np.asarray(nav.velocity_m_s[:2], dtype=float)
        sog = float(math.hypot(*vel))
        remaining = max(self.path.length - g, 0.0)
        course = float(self.path.tangent_angle(self.path.length))
        cog = float(math.atan2(vel[1], vel[0])) if sog > 0.05 else float(nav.heading_rad)
        self.arrival = {
            "arrival_time_s": round(float(t_s) + (remaining / sog if sog > 0.05 else 0.0), 3),
            "planned_arrival_s": round(self.team_arrival_s, 3),
            "transit_length_m": round(self.path.length, 3),
            "lead_in_m": round(self.lead_in_m, 3),
            "bump_m": round(self.bump_m, 3),
            "transit_speed_m_s": round(self.speed_m_s, 4),
            "position_error_m": round(float(math.hypot(*(np.asarray(nav.position_m[:2]) - self.path.point(g)))), 3),
            "course_error_deg": round(math.degrees(float(wrap_angle(cog - course))), 3),
            "heading_error_deg": round(math.degrees(float(wrap_angle(nav.heading_rad - course))), 3),
            "speed_m_s": round(sog, 4),
            "speed_error_m_s": round(sog - self.cruise_m_s, 4),
        }
