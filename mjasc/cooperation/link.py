"""One vessel's end of the team's link: what its coordination method may do with the medium.

The :class:`~mjasc.cooperation.comms.CommsNetwork` is the environment's shared broadcast medium
(distance-dependent delay and loss). A vessel's coordination method gets a :class:`LinkEndpoint`
on it: it can broadcast its own messages and receive those delivered to it by now, and read its
own link statistics. It cannot read what is in flight, what others received, or where anyone is.
"""

from __future__ import annotations

__all__ = ["LinkEndpoint"]


class LinkEndpoint:
    """Vessel ``name``'s end of ``network`` (a :class:`~mjasc.cooperation.comms.CommsNetwork`)."""

    __slots__ = ("_network", "name")

    def __init__(self, network, name: str):
        if network is None:
            raise ValueError(f"{name}.comms: coordination needs a comms network")
        self._network = network
        self.name = str(name)

    @property
    def team(self) -> tuple[str, ...]:
        """The names of the team on this link (its members, in scenario order)."""
        return tuple(self._network.team)

    def send(self, t_s: float, payload, own_position_m) -> int:
        """Broadcast ``payload`` (a frozen message such as
        :class:`~mjasc.cooperation.messages.TeamMessage`) at ``t_s`` [s] from the vessel's own
        position (2,) world [m]; returns the message id."""
        return self._network.send(t_s, self.name, payload, own_position_m)

    def receive(self, t_s: float, own_position_m) -> list:
        """The messages delivered to this vessel by ``t_s`` [s]
        (:class:`~mjasc.cooperation.comms.Message`: sender, sent and received times, payload)."""
        return self._network.receive(t_s, self.name, own_position_m)

    def receive_raw(self, t_s: float, own_position_m, decide: bool = True) -> list:
        """:meth:`receive` as plain tuples (sender, sent time [s], received time [s], payload):
        no :class:`~mjasc.cooperation.comms.Message` per message; the payload is shared (a typed
        message is immutable; do not change a dict payload). ``decide=False``: only what
        :meth:`decide_together` decided already."""
        return self._network.receive_raw(t_s, self.name, own_position_m, decide)

    @staticmethod
    def decide_together(endpoints, t_s: float, own_positions_m, limits=None) -> None:
        """Decide the link for several vessels' ends of one network at once, in their order, as
        their :meth:`receive` calls one after the other would (the same draws): ``own_positions_m``
        each one's position (2,) world [m]; ``limits``: each one decides only the messages whose id
        is below its limit (a comms slot: what was sent up to its own message)
        (:meth:`~mjasc.cooperation.comms.CommsNetwork.decide_many`)."""
        network, names = None, []
        for e in endpoints:
            if network is None:
                network = e._network
            elif e._network is not network:
                raise ValueError("decide_together: the endpoints must share one network")
            names.append(e.name)
        if names:
            network.decide_many(t_s, names, own_positions_m, limits)

    @staticmethod
    def receive_together(endpoints, t_s: float, own_positions_m, limits=None) -> list:
        """:meth:`decide_together` then each one's :meth:`receive_raw` (``decide=False``), in one
        call: a list per endpoint (in their order) of what arrived by ``t_s`` (the same decisions,
        draws and statistics; :meth:`~mjasc.cooperation.comms.CommsNetwork.receive_many`); ``limits`` as
        for :meth:`decide_together`."""
        if not endpoints:
            return []
        network = endpoints[0]._network
        names = []
        for e in endpoints:  # (one loop: the check and the names)
            if e._network is not network:
                raise ValueError("receive_together: the endpoints must share one network")
            names.append(e.name)
        return network.receive_many(t_s, names, own_positions_m, limits)

    def stats(self) -> dict:
        """This vessel's link statistics (sent, received, lost, delays)."""
        return self._network.stats(self.name)
