"""Rerun recordings: every run is a ``.rrd`` file with a default blueprint for timeline review.

Entities live in a 3-D world (ENU, z up, everything on z ≈ 0) viewed from above, because Rerun's
2-D views draw y downwards and the world frame here is y-north-up. Timeline: ``sim_time``
(simulation seconds). Two runs with the same scenario and seed write the same bytes: the recording
and blueprint store ids and the blueprint's view and container ids are derived from the scenario
name and seed, wall-clock log time is disabled, the recording properties (which hold the wall-clock
start time) are not sent, only the recording's name, the SDK's batcher cuts chunks by size only,
and :meth:`Recorder.close` re-encodes the finished file with derived row and chunk ids
(:mod:`mjasc.runs.rrd_canonical`: the SDK draws those from the wall clock).

The default blueprint and the legend are in :mod:`mjasc.runs.blueprint` (re-exported here).

**Detail.** ``[outputs] recording_detail`` (:data:`DETAILS`) says what the run's components log:
``standard`` (the default) is what a reviewer needs — hulls, trails, paths, speeds, thrust,
heading, cross-track, each vessel's confirmed tracks as one labelled point batch, the avoidance
mode, conflicts and detours, the formation plots, the event log — at about 0.1–0.5 MB per
vessel-minute; ``full`` adds the sensor returns and detections, track ellipses, discs and velocity
arrows, one time series per track (ω̂, V̂, mode probabilities), track births, every predicted
track and the detour's flow field (several MB per vessel-minute, growing with the tracks each
vessel holds). Components ask :attr:`Recorder.full`.

**Fleets.** At standard detail the vessels without per-vessel views share one entity per kind
(hull, position, trail, mission path; one series per vessel in each plot); their avoidance
overlays, tracks, map and mode lanes stay per vessel. ``full`` keeps an entity per vessel. That
part of the recorder is :class:`~mjasc.runs.recording_vessels.VesselSeries`, its base class.

**Buffered columns.** Nothing is written per row while the run goes: rows are buffered per entity
(or per group of entities that share their times, :meth:`Recorder.fleet_scalars` and friends: one
call per record tick for the whole fleet) and written column-wise with ``send_columns`` — one
chunk per entity and flush — when :data:`FLUSH_ROWS` rows have piled up and at :meth:`close`. A
``log`` per row costs ~0.5 ms in the Rerun SDK; a column costs that once. The truth's per-tick
fleet rows are not even buffered as rows: its record kernel writes them into preallocated arrays
(:mod:`mjasc.runs.fleet_columns`, :meth:`Recorder.fleet_columns`) that the flush reads whole (the
rows a record tick adds are counted at its end, so a flush comes between ticks). :meth:`Recorder.close`
always flushes, so a run that stops on an error keeps everything recorded until then.

**Few chunks.** Every chunk costs the SDK, the re-encoding (:mod:`mjasc.runs.rrd_canonical`) and
the footer, so a 10 s recording of 50 vessels is mostly chunks, not rows. Labels and strip colours
go into their points' or strips' chunk (null in the rows without: Rerun's latest-at skips null
rows, so those keep the latest labels, as Rerun's own chunk compaction writes them); a vessel
without views has its overlays' styles written with each overlay's first rows
(:meth:`Recorder.vessel_style`), and a point or strip entity whose rows are all empty and that
never drew anything is not written at all (empty rows only clear what was drawn: the overlays of
a vessel that never meets a conflict).
"""

from __future__ import annotations

import os
import uuid
import warnings
from collections import defaultdict
from itertools import chain
from pathlib import Path

import numpy as np
import pyarrow as pa
import rerun as rr
import rerun.blueprint as rrb

from mjasc.runs.blueprint import (LEGEND_CLASSES, MODE_STATES, OTHERS, PALETTE, annotation_context,  # noqa: F401
                                  default_blueprint, legend_classes, legend_colour, legend_markdown,
                                  stable_blueprint_ids, vessel_colour)
