"""The team link's parameters: the loss and delay laws' numbers, the presets (``radio``,
``acoustic``) and the topology (who can hear whom) — :class:`NetworkConfig`, read from the
scenario's top-level ``[comms]`` table by :func:`parse_network_options`. The laws themselves are
described in :mod:`mjasc.cooperation.comms`."""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from mjasc.core.config_tables import ConfigError, check_keys, check_params, dataclass_from_table, param, show, string
from mjasc.core.config_tables import table as as_table

__all__ = ["NetworkConfig", "parse_network_options", "PRESETS", "TOPOLOGIES"]

#: Who can hear whom on the link (:attr:`NetworkConfig.topology`).
TOPOLOGIES = ("all", "ring", "leader_followers", "graph")


def _links(value, where: str) -> tuple:
    """``links = [["a", "b"], ...]`` → a tuple of (a, b) name pairs (a ≠ b)."""
    if not isinstance(value, (list, tuple)):
        raise ConfigError(f"{where}: must be an array of [name, name] pairs, got {show(value)}")
    out = []
    for k, pair in enumerate(value):
        if not (isinstance(pair, (list, tuple)) and len(pair) == 2 and all(isinstance(x, str) for x in pair)):
            raise ConfigError(f"{where}[{k}]: must be a pair of vessel names [\"a\", \"b\"], got {show(pair)}")
        if pair[0] == pair[1]:
            raise ConfigError(f"{where}[{k}]: a link joins two different vessels, got {show(list(pair))}")
        out.append((pair[0], pair[1]))
    return tuple(out)


@dataclass(frozen=True)
class NetworkConfig:
    """Link model parameters (SI). Defaults: the ``radio`` preset."""

    range_m: float = param(1000.0, positive=True, unit="m", doc="R: messages farther than this are always lost")
    loss_probability: float = param(0.0, nonneg=True, maximum=1.0, doc="p₀: the loss probability near the sender")
    loss_exponent: float = param(4.0, positive=True, doc="n: how fast the loss rises to 1 at the range R")
    base_delay_s: float = param(0.02, nonneg=True, unit="s", doc="modem / MAC / processing latency")
    propagation_speed_m_s: float = param(3.0e8, positive=True, unit="m/s", doc="c: the delay grows by d / c")
    jitter_s: float = param(0.01, nonneg=True, unit="s", doc="a uniform extra delay in [0, jitter]")
    topology: str = param("all", choices=TOPOLOGIES, doc="who can hear whom: all, ring (team order), "
                                                          "leader_followers, graph (links)")
    leader: str | None = param(None, doc="leader_followers: the leader's name (default: the first vessel)")
    links: tuple = param((), reader=_links,
                         doc="graph: undirected links [[\"a\", \"b\"], ...] between team members")

    def __post_init__(self):
        check_params(self, "comms")
        if self.topology == "graph" and not self.links:
            raise ConfigError("comms.links: a graph topology needs links [[\"a\", \"b\"], ...], got []")
        if self.links and self.topology != "graph":  # (they would be ignored: say so)
            raise ConfigError(f"comms.links: only with topology = \"graph\" (the topology is {self.topology!r}, "
                              "which would ignore them)")
        if self.leader is not None and self.topology != "leader_followers":
            raise ConfigError(f"comms.leader: only with topology = \"leader_followers\" (the topology is "
                              f"{self.topology!r}, which would ignore it; a coordination leader is "
                              "[vessels.comms] role = \"leader\")")

    def hears(self, team) -> dict[str, frozenset]:
        """Receiver → the senders it can hear, for the team ``team`` (names in scenario order);
        ValueError naming ``comms.leader`` / ``comms.links[k]`` for a name not in the team."""
        team = list(team)
        n = len(team)
        if self.topology == "all":
            return {r: frozenset(team) - {r} for r in team}
        if self.topology == "ring":
            return {r: frozenset({team[(i - 1) % n], team[(i + 1) % n]}) - {r} for i, r in enumerate(team)}
        if self.topology == "leader_followers":
            leader = self.leader if self.leader is not None else team[0]
            if leader not in team:
                raise ConfigError(f"comms.leader: {leader!r} is not a team member ({', '.join(team)})")
            return {r: (frozenset(team) - {r} if r == leader else frozenset({leader})) for r in team}
        edges: dict[str, set] = {r: set() for r in team}
        for k, (a, b) in enumerate(self.links):
            for name in (a, b):
                if name not in edges:
                    raise ConfigError(f"comms.links[{k}]: {name!r} is not a team member ({', '.join(team)})")
            edges[a].add(b)
            edges[b].add(a)
        return {r: frozenset(e) for r, e in edges.items()}

    def loss_at(self, distance_m) -> np.ndarray:
        """Loss probability p(d) for distances [m] (any shape)."""
        d = np.asarray(distance_m, dtype=float)
        p = self.loss_probability + (1.0 - self.loss_probability) * np.clip(d / self.range_m, 0.0, None) ** self.loss_exponent
        return np.where(d >= self.range_m, 1.0, np.minimum(p, 1.0))

    def mean_delay_at(self, distance_m) -> np.ndarray:
        """Mean delay E[τ(d)] [s] for distances [m] (any shape)."""
        d = np.asarray(distance_m, dtype=float)
        return self.base_delay_s + d / self.propagation_speed_m_s + 0.5 * self.jitter_s


PRESETS = {
    "radio": NetworkConfig(),
    "acoustic": NetworkConfig(range_m=2000.0, loss_probability=0.05, loss_exponent=2.0, base_delay_s=0.5,
                              propagation_speed_m_s=1500.0, jitter_s=0.2),
}


def parse_network_options(table: dict, where: str = "comms") -> NetworkConfig:
    """The scenario's top-level ``[comms]`` table → :class:`NetworkConfig`.

    Keys: ``preset`` (``radio`` | ``acoustic``, default ``radio``) and any field of
    :class:`NetworkConfig`. Raises ValueError naming ``f"{where}.{key}"`` and the reason.
    """
    check_keys(as_table(table, where), {"preset", *(f.name for f in fields(NetworkConfig))}, where)
    preset = string(table.get("preset", "radio"), f"{where}.preset", choices=PRESETS)
    overrides = {k: v for k, v in table.items() if k != "preset"}
    if not overrides:
        return PRESETS[preset]
    return dataclass_from_table(NetworkConfig, overrides, where, defaults=PRESETS[preset])
