"""The fleet side of a Rerun recording: which vessels get their own views, their colours, and the
plot series of the vessels without views batched into one entity per kind.

Rerun's footer holds ~0.5 kB per entity and component, whatever the run's length. At standard
detail the vessels without per-vessel views (beyond :data:`~mjasc.runs.blueprint.MAX_VIEW_VESSELS`,
:meth:`VesselSeries.set_vessels`) share one entity per kind — ``world/vessels/_others/...`` an
instance per vessel, ``plots/<kind>/_others`` a series per vessel (``_others`` is
:data:`~mjasc.runs.blueprint.OTHERS`); ``full`` detail keeps an entity per vessel.

:class:`VesselSeries` is the base of :class:`mjasc.runs.recording.Recorder`, which supplies the
buffered rows these methods write into (``fleet_scalars``, ``fleet_points``, ``points``, ...).
"""

from __future__ import annotations

import numpy as np
import rerun as rr

from mjasc.runs.blueprint import OTHERS, legend_colour
from mjasc.runs.recording_columns import rgba, scalar_column, time_column

__all__ = ["VesselSeries"]


class VesselSeries:
    """The vessel-facing part of :class:`~mjasc.runs.recording.Recorder` (see the module docstring)."""

    def _init_vessels(self) -> None:
        #: Vessel name → RGB, set by the runner: components style their entities and plots with it.
        self.colours: dict[str, tuple[int, int, int]] = {}
        #: Vessels with per-vessel views (follow, body-frame sensor, threat panel); None: every vessel.
        #: Data only those views show is not logged for the others (a large fleet's recording size).
        self.view_vessels: frozenset[str] | None = None
        #: Standard detail: the vessels without views (in vessel order) whose plot series go into one
        #: entity per kind with a series each (:meth:`vessel_scalar`); set by :meth:`set_vessels`.
        self.batched: tuple[str, ...] = ()
        self._batch_index: dict[str, int] = {}
        self._batch_rows: dict[str, dict[float, np.ndarray]] = {}  # batch entity → time → row (NaN: none)
        self._batch_styles: dict[str, dict[int, tuple]] = {}  # batch entity → member → (name, colour, width)
        self._batch_styled: dict[str, tuple] = {}  # batch entity → style last written
        self._own_entities: dict[tuple[str, str], str] = {}  # (template, vessel) → entity (vessel_scalar)
        # (template, vessel) → its entity's buffered (times, values) in _scalars (vessel_scalar; until flush)
        self._own_buffers: dict[tuple[str, str], tuple[list, list]] = {}

    def set_vessels(self, names: tuple[str, ...], view_vessels) -> None:
        """The run's vessels and those with per-vessel views (:attr:`view_vessels`). At standard
        detail the others' plot series are batched (:meth:`vessel_scalar`): every entity costs
        ~0.5 kB of Rerun's footer per component, whatever the run's length."""
        self.view_vessels = frozenset(view_vessels)
        self.batched = () if self.full else tuple(n for n in names if n not in self.view_vessels)
        self._batch_index = {n: k for k, n in enumerate(self.batched)}

    def vessel_entity(self, template: str, vessel_name: str) -> str:
        """The entity of a vessel's series ``template`` (``"plots/speed/{}/actual"``): its own, or
        the batch entity (``{}`` → :data:`OTHERS`) of the vessels in :attr:`batched`."""
        return template.format(OTHERS if vessel_name in self._batch_index else vessel_name)

    def has_views(self, vessel_name: str) -> bool:
        """Does ``vessel_name`` get per-vessel views (:attr:`view_vessels`)?"""
        return self.view_vessels is None or vessel_name in self.view_vessels

    def colour(self, vessel_name: str, default=(200, 200, 200)) -> tuple[int, int, int]:
        """The vessel's colour (:attr:`colours`), ``default`` for an unknown vessel."""
        return self.colours.get(vessel_name, default)

    @staticmethod
    def legend_colour(class_id: int) -> tuple[int, int, int]:
        """The RGB of a legend overlay class (:data:`~mjasc.runs.blueprint.LEGEND_CLASSES`): components
        draw their overlays in the legend's colours."""
        return legend_colour(class_id)

    def vessel_style(self, vessel_name: str, entity: str, archetype) -> None:
        """The style of one of ``vessel_name``'s entities: written now for a vessel with views
        (:meth:`has_views`: its panels and follow view show every overlay's style, drawn or not),
        with the entity's first rows for the others (:meth:`style`)."""
        (self.static if self.has_views(vessel_name) else self.style)(entity, archetype)

    def vessel_series_style(self, template: str, vessel_name: str, name: str, colour=None, width: float = 1.5) -> None:
        """:meth:`series_style` of a vessel's series ``template`` (:meth:`vessel_entity`); a batched
        vessel's style is one series of its batch entity's style, written once at :meth:`flush`."""
        k = self._batch_index.get(vessel_name)
        if k is None:
            self.series_style(template.format(vessel_name), name, colour, width)
        else:
            self._batch_styles.setdefault(template.format(OTHERS), {})[k] = (name, colour, width)

    def vessel_scalar(self, template: str, vessel_name: str, t_s: float, value: float) -> None:
        """A vessel's value of the series ``template`` at t_s (:meth:`vessel_entity`): a row of its
        own entity, or its series' value in the row at t_s of the batch entity (the vessels in
        :attr:`batched`, one series each in vessel order; NaN where a vessel has no value)."""
        buffer = self._own_buffers.get((template, vessel_name))  # (the buffer scalar() appends to)
        if buffer is None:
            k = self._batch_index.get(vessel_name)
            if k is not None:
                self._batch_value(template.format(OTHERS), t_s, k, value)
                return
            entity = self._own_entities.get((template, vessel_name))
            if entity is None:
                entity = self._own_entities[(template, vessel_name)] = template.format(vessel_name)
            buffer = self._own_buffers[(template, vessel_name)] = self._scalars[entity]
        buffer[0].append(t_s)
        buffer[1].append(float(value))
        self._count(1)

    def batch_scalars(self, template: str, t_s: float, values) -> None:
        """The values (one per vessel of :attr:`batched`, in order) of the series ``template`` at
        t_s: the batch entity's row at t_s (the own vessels' values go to :meth:`fleet_scalars`)."""
        self._batch_rows.setdefault(template.format(OTHERS), {})[t_s] = np.array(values, dtype=np.float64)
        self._count(len(self.batched))

    def vessel_strips(self, template: str, entities: tuple[str, ...], t_s: float, strips_xy, z: float = 0.0) -> None:
        """:meth:`fleet_strips` of every vessel (strips (n, m, 2) in vessel order, ``entities`` from
        :meth:`vessel_entities`): the batched vessels' strips in one row of the batch entity."""
        s = np.asarray(strips_xy, dtype=np.float64)
        self.fleet_strips(entities, t_s, s[:len(entities)] if self.batched else s, z)
        if self.batched:
            self.strips(template.format(OTHERS), t_s, list(s[len(entities):]), z)

    def vessel_entities(self, template: str, names: tuple[str, ...]) -> tuple[str, ...]:
        """The own entities of ``template`` for the vessels of ``names`` that are not batched; the
        batched ones must come last (as :meth:`set_vessels` keeps them: views go to the first)."""
        own = tuple(n for n in names if n not in self._batch_index)
        assert tuple(names[len(own):]) == self.batched or not self.batched, "batched vessels come last"
        return tuple(template.format(n) for n in own)

    def _batch_value(self, entity: str, t_s: float, k: int, value: float) -> None:
        rows = self._batch_rows.setdefault(entity, {})
        row = rows.get(t_s)
        if row is None:
            row = rows[t_s] = np.full(len(self.batched), np.nan)
        row[k] = value
        self._count(1)

    def _write_batches(self, time_column=time_column) -> None:
        """Write the batch entities' buffered rows (:meth:`batch_scalars`), their times through
        ``time_column`` (the flush's :class:`~mjasc.runs.recording_columns.SharedTimes`)."""
        for entity, rows in self._batch_rows.items():
            styles = self._batch_styles.get(entity, {})
            style = tuple(styles.get(k, (n, self.colour(n), 1.5)) for k, n in enumerate(self.batched))
            if self._batch_styled.get(entity) != style:  # once (styles are set before the first row)
                self._batch_styled[entity] = style
                self.static(entity, rr.SeriesLines(names=[s[0] for s in style],
                                                   colors=[rgba(s[1] if s[1] is not None else (200, 200, 200))
                                                           for s in style],
                                                   widths=[s[2] for s in style]))
            if not rows:
                continue
            times = sorted(rows)
            data = np.stack([rows[t] for t in times])  # (T, batched)
            self.rec.send_columns(entity, indexes=[time_column(times)],
                                  columns=[scalar_column(data.reshape(-1), data.shape[1])])
            rows.clear()
