"""The confirmed-track rows of standard detail for a whole fleet tracker: one read of the fleet's
arrays per record tick instead of a read, a label check and a row per vessel.

At standard detail each vessel's ``world/vessels/<v>/tracks/positions`` gets a row (its confirmed
tracks' positions [m], world ENU, bank order) at every record tick after its tracker stepped — the
first record tick included — unless it tracks nothing and tracked nothing at its last row; the row
carries the labels ``<v>:T<id>[ (<team mate>)][ static]`` whenever they differ from the labels of
its previous row (:mod:`mjasc.perception.recording`, which writes the same rows one vessel at a
time at full detail and for vessels with a plugin tracker).

:class:`FleetTrackRows` does this for every vessel of one
:class:`~mjasc.perception.tracking.fleet.FleetTracker`: at each record tick (:meth:`~FleetTrackRows.record`)
it compares the tracker's per-vessel scan counter with the one at each vessel's previous row, and
when any vessel stepped it gathers the fleet's confirmed rows once (grouped by vessel), checks every
vessel's label key (ids, static flags, team mates) against its previous row's with a few whole-array
comparisons — per vessel only when something differs — and appends the tick's positions to
growing arrays. Python per vessel is left for events only: a changed label key, and a vessel's
first row since a flush, which its :class:`~mjasc.perception.recording.PerceptionLog` registers
with the recorder where its own row would have gone (the recorder's chunks keep their order: the
same bytes). At the flush each vessel's rows are one fancy index into those arrays
(:class:`VesselTrackRows`, read by :meth:`~mjasc.runs.recording.Recorder.point_rows`).

The rows a tick adds are counted with the recorder at the next tick (or written by the close), so
a flush comes between two record ticks.
"""

from __future__ import annotations

import numpy as np

from mjasc.perception.track_row_kernels import track_rows_into

__all__ = ["FleetTrackRows", "VesselTrackRows", "fleet_track_rows", "track_labels", "TRACKS_Z_M"]

#: The height the confirmed tracks are drawn at in the top-down view [m].
TRACKS_Z_M = 0.3


def track_labels(vessel_name: str, ids, team, static) -> list[str]:
    """``<vessel>:T<id>[ (<team mate>)][ static]`` per confirmed track (ids, team mates and static
    flags of the confirmed tracks)."""
    return [f"{vessel_name}:T{i}" + (f" ({m})" if m else "") + (" static" if st else "")
            for i, m, st in zip(ids, team, static)]


class _Grown:
    """Rows of one float64 or int array that double their capacity when full."""

    __slots__ = ("data", "n")

    def __init__(self, shape: tuple[int, ...], dtype, capacity: int):
        self.data = np.empty((capacity, *shape), dtype=dtype)
        self.n = 0

    def reserve(self, k: int) -> int:
        """Room for k more rows; the index of the first."""
        n = self.n
        if n + k > len(self.data):
            grown = np.empty((max(2 * len(self.data), n + k), *self.data.shape[1:]), dtype=self.data.dtype)
            grown[:n] = self.data[:n]
            self.data = grown
        self.n = n + k
        return n


