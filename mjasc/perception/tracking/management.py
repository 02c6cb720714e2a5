"""Track management of a vessel's tracker: the life of each track from birth to loss, and the
per-track quantities that are not the IMM's (:mod:`mjasc.perception.tracking`, items 4–6).

* **Confirmation (M of N).** A track is born *tentative* (from a detection that no track claimed
  and that lies outside every track's gate and disc); it is *confirmed* once it was updated in
  ``confirm_hits`` (M) of its last ``confirm_window`` (N) scans, and a tentative track that can no
  longer reach M of N is dropped silently (clutter).
* **Loss.** A confirmed track is *lost* when it was not updated for ``max_coast_s`` (occlusions
  shorter than that are coasted and recovered), when its 1-σ position uncertainty exceeds
  ``max_position_std_m``, or when its predicted position is out of sensor range (beyond
  ``max_range_m + range_margin_m``). Two tracks closer than ``merge_fraction`` × the larger radius
  describe one object: the one with fewer updates goes (confirmed before tentative).
* **Radius** per track: the detections' radii, smoothed asymmetrically (quick to grow, slow to
  shrink: an elongated hull looks narrow bow-on); a partly hidden (occluded) detection only grows
  it (what is seen of an object is a lower bound of its size: a boat emerging from behind a quay
  is first seen as a sliver, and a track that kept that sliver's radius had a tracked disc too
  small to keep the boat's returns out of the static map).
* **Static objects**: a confirmed track older than ``static_min_age_s`` whose speed estimate is
  below ``static_speed_m_s`` is static (``TrackEstimate.is_static``); it becomes moving again above
  twice that speed.
* **Moved**: where a track was when first seen confirmed; once it is ``MOVED_M`` from there it has
  *moved* (a boat that stops stays a boat: the perception keeps its returns out of the static map).

Rows belong to vessels (a fleet's tracker, :mod:`mjasc.perception.tracking.fleet`): every decision
is per row, but for merging, which pairs only tracks of the same vessel.

:class:`TrackManagement` holds these per-track arrays, rows aligned with the IMM bank's; it decides,
the tracker (:class:`mjasc.perception.tracking.tracker.MultiTargetTracker`) applies the decisions
to the bank and records the events.
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.compiled import kernel
from mjasc.perception.tracking.config import TrackingConfig
from mjasc.perception.tracking.loss_kernels import (drop_rows, every_drop_rows, every_drops_into,
                                                    lost_reason)
from mjasc.perception.tracking.track_columns import TrackColumns, column

__all__ = ["TrackManagement", "MOVED_M", "scan_rows", "moved_rows"]

#: A confirmed track that moved this far from where it was confirmed has moved (stays "moving") [m].
MOVED_M = 3.0


def _popcount_table(bits: int) -> np.ndarray:
    return np.array([bin(i).count("1") for i in range(1 << bits)], dtype=np.int64)


class TrackManagement:
    """Per-track management state, one row per bank row: update history (M of N), scans and
    updates since birth, confirmed / static / moved flags, birth and last-update times [s], radius
    [m], where it was first seen confirmed [m] — columns of a
    :class:`~mjasc.perception.tracking.track_columns.TrackColumns` (``columns``: a tracker's store,
    whose births and drops it makes; None: a store of its own, changed by :meth:`append`, :meth:`keep`)."""

    _ROWS = ("_hist", "_scans", "_n_upd", "_confirmed", "_static", "_born", "_last", "_radius", "_anchor",
             "_anchored", "_moved")

    def __init__(self, config: TrackingConfig, columns: TrackColumns | None = None):
        self.config = config
        self._window_mask = (1 << config.confirm_window) - 1
        self._popcount = _popcount_table(config.confirm_window)
        self._drop_bufs = (np.empty(0, dtype=bool), np.empty(0, dtype=np.int64), np.empty(0))  # (drops_every)
        # drop_rows' constants (drops_every)
        self._window, self._hits = int(config.confirm_window), int(config.confirm_hits)
        self._max_coast, self._max_var = float(config.max_coast_s), float(config.max_position_std_m**2)
        self._margin, self._fraction = float(config.range_margin_m), float(config.merge_fraction)
        # (every_drops_into's constants after the columns)
        self.drop_constants = (self._popcount, self._window, self._hits, self._max_coast, self._max_var, self._margin,
                               self._fraction)
        self.cols = TrackColumns(config.confirm_hits <= 1) if columns is None else columns
        #: :func:`scan_rows`' constants: (popcount table, window mask, grow and shrink gains, M, static
        #: minimum age [s], static speed [m/s])
        self.scan_constants = (self._popcount, self._window_mask, float(config.radius_grow_gain),
                               float(config.radius_shrink_gain), int(config.confirm_hits),
                               float(config.static_min_age_s), float(config.static_speed_m_s))

    # the store's columns (views: stale after a birth or drop)
    _hist = column("hist")  # update history bits, newest = bit 0
    _scans = column("scans")  # scans since birth (incl. the first)
    _n_upd = column("n_upd")
    _confirmed = column("confirmed")
    _static = column("static")
    _born = column("born")
    _last = column("last")
    _radius = column("radius")
    _anchor = column("anchor")
    _anchored = column("anchored")
    _moved = column("moved")

    # ------------------------------------------------------------------ rows
    def append(self, t_s, radius) -> None:
        """Tracks born at t_s [s] (scalar or (k,)) from detections of radius [m] (k,) (their first
        update): new rows of the store (:meth:`TrackColumns.append`)."""
        self.cols.append(t_s, radius)

    def keep(self, keep: np.ndarray) -> None:
        """Keep the rows where ``keep`` (n,) is True (:meth:`TrackColumns.keep`)."""
        self.cols.keep(keep)

    # ------------------------------------------------------------------ read-outs
    @property
    def confirmed(self) -> np.ndarray:
        """(n,) bool."""
        return self._confirmed.copy()

    @property
    def static(self) -> np.ndarray:
        """(n,) bool: confirmed, old enough and slow (see the module docstring)."""
        return self._static.copy()

    @property
    def moved(self) -> np.ndarray:
        """(n,) bool: confirmed and once ``MOVED_M`` from where it was first seen confirmed."""
        return self._moved.copy()

    @property
    def radii_m(self) -> np.ndarray:
        """(n,) smoothed radius per track [m]."""
        return self._radius.copy()

    @property
    def born_s(self) -> np.ndarray:
        """(n,) birth time per track [s]."""
        return self._born.copy()

    @property
    def n_updates(self) -> np.ndarray:
        return self._n_upd.copy()

    # ------------------------------------------------------------------ per scan
    def after_update(self, rows, t_s, used, assigned_det, rad, occ, speeds) -> np.ndarray:
        """Record the scan of the tracks ``rows`` (indices or a slice) at t_s ((k,) or scalar [s]):
        ``used`` (k,) bool rows updated with their detection ``assigned_det`` (k,) (index into
        the detections' radii ``rad`` [m] and occluded flags ``occ``); ``speeds`` (k,) the tracks'
        speeds after the update [m/s]. Returns (k,) bool: the tracks confirmed now. (One compiled
        pass, :func:`scan_rows`; tests/test_tracking_fleet_store.py keeps the numpy form.)"""
        c = self.cols
        idx = np.arange(c.n)[rows] if isinstance(rows, slice) else rows
        t = np.full(idx.size, float(t_s)) if np.ndim(t_s) == 0 else t_s
        new_conf = np.empty(idx.size, dtype=bool)
        scan_rows(idx, t, used, assigned_det, rad, occ, speeds, c.hist, c.scans, c.n_upd, c.last,
                  c.radius, c.confirmed, c.static, c.born, *self.scan_constants, new_conf)
        return new_conf

    def drops(self, rows, group, t_s, positions, position_covariances, origins_m, max_range_m):
        """Which of the tracks ``rows`` (k,) (indices, or a slice) go after their scan at t_s ((k,) or scalar [s]), given
        their vessel ``group`` (k,) (only tracks of one vessel merge), positions (k, 2) [m] and
        position covariances (k, 2, 2) [m²], their sensor at ``origins_m`` (k, 2) (NaN: no range
        test) with range ``max_range_m`` (k,) [m]; rows are in bank order.

        Returns (drop, reason, merged): drop (k,) bool; reason (k,) str, why a confirmed track is
        lost ('' for tentative tracks and merged confirmed ones); merged, the confirmed tracks
        merged into another, as (position in rows, kept position) pairs in the order found.
        """
        cfg, cols = self.config, self.cols
        k = positions.shape[0]
        idx = np.arange(cols.n)[rows] if isinstance(rows, slice) else rows
        t = np.full(k, float(t_s)) if np.ndim(t_s) == 0 else t_s
        mr = np.full(k, float(max_range_m)) if np.ndim(max_range_m) == 0 else max_range_m
        drop, code, lam, since, rng, go, kept = drop_rows(
            idx, t, np.ascontiguousarray(group, dtype=np.int64), cols.hist, cols.scans, cols.confirmed, cols.last,
            cols.n_upd, cols.radius, self._popcount, position_covariances, positions, origins_m, mr,
            int(cfg.confirm_window), int(cfg.confirm_hits), float(cfg.max_coast_s), float(cfg.max_position_std_m**2),
            float(cfg.range_margin_m), float(cfg.merge_fraction))
        return drop, _reasons(k, code, lam, since, rng), list(zip(go.tolist(), kept.tolist()))

    def drops_all(self, group, pos_of, t_o, states, covariances, origins_m, max_range_m):
        """:meth:`drops` of every row, each row's values gathered from its vessel's in the same compiled
        call (:func:`every_drop_rows`): ``group`` (n,) each row's vessel, ``pos_of`` (n_owners,) its
        position among the scanning vessels (every vessel scanned), t_o (p,) [s] and ``origins_m``
        (p, 2) [m] per position, states (n, ≥ 2) [m] (the first two columns: positions) and
        covariances (n, ≥ 2, ≥ 2) [m²] per row, ``max_range_m`` (n_owners,) [m] per vessel. Returns
        what :meth:`drops` does."""
        cfg, cols = self.config, self.cols
        drop, code, lam, since, rng, go, kept = every_drop_rows(
            group, pos_of, t_o, states, covariances, origins_m, max_range_m, cols.hist, cols.scans, cols.confirmed,
            cols.last, cols.n_upd, cols.radius, self._popcount, int(cfg.confirm_window), int(cfg.confirm_hits),
            float(cfg.max_coast_s), float(cfg.max_position_std_m**2), float(cfg.range_margin_m),
            float(cfg.merge_fraction))
        return drop, _reasons(group.size, code, lam, since, rng), list(zip(go.tolist(), kept.tolist()))

    def drops_every(self, group, pos_of, t_o, states, covariances, origins_m, max_range_m):
        """:meth:`drops_all` (arguments as there) in the form a fleet tracker's step reads: (drop (n,)
        bool, the number dropped, lost, merged) — lost: the confirmed tracks lost, as (row, reason)
        pairs in row order (the rows where :meth:`drops_all`'s reason is not ''); merged as there.
        One compiled call writing into the manager's buffers (:func:`every_drops_into`)."""
        n = group.size
        bufs = self.drop_buffers(n)
        args = self.drop_args(group, pos_of, t_o, states, covariances, origins_m, max_range_m)
        L, g, n_drop = every_drops_into(*args, *bufs)
        return self.drops_read(bufs, n, L, g, n_drop)

    def drop_args(self, group, pos_of, t_o, states, covariances, origins_m, max_range_m) -> tuple:
        """:func:`every_drops_into`'s arguments before its buffers: the step's (those of
        :meth:`drops_every`), then the columns' and the drop constants."""
        cols = self.cols
        return (group, pos_of, t_o, states, covariances, origins_m, max_range_m, cols.hist, cols.scans, cols.confirmed,
                cols.last, cols.n_upd, cols.radius, *self.drop_constants)

    def drop_buffers(self, n: int) -> tuple:
        """(drop, ints, vals): the buffers :func:`every_drops_into` writes n rows' drops into, grown
        when too small (each array a kernel returns is an object made)."""
        bufs = self._drop_bufs
        if bufs[0].size < n:
            m = n + max(16, n // 2)
            bufs = self._drop_bufs = (np.empty(m, dtype=bool), np.empty(4 * m, dtype=np.int64), np.empty(3 * m))
        return bufs

    def drops_read(self, bufs, n: int, L: int, g: int, n_drop: int) -> tuple:
        """:meth:`drops_every`'s value from what :func:`every_drops_into` (into ``bufs`` of
        :meth:`drop_buffers`, which always have room) returned: L lost, g merged, n_drop dropped."""
        if g < 0:
            raise RuntimeError(f"track management: drop buffers of {bufs[1].size} ints too small for {n} rows")
        drop, ints, vals = bufs[0][:n], bufs[1][:2 * L + 2 * g], bufs[2][:3 * L].reshape(3, L)
        if not (L or g):
            return drop, n_drop, (), ()
        il = ints.tolist()
        lost = []
        if L:
            lam, since, rng = vals.tolist()
            for a, (j, c) in enumerate(zip(il[:L], il[L:2 * L])):
                lost.append((j, lost_reason(c, lam[a], since[a], rng[a])))
        return drop, n_drop, lost, list(zip(il[2 * L:2 * L + g], il[2 * L + g:]))

    def note_moved(self, positions: np.ndarray) -> None:
        """After a scan: anchor the tracks confirmed for the first time where they are (positions
        (n, ≥ 2) [m]: the first two columns), and mark the confirmed ones now ``MOVED_M`` from their
        anchor as moved (one compiled pass, :func:`moved_rows`)."""
        if type(positions) is not np.ndarray or positions.dtype != np.float64:
            positions = np.asarray(positions, dtype=float)
        if positions.ndim != 2:  # (no tracks: an empty list of positions)
            positions = positions.reshape(-1, 2)
        c = self.cols
        moved_rows(positions, c.confirmed, c.anchored, c.anchor, c.moved, MOVED_M)


def _reasons(k: int, code, lam, since, rng) -> list:
    """Why each of k rows is lost ('' for none), from :func:`drop_rows`' codes and values."""
    reason = [""] * k
    for j in code.nonzero()[0].tolist():  # why the confirmed ones are lost
        reason[j] = lost_reason(code[j], lam[j], since[j], rng[j])
    return reason


@kernel
def scan_rows(idx, t, used, assigned, rad, occ, speeds, hist, scans, n_upd, last, radius, confirmed, static, born,
              popcount, window_mask, grow_gain, shrink_gain, confirm_hits, min_age, static_speed, new_conf):
    """:meth:`TrackManagement.after_update` of the rows ``idx`` (k,) in place, per row in the order
    of its numpy form: history bits, counters, last update time, the radius smoothed towards the
    detection's (an occluded one only grows it), confirmation (new_conf (k,) written) and the static flag."""
    for j in range(idx.size):
        k = idx[j]
        u = used[j]
        h = ((hist[k] << 1) | u) & window_mask
        hist[k] = h
        scans[k] += 1
        n_upd[k] += u
        if u:
            last[k] = t[j]
            a = assigned[j]
            r_new, r_old = rad[a], radius[k]
            if r_new > r_old:  # (a partly hidden object is at least as large as what is seen of it)
                radius[k] = r_old + grow_gain * (r_new - r_old)
            elif occ.size == 0 or not occ[max(a, 0)]:
                radius[k] = r_old + shrink_gain * (r_new - r_old)
        conf = confirmed[k]
        nc = not conf and popcount[h] >= confirm_hits
        conf = conf or nc
        confirmed[k] = conf
        new_conf[j] = nc
        old = (t[j] - born[k]) >= min_age
        slow = speeds[j] < 2 * static_speed if static[k] else speeds[j] < static_speed
        static[k] = conf and old and slow


@kernel
def moved_rows(positions, confirmed, anchored, anchor, moved, moved_m):
    """:meth:`TrackManagement.note_moved` per row, in place: a confirmed row not anchored yet is
    anchored at its position (n, ≥ 2) [m]; an anchored one is moved once
    ``hypot(x − anchor_x, y − anchor_y) ≥ moved_m``."""
    for k in range(confirmed.size):
        if confirmed[k] and not anchored[k]:
            anchor[k, 0] = positions[k, 0]
            anchor[k, 1] = positions[k, 1]
            anchored[k] = True
        if anchored[k] and math.hypot(positions[k, 0] - anchor[k, 0], positions[k, 1] - anchor[k, 1]) >= moved_m:
            moved[k] = True
