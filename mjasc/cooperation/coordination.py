"""Coordination controller for cooperative path following: γ consensus over a lossy, delayed link.

Each vessel i follows its own mission path of length L_i (digest §1, "cooperative path following":
paths parameterized so that equal path parameters mean "in formation"); thesis §6.4 runs three
ASCs in line formation on an L-shaped path exchanging path parameters over comms (digest §6).
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
avoidance component's ``planned_trajectory`` when it has one, else from its path follower at the
mission speed × the coordination factor — plus its radius. :meth:`Coordination.team_intentions`
hands the newest one of each team mate to the avoidance layer as :class:`TeamIntention`.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields

import numpy as np

from mjasc.cooperation.comms import CommsNetwork
from mjasc.core.config_tables import ConfigError, boolean, dataclass_from_table, number, show, string

__all__ = ["CoordinationConfig", "Coordination", "TeamIntention", "parse_coordination_options"]


@dataclass(frozen=True)
class CoordinationConfig:
    """Gains and formation role of one vessel (``[vessels.comms]``). The broadcast period is the
    runner's comms slot, ``rates.comms_hz``."""

    max_speed_correction: float = 0.5  # k ∈ (0, 1): consensus term moves the speed in [(1−k), (1+k)]·nominal
    error_scale_m: float = 10.0  # e_s [m]: tanh(e/e_s); linear gain k/e_s per metre of error
    formation_offset_m: float = 0.0  # o_i [m]: desired lead along own path over the formation reference
    role: str = "peer"  # "peer" (consensus) | "leader" (keeps its nominal speed)
    neighbour_timeout_s: float = 5.0  # a neighbour whose latest message is older is dropped from N_i
    extrapolate: bool = True  # ξ̂_j = ξ_j + ξ̇_j (t − t_j)
    formation_tolerance_m: float = 1.0  # formation spread [m] below this counts as "in formation" (summary only)
    intent_horizon_s: float = 60.0  # the broadcast plan covers this far ahead [s] (0: no plan, pose only)
    intent_step_s: float = 1.0  # spacing of the plan's samples [s]

    def __post_init__(self):
        _validate(self, "comms")


_POSITIVE = ("error_scale_m", "neighbour_timeout_s", "formation_tolerance_m", "intent_step_s")


_ROLES = ("leader", "peer")


def _validate(cfg: CoordinationConfig, where: str) -> None:
    """Validate a :class:`CoordinationConfig` (ValueError naming ``f"{where}.{key}"``)."""
    string(cfg.role, f"{where}.role", choices=_ROLES)
    boolean(cfg.extrapolate, f"{where}.extrapolate")
    for f in fields(cfg):
        if f.name not in ("role", "extrapolate"):
            number(getattr(cfg, f.name), f"{where}.{f.name}", positive=f.name in _POSITIVE)
    number(cfg.intent_horizon_s, f"{where}.intent_horizon_s", nonneg=True)
    if not 0.0 < cfg.max_speed_correction < 1.0:
        raise ConfigError(f"{where}.max_speed_correction: must be in (0, 1) so that the speed stays positive, "
                          f"got {show(cfg.max_speed_correction)}")


def parse_coordination_options(table: dict, where: str = "comms") -> CoordinationConfig:
    """A ``[vessels.comms]`` table → :class:`CoordinationConfig` (ValueError names ``where.<key>``)."""
    return dataclass_from_table(CoordinationConfig, table, where, check=_validate)


@dataclass(frozen=True, eq=False)
class TeamIntention:
    """A team mate's newest message about itself (world ENU, SI, absolute times).

    name, sent_time_s: who and when. position_m (2,), heading_rad, velocity_m_s (2,): its own
    navigation at ``sent_time_s``. radius_m: its bounding radius [m] (None if not sent).
    plan_times_s (k,), plan_points_m (k, 2): where it intends to be (k = 0: no plan; then
    :meth:`positions` extrapolates the velocity)."""

    name: str
    sent_time_s: float
    position_m: np.ndarray
    heading_rad: float
    velocity_m_s: np.ndarray
    radius_m: float | None = None
    plan_times_s: np.ndarray = field(default_factory=lambda: np.zeros(0))
    plan_points_m: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))

    @property
    def has_plan(self) -> bool:
        return self.plan_times_s.size >= 2

    def positions(self, times_s) -> np.ndarray:
        """Intended positions (n, 2) at absolute ``times_s``: the plan, linearly interpolated;
        before its start along the broadcast velocity, after its end along its last segment."""
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

    def max_speed_m_s(self) -> float:
        """Largest speed along the plan (or the broadcast speed) [m/s]."""
        v = float(np.hypot(*self.velocity_m_s))
        if self.has_plan:
            seg = np.hypot(*np.diff(self.plan_points_m, axis=0).T) / np.maximum(np.diff(self.plan_times_s), 1e-9)
            v = max(v, float(seg.max()))
        return v


