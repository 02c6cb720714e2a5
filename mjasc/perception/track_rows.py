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

from mjasc.perception.tracking.step_kernels import confirmed_by_owner

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
        self._key = (np.zeros(no + 1, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros(0, dtype=bool),
                     np.zeros(0, dtype=object))  # (first (no + 1,), ids, static flags, team mates) grouped by vessel
        # the buffered rows: per record tick with rows its time [s], each vessel's slice of the
        # positions (first + the tick's offset) and whether the vessel has a row; the labels of
        # the rows that carry them
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
        scans = ft.scan_counts
        updated = scans != self._logged_scans
        updated &= self.ours
        if not updated.any():
            return
        c = ft.cols
        rows, first = confirmed_by_owner(c.confirmed, c.owner, ft.n_owners)
        key = (first, c.local_id[rows], c.static[rows], c.team[rows])
        changed = self._changed(updated, key)
        has_row = updated & (changed | (first[1:] != first[:-1]))
        np.copyto(self._logged_scans, scans, where=updated)
        if not has_row.any():
            return
        k = self._times.reserve(1)
        self._times.data[k] = t_s
        a = self._xy_m.reserve(rows.size)
        self._xy_m.data[a:a + rows.size] = ft.bank.positions_of(rows)
        self._first.reserve(1)
        np.add(first, a, out=self._first.data[k])
        self._has_row.reserve(1)
        self._has_row.data[k] = has_row
        if changed.any():
            names, labels = self.names, self._labels
            ids, static, team = key[1], key[2], key[3]
            for o in changed.nonzero()[0].tolist():
                s = slice(first[o], first[o + 1])
                labels[(k, o)] = track_labels(names[o], ids[s], team[s].tolist(), static[s])
        self._uncounted = int(np.count_nonzero(has_row))
        new = has_row & ~self._entered
        if new.any():  # (a vessel's first row since a flush: its log registers it in its own turn)
            self._entered |= new
            for o in new.nonzero()[0].tolist():
                self._logs[o].enter_track_rows(self.vessel_rows[o])

    def _changed(self, updated: np.ndarray, key: tuple) -> np.ndarray:
        """(no,) bool: the vessels ``updated`` whose label key ``key`` (first, ids, static flags, team
        mates, grouped by vessel) differs from the one at their previous row; the keys of the
        ``updated`` vessels become the previous rows' keys."""
        old = self._key
        never = self._never
        if not never.any() and _same_key(key, old):  # (nothing changed anywhere: the usual tick)
            return np.zeros_like(updated)
        changed = never & updated
        first, lf = key[0].tolist(), old[0].tolist()
        parts = []
        for o in range(len(first) - 1):  # (a changed key somewhere: per vessel)
            a, b, la, lb = first[o], first[o + 1], lf[o], lf[o + 1]
            if updated[o]:
                if not changed[o] and (b - a != lb - la or not _same_key(
                        (None, key[1][a:b], key[2][a:b], key[3][a:b]), (None, old[1][la:lb], old[2][la:lb],
                                                                        old[3][la:lb]), start=1)):
                    changed[o] = True
                parts.append((key, a, b))
            else:
                parts.append((old, la, lb))
        lengths = [b - a for _, a, b in parts]
        merged_first = np.zeros(len(parts) + 1, dtype=np.int64)
        np.cumsum(lengths, out=merged_first[1:])
        self._key = (merged_first, *(_concat([k[j][a:b] for k, a, b in parts], key[j]) for j in (1, 2, 3)))
        never &= ~updated
        return changed

    # ------------------------------------------------------------------ the recorder's flush
    def vessel_points(self, owner: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, list]:
        """A vessel's buffered rows: their times (T,) [s], positions (Σk, 2) [m] in row order, the
        number of positions of each row (T,) int32 and each row's labels (None: unchanged)."""
        n = self._times.n
        ticks = self._has_row.data[:n, owner].nonzero()[0]
        starts = self._first.data[ticks, owner]
        per_row = (self._first.data[ticks, owner + 1] - starts).astype(np.int32)
        total = int(per_row.sum())
        # the rows' position indices: each row's run starts..starts+k, laid end to end
        offsets = np.zeros(len(per_row), dtype=np.int64)
        np.cumsum(per_row[:-1], out=offsets[1:])
        index = np.arange(total, dtype=np.int64) + np.repeat(starts - offsets, per_row)
        labels = self._labels
        return (self._times.data[ticks], self._xy_m.data[index], per_row,
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


def _same_key(key: tuple, other: tuple, start: int = 0) -> bool:
    """Are two label keys (first, ids, static flags, team mates) equal (from field ``start`` on)?"""
    for a, b in zip(key[start:], other[start:]):
        if a.shape != b.shape or not (a == b).all():
            return False
    return True


def _concat(parts: list, like: np.ndarray) -> np.ndarray:
    return np.concatenate(parts) if parts else like[:0]


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
