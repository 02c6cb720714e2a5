"""Coordination controller for cooperative path following: γ consensus over a lossy, delayed link.

Each vessel i follows its own mission path of length L_i (docs/thesis.md §1, "cooperative path following":
paths parameterized so that equal path parameters mean "in formation"); thesis §6.4 runs three
ASCs in line formation on an L-shaped path exchanging path parameters over comms (docs/thesis.md §6).
The coordination state is the *normalized* path parameter

    ξ_i = (γ_i − o_i) / L_i          γ_i progress along the mission path [m], o_i formation offset [m]

so that parallel paths of different lengths (e.g. L-paths whose rounded corners have different
radii) coincide when the team is in formation: ξ_i = ξ_j for all i, j.

Speed law (the classical cooperative path-following law of Ghabcheloo, Aguiar, Pascoal,
Silvestre, Kaminer & Hespanha, "Coordinated path-following in the presence of communication
losses and time delays", SIAM J. Control Optim. 48(1), 2009; and Ghabcheloo et al., "Nonlinear
coordination control for a group of mobile robots with fixed path following", Int. J. Control
79(12), 2006), written in metres of path::

    e_i   = L̄ Σ_{j ∈ N_i(t)} (ξ_i − ξ̂_j(t))                 coordination error [m]
    f_i   = (ω_d L_i / v_i) · (1 − k tanh(e_i / e_s))        factor on the mission speed v_i
    v_cmd = f_i v_i,  capped at the vessel's top speed

with N_i(t) the neighbours heard within ``neighbour_timeout_s``, ξ̂_j(t) = ξ_j(t_j) + ξ̇_j (t − t_j)
the latest received value extrapolated with the neighbour's broadcast path rate (delay
compensation; ``extrapolate = false`` uses the held value as in the paper), L̄ the mean path
length and ω_d = v̄ / L̄ the formation's nominal rate [1/s] (v̄ the mean mission speed), both
over the vessel and the neighbours it has heard. The feed-forward ω_d L_i / v_i makes every
vessel progress at the same normalized rate when in formation; the saturated consensus term
(k < 1 keeps the speed positive) closes the gaps. Linearized, with all-to-all links and equal
speeds, the pairwise differences ξ_i − ξ_j decay as exp(−λ t) with

    λ = n · k · v̄ / e_s       (n team members: the Laplacian of the complete graph has eigenvalue n)

and with delays τ the loop stays stable while λ τ < π/2 (consensus with delayed relative
information; the extrapolation above removes most of the delay).

``role = "leader"``: the vessel keeps its feed-forward speed (no consensus term) and the others
converge to it (leader–follower coordination).

**Intentions.** Each message also carries the sender's plan: where it intends to be over the next
``intent_horizon_s`` seconds, sampled every ``intent_step_s`` along the path it is *actually*
following (a detour included) at its planned speed (a velocity correction included) — from its
avoidance's ``planned_trajectory`` when the vessel has collision avoidance (the vessel hands it to
:meth:`Coordination.exchange`), else along its guidance's current path at the mission speed × the
coordination factor — plus its radius. Messages are typed
(:class:`~mjasc.cooperation.messages.TeamMessage`); :meth:`Coordination.team_picture` hands the
newest one of each team mate, as a :class:`~mjasc.cooperation.messages.TeamIntention`, to the rest
of the vessel. The controller holds no reference to the vessel or its other components: what it
needs of them (its own navigation, γ, the guidance state, the plan) is handed in each call.
"""

from __future__ import annotations

import numpy as np