from mjasc.runs.fleet_columns import ColumnGroup
from mjasc.runs.outputs import no_room, part_path
from mjasc.runs.recording_columns import (TIMELINE, SharedTimes, concat_xy, flat_strip_column, packed_colours,
                                          points_column, rgba, scalar_column, sparse_column, stack_rows, strip_column,
                                          xyz_at)
from mjasc.runs.recording_vessels import VesselSeries
from mjasc.runs.rrd_canonical import BATCHER_FLUSH_BYTES
from mjasc.runs.rrd_closing import ReencodingError, close_canonical
from mjasc.runs.scenario import RECORDING_DETAILS as DETAILS

__all__ = ["Recorder", "default_blueprint", "TIMELINE", "DETAILS", "vessel_colour", "legend_classes",
           "annotation_context", "legend_markdown", "LEGEND_CLASSES", "OTHERS"]

#: Buffered rows (summed over entities; a fleet row of n vessels counts n) that trigger a flush.
FLUSH_ROWS = 1_000_000
#: How long :meth:`Recorder.close` waits for the SDK while the file does not grow [s]: its writer
#: thread, stopped by a full disk, may otherwise never answer (the SDK's flush then blocks for good).
SDK_FLUSH_TIMEOUT_S = 120.0
_FLUSH_STEP_S = 1.0  # (how often the file's growth and the disk's room are looked at meanwhile)


_ABANDONED: list = []  # SDK streams whose writer stopped (RecordingNotWritten): never dropped


class RecordingNotWritten(RuntimeError):
    """The SDK could not write the recording (a full disk); ``reason`` says why in a few words. The
    temporary file is removed and the SDK's stream abandoned (its flush and disconnect would block)."""

    def __init__(self, path, reason: str):
        super().__init__(f"{path}: {reason}")
        self.reason = reason


def size_only_batcher() -> rr.ChunkBatcherConfig:
    """The SDK's chunk batcher cutting chunks by size only, never by its wall-clock tick: the same
    data gives the same chunks (what :func:`~mjasc.runs.rrd_canonical.canonicalise` needs)."""
    return rr.ChunkBatcherConfig(flush_tick=1e9, flush_num_bytes=BATCHER_FLUSH_BYTES, flush_num_rows=2**63 - 1)