class FleetTrackRows:
    """The standard-detail track rows of the vessels on one fleet tracker (module docstring).

    ``tracker``: the :class:`~mjasc.perception.tracking.fleet.FleetTracker`; ``owners``: the
    vessels written here (their owner indices in it), ``names`` their vessel names and ``logs``
    their :class:`~mjasc.perception.recording.PerceptionLog` s (told when to register a vessel's
    rows with the recorder); ``perception_fleet``: their
    :class:`~mjasc.perception.fleet.PerceptionFleet`, if any (flushed before each read)."""

    def __init__(self, tracker, owners: list[int], names: list[str], logs: list, perception_fleet=None):
        self.tracker = tracker
        self._perception = perception_fleet  # (its queued work done before a read, as Perception.tracker does)
        no = tracker.n_owners
        self.names: list[str | None] = [None] * no
        self._logs: list = [None] * no
        self.ours = np.zeros(no, dtype=bool)  # the vessels written here
        for o, name, log in zip(owners, names, logs):
            self.names[o], self._logs[o], self.ours[o] = name, log, True
        self.vessel_rows = [VesselTrackRows(self, o) if self.ours[o] else None for o in range(no)]
        # each vessel's scan counter and label key at its previous row (none yet: every vessel's
        # first record tick writes a row, even an empty one, as the per-vessel log did)
        self._logged_scans = np.full(no, -1, dtype=np.int64)
        self._never = self.ours.copy()
        self._key = (np.zeros(no + 1, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros(0, dtype=bool), [])
        # the kernel's scratch (track_rows_into): the confirmed rows grouped by vessel, each vessel's
        # first position in them, and per vessel updated / changed label key
        self._rows = np.empty(64, dtype=np.int64)
        self._first_now = np.empty(no + 1, dtype=np.int64)
        self._updated, self._changed = np.zeros(no, dtype=bool), np.zeros(no, dtype=bool)
        # the buffered rows: per record tick with rows its time [s], each vessel's slice of the
        # positions (``first`` [o]:[o + 1]) and whether the vessel has a row; the labels of the rows
        # that carry them
        self._times = _Grown((), np.float64, 256)
        self._first = _Grown((no + 1,), np.int64, 256)
        self._has_row = _Grown((no,), bool, 256)
        self._xy_m = _Grown((2,), np.float64, 1024)
        self._labels: dict[tuple[int, int], list[str]] = {}  # (tick, owner) → the row's labels
        self._entered = np.zeros(no, dtype=bool)  # told to register with the recorder since its last flush
        self._registered = np.zeros(no, dtype=bool)  # registered (in its log's turn) since then
        self._uncounted = 0  # rows not yet counted with the recorder (counted at the next tick)

    # ------------------------------------------------------------------ each record tick
    def record(self, rec, t_s: float) -> None:
        """The record tick at t_s [s]: a row for each vessel whose tracker stepped since its previous
        row (module docstring); ``rec`` the :class:`~mjasc.runs.recording.Recorder` (counted rows)."""
        if self._uncounted:
            rec.count(self._uncounted)  # (the previous tick's rows: a flush between ticks)
            self._uncounted = 0
        if self._perception is not None:
            self._perception.flush()
        ft = self.tracker
        c = ft.cols
        n = c.confirmed.size
        if n > self._rows.size:
            self._rows = np.empty(2 * n, dtype=np.int64)
        xy, times = self._xy_m, self._times
        at, i = xy.n, times.n
        xy.reserve(n)  # (room for every row and the tick: the kernel writes them; kept if it has rows)
        self._first.reserve(1)
        self._has_row.reserve(1)
        times.reserve(1)
        times.n = self._first.n = self._has_row.n = i
        xy.n = at
        has_row = self._has_row.data[i]
        key = self._key
        k, n_rows, any_changed, aligned, any_new = track_rows_into(
            c.confirmed, c.owner, c.local_id, c.static, ft.bank.state_rows, self.ours, ft.scan_counts,
            self._logged_scans, self._never, self._entered, key[0], key[1], key[2], self._rows, self._first_now,
            xy.data, at, self._first.data[i], self._updated, has_row, self._changed)
        if k < 0:  # (no vessel stepped)
            return
        rows, first = self._rows[:k], self._first_now
        team = c.team[rows].tolist()
        if any_changed or not aligned or team != key[3]:  # (a label key changed somewhere: checked per vessel)
            self._new_keys(rows, team, has_row)
            n_rows = int(np.count_nonzero(has_row))
            any_changed = True
            any_new = True
        if not n_rows:
            return
        xy.n = at + k
        times.n = self._first.n = self._has_row.n = i + 1
        times.data[i] = t_s
        self._uncounted = n_rows
        if any_changed:
            names, labels, ids, static = self.names, self._labels, c.local_id, c.static
            for o in self._changed.nonzero()[0].tolist():
                r = rows[first[o]:first[o + 1]]
                labels[(i, o)] = track_labels(names[o], ids[r], team[first[o]:first[o + 1]], static[r])
        if any_new:  # (a vessel's first row since a flush: its log registers it in its own turn)
            new = has_row & ~self._entered
            self._entered |= new
            for o in new.nonzero()[0].tolist():
                self._logs[o].enter_track_rows(self.vessel_rows[o])

    def _new_keys(self, rows: np.ndarray, team: list, has_row: np.ndarray) -> None:
        """A label key changed somewhere (the kernel's ids and static flags, or the team mates of the
        whole fleet): mark the stepped vessels whose team mates changed too (``has_row``: a changed
        key always gives a row), and keep the stepped vessels' keys as their previous rows' — in a
        few whole-array operations whatever the number of vessels."""
        c = self.tracker.cols
        first, (key_first, key_ids, key_static, key_team) = self._first_now, self._key
        updated, changed = self._updated, self._changed
        k = first[-1]
        now, before = np.diff(first), np.diff(key_first)
        team_now = np.empty(k, dtype=object)
        team_now[:] = team
        team_before = np.empty(len(key_team), dtype=object)
        team_before[:] = key_team
        # the stepped vessels with as many rows as before and the same ids and flags: their team mates row by row
        same = updated & ~changed & (now == before)
        if same.any():
            at_now = _runs(first[:-1][same], now[same])
            at_before = _runs(key_first[:-1][same], now[same])
            differ = team_now[at_now] != team_before[at_before]
            if differ.any():
                vessels = np.repeat(same.nonzero()[0], now[same])[differ]
                changed[vessels] = has_row[vessels] = True
        # the new keys: the stepped vessels' rows now, the others' as before (rows now, then before, taken)
        counts = np.where(updated, now, before)
        new_first = np.zeros(len(counts) + 1, dtype=np.int64)
        np.cumsum(counts, out=new_first[1:])
        take = _runs(np.where(updated, first[:-1], key_first[:-1] + k), counts)
        self._key = (new_first, np.concatenate((c.local_id[rows], key_ids))[take],
                     np.concatenate((c.static[rows], key_static))[take],
                     np.concatenate((team_now, team_before))[take].tolist())

    # ------------------------------------------------------------------ the recorder's flush
    def vessel_points(self, owner: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, list]:
        """A vessel's buffered rows: their times (T,) [s], positions (Σk, 2) [m] in row order, the
        number of positions of each row (T,) int32 and each row's labels (None: unchanged)."""
        n = self._times.n
        ticks = self._has_row.data[:n, owner].nonzero()[0]
        starts = self._first.data[ticks, owner]
        per_row = (self._first.data[ticks, owner + 1] - starts).astype(np.int32)
        labels = self._labels
        return (self._times.data[ticks], self._xy_m.data[_runs(starts, per_row)], per_row,
                [labels.get((k, owner)) for k in ticks.tolist()])

    def registered(self, owner: int) -> None:
        """The vessel's rows are registered with the recorder (its log's turn of the tick)."""
        self._registered[owner] = True

    def clear(self) -> None:
        """Forget the buffered rows (the recorder wrote them); a vessel's next row registers again.
        A flush inside a record tick (the recorder's row count reached) keeps the tick's rows of
        the vessels whose logs have not registered them yet: they register after it."""
        pending = self._entered & ~self._registered
        kept = None
        if pending.any() and self._times.n:
            k = self._times.n - 1  # (the rows not registered yet are the latest tick's)
            first = self._first.data[k]
            lo, hi = int(first[0]), int(first[-1])
            kept = (self._times.data[k], first - lo, self._has_row.data[k] & pending, self._xy_m.data[lo:hi].copy(),
                    {(0, o): v for (j, o), v in self._labels.items() if j == k and pending[o]})
        self._times.n = self._first.n = self._has_row.n = self._xy_m.n = 0
        self._labels.clear()
        self._entered[:] = pending
        self._registered[:] = False
        if kept is not None:
            t, first, has_row, xy, labels = kept
            self._times.reserve(1)
            self._first.reserve(1)
            self._has_row.reserve(1)
            self._times.data[0], self._first.data[0], self._has_row.data[0] = t, first, has_row
            self._xy_m.reserve(len(xy))
            self._xy_m.data[:len(xy)] = xy
            self._labels.update(labels)


def _runs(starts: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """The indices of the runs ``starts[j]``, …, ``starts[j] + lengths[j] − 1``, laid end to end."""
    offsets = np.zeros(len(lengths), dtype=np.int64)
    np.cumsum(lengths[:-1], out=offsets[1:])
    return np.arange(int(lengths.sum()), dtype=np.int64) + np.repeat(starts - offsets, lengths)


def fleet_track_rows(agents) -> list[FleetTrackRows]:
    """The :class:`FleetTrackRows` of a run's vessels whose perception tracks with a fleet tracker (one
    per fleet tracker; a vessel with a plugin tracker logs its tracks itself). Their logs are told
    to leave the tracks' rows to them (:meth:`~mjasc.perception.recording.PerceptionLog.tracks_by_fleet`)."""
    groups: dict[int, tuple] = {}
    for agent in agents:
        p = agent.perception
        tracker = getattr(p, "_tracker", None) if getattr(p, "method", None) is None else None
        if tracker is None:
            continue
        ft = tracker.fleet
        group = groups.setdefault(id(ft), (ft, p.fleet, [], [], []))
        group[2].append(tracker.owner)
        group[3].append(agent.name)
        group[4].append(p.recording_log())
    out = []
    for ft, perception_fleet, owners, names, logs in groups.values():
        rows = FleetTrackRows(ft, owners, names, logs, perception_fleet)
        for log in logs:
            log.tracks_by_fleet()
        out.append(rows)
    return out


class VesselTrackRows:
    """One vessel's rows in a :class:`FleetTrackRows`, as the recorder's flush reads a point entity's
    buffered rows (:meth:`~mjasc.runs.recording.Recorder.point_rows`)."""

    __slots__ = ("fleet", "owner")

    def __init__(self, fleet: FleetTrackRows, owner: int):
        self.fleet, self.owner = fleet, owner

    def rows(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, list]:
        """Times (T,) [s], positions (Σk, 2) [m], points per row (T,) int32, labels per row (or None)."""
        return self.fleet.vessel_points(self.owner)

    def clear(self) -> None:
        """Called by the flush after reading every entity: the fleet's buffers are shared."""
        self.fleet.clear()

    def registered(self) -> None:
        """The recorder reads these rows at its next flush (their log registered them)."""
        self.fleet.registered(self.owner)
