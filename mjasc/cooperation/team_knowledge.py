"""What a vessel's coordination knows of its team, handed to the rest of the vessel
(:class:`~mjasc.cooperation.coordination.Coordination`'s read-outs): each team mate's newest message as
a :class:`~mjasc.cooperation.messages.TeamIntention` (its plan and radius), the team picture (those
intentions and the latest factor on the mission speed), the shared tracks and the latest received
positions (world ENU [m], times [s]).

:class:`TeamKnowledge` is a base class of ``Coordination``: it reads the coordination's
``neighbours`` (name → the newest message as received), ``config``, ``last_factor`` and its caches of
intentions (``_intent_cache``, ``_intentions``: None after a message arrived).
"""

from __future__ import annotations

from mjasc.cooperation.messages import TeamIntention, TeamPicture

__all__ = ["TeamKnowledge"]


class TeamKnowledge:
    """The team read-outs of a coordination (module docstring)."""

    def team_intentions(self, t_s: float | None = None, max_age_s: float | None = None) -> dict[str, TeamIntention]:
        """Each team mate's newest message as a :class:`TeamIntention` (name → intention); with
        ``t_s`` and ``max_age_s`` only those sent at most ``max_age_s`` before ``t_s``."""
        out = {}
        for n, nb in self.neighbours.items():
            if max_age_s is not None and t_s is not None and t_s - nb.sent_time_s > max_age_s:
                continue
            cached = self._intent_cache.get(n)
            if cached is not None and cached.sent_time_s == nb.sent_time_s:
                out[n] = cached
                continue
            out[n] = self._intent_cache[n] = TeamIntention.from_message(nb.message, nb.sent_time_s)
        return out

    def team_picture(self, t_s: float) -> TeamPicture:
        """What this vessel knows of its team now: every team mate's newest intention and the
        latest factor on the mission speed (the intentions' mapping is rebuilt only when a message
        has arrived; treat it as read-only)."""
        if self._intentions is None:
            self._intentions = self.team_intentions()
        picture = object.__new__(TeamPicture)  # TeamPicture(t, intentions, factor) without its __init__
        picture.__dict__.update(time_s=float(t_s), intentions=self._intentions, speed_factor=self.last_factor)
        return picture

    def track_sharing(self):
        """The team-shared perception settings
        (:class:`~mjasc.perception.track_fusion.FusionSettings`) when ``share_tracks`` is on, else None."""
        if not self.config.share_tracks:
            return None
        from mjasc.perception.track_fusion import FusionSettings

        c = self.config
        return FusionSettings(c.share_max_tracks, c.share_max_age_s, c.share_gate)

    def team_tracks(self) -> dict:
        """Each team mate's newest message's shared tracks: name → (sent time [s], tuple of
        :class:`~mjasc.core.estimates.SharedTrack`); an empty tuple (it sees nothing now) replaces
        what the receiver kept of that team mate."""
        return {n: (nb.sent_time_s, tuple(getattr(nb.message, "tracks", ()))) for n, nb in self.neighbours.items()}

    def team_positions(self) -> dict:
        """Latest received position of every team mate: name → (sent time [s], (2,) world [m])."""
        return {n: (nb.sent_time_s, nb.message.position_m) for n, nb in self.neighbours.items()}