class Recorder(VesselSeries):
    """Writes one ``.rrd`` file. Buffered rows are written by :meth:`flush` / :meth:`close`.

    ``detail`` is one of :data:`DETAILS`; a Recorder made directly (tests, figures) records
    everything (``full``); the runner passes the scenario's ``[outputs] recording_detail``."""

    def __init__(self, path: str | Path, recording_name: str, seed: int, blueprint: rrb.Blueprint | None = None,
                 detail: str = "full"):
        if detail not in DETAILS:
            raise ValueError(f"detail: must be one of {', '.join(DETAILS)}, got {detail!r}")
        self.detail = detail
        self.full = detail == "full"
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._part = part_path(self.path)  # written here, renamed to path by close()
        rid = str(uuid.uuid5(uuid.NAMESPACE_URL, f"mjasc/{recording_name}/{seed}"))
        self._ids = (rid, str(uuid.uuid5(uuid.NAMESPACE_URL, f"mjasc/{recording_name}/{seed}/blueprint")))
        # No recording properties: they would carry the wall-clock start time; the name alone is sent.
        self.rec = rr.RecordingStream("mjasc", recording_id=rid, send_properties=False,
                                      batcher_config=size_only_batcher())
        self.rec.set_log_time_enabled(False)
        blueprint = blueprint or default_blueprint()
        stable_blueprint_ids(blueprint, f"mjasc/{recording_name}/{seed}/blueprint")
        self.rec.save(str(self._part), default_blueprint=blueprint)
        self.rec.send_recording_name(str(recording_name))
        self.rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        self._scalars: dict[str, tuple[list, list]] = defaultdict(lambda: ([], []))
        self._texts: dict[str, tuple[list, list, list]] = defaultdict(lambda: ([], [], []))
        # (entity, z) → times, rows and per row its labels / strip colours or None (the latest stay)
        self._points: dict[tuple, tuple[list, list, list]] = defaultdict(lambda: ([], [], []))
        self._strips: dict[tuple, tuple[list, list, list]] = defaultdict(lambda: ([], [], []))
        self._arrows: dict[tuple, tuple[list, list, list]] = defaultdict(lambda: ([], [], []))  # (entity, z)
        # (kind, entities, z) → (times, rows) lists, or a ColumnGroup (fleet_columns)
        self._fleet: dict[tuple, tuple[list, list] | ColumnGroup] = defaultdict(lambda: ([], []))
        self._states: dict[str, tuple[list, list]] = defaultdict(lambda: ([], []))  # StateChange
        self._documents: dict[str, tuple[list, list]] = defaultdict(lambda: ([], []))  # markdown TextDocument
        self._styles: dict[str, object] = {}  # entity → its static style, written with its first rows (style())
        self._drawn: set[str] = set()  # point and strip entities that had a row with something in it
        self._pending = 0
        self._closed = False
        self._init_vessels()

    # ---------------------------------------------------------------- immediate logging
    def static(self, entity: str, archetype) -> None:
        self.rec.log(entity, archetype, static=True)

    def style(self, entity: str, archetype) -> None:
        """The static style of ``entity`` (colours, radii, classes: an archetype's ``from_fields``
        without data), written with the entity's first rows (:meth:`flush`, :meth:`log`): an
        entity that never gets a row is not written at all (its style alone would cost a chunk
        and footer; most of a large fleet's overlays never show)."""
        self._styles[entity] = archetype

    def _write_style(self, entity: str) -> None:
        style = self._styles.pop(entity, None)
        if style is not None:
            self.rec.log(entity, style, static=True)

    def log(self, entity: str, archetype, t_s: float) -> None:
        """One row now (sporadic data only: each call costs ~0.5 ms)."""
        if self._styles:
            self._write_style(entity)
        self.rec.set_time(TIMELINE, duration=float(t_s))
        self.rec.log(entity, archetype)

    def series_style(self, entity: str, name: str, colour=None, width: float = 1.5) -> None:
        self.static(entity, rr.SeriesLines(names=name, colors=colour if colour is not None else [200, 200, 200],
                                           widths=width))

    # ---------------------------------------------------------------- buffered rows, one entity
    def event(self, t_s: float, text: str, level: str = "INFO", entity: str = "events") -> None:
        """A line in a text log (``events``: mode changes, detections, warnings)."""
        times, texts, levels = self._texts[entity]
        times.append(t_s)
        texts.append(text)
        levels.append(level)
        self._count(1)

    def state(self, entity: str, t_s: float, state: str) -> None:
        """A state change (``StateChange``: a lane of a state timeline view) at t_s."""
        times, states = self._states[entity]
        times.append(t_s)
        states.append(str(state))
        self._count(1)

    def document(self, entity: str, t_s: float, markdown: str) -> None:
        """A markdown document's new text at t_s (``TextDocument``; the view shows the latest)."""
        times, texts = self._documents[entity]
        times.append(t_s)
        texts.append(markdown)
        self._count(1)

    def scalar(self, entity: str, t_s: float, value: float) -> None:
        times, values = self._scalars[entity]
        times.append(t_s)
        values.append(float(value))
        self._pending += 1  # (_count(1) inlined)
        if self._pending >= FLUSH_ROWS:
            self.flush()

    def points(self, entity: str, t_s: float, positions_xy: np.ndarray, z: float = 0.0, labels=None) -> None:
        """A row of points (world xy [m] at height z); ``labels`` (one per point) in the same row.
        Rows without labels keep the latest labels (Rerun's latest-at), so labels need only be
        given when they change."""
        times, rows, label_rows = self._points[(entity, z)]
        times.append(t_s)
        rows.append(np.asarray(positions_xy, dtype=np.float64).reshape(-1, 2))
        label_rows.append(None if labels is None else list(labels))
        self._pending += 1  # (_count(1) inlined: a call per vessel and record tick)
        if self._pending >= FLUSH_ROWS:
            self.flush()

    def strips(self, entity: str, t_s: float, strips_xy: list[np.ndarray], z: float = 0.0, colours=None) -> None:
        """A row of line strips (each (m, 2) world xy [m], or an array (k, m, 2) of k strips) at height
        z; ``colours`` one RGB(A) per strip."""
        times, rows, colour_rows = self._strips[(entity, z)]
        times.append(t_s)
        if type(strips_xy) is np.ndarray and strips_xy.ndim == 3 and strips_xy.dtype == np.float64 and \
                strips_xy.shape[2] == 2:  # (k, m, 2): its rows as they are (what the conversion would give)
            rows.append(list(strips_xy))
        else:
            rows.append([np.asarray(s, dtype=np.float64).reshape(-1, 2) for s in strips_xy])
        colour_rows.append(None if colours is None else [rgba(c) for c in colours])
        self._count(1)

    def arrows(self, entity: str, t_s: float, origins_xy: np.ndarray, vectors_xy: np.ndarray, z: float = 0.0) -> None:
        times, origins, vectors = self._arrows[(entity, z)]
        times.append(t_s)
        origins.append(np.asarray(origins_xy, dtype=np.float64).reshape(-1, 2))
        vectors.append(np.asarray(vectors_xy, dtype=np.float64).reshape(-1, 2))
        self._count(1)

    # ---------------------------------------------------------------- buffered rows, one per entity of a group
    def fleet_scalars(self, entities: tuple[str, ...], t_s: float, values) -> None:
        """One scalar for each entity (values (n,)); a non-finite value is left out of its series."""
        self._fleet_row(("scalar", entities, 0.0), t_s, np.asarray(values, dtype=np.float64).reshape(len(entities)))

    def fleet_points(self, entities: tuple[str, ...], t_s: float, positions_xy, z: float = 0.0) -> None:
        """One point for each entity (positions (n, 2) world xy [m]) at height z."""
        self._fleet_row(("points", entities, z), t_s, np.asarray(positions_xy, dtype=np.float64).reshape(-1, 2))

    def fleet_strips(self, entities: tuple[str, ...], t_s: float, strips_xy, z: float = 0.0) -> None:
        """One line strip for each entity (strips (n, m, 2) world xy [m]; m may change between rows) at height z."""
        self._fleet_row(("strips", entities, z), t_s, np.asarray(strips_xy, dtype=np.float64))

    def fleet_columns(self, kind: str, entities: tuple[str, ...], group, z: float = 0.0) -> None:
        """Have the rows of the fleet group (``kind`` "scalar", "points" or "strips", one value per
        entity, as :meth:`fleet_scalars` and friends) read from ``group`` (a
        :class:`~mjasc.runs.fleet_columns.ColumnGroup`, filled by the caller) at :meth:`flush`, in
        the order of the groups' first rows as the per-tick calls. Register it with its first row
        and again after a flush (which clears it), and count its rows with :meth:`count`."""
        self._fleet[(kind, entities, z)] = group

    def count(self, rows: int) -> None:
        """``rows`` more buffered rows (of groups the caller fills: :meth:`fleet_columns`)."""
        self._count(rows)

    def _fleet_row(self, key: tuple, t_s: float, row: np.ndarray) -> None:
        times, rows = self._fleet[key]
        times.append(t_s)
        rows.append(row)
        self._count(len(key[1]))

    def _count(self, rows: int) -> None:
        self._pending += rows
        if self._pending >= FLUSH_ROWS:
            self.flush()

    # ---------------------------------------------------------------- writing
    def flush(self) -> None:
        """Write every buffered row column-wise (one chunk per entity) and empty the buffers; an
        entity's pending :meth:`style` goes just before its first rows."""
        send_columns = self.rec.send_columns
        time_column = SharedTimes()  # (the entities a record tick writes share their times: one column)

        def send(entity: str, indexes, columns) -> None:
            if self._styles:
                self._write_style(entity)
            send_columns(entity, indexes=indexes, columns=columns)
        for entity, (times, values) in self._scalars.items():
            send(entity, indexes=[time_column(times)], columns=[scalar_column(values)])
        for entity, (times, texts, levels) in self._texts.items():
            send(entity, indexes=[time_column(times)], columns=rr.TextLog.columns(text=texts, level=levels))
        for entity, (times, states) in self._states.items():
            send(entity, indexes=[time_column(times)], columns=rr.StateChange.columns(state=states))
        for entity, (times, texts) in self._documents.items():
            send(entity, indexes=[time_column(times)],
                 columns=rr.TextDocument.columns(text=texts, media_type=["text/markdown"] * len(texts)))
        for (entity, z), (times, rows, labels) in self._points.items():  # labels in the same chunk
            per_row = np.fromiter(map(len, rows), dtype=np.int32, count=len(rows))
            if not self._draws(entity, per_row.any()):
                continue
            columns = [points_column(concat_xy(rows), z, per_row)]
            if any(r is not None for r in labels):
                columns.append(sparse_column(rr.Points3D.descriptor_labels(), labels,
                                              lambda flat: pa.array(flat, pa.string())))
            send(entity, indexes=[time_column(times)], columns=columns)
        for (entity, z), (times, rows, colours) in self._strips.items():  # colours in the same chunk
            per_row = np.fromiter(map(len, rows), dtype=np.int32, count=len(rows))
            if not self._draws(entity, per_row.any()):
                continue
            columns = [strip_column(list(chain.from_iterable(rows)), z, per_row)]
            if any(r is not None for r in colours):
                columns.append(sparse_column(rr.LineStrips3D.descriptor_colors(), colours, packed_colours))
            send(entity, indexes=[time_column(times)], columns=columns)
        for (entity, z), (times, origins, vectors) in self._arrows.items():
            send(entity, indexes=[time_column(times)],
                 columns=rr.Arrows3D.columns(origins=xyz_at(concat_xy(origins), z),
                                             vectors=xyz_at(concat_xy(vectors), 0.0))
                 .partition([len(o) for o in origins]))
        for (kind, entities, z), buffer in self._fleet.items():
            if type(buffer) is tuple:  # (times, rows) lists
                times, rows = buffer
                t, data = np.asarray(times, dtype=np.float64), None
            else:  # a ColumnGroup (fleet_columns): its rows already in arrays
                rows = ()
                t, data = buffer.entity_first()
            index = [time_column(t)]  # (the group's entities share their times: one column for all)
            if kind == "strips":  # the strips of a row have the same length; rows may differ
                ones = np.ones(len(t), dtype=np.int32)
                if data is None and len({r.shape for r in rows}) == 1:  # every row alike (hulls): one stack
                    data = stack_rows(rows)  # (n, T, m, 2)
                if data is not None:
                    for entity, d in zip(entities, data):
                        send(entity, indexes=index, columns=[strip_column(d, z, ones)])
                    continue
                # rows (n, m_i, 2) of different m_i: every entity's points in one concatenation (n, Σm_i, 2)
                lengths = np.fromiter((r.shape[1] for r in rows), dtype=np.int32, count=len(rows))
                flat = np.concatenate(rows, axis=1)
                for entity, points in zip(entities, flat):
                    send(entity, indexes=index, columns=[flat_strip_column(points, lengths, z, ones)])
                continue
            if data is None:
                data = stack_rows(rows)  # (n, T, ...)
            if kind == "scalar":
                self._send_scalars(send, entities, t, index, data, time_column)
                continue
            for entity, d in zip(entities, data):
                send(entity, indexes=index, columns=[points_column(d, z, 1)])
        self._write_batches(time_column)
        for buffer in self._fleet.values():
            if type(buffer) is not tuple:
                buffer.clear()  # (after every group was read: groups may share their arrays)
        for buffer in (self._scalars, self._own_buffers, self._texts, self._states, self._documents, self._points,
                       self._strips, self._arrows, self._fleet):
            buffer.clear()
        self._pending = 0

    @staticmethod
    def _send_scalars(send, entities: tuple, t: np.ndarray, index: list, data: np.ndarray, time_column) -> None:
        """A fleet group's scalar rows (data (n, T), times t (T,) [s], their column ``index``), an
        entity each; a non-finite value is left out of its entity's series (its times through
        ``time_column``, the flush's :class:`~mjasc.runs.recording_columns.SharedTimes`)."""
        finite = np.isfinite(data)
        every = finite.all(axis=1).tolist()
        for j, entity in enumerate(entities):
            if every[j]:  # (no value left out: the group's times)
                send(entity, indexes=index, columns=[scalar_column(data[j])])
            elif (ok := finite[j]).any():
                send(entity, indexes=[time_column(t[ok])], columns=[scalar_column(data[j][ok])])

    def _draws(self, entity: str, anything: bool) -> bool:
        """Are the buffered point or strip rows of ``entity`` to be written? Not when every one
        is empty and the entity never showed anything: empty rows only clear what was drawn (an
        overlay of a vessel that never meets a conflict costs no chunk and no style)."""
        if anything:
            self._drawn.add(entity)
        return entity in self._drawn

    def close(self) -> None:
        """Flush, write the file footer (a reader needs it), re-encode the file with derived ids
        (:func:`~mjasc.runs.rrd_canonical.canonicalise`'s bytes; the re-encoding overlaps the
        SDK's last writes: :func:`~mjasc.runs.rrd_closing.close_canonical`) and rename it from its temporary name
        (``.recording.part.rrd``) to its own: a file under the final name is always complete.
        Should the re-encoding fail (a Rerun upgrade changed the container), the SDK's file is kept
        (same content, not the same bytes) with a warning. Safe to call twice."""
        if self._closed:
            return
        try:
            self.flush()
        finally:
            self._closed = True
            canonical = self._part.with_name(self._part.name + ".canonical")
            try:  # (the SDK's flush and disconnect, the re-encoding meanwhile: mjasc.runs.rrd_closing)
                close_canonical(self._part, canonical, self._ids, self._sdk_flush, self.rec.disconnect)
                os.replace(canonical, self._part)
            except RecordingNotWritten:  # (a full disk: nothing half-written is left)
                canonical.unlink(missing_ok=True)
                self._part.unlink(missing_ok=True)
                rr.unregister_shutdown()  # (its flush at exit would block on the abandoned stream,
                _ABANDONED.append(self.rec)  # and so would dropping it: kept until the process ends)
                raise
            except (ReencodingError, OSError) as e:  # the recording itself is complete either way
                canonical.unlink(missing_ok=True)
                e = e.__cause__ or e
                warnings.warn(f"{self.path}: recording kept as the Rerun SDK wrote it (not byte-reproducible): "
                              f"{type(e).__name__}: {e}", RuntimeWarning, stacklevel=2)
            os.replace(self._part, self.path)

    def _sdk_flush(self) -> None:
        """The SDK's flush, bounded (:data:`SDK_FLUSH_TIMEOUT_S`); a full disk is
        :class:`RecordingNotWritten` (its writer thread stopped: a flush could block for good)."""
        if no_room(self._part.parent):
            raise RecordingNotWritten(self.path, "no space left on device")
        size, still = -1, 0.0
        while True:
            try:
                self.rec.flush(timeout_sec=_FLUSH_STEP_S)
                return
            except RuntimeError as e:  # ("File-writer thread shut down prematurely", "Flush timed out")
                if no_room(self._part.parent):
                    raise RecordingNotWritten(self.path, "no space left on device") from e
                if "timed out" not in str(e):
                    raise RecordingNotWritten(self.path, f"the Rerun SDK could not write it ({e})") from e
                try:  # (a large recording on a slow disk: waited for while its file grows)
                    now = self._part.stat().st_size
                except OSError:
                    now = size
                still = still + _FLUSH_STEP_S if now == size else 0.0
                size = now
                if still >= SDK_FLUSH_TIMEOUT_S:
                    raise RecordingNotWritten(self.path, f"the Rerun SDK stopped writing it ({e})") from e

    def discard(self) -> None:
        """Stop recording and remove the temporary file: nothing under the final name (a recording
        whose producer failed midway; a run keeps its partial outputs instead, with its status)."""
        if self._closed:
            return
        self._closed = True
        try:
            self.rec.disconnect()
        finally:
            self._part.unlink(missing_ok=True)

    def __enter__(self) -> "Recorder":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
