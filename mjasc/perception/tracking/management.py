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
  shrink: an elongated hull looks narrow bow-on); a partly hidden (occluded) detection does not
  change it.
* **Static objects**: a confirmed track older than ``static_min_age_s`` whose speed estimate is
  below ``static_speed_m_s`` is static (``TrackEstimate.is_static``); it becomes moving again above
  twice that speed.

:class:`TrackManagement` holds these per-track arrays, rows aligned with the IMM bank's; it decides,
the tracker (:class:`mjasc.perception.tracking.tracker.MultiTargetTracker`) applies the decisions
to the bank and records the events.
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.perception.tracking.config import TrackingConfig

__all__ = ["TrackManagement"]


def _popcount_table(bits: int) -> np.ndarray:
    return np.array([bin(i).count("1") for i in range(1 << bits)], dtype=np.int64)


class TrackManagement:
    """Per-track management state, one row per bank row: update history (M of N), scans and
    updates since birth, confirmed / static flags, birth and last-update times [s], radius [m]."""

    _ROWS = ("_hist", "_scans", "_n_upd", "_confirmed", "_static", "_born", "_last", "_radius")

    def __init__(self, config: TrackingConfig):
        self.config = config
        self._window_mask = (1 << config.confirm_window) - 1
        self._popcount = _popcount_table(config.confirm_window)
        self._hist = np.zeros(0, dtype=np.int64)  # update history bits, newest = bit 0
        self._scans = np.zeros(0, dtype=np.int64)  # scans since birth (incl. the first)
        self._n_upd = np.zeros(0, dtype=np.int64)
        self._confirmed = np.zeros(0, dtype=bool)
        self._static = np.zeros(0, dtype=bool)
        self._born = np.zeros(0)
        self._last = np.zeros(0)
        self._radius = np.zeros(0)

    # ------------------------------------------------------------------ rows
    def append(self, t_s: float, radius: float) -> None:
        """A track born at t_s [s] from a detection of this radius [m] (its first update)."""
        self._hist = np.append(self._hist, 1)
        self._scans = np.append(self._scans, 1)
        self._n_upd = np.append(self._n_upd, 1)
        self._confirmed = np.append(self._confirmed, self.config.confirm_hits <= 1)
        self._static = np.append(self._static, False)
        self._born = np.append(self._born, t_s)
        self._last = np.append(self._last, t_s)
        self._radius = np.append(self._radius, radius)

    def keep(self, keep: np.ndarray) -> None:
        """Keep the rows where ``keep`` (n,) is True."""
        for name in self._ROWS:
            setattr(self, name, getattr(self, name)[keep])

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
    def radii_m(self) -> np.ndarray:
        """(n,) smoothed radius per track [m]."""
        return self._radius.copy()

    @property
    def born_s(self) -> np.ndarray:
        """(n,) birth time per track [s]."""
        return self._born.copy()

    # ------------------------------------------------------------------ per scan
    def after_update(self, t_s: float, used, assigned_det, rad, occ, speeds) -> np.ndarray:
        """Record the scan at t_s: ``used`` (n,) bool rows updated with their detection
        ``assigned_det`` (n,) of radii ``rad`` (m,) [m], occluded ``occ`` (m,); ``speeds`` (n,) the
        tracks' speeds after the update [m/s]. Returns (n,) bool: the tracks confirmed now."""
        cfg = self.config
        self._hist = ((self._hist << 1) | used) & self._window_mask
        self._scans += 1
        self._n_upd += used
        self._last = np.where(used, t_s, self._last)
        grow = used & ~occ[np.maximum(assigned_det, 0)] if occ.size else used
        if grow.any():
            r_new = rad[assigned_det[grow]]
            r_old = self._radius[grow]
            gain = np.where(r_new > r_old, cfg.radius_grow_gain, cfg.radius_shrink_gain)
            self._radius[grow] = r_old + gain * (r_new - r_old)
        new_conf = ~self._confirmed & (self._popcount[self._hist] >= cfg.confirm_hits)
        self._confirmed |= new_conf
        old = (t_s - self._born) >= cfg.static_min_age_s
        self._static = self._confirmed & old & np.where(self._static, speeds < 2 * cfg.static_speed_m_s,
                                                         speeds < cfg.static_speed_m_s)
        return new_conf

    def drops(self, t_s: float, positions, position_covariances, origin_m, max_range_m: float):
        """Which tracks go after the scan at t_s, given their positions (n, 2) [m] and position
        covariances (n, 2, 2) [m²], the sensor at ``origin_m`` (None: no range test) with range
        ``max_range_m`` [m].

        Returns (drop, reason, merged): drop (n,) bool; reason (n,) str, why a confirmed track is
        lost ('' for tentative tracks and merged confirmed ones); merged, the confirmed tracks
        merged into another, as (row, kept row) pairs in the order they were found.
        """
        cfg = self.config
        n = self._hist.size
        drop = np.zeros(n, dtype=bool)
        reason = [""] * n
        merged = []
        # tentative tracks that can no longer reach M of N
        misses = np.minimum(self._scans, cfg.confirm_window) - self._popcount[self._hist]
        hopeless = ~self._confirmed & (misses > cfg.confirm_window - cfg.confirm_hits)
        drop |= hopeless
        pos = positions
        Pc = position_covariances
        tr = 0.5 * (Pc[:, 0, 0] + Pc[:, 1, 1])
        lam = tr + np.sqrt(np.maximum(tr**2 - (Pc[:, 0, 0] * Pc[:, 1, 1] - Pc[:, 0, 1] ** 2), 0.0))
        conf = self._confirmed
        for k in np.flatnonzero(conf & (t_s - self._last > cfg.max_coast_s)):
            drop[k], reason[k] = True, f"not seen for {t_s - self._last[k]:.1f} s"
        for k in np.flatnonzero(conf & ~drop & (lam > cfg.max_position_std_m**2)):
            drop[k], reason[k] = True, f"position uncertainty {math.sqrt(lam[k]):.1f} m"
        if origin_m is not None and math.isfinite(max_range_m):
            rng = np.hypot(*(pos - np.asarray(origin_m)).T)
            out = rng > max_range_m + cfg.range_margin_m
            for k in np.flatnonzero(out & ~drop):
                drop[k], reason[k] = True, f"out of range ({rng[k]:.0f} m)"
        # duplicates: the track with fewer updates goes
        live = np.flatnonzero(~drop)
        if live.size > 1:
            p = pos[live]
            dd = np.hypot(*(p[:, None, :] - p[None, :, :]).transpose(2, 0, 1))
            lim = cfg.merge_fraction * np.maximum(self._radius[live][:, None], self._radius[live][None, :])
            ii, jj = np.nonzero(np.triu(dd < lim, 1))
            for a, b in zip(live[ii], live[jj]):
                if drop[a] or drop[b]:
                    continue
                keep, go = (a, b) if (conf[a], self._n_upd[a]) >= (conf[b], self._n_upd[b]) else (b, a)
                drop[go] = True
                reason[go] = ""
                if conf[go]:
                    merged.append((go, keep))
        return drop, reason, merged
