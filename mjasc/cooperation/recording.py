"""How the team's comms link and each vessel's coordination draw themselves in the Rerun recording.

From the link's :class:`~mjasc.cooperation.comms.LinkOutcome` (each message's fate per receiver,
:meth:`~mjasc.cooperation.comms.CommsNetwork.drain_outcomes`) and its counters
(:meth:`~mjasc.cooperation.comms.CommsNetwork.stats`), at the record ticks:

    world/comms/delivered     a line from sender to receiver for every message sent in the last
                              ``LINK_WINDOW_S``, in the sender's colour (legend class 113)
    world/comms/lost          a lost message: a thin grey line from the sender stopping halfway to
                              the receiver (legend class 114)
    plots/comms/<v>/received  messages received by vessel v so far (a count, every ``COUNT_PERIOD_S``)
    plots/comms/<v>/lost      messages lost on their way to v so far (when it changed)

and at the run's end both counts as they stand (:meth:`CommsLog.finish`: the summary's).

The counts are written for the vessels with per-vessel views only
(:meth:`~mjasc.runs.recording.Recorder.has_views`: a large fleet's recording size).

Lines are drawn for teams of at most ``MAX_LINE_VESSELS`` (a team of n has n(n − 1) links: 50
vessels on a 1 Hz link would draw 2450 lines a second); larger teams get the counts only. Lines
join the vessels' positions at the record tick (world ENU [m], drawn at z = 0.6 above the
hulls, 1.5 UI points wide, lost ones 1); rows are written when the set of lines changes (an empty row clears them), and at least
every ``LINK_WINDOW_S`` while lines are shown (they follow the vessels).

Each vessel's coordination (:class:`CoordinationLog`) plots ``plots/coordination/<v>/gamma_normalized``,
``spread_m`` and ``speed_factor`` (and ``error_m``, its lead, in the full recording).
"""

from __future__ import annotations

import math
from itertools import chain

import numpy as np

__all__ = ["CommsLog", "CoordinationLog", "LINK_WINDOW_S", "COUNT_PERIOD_S", "MAX_LINE_VESSELS"]

#: A message's line stays this long after it was sent [s].
LINK_WINDOW_S = 1.0
#: The message counts are written at most this often [s].
COUNT_PERIOD_S = 5.0
#: Teams larger than this get no lines, only the counts.
MAX_LINE_VESSELS = 12
_DELIVERED, _LOST = 113, 114
_Z = 0.6
# CoordinationLog's series (Recorder.vessel_scalar templates)
_GAMMA, _SPREAD, _FACTOR = ("plots/coordination/{}/gamma_normalized", "plots/coordination/{}/spread_m",
                            "plots/coordination/{}/speed_factor")