from mjasc.cooperation import fleet_speed_law
from mjasc.cooperation.comms import CommsNetwork
from mjasc.cooperation.coordination_config import CoordinationConfig, _validate, parse_coordination_options
from mjasc.cooperation.formation_history import FormationHistory
from mjasc.cooperation.link import LinkEndpoint
from mjasc.cooperation.messages import TeamIntention, TeamMessage
from mjasc.cooperation.recording import CoordinationLog
from mjasc.cooperation.team_knowledge import TeamKnowledge
from mjasc.cooperation.team_view import _error_floats, _law_terms, _Neighbour, _sum, _TeamView  # noqa: F401
from mjasc.core.compiled import clip_float
from mjasc.guidance.path_following import PathFollowingConfig
from mjasc.plugins.stages import CoordinationMethod

__all__ = ["CoordinationConfig", "Coordination", "TeamIntention", "parse_coordination_options"]

#: The formation is sampled until the own path's end within this [m] (the follower's default finish tolerance).
_PATH_END_M = PathFollowingConfig().finish_tolerance_m


class Coordination(TeamKnowledge, CoordinationMethod):
    """The thesis's cooperative path following: consensus on the path parameter over the link.

    One vessel's coordination controller (the ``coordination`` component of ``VesselAgent``),
    registered as the coordination method ``"thesis"`` (options: :class:`CoordinationConfig`).

    name: the vessel's name on the link; network: its end of the team's link
    (:class:`~mjasc.cooperation.link.LinkEndpoint`; a :class:`CommsNetwork` is wrapped in one); mission_path: the vessel's mission path (its length is L_i; None
    for a vessel without one: it broadcasts its pose only); mission_speed_m_s: its mission's
    cruise speed v_i; radius_m: its bounding radius, broadcast to the team (None: not sent);
    top_speed_m_s: the cap on the corrected speed.
    """

    method = "thesis"
    takes_right_of_way = True
    Options = CoordinationConfig
    check_options = staticmethod(_validate)

    @classmethod
    def from_context(cls, context, options) -> "Coordination":
        """The method for one vessel from its :class:`~mjasc.plugins.context.StageContext`."""
        v = context.vessel
        return cls(context.vessel_name, context.link, options, context.rng, mission_path=context.mission_path,
                   mission_speed_m_s=context.mission_speed_m_s, radius_m=v.radius_m, top_speed_m_s=v.top_speed_m_s)

    def __init__(self, name: str, network: CommsNetwork | LinkEndpoint, config: CoordinationConfig | None = None,
                 rng: np.random.Generator | None = None, *, mission_path=None, mission_speed_m_s: float = 1.0,
                 radius_m: float | None = None, top_speed_m_s: float = np.inf):
        self.name = name
        self.link = network if isinstance(network, LinkEndpoint) else LinkEndpoint(network, name)
        self.config = config if config is not None else CoordinationConfig()
        self.rng = rng  # unused: the law is deterministic; kept for the component interface
        self.path = mission_path  # the mission path (a detour never changes L_i)
        self.path_length_m = float(mission_path.length) if mission_path is not None else None
        self.mission_speed_m_s = float(mission_speed_m_s)
        self.phase = 0  # the mission phase (set_mission); mates coordinate within a phase only
        self.radius_m = None if radius_m is None else float(radius_m)
        self.top_speed_m_s = float(top_speed_m_s)
        self.neighbours: dict[str, _Neighbour] = {}
        self._team: _TeamView | None = None  # the neighbours as the law uses them (rebuilt on change)
        self._intent_cache: dict[str, TeamIntention] = {}
        self._intentions: dict[str, TeamIntention] | None = None  # team_picture's mapping, until a message arrives
        self._events: list[tuple[float, str]] = []
        self.received = 0
        self.last_error_m = 0.0
        self.last_factor = 1.0
        self.last_xi = np.nan
        self.last_spread_m = 0.0
        self._history = FormationHistory()  # (t, lead, spread) at exchanges with ≥ 1 neighbour
        self._log = CoordinationLog()
        self._tracks_sent = 0

    # ------------------------------------------------------------------ state
    def set_mission(self, t_s: float, leg) -> None:
        """A new mission leg (:class:`~mjasc.missions.legs.MissionLeg`): its path is the one whose
        length is L_i and its speed v_i; an uncoordinated leg (target tracking) takes no part in the
        consensus (factor 1, no ξ broadcast). Mates in another phase are not coordinated with."""
        if leg.coordinated:
            self.path, self.path_length_m = leg.path, float(leg.path.length)
        else:
            self.path = self.path_length_m = None
        self.mission_speed_m_s = float(leg.speed_m_s)
        self.phase = int(leg.index)
        self._team = None

    def xi(self, gamma_m: float) -> float:
        """Own normalized coordination state ξ_i = (γ_i − o_i) / L_i."""
        if self.path_length_m is None:
            return np.nan
        return (float(gamma_m) - self.config.formation_offset_m) / self.path_length_m

    def plan_request(self) -> tuple[float, float] | None:
        """(horizon [s], step [s]) of the plan this vessel broadcasts, or None (pose only)."""
        h = self.config.intent_horizon_s
        return (h, self.config.intent_step_s) if h > 0 else None

    def _message(self, t_s: float, nav, gamma_m: float, guidance=None, plan=None, tracks=(), mission=None,
                 gives_way_to=(), stands_on_to=()) -> TeamMessage:
        # TeamMessage(name, position, heading, velocity, speed, radius, ...) without the frozen
        # __init__'s sixteen setattr calls: every field in order, the defaults where there is no value
        plan = plan if plan is not None else self._own_plan(t_s, guidance)
        plan_t, plan_xy = plan if plan is not None else (np.zeros(0), np.zeros((0, 2)))
        length = self.path_length_m
        if length is not None:
            g = clip_float(float(gamma_m), 0.0, length)
            chi = float(self.path.tangent_angle(g))
            along = float(np.dot(nav.velocity_m_s[:2], (np.cos(chi), np.sin(chi))))
            offset = self.config.formation_offset_m
            gamma, xi, rate = float(gamma_m), (float(gamma_m) - offset) / length, along / length  # (xi(γ))
        else:
            gamma = xi = rate = offset = None
        msg = object.__new__(TeamMessage)
        msg.__dict__.update(sender=self.name, position_m=np.array(nav.position_m[:2], dtype=float),
                            heading_rad=float(nav.heading_rad),
                            velocity_m_s=np.array(nav.velocity_m_s[:2], dtype=float),
                            mission_speed_m_s=self.mission_speed_m_s, radius_m=self.radius_m, plan_times_s=plan_t,
                            plan_points_m=plan_xy, gamma_m=gamma, path_length_m=length, xi=xi, xi_rate_1_s=rate,
                            offset_m=offset, tracks=tuple(tracks) if tracks else (),
                            phase=self.phase if mission is not None else 0, mission=mission,
                            gives_way_to=tuple(gives_way_to) if gives_way_to else (),
                            stands_on_to=tuple(stands_on_to) if stands_on_to else ())
        return msg

    def _own_plan(self, t_s: float, guidance):
        """(times (k,), points (k, 2)) along the guidance's current path at the mission speed × the
        latest coordination factor, or None (no plan asked for, or no guidance). Used when the
        vessel has no collision avoidance to hand in its planned trajectory."""
        req = self.plan_request()
        if req is None or guidance is None:
            return None
        h, dt = req
        path = guidance.path
        times = t_s + np.arange(0.0, h + 0.5 * dt, dt)
        v = self.mission_speed_m_s * (self.last_factor if np.isfinite(self.last_factor) else 1.0)
        g = np.clip(float(guidance.gamma_m) + v * (times - t_s), 0.0, path.length)
        return times, np.asarray(path.point(g), dtype=float).reshape(-1, 2)

    def _poll(self, t_s: float, nav, decide: bool = True) -> None:
        """Read arrived messages, keep each neighbour's newest, time out stale ones."""
        arrived = self.link.receive_raw(t_s, nav.position_m, decide)
        if arrived:
            self._take(t_s, arrived)
        self._time_out(t_s)

    def _take(self, t_s: float, arrived: list) -> None:
        """:meth:`_poll`'s first half: keep each sender's newest of the messages ``arrived``
        (the link's plain tuples, :meth:`~mjasc.cooperation.link.LinkEndpoint.receive_raw`)."""
        if arrived:
            self.received += len(arrived)
            neighbours = self.neighbours
            for sender, sent, received, payload in arrived:
                old = neighbours.get(sender)
                if old is not None:
                    if sent <= old.sent_time_s:
                        continue  # overtaken by a newer message (jitter)
                    if not old.active:
                        self._events.append((t_s, f"comms: regained {sender} after {sent - old.sent_time_s:.1f} s"))
                neighbours[sender] = _Neighbour(sent, received, payload, True)
                self._team = self._intentions = None

    def _time_out(self, t_s: float) -> None:
        """:meth:`_poll`'s second half: a neighbour not heard for ``neighbour_timeout_s`` is lost."""
        timeout = self.config.neighbour_timeout_s
        if t_s - self._oldest_active_s() > timeout:
            for name, nb in self.neighbours.items():
                if nb.active and t_s - nb.sent_time_s > timeout:
                    nb.active = False
                    self._team = None
                    self._events.append((t_s, f"comms: lost {name} (last message {t_s - nb.sent_time_s:.1f} s old)"))

    def active_neighbours(self) -> list[str]:
        return [n for n, nb in self.neighbours.items() if nb.active]

    def _team_view(self) -> "_TeamView":
        """What the law needs of the neighbours, rebuilt only when a message arrives or a neighbour
        times out (:class:`_TeamView`)."""
        if self._team is None:
            self._team = _TeamView(self, self.neighbours.values())
        return self._team

    def _oldest_active_s(self) -> float:
        """Send time of the oldest newest message among the active neighbours (+inf: none)."""
        return self._team_view().oldest_active_s

    def _estimates(self, t_s: float) -> tuple[np.ndarray, float, float]:
        """(ξ̂_j of the active neighbours with a path, L̄, ω_d)."""
        view = self._team_view()
        return np.array(view.xi_hat(t_s, self.config.extrapolate)), view.l_bar, view.omega

    def coordination_error(self, t_s: float, gamma_m: float) -> tuple[float, float, float, int]:
        """As this vessel sees the team (active neighbours' extrapolated ξ̂_j), in metres of path:
        (e_i = L̄ Σ_j (ξ_i − ξ̂_j) the law's error, lead = L̄ mean_j (ξ_i − ξ̂_j) how far it is ahead of
        its neighbours, spread = L̄ (max − min) of {ξ_i, ξ̂_j} the formation's extent, |N_i|)."""
        if self.path_length_m is None:
            return 0.0, 0.0, 0.0, 0
        view = self._team_view()
        if view.arrays is None:  # below 8 neighbours: the same numbers in plain floats
            xis = view.xi_hat(t_s, self.config.extrapolate)
            if not xis:
                return 0.0, 0.0, 0.0, 0
            got = _error_floats(xis, self.xi(gamma_m), view.l_bar)
            if got is not None:
                return (*got, len(xis))
        xis, l_bar, _ = self._estimates(t_s)
        if not len(xis):
            return 0.0, 0.0, 0.0, 0
        own = self.xi(gamma_m)
        d = l_bar * (own - xis)
        spread = l_bar * (max(own, xis.max()) - min(own, xis.min()))
        return float(d.sum()), float(d.mean()), float(spread), len(xis)

    # ------------------------------------------------------------------ component interface
    def exchange(self, t_s: float, nav, gamma_m: float, guidance=None, plan=None, tracks=(), mission=None,
                 gives_way_to=(), stands_on_to=()) -> None:
        """Comms slot: broadcast own ξ, path rate, pose and plan; read what has arrived.

        nav: own :class:`~mjasc.core.navigation.OwnNavigation`; gamma_m: progress along the mission
        path [m]; guidance: the :class:`~mjasc.guidance.state.GuidanceState` (for the plan when
        ``plan`` is None); plan: (times (k,), points (k, 2)) the vessel's planned trajectory over
        :meth:`plan_request` (from its collision avoidance), or None; tracks: the vessel's own
        confirmed tracks to share (:class:`~mjasc.core.estimates.SharedTrack`, with ``share_tracks``;
        sent as given, the caller caps them); mission: the vessel's
        :class:`~mjasc.missions.legs.MissionBroadcast` (a chained mission), sent with its phase;
        gives_way_to, stands_on_to: the team mates the vessel gives way to / stands on toward now
        (its avoidance's ``gives_way_to()`` and ``stands_on_to()``: how team mates settle who gives
        way, :mod:`~mjasc.avoidance.triage`)."""
        self.broadcast(t_s, nav, gamma_m, guidance, plan, tracks, mission, gives_way_to, stands_on_to)
        self.take_in(t_s, nav, gamma_m)

    def broadcast(self, t_s: float, nav, gamma_m: float, guidance=None, plan=None, tracks=(), mission=None,
                  gives_way_to=(), stands_on_to=()) -> int:
        """The first half of :meth:`exchange`: broadcast the message; returns its id on the link."""
        if tracks and self.config.share_tracks:
            self._tracks_sent += len(tracks)
        return self.link.send(t_s, self._message(t_s, nav, gamma_m, guidance, plan,
                                                 tracks if self.config.share_tracks else (), mission, gives_way_to,
                                                 stands_on_to),
                              nav.position_m)

    def take_in(self, t_s: float, nav, gamma_m: float, decided: bool = False) -> None:
        """The second half of :meth:`exchange`: read what has arrived, note the formation's state.
        ``decided``: the link was decided for this vessel already (:meth:`decide_link`)."""
        self._poll(t_s, nav, decide=not decided)
        _, lead, spread, n = self.coordination_error(t_s, gamma_m)
        self.last_xi, self.last_spread_m = self.xi(gamma_m), spread
        self.note_formation(t_s, gamma_m, lead, spread, n)

    def note_formation(self, t_s: float, gamma_m: float, lead_m: float, spread_m: float, n: int) -> None:
        """A sample of the formation's state for the summary, when a neighbour was heard and the
        vessel's own path has not ended (within the path follower's default finish tolerance of its
        end): at its end a vessel stops, its ξ_i stays at 1 − o_i/L_i, and the spread it saw then grew
        or shrank with the others' progress — an echelon in formation from 29 s reported none
        (``in_formation_from_s`` None, ``final_spread_m`` 15 m) over a run that outlasted its paths."""
        if n and (self.path_length_m is None or gamma_m < self.path_length_m - _PATH_END_M):
            self._history.add(t_s, lead_m, spread_m)

    @staticmethod
    def decide_link(coordinations, t_s: float, positions_m, limits=None) -> None:
        """Decide the link for several vessels' coordination at ``t_s`` in one pass, in their
        order, before their :meth:`speed_correction` (or, with ``limits`` = each one's message id
        + 1, their :meth:`take_in` with ``decided``): the same draws as their calls one after the
        other (:meth:`~mjasc.cooperation.link.LinkEndpoint.decide_together`)."""
        LinkEndpoint.decide_together([c.link for c in coordinations], t_s, positions_m, limits)

    @staticmethod
    def take_in_fleet(coordinations, t_s: float, positions_m, gammas_m, limits) -> None:
        """:meth:`decide_link` with ``limits`` then each one's :meth:`take_in` with ``decided``, in one
        pass (:func:`~mjasc.cooperation.fleet_speed_law.take_in_fleet`)."""
        fleet_speed_law.take_in_fleet(coordinations, t_s, positions_m, gammas_m, limits)

    def speed_correction(self, t_s: float, nav, gamma_m: float) -> float:
        """Factor f_i on the mission speed (see the module docstring), from the newest data."""
        law = self._consensus(t_s, nav, gamma_m)
        if law is None:
            return 1.0
        cfg = self.config
        return self._factor(law, None if cfg.role == "leader" else np.tanh(law[2] / cfg.error_scale_m))

    @staticmethod
    def speed_correction_many(calls) -> list[float]:
        """:meth:`speed_correction` of several vessels, ``calls`` = [(coordination, t, nav, γ)]
        (:func:`~mjasc.cooperation.fleet_speed_law.speed_correction_many`)."""
        return fleet_speed_law.speed_correction_many(calls)

    @staticmethod
    def speed_correction_fleet(coordinations, t_s: float, positions_m, gammas_m) -> list[float]:
        """:meth:`decide_link` then :meth:`speed_correction_many` of several vessels at one time
        ``t_s`` in one pass (:func:`~mjasc.cooperation.fleet_speed_law.speed_correction_fleet`)."""
        return fleet_speed_law.speed_correction_fleet(coordinations, t_s, positions_m, gammas_m)

    def _consensus(self, t_s: float, nav, gamma_m: float):
        """Read the arrivals; then (the team view, ξ_own, e_i, |N_i|), or None without a path."""
        self._poll(t_s, nav)
        return self._law(t_s, gamma_m)

    def _law(self, t_s: float, gamma_m: float):
        """:meth:`_consensus` after the arrivals were read."""
        if self.path_length_m is None:
            return None
        view = self._team_view()
        own = self.xi(gamma_m)
        n = len(view.rows)
        e = view.l_bar * view.gap_sum(t_s, self.config.extrapolate, own) if n else 0.0
        return view, own, e, n

    def _factor(self, law, tanh) -> float:
        """f_i from :meth:`_consensus`'s ``law`` and tanh(e_i / e_s) (None for a leader); notes
        the lead, factor and ξ."""
        view, own, e, n = law
        ff = view.omega * self.path_length_m / self.mission_speed_m_s
        lead = e / n if n else 0.0
        corr = 0.0 if tanh is None else self.config.max_speed_correction * tanh
        f = ff * (1.0 - corr)
        f = float(min(f, self.top_speed_m_s / self.mission_speed_m_s))
        self.last_error_m, self.last_factor, self.last_xi = lead, f, own
        return f

    def drain_events(self) -> list[tuple[float, str]]:
        out, self._events = self._events, []
        return out

    def log(self, recorder, t_s: float, vessel_name: str) -> None:
        """Plot this vessel's γ/L, lead, formation spread and speed factor (:class:`CoordinationLog`)."""
        self._log.log(recorder, t_s, vessel_name, self.link.team, self.last_xi, self.last_error_m, self.last_spread_m,
                      self.last_factor)

    def summary(self) -> dict:
        """This vessel's view of the formation, sampled at each exchange: its lead over the
        neighbours and the formation spread (see :meth:`coordination_error`, metres of path), the
        time from which the spread stays below ``formation_tolerance_m``; and its link statistics."""
        link = self.link.stats()
        out = {"method": self.method, "role": self.config.role, "messages_sent": link["sent"], "messages_received": link["delivered"],
               "messages_lost": link["lost"], "loss_rate": round(link["loss_rate"], 4),
               "mean_delay_s": None if not link["delivered"] else round(float(link["mean_delay_s"]), 4),
               "neighbours_active": sorted(self.active_neighbours()),
               "neighbours_lost": sorted(n for n, nb in self.neighbours.items() if not nb.active)}
        if self.config.share_tracks:
            out["tracks_sent"] = self._tracks_sent
        out.update(self._history.statistics(self.config.formation_tolerance_m))
        return out
