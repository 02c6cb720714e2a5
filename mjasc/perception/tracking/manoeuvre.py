"""Manoeuvre detection and adjustable process noise for a vessel's tracks (Bar-Shalom, Li &
Kirubarajan 2001, §11.2; :mod:`mjasc.perception.tracking`).

The normalized innovation squared of each associated detection, ε = d²_ij (χ²₂, mean 2, under the
filter's own model; :func:`mjasc.perception.tracking.association.association_costs`), is averaged
with fading factor α: ``ε̄ ← α ε̄ + (1 − α) min(ε, gate)``. While ε̄ exceeds
``manoeuvre_threshold`` the track manoeuvres beyond what the IMM's models explain (a speed change:
every model has the same tiny Q_V; a turn sharper than the fastest model), until it falls below
``manoeuvre_end_threshold`` (hysteresis: the filter keeps following the change while the average
decays); each of its cycles then gets the extra process noise diag(Q_θ,m, Q_V,m)·Ts
(:meth:`mjasc.perception.imm.bank.IMMBank.add_process_noise`), so the speed (course) estimate
follows within a second instead of the track coasting on at its old speed out of its own gate.
With ``manoeuvre_speed_noise_m2_s3 = manoeuvre_heading_noise_rad2_s = 0`` the detector is off.
"""

from __future__ import annotations

import numpy as np

from mjasc.core.compiled import kernel, minimum
from mjasc.perception.imm.bank import IMMBank
from mjasc.perception.tracking.config import TrackingConfig
from mjasc.perception.tracking.track_columns import TrackColumns, column

__all__ = ["ManoeuvreDetector"]


class ManoeuvreDetector:
    """Per track (rows aligned with the bank's): the faded average ε̄ of the normalized innovation
    squared (2: no manoeuvre) and whether the track manoeuvres — columns of a
    :class:`~mjasc.perception.tracking.track_columns.TrackColumns` (``columns``: a tracker's store;
    None: a store of its own)."""

    def __init__(self, config: TrackingConfig, columns: TrackColumns | None = None):
        self.config = config
        self.cols = TrackColumns(config.confirm_hits <= 1) if columns is None else columns
        self._off = config.manoeuvre_speed_noise_m2_s3 == 0 and config.manoeuvre_heading_noise_rad2_s == 0
        self._fading = (float(config.manoeuvre_fading), float(config.manoeuvre_threshold),
                        float(config.manoeuvre_end_threshold))  # (fade_nis' a, start, end)

    # the store's columns (views: stale after a birth or drop)
    _nis = column("nis")  # faded average of the normalized innovation squared (2: no manoeuvre)
    _man = column("manoeuvring")  # manoeuvring (between the start and end thresholds)

    def append(self, k: int = 1) -> None:
        """k new tracks: ε̄ = 2, not manoeuvring (new rows of the store: :meth:`TrackColumns.append`)."""
        self.cols.append(0.0, np.zeros(k))

    def keep(self, keep: np.ndarray) -> None:
        """Keep the rows where ``keep`` (n,) is True (:meth:`TrackColumns.keep`)."""
        self.cols.keep(keep)

    @property
    def manoeuvring(self) -> np.ndarray:
        """(n,) bool: the track is manoeuvring (its process noise is raised)."""
        return self.cols.manoeuvring.copy()

    def detect(self, rows, d2, gate: float, t_s, bank: IMMBank) -> None:
        """Update ε̄ of the tracks ``rows`` (indices) that have a detection, of squared Mahalanobis
        distance ``d2`` (each capped at ``gate``), and raise the process noise of the manoeuvring
        ones in ``bank`` for the cycle to t_s (scalar or per row [s])."""
        cfg = self.config
        if self._off or rows.size == 0:
            return
        hot = np.empty(rows.size, dtype=bool)
        n_hot = fade_nis(rows, d2, gate if type(gate) is float else float(gate), *self._fading, self.cols.nis,
                         self.cols.manoeuvring, hot)
        if n_hot:
            hot_rows = rows[hot]
            t_hot = t_s[hot] if type(t_s) is np.ndarray and t_s.ndim else t_s  # (np.ndim(t_s) without its calls)
            dt = np.maximum(t_hot - bank.times_s[hot_rows], 0.0)
            # (dt ≥ 0 and the config's noise levels ≥ 0: the checked form of add_process_noise)
            bank.add_process_noise_rows(hot_rows, cfg.manoeuvre_heading_noise_rad2_s * dt,
                                        cfg.manoeuvre_speed_noise_m2_s3 * dt)


@kernel
def fade_nis(rows, d2, gate, a, start, end, nis, man, hot):
    """:meth:`ManoeuvreDetector.detect`'s average and hysteresis per row k = rows[j], in place, in
    the order of its numpy form: ``ε̄_k = a·ε̄_k + (1 − a)·minimum(d2_j, gate)``; manoeuvring
    while ε̄ ≥ ``end`` once it was, from ε̄ > ``start`` on (hot (k,) written). Returns the number
    manoeuvring. (tests/test_tracking_step_kernels.py keeps the numpy form.)"""
    n = 0
    for j in range(rows.size):
        k = rows[j]
        v = a * nis[k] + (1.0 - a) * minimum(d2[j], gate)
        nis[k] = v
        m = v >= end if man[k] else v > start
        man[k] = m
        hot[j] = m
        n += m
    return n