class CommsLog:
    """Logging state of the link (one per run): the recent outcomes and the counts."""

    def __init__(self, names: tuple[str, ...]):
        self.names = tuple(names)
        self.lines = len(self.names) <= MAX_LINE_VESSELS
        self._index = {n: k for k, n in enumerate(self.names)}
        self._recent: list = []
        self._oldest_s = np.inf  # the earliest send time in _recent [s]
        self._pairs: tuple = ((), ())  # the (delivered, lost) pairs of _recent
        self._shown: tuple = ((), ())  # the (delivered, lost) pairs last drawn
        self._shown_t = -np.inf
        self._written: dict[str, tuple[float, int, int]] = {}  # receiver → (t, received, lost) last written
        self._changes = None  # the link's count_changes when the counts were last asked (log)
        # the earliest last-written time [s] of the vessels whose received count changed but is not
        # written yet (COUNT_PERIOD_S not over since; None: no such vessel)
        self._waiting_s: float | None = None
        self._styled = False
        self._counted: tuple[int, ...] = ()  # indices of the vessels whose counts are written
        self._gathered: dict[tuple, tuple] = {}  # (delivered, lost) pairs → their indices and colours (_gathers)

    def _style(self, recorder) -> None:
        import rerun as rr

        if self.lines:
            recorder.style("world/comms/delivered", rr.LineStrips3D.from_fields(
                radii=[-1.5], class_ids=[_DELIVERED], show_labels=[False]))
            recorder.style("world/comms/lost", rr.LineStrips3D.from_fields(
                colors=[recorder.legend_colour(_LOST)], radii=[-1.0], class_ids=[_LOST], show_labels=[False]))
        self._counted = tuple(k for k, n in enumerate(self.names) if recorder.has_views(n))
        for n in (self.names[k] for k in self._counted):
            col = recorder.colour(n)
            recorder.series_style(f"plots/comms/{n}/received", f"{n} received", col, 1.5)
            recorder.series_style(f"plots/comms/{n}/lost", f"{n} lost", (*col, 130), 1.0)
        self._styled = True

    def log(self, recorder, t_s: float, outcomes, positions_xy, counts, changes=None) -> None:
        """Add ``outcomes`` (decided since the last call; unused without lines) and draw the links
        alive at t_s; ``positions_xy`` (n, 2) the vessels' positions [m] in the order of
        :attr:`names`, ``counts(name)`` → (messages received, lost so far) of a vessel (asked only
        for the vessels whose counts are written, and only when ``changes`` — a number that changes
        with the counts, the link's ``count_changes`` — did or a waiting received count is due;
        None: at every call)."""
        if not self._styled:
            self._style(recorder)
        waiting = self._waiting_s
        if changes is None or changes != self._changes or \
                (waiting is not None and t_s - waiting >= COUNT_PERIOD_S - 1e-9):  # (else nothing to write)
            self._changes, waiting = changes, None
            for k in self._counted:
                n = self.names[k]
                received_now, lost_now = counts(n)
                t0, received, lost = self._written.get(n, (-np.inf, -1, -1))
                if lost_now != lost or (received_now != received and t_s - t0 >= COUNT_PERIOD_S - 1e-9):
                    self._written[n] = (t_s, received_now, lost_now)
                    recorder.scalar(f"plots/comms/{n}/received", t_s, received_now)
                    recorder.scalar(f"plots/comms/{n}/lost", t_s, lost_now)
                elif received_now != received and (waiting is None or t0 < waiting):
                    waiting = t0  # (t_s − t0 is largest for the earliest t0: the first one due)
            self._waiting_s = waiting
        if not self.lines:
            return
        cutoff = t_s - LINK_WINDOW_S
        if outcomes or (self._recent and self._oldest_s <= cutoff):  # else the same links as last time
            recent = self._recent = [o for o in chain(self._recent, outcomes) if o.sent_time_s > cutoff]
            self._oldest_s = min([o.sent_time_s for o in recent], default=np.inf)
            delivered = {(o.sender, o.receiver) for o in recent if not o.lost}
            lost = tuple(sorted({(o.sender, o.receiver) for o in recent if o.lost} - delivered))
            delivered = tuple(sorted(delivered))
            self._pairs = (delivered, lost)
        delivered, lost = self._pairs
        if (delivered, lost) == self._shown and not ((delivered or lost) and t_s - self._shown_t >= LINK_WINDOW_S):
            return  # nothing new to draw (shown links are redrawn where the vessels are now every window)
        self._shown, self._shown_t = (delivered, lost), t_s
        p = np.asarray(positions_xy, dtype=float)
        # One gather per kind: the delivered lines (m, 2, 2) sender → receiver, the lost ones from
        # the sender to halfway (the same numbers as a line per pair).
        at_delivered, colours, at_lost = self._gathers(recorder, delivered, lost)
        recorder.strips("world/comms/delivered", t_s, p[at_delivered], z=_Z, colours=colours)
        halfway = ()  # (no lost message: the same empty row without the gather)
        if lost:
            halfway = p[at_lost]  # (m, 2, 2): each sender → receiver, the receiver's end moved halfway
            halfway[:, 1] = 0.5 * (halfway[:, 0] + halfway[:, 1])
        recorder.strips("world/comms/lost", t_s, halfway, z=_Z)

    def finish(self, recorder, t_s: float, counts) -> None:
        """The counts as they stand at the run's end ``t_s`` (a row for each vessel whose counts
        changed since they were last written: a received count is written at most every
        ``COUNT_PERIOD_S``, so the plots would end below the summary's ``comms`` counts)."""
        if not self._styled:
            return  # (no record tick: nothing drawn, nothing to end)
        for k in self._counted:
            n = self.names[k]
            now = counts(n)
            if self._written.get(n, (None, -1, -1))[1:] != now:
                self._written[n] = (t_s, *now)
                recorder.scalar(f"plots/comms/{n}/received", t_s, now[0])
                recorder.scalar(f"plots/comms/{n}/lost", t_s, now[1])
        self._waiting_s = None

    def _gathers(self, recorder, delivered: tuple, lost: tuple) -> tuple:
        """The vessel indices (m, 2) of the delivered and lost pairs and the delivered lines'
        colours (the sender's, alpha 160), made once per set of pairs (a team's few pairs recur)."""
        got = self._gathered.get((delivered, lost))
        if got is None:
            index = self._index
            if len(self._gathered) >= 256:  # (a team of 12 has 132 pairs: bounded all the same)
                self._gathered.clear()
            got = self._gathered[(delivered, lost)] = (
                np.array([[index[a], index[b]] for a, b in delivered], dtype=np.intp).reshape(-1, 2),
                [(*recorder.colour(a), 160) for a, _ in delivered],
                np.array([[index[a], index[b]] for a, b in lost], dtype=np.intp).reshape(-1, 2))
        return got


class CoordinationLog:
    """How a vessel's coordination draws itself, at the record ticks: its normalized path parameter
    γ/L (when it has a path), its formation spread [m of path] and its factor on the mission speed
    (one entity per quantity shared by the vessels without views:
    :meth:`~mjasc.runs.recording.Recorder.vessel_scalar`), and with the full recording its lead over
    the neighbours [m of path] (no view in the default blueprint)."""

    def __init__(self):
        self._styled = False

    def log(self, recorder, t_s: float, vessel_name: str, team, xi: float, lead_m: float, spread_m: float,
            factor: float) -> None:
        if not self._styled:
            from mjasc.runs.recording import vessel_colour

            col = vessel_colour(team.index(vessel_name)) if vessel_name in team else None
            recorder.vessel_series_style(_GAMMA, vessel_name, f"{vessel_name} γ/L", col)
            if recorder.full:
                recorder.series_style(f"plots/coordination/{vessel_name}/error_m", f"{vessel_name} lead [m]", col)
            recorder.vessel_series_style(_SPREAD, vessel_name, f"{vessel_name} formation spread [m]", col)
            recorder.vessel_series_style(_FACTOR, vessel_name, f"{vessel_name} speed factor", col)
            self._styled = True
        scalar = recorder.vessel_scalar
        if math.isfinite(xi):
            scalar(_GAMMA, vessel_name, t_s, xi)
        if recorder.full:
            recorder.scalar(f"plots/coordination/{vessel_name}/error_m", t_s, lead_m)
        scalar(_SPREAD, vessel_name, t_s, spread_m)
        scalar(_FACTOR, vessel_name, t_s, factor)
