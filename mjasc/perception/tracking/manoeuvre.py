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

from mjasc.core.compiled import kernel, maximum, minimum
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
        self._noise = (float(config.manoeuvre_heading_noise_rad2_s), float(config.manoeuvre_speed_noise_m2_s3))

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
        ones in ``bank`` for the cycle to t_s ((k,) per row [s]): the tracks past start-up in the same
        compiled call (:func:`manoeuvre_noise`), those in start-up through the bank's
        ``add_process_noise_rows``."""
        if self._off or rows.size == 0:
            return
        t_last, P, active = bank.noise_arrays()
        warm = np.empty(rows.size, dtype=np.int64)
        n_full, n_warm = manoeuvre_noise(rows, d2, gate if type(gate) is float else float(gate), *self._fading,
                                         self.cols.nis, self.cols.manoeuvring, t_s, t_last, P, active, *self._noise,
                                         warm)
        self.noise_added(rows, t_s, bank, n_full, n_warm, warm)

    def noise_args(self, bank: IMMBank) -> tuple:
        """What a compiled caller of :func:`manoeuvre_noise` passes after rows … gate and t_s, t_last (the bank's
        times) — (a, start, end, ε̄, manoeuvring, the bank's P, q_heading, q_speed) — led by whether the
        detector is on; it calls :meth:`noise_added` after."""
        return (not self._off, *self._fading, self.cols.nis, self.cols.manoeuvring, bank.noise_arrays()[1], *self._noise)

    def noise_added(self, rows, t_s, bank: IMMBank, n_full: int, n_warm: int, warm) -> None:
        """After :func:`manoeuvre_noise` of rows, t_s into ``bank`` (its returns n_full, n_warm and its
        positions ``warm``): the bank told of its changed P, and the manoeuvring tracks in start-up given
        theirs through the bank's ``add_process_noise_rows``."""
        if n_full:
            bank.noise_added()
        if n_warm:  # (manoeuvring tracks in start-up: their filters' velocity variances)
            cfg = self.config
            j = warm[:n_warm]
            w = rows[j]
            dt = np.maximum(t_s[j] - bank.noise_arrays()[0][w], 0.0)
            bank.add_process_noise_rows(w, cfg.manoeuvre_heading_noise_rad2_s * dt, cfg.manoeuvre_speed_noise_m2_s3 * dt)


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


@kernel
def manoeuvre_noise(rows, d2, gate, a, start, end, nis, man, t_s, t_last, P, active, q_heading, q_speed, warm):
    """:meth:`ManoeuvreDetector.detect` in one call: :func:`fade_nis` of rows, d2 (k,) (gate … man as
    there), then for each manoeuvring row k = rows[j] past start-up (``active[k]`` False) the process noise
    of its cycle to t_s[j] [s] from its last t_last[k] [s], Ts = max(t_s[j] − t_last[k], 0), added to every
    model's P[k, :, 2, 2] (q_heading·Ts [rad²]) and P[k, :, 3, 3] (q_speed·Ts [m²/s²]) in place — the
    bank's ``add_process_noise_rows`` of those rows (the same products and sums); the positions j of the
    manoeuvring rows in start-up written into warm (the caller adds theirs). Returns (the number of rows
    noise was added to, the number in start-up)."""
    k = rows.size
    hot = np.empty(k, dtype=np.bool_)
    n_full = n_warm = 0
    if fade_nis(rows, d2, gate, a, start, end, nis, man, hot) == 0:
        return 0, 0
    for j in range(k):
        if not hot[j]:
            continue
        r = rows[j]
        if active[r]:
            warm[n_warm] = j
            n_warm += 1
            continue
        dt = maximum(t_s[j] - t_last[r], 0.0)
        dth = q_heading * dt
        dv = q_speed * dt
        for m in range(P.shape[1]):
            P[r, m, 2, 2] += dth
        for m in range(P.shape[1]):
            P[r, m, 3, 3] += dv
        n_full += 1
    return n_full, n_warm
