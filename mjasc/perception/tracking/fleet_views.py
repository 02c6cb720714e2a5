"""FleetViews: what a fleet tracker (:class:`mjasc.perception.tracking.fleet.FleetTracker`) hands
out — the mixin it inherits (the tracker itself steps, adds and drops the rows; this reads them).

Per vessel: its events (:class:`TrackEvent`), its rows in the bank, their number, its counters and
last assignment, its confirmed tracks as :class:`~mjasc.core.estimates.TrackRows` (every vessel's
made at once on the first read after a step: :mod:`mjasc.perception.tracking.report_fields`) or as
:class:`~mjasc.core.estimates.TrackEstimate` s, a track's outline; for the fleet, every vessel's
moving confirmed tracks at once.

The mixin reads the tracker's ``bank``, ``cols``
(:class:`~mjasc.perception.tracking.track_columns.TrackColumns`), ``outlines``, ``team``, ``config``,
``version``, ``_max_range``, ``_counts``, ``_last_assign``, ``_rows_cache``, ``_sizes`` and
``_reports``, set by ``FleetTracker.__init__``; its own state is two read caches of the recording's
track read (``_report_read``: the reports' columns, ``_points_read``: the latest fleet-wide gather,
:meth:`FleetViews.confirmed_points_of`), set on first use.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import repeat

import numpy as np

from mjasc.core.estimates import TrackEstimate, TrackRows, track_estimate_rows
from mjasc.perception.tracking.report_fields import report_columns, report_columns_numpy, report_estimates
from mjasc.perception.tracking.step_kernels import confirmed_by_owner

__all__ = ["FleetViews", "TrackEvent", "COUNT_KEYS"]

#: Per-vessel counters (``FleetTracker.counts(owner)``).
COUNT_KEYS = ("born", "confirmed", "lost", "merged", "scans", "detections", "associated")
_BORN, _CONF, _LOST, _MERGED, _SCANS, _DETS, _ASSOC = range(7)  # (their columns)


@dataclass(frozen=True)
class TrackEvent:  # something that happened to one of a vessel's tracks at time_s [s] (FleetTracker.events)
    time_s: float
    kind: str  # "born" | "confirmed" | "lost" | "merged"
    track_id: int
    text: str

_NO_ROWS = TrackRows(([], [], np.zeros((0, 2)), [], [], [], [], np.zeros((0, 2, 2)), [], [], [], ()))


class FleetViews:
    """The read-only views of :class:`~mjasc.perception.tracking.fleet.FleetTracker`'s rows (a mixin:
    the tracker's base class; see the module docstring for the attributes it reads)."""

    # ------------------------------------------------------------------ vessels
    @property
    def n_owners(self) -> int:
        return self._max_range.size

    @property
    def owner(self) -> np.ndarray:
        """(n,) per row: its vessel (a view of the store's column: stale after a birth or drop)."""
        return self.cols.owner

    @property
    def local_id(self) -> np.ndarray:
        """(n,) per row: its id in its vessel's numbering (a view: stale after a birth or drop)."""
        return self.cols.local_id

    def rows_of(self, owner: int) -> np.ndarray:
        """Bank rows of a vessel's tracks, in bank order (= the order of its own tracker)."""
        got = self._rows_cache.get(owner)
        if got is None or got[0] != self.version:
            own = self.cols.owner
            got = (self.version, (own == owner).nonzero()[0] if self.n_owners > 1 else np.arange(own.size))
            self._rows_cache[owner] = got
        return got[1]

    def n_rows(self, owner: int) -> int:
        """The number of a vessel's tracks (``rows_of(owner).size``; every vessel's counted at once,
        once per change of rows)."""
        got = self._sizes
        no = self._max_range.size
        if got[0] != self.version or got[2] != no:
            got = self._sizes = (self.version, np.bincount(self.cols.owner, minlength=no).tolist(), no)
        return got[1][owner]

    def confirmed_rows(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Every vessel's confirmed tracks, in bank order: their vessels (k,), ids (k,), positions
        (k, 2) [m] as last estimated and static flags (k,) — a vessel's rows among them are, in the
        same order, what its tracker's ``scored_positions`` gives before it predicts them to a tick
        (a run's evaluation samples them all at once: mjasc.evaluation.track_samples)."""
        c = self.cols
        rows = c.confirmed.nonzero()[0]
        return c.owner[rows], c.local_id[rows], self.bank.positions_of(rows), c.static[rows]

    def confirmed_points_of(self, owner: int, epoch=None) -> tuple:
        """A vessel's confirmed tracks as the recording draws them at standard detail, in bank
        order: ids (k,), positions (k, 2) [m], static flags (k,) and team mates (k names or None)
        — ``MultiTargetTracker.confirmed_points``; ids and flags as lists when read from the
        reports. Read from the columns of :meth:`report_rows` when the reports of the latest step
        are made (a control tick asked for them: the same numbers, nothing gathered again), else
        gathered: with an ``epoch`` (the recording's tick time [s]) every vessel's at once on the
        first call of that epoch, the others slices of that read (the caller promises that the
        tracker did not step between two calls of one epoch: a record tick reads every vessel in
        one slot; a step that added or dropped rows is noticed anyway)."""
        made = self._reports
        if made is not None:
            got = self.__dict__.get("_report_read")
            if got is not None and got[0] is made:
                return self._report_points(got[1], owner)
        if epoch is None:
            return self._confirmed_points_read()[owner]
        got = self.__dict__.get("_points_read")
        if got is None or got[0] != epoch or got[1] != self.version:
            got = self._points_read = (epoch, self.version, self._confirmed_points_read())
        return got[2][owner]

    @staticmethod
    def _report_points(columns: tuple, owner: int) -> tuple:
        """:meth:`confirmed_points_of` from the report's columns (``report_columns``)."""
        if len(columns) == 1 or owner not in columns[0]:
            return [], np.zeros((0, 2)), [], []
        a, b = columns[0][owner]
        return columns[2][a:b], columns[4][a:b], columns[11][a:b], columns[12][a:b]

    def _confirmed_points_read(self) -> list:
        """Every vessel's (ids, positions, static, team) of :meth:`confirmed_points_of`, one gather."""
        c, no = self.cols, self._max_range.size
        rows, first = confirmed_by_owner(c.confirmed, c.owner, no)
        ids, xy, static, team = c.local_id[rows], self.bank.positions_of(rows), c.static[rows], c.team[rows].tolist()
        f = first.tolist()
        return [(ids[a:b], xy[a:b], static[a:b], team[a:b]) for a, b in zip(f, f[1:])]

    def counts(self, owner: int) -> dict:
        return dict(zip(COUNT_KEYS, self._counts[owner].tolist()))

    def last_assignment(self, owner: int) -> dict:
        """{track id: detection index} of the vessel's last scan (updates and births)."""
        pieces = self._last_assign[owner]
        if not pieces:
            return {}
        ids = np.concatenate([i[a:b] for i, _, a, b in pieces])
        dets = np.concatenate([d[a:b] for _, d, a, b in pieces])
        return dict(zip(ids.tolist(), dets.tolist()))

    # ------------------------------------------------------------------ outputs
    def estimates(self, owner: int, include_tentative: bool = False) -> list[TrackEstimate]:
        """TrackEstimate of every confirmed track of a vessel (and tentative ones if asked), in
        bank order: the objects of :meth:`report_rows` (the same until the next step) in a new list."""
        if include_tentative:
            return self._estimates_of(self.rows_of(owner))
        return list(self.report_rows(owner))

    def report_rows(self, owner: int) -> TrackRows:
        """A vessel's confirmed tracks in bank order as :class:`~mjasc.core.estimates.TrackRows`
        (the estimates made on first read; ids, times and positions readable without them). Every
        vessel's rows are made at once, on the first call after a step (each vessel asks at least
        once per step — again after comms, between steps: one pass instead of one per vessel and
        call, :meth:`_report_columns`, :meth:`_report_estimates`); the same value until the next step."""
        made = self._reports
        if made is None:
            columns = self._report_columns()
            made = self._reports = self._report_estimates(columns)
            self._report_read = (made, columns)  # (what confirmed_points_of reads while these reports hold)
        return made[owner] if owner in made else _NO_ROWS

    # the report's columns and rows (mjasc.perception.tracking.report_fields), bound as methods
    _report_estimates = report_estimates
    _report_columns = report_columns
    _report_columns_numpy = report_columns_numpy

    def _estimates_of(self, rows) -> list[TrackEstimate]:
        """TrackEstimate of the tracks ``rows`` (indices), in that order."""
        if rows.size == 0:
            return []
        t, pos, th, v, w, P = self.bank.estimate_fields(rows)
        static = self.cols.static[rows]
        slow = (static | (v < self.config.static_speed_m_s)).tolist()
        # Python values per track in one conversion per field; each track's position and
        # covariance are rows of arrays made for this call (views: no track shares another's).
        k_rows = rows.tolist()
        radius = self.cols.radius[rows]
        outline = self.outlines.outline  # (= self.outline(k): pos, radius are row k's)
        outlines = [outline(k, pos[j], radius[j]) if lk else None for j, (k, lk) in enumerate(zip(k_rows, slow))]
        ids = self.cols.local_id[rows].tolist()
        return track_estimate_rows(ids, t.tolist(), pos, th.tolist(), v.tolist(), w.tolist(),
                                   radius.tolist(), P, static.tolist(), self.team.members(rows),
                                   outlines, repeat(None, len(k_rows)))

    def outline(self, row: int) -> np.ndarray:
        """(k, 2) CCW outline [m] of the track in bank row ``row``
        (:mod:`mjasc.perception.tracking.outlines`)."""
        return self.outlines.outline(row, self.bank.positions[row], self.cols.radius[row])