@dataclass
class _Neighbour:
    sent_time_s: float
    received_time_s: float
    payload: dict
    active: bool = True


class Coordination:
    """One vessel's coordination controller (the ``coordination`` component of ``VesselAgent``).

    Uses from the agent: ``name``, ``config.path`` or ``follower.path`` (the mission path, whose
    length is L_i), ``mission_speed_m_s`` and ``vessel.top_speed_m_s`` (both optional).
    """

    def __init__(self, agent, network: CommsNetwork, config: CoordinationConfig | None = None,
                 rng: np.random.Generator | None = None):
        if network is None:
            raise ValueError(f"{agent.name}.comms: coordination needs a comms network")
        self.name = agent.name
        self.agent = agent
        self.network = network
        self.config = config if config is not None else CoordinationConfig()
        self.rng = rng  # unused: the law is deterministic; kept for the component interface
        path = getattr(getattr(agent, "config", None), "path", None)
        if path is None and getattr(agent, "follower", None) is not None:
            path = agent.follower.path
        self.path = path  # the mission path (a detour never changes L_i)
        self.path_length_m = float(path.length) if path is not None else None
        self.mission_speed_m_s = float(getattr(agent, "mission_speed_m_s", 1.0))
        vessel = getattr(agent, "vessel", None)
        self.top_speed_m_s = float(vessel.top_speed_m_s) if vessel is not None else np.inf
        self.neighbours: dict[str, _Neighbour] = {}
        self._intent_cache: dict[str, TeamIntention] = {}
        self._events: list[tuple[float, str]] = []
        self.received = 0
        self.last_error_m = 0.0
        self.last_factor = 1.0
        self.last_xi = np.nan
        self.last_spread_m = 0.0
        self._history: list[tuple[float, float, float]] = []  # (t, lead, spread) at exchanges with ≥ 1 neighbour
        self._logged_style = False

    # ------------------------------------------------------------------ state
    def xi(self, gamma_m: float) -> float:
        """Own normalized coordination state ξ_i = (γ_i − o_i) / L_i."""
        if self.path_length_m is None:
            return np.nan
        return (float(gamma_m) - self.config.formation_offset_m) / self.path_length_m

    def _payload(self, t_s: float, nav, gamma_m: float) -> dict:
        p = {"position_m": np.array(nav.position_m[:2], dtype=float), "heading_rad": float(nav.heading_rad),
             "velocity_m_s": np.array(nav.velocity_m_s[:2], dtype=float),
             "mission_speed_m_s": self.mission_speed_m_s}
        vessel = getattr(self.agent, "vessel", None)
        if vessel is not None and getattr(vessel, "radius_m", None) is not None:
            p["radius_m"] = float(vessel.radius_m)
        plan = self._plan(t_s, nav)
        if plan is not None:
            p["plan_t_s"], p["plan_xy_m"] = plan
        if self.path_length_m is not None:
            g = float(np.clip(gamma_m, 0.0, self.path_length_m))
            chi = float(self.path.tangent_angle(g))
            along = float(np.dot(nav.velocity_m_s[:2], (np.cos(chi), np.sin(chi))))
            p.update(gamma_m=float(gamma_m), path_length_m=self.path_length_m, xi=self.xi(gamma_m),
                     xi_rate_1_s=along / self.path_length_m, offset_m=self.config.formation_offset_m)
        return p

    def _plan(self, t_s: float, nav):
        """(times (k,), points (k, 2)) of where this vessel intends to be, or None: its avoidance's
        ``planned_trajectory`` (the active path — a detour too — at the planned speed), else its
        follower's path ahead at the mission speed × the latest coordination factor."""
        h, dt = self.config.intent_horizon_s, self.config.intent_step_s
        if h <= 0:
            return None
        fn = getattr(getattr(self.agent, "avoidance", None), "planned_trajectory", None)
        if callable(fn):
            return fn(t_s, nav, h, dt)
        follower = getattr(self.agent, "follower", None)
        path = getattr(follower, "path", None)
        if path is None or not hasattr(path, "point") or not hasattr(follower, "gamma_m"):
            return None
        times = t_s + np.arange(0.0, h + 0.5 * dt, dt)
        v = self.mission_speed_m_s * (self.last_factor if np.isfinite(self.last_factor) else 1.0)
        g = np.clip(float(follower.gamma_m) + v * (times - t_s), 0.0, path.length)
        return times, np.asarray(path.point(g), dtype=float).reshape(-1, 2)

    def _poll(self, t_s: float, nav) -> None:
        """Read arrived messages, keep each neighbour's newest, time out stale ones."""
        for msg in self.network.receive(t_s, self.name, nav.position_m):
            self.received += 1
            old = self.neighbours.get(msg.sender)
            if old is not None and msg.sent_time_s <= old.sent_time_s:
                continue  # overtaken by a newer message (jitter)
            if old is not None and not old.active:
                self._events.append((t_s, f"comms: regained {msg.sender} after {msg.sent_time_s - old.sent_time_s:.1f} s"))
            self.neighbours[msg.sender] = _Neighbour(msg.sent_time_s, msg.received_time_s, msg.payload, True)
        for name, nb in self.neighbours.items():
            if nb.active and t_s - nb.sent_time_s > self.config.neighbour_timeout_s:
                nb.active = False
                self._events.append((t_s, f"comms: lost {name} (last message {t_s - nb.sent_time_s:.1f} s old)"))

    def active_neighbours(self) -> list[str]:
        return [n for n, nb in self.neighbours.items() if nb.active]

    def _estimates(self, t_s: float) -> tuple[np.ndarray, float, float]:
        """(ξ̂_j of the active neighbours with a path, L̄, ω_d)."""
        lengths = [self.path_length_m]
        speeds = [self.mission_speed_m_s]
        xis = []
        for nb in self.neighbours.values():
            p = nb.payload
            if "xi" not in p:
                continue
            lengths.append(p["path_length_m"])
            speeds.append(p["mission_speed_m_s"])
            if not nb.active:
                continue
            x = p["xi"]
            if self.config.extrapolate:
                x_end = 1.0 - p["offset_m"] / p["path_length_m"]  # the neighbour stops at the end of its path
                x = min(x + p["xi_rate_1_s"] * (t_s - nb.sent_time_s), max(x, x_end))
            xis.append(x)
        l_bar = float(np.mean(lengths))
        return np.array(xis), l_bar, float(np.mean(speeds)) / l_bar

    def coordination_error(self, t_s: float, gamma_m: float) -> tuple[float, float, float, int]:
        """As this vessel sees the team (active neighbours' extrapolated ξ̂_j), in metres of path:
        (e_i = L̄ Σ_j (ξ_i − ξ̂_j) the law's error, lead = L̄ mean_j (ξ_i − ξ̂_j) how far it is ahead of
        its neighbours, spread = L̄ (max − min) of {ξ_i, ξ̂_j} the formation's extent, |N_i|)."""
        if self.path_length_m is None:
            return 0.0, 0.0, 0.0, 0
        xis, l_bar, _ = self._estimates(t_s)
        if not len(xis):
            return 0.0, 0.0, 0.0, 0
        own = self.xi(gamma_m)
        d = l_bar * (own - xis)
        spread = l_bar * (max(own, xis.max()) - min(own, xis.min()))
        return float(d.sum()), float(d.mean()), float(spread), len(xis)

    # ------------------------------------------------------------------ component interface
    def exchange(self, t_s: float, nav, gamma_m: float) -> None:
        """Comms slot: broadcast own ξ, path rate and pose; read what has arrived."""
        self.network.send(t_s, self.name, self._payload(t_s, nav, gamma_m), nav.position_m)
        self._poll(t_s, nav)
        _, lead, spread, n = self.coordination_error(t_s, gamma_m)
        self.last_xi, self.last_spread_m = self.xi(gamma_m), spread
        if n:
            self._history.append((float(t_s), lead, spread))

    def speed_correction(self, t_s: float, nav, gamma_m: float) -> float:
        """Factor f_i on the mission speed (see the module docstring), from the newest data."""
        self._poll(t_s, nav)
        if self.path_length_m is None:
            return 1.0
        xis, l_bar, omega = self._estimates(t_s)
        ff = omega * self.path_length_m / self.mission_speed_m_s
        e = float(l_bar * np.sum(self.xi(gamma_m) - xis)) if len(xis) else 0.0
        lead = e / len(xis) if len(xis) else 0.0
        corr = 0.0 if self.config.role == "leader" else self.config.max_speed_correction * np.tanh(e / self.config.error_scale_m)
        f = ff * (1.0 - corr)
        f = float(min(f, self.top_speed_m_s / self.mission_speed_m_s))
        self.last_error_m, self.last_factor, self.last_xi = lead, f, self.xi(gamma_m)
        return f

    def team_intentions(self, t_s: float | None = None, max_age_s: float | None = None) -> dict[str, TeamIntention]:
        """Each team mate's newest message as a :class:`TeamIntention` (name → intention); with
        ``t_s`` and ``max_age_s`` only those sent at most ``max_age_s`` before ``t_s``."""
        out = {}
        for n, nb in self.neighbours.items():
            p = nb.payload
            if "position_m" not in p:
                continue
            if max_age_s is not None and t_s is not None and t_s - nb.sent_time_s > max_age_s:
                continue
            cached = self._intent_cache.get(n)
            if cached is not None and cached.sent_time_s == nb.sent_time_s:
                out[n] = cached
                continue
            vel = np.asarray(p.get("velocity_m_s", (0.0, 0.0)), dtype=float)[:2]
            plan_t = np.asarray(p.get("plan_t_s", ()), dtype=float).reshape(-1)
            plan_xy = np.asarray(p.get("plan_xy_m", np.zeros((0, 2))), dtype=float).reshape(-1, 2)
            if plan_t.size != plan_xy.shape[0]:
                plan_t, plan_xy = np.zeros(0), np.zeros((0, 2))
            out[n] = self._intent_cache[n] = TeamIntention(
                n, float(nb.sent_time_s), np.asarray(p["position_m"], dtype=float)[:2],
                float(p.get("heading_rad", np.arctan2(vel[1], vel[0]))), vel, p.get("radius_m"), plan_t, plan_xy)
        return out

    def team_positions(self) -> dict:
        """Latest received position of every team mate: name → (sent time [s], (2,) world [m])."""
        return {n: (nb.sent_time_s, nb.payload["position_m"]) for n, nb in self.neighbours.items()}

    def drain_events(self) -> list[tuple[float, str]]:
        out, self._events = self._events, []
        return out

    def log(self, recorder, t_s: float, vessel_name: str) -> None:
        base = f"plots/coordination/{vessel_name}"
        if not self._logged_style:
            from mjasc.runs.recording import vessel_colour

            col = vessel_colour(self.network.team.index(vessel_name)) if vessel_name in self.network.team else None
            recorder.series_style(f"{base}/gamma_normalized", f"{vessel_name} γ/L", col)
            recorder.series_style(f"{base}/error_m", f"{vessel_name} lead [m]", col)
            recorder.series_style(f"{base}/spread_m", f"{vessel_name} formation spread [m]", col)
            recorder.series_style(f"{base}/speed_factor", f"{vessel_name} speed factor", col)
            self._logged_style = True
        if np.isfinite(self.last_xi):
            recorder.scalar(f"{base}/gamma_normalized", t_s, self.last_xi)
        recorder.scalar(f"{base}/error_m", t_s, self.last_error_m)
        recorder.scalar(f"{base}/spread_m", t_s, self.last_spread_m)
        recorder.scalar(f"{base}/speed_factor", t_s, self.last_factor)

    def summary(self) -> dict:
        """This vessel's view of the formation, sampled at each exchange: its lead over the
        neighbours and the formation spread (see :meth:`coordination_error`, metres of path), the
        time from which the spread stays below ``formation_tolerance_m``; and its link statistics."""
        link = self.network.stats(self.name)
        out = {"role": self.config.role, "messages_sent": link["sent"], "messages_received": link["delivered"],
               "messages_lost": link["lost"], "loss_rate": round(link["loss_rate"], 4),
               "mean_delay_s": None if not link["delivered"] else round(float(link["mean_delay_s"]), 4),
               "neighbours_active": sorted(self.active_neighbours()),
               "neighbours_lost": sorted(n for n, nb in self.neighbours.items() if not nb.active)}
        if self._history:
            t, lead, spread = np.array(self._history).T
            a = np.abs(lead)
            out.update(initial_error_m=round(float(lead[0]), 3), final_error_m=round(float(lead[-1]), 3),
                       max_abs_error_m=round(float(a.max()), 3), mean_abs_error_m=round(float(a.mean()), 3),
                       initial_spread_m=round(float(spread[0]), 3), final_spread_m=round(float(spread[-1]), 3),
                       max_spread_m=round(float(spread.max()), 3), mean_spread_m=round(float(spread.mean()), 3))
            outside = np.nonzero(spread >= self.config.formation_tolerance_m)[0]
            if not len(outside):
                out["in_formation_from_s"] = round(float(t[0]), 3)
            elif outside[-1] + 1 < len(t):
                out["in_formation_from_s"] = round(float(t[outside[-1] + 1]), 3)
            else:
                out["in_formation_from_s"] = None
        return out
