"""MultiTargetTracker: the tracks of one vessel, one :meth:`~MultiTargetTracker.step` per scan —
association, the batched IMM update, track management, outlines and team mates (thesis §3.2.1,
docs/thesis.md §2; :mod:`mjasc.perception.tracking` for the whole procedure).

Every track of a vessel lives in one batched :class:`mjasc.perception.imm.IMMBank` (all tracks
predicted and updated in one call). One step:

1. gated GNN association of the scan's target detections with the tracks
   (:mod:`~mjasc.perception.tracking.association`), a partly hidden detection's variance inflated
   by the unseen part of the track's radius;
2. manoeuvre detection on the associated tracks (:mod:`~mjasc.perception.tracking.manoeuvre`);
3. **update** of every track at once: assigned tracks with their detection (and its σ²), the
   others coast (``IMMBank.update(z, t, mask, measurement_variance)``);
4. track management (:mod:`~mjasc.perception.tracking.management`): confirmation, radius, static
   test, outlines of slow tracks (:mod:`~mjasc.perception.tracking.outlines`), then losses and
   merges;
5. births from the detections that no track claimed and that lie outside every track's gate and
   disc;
6. team mates matched from their broadcasts (:mod:`~mjasc.perception.tracking.team`).

Events (born, confirmed, lost, merged, with the reason) are kept for the recording.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mjasc.core.estimates import TrackEstimate
from mjasc.perception.detection import Detections
from mjasc.perception.imm.bank import IMMBank
from mjasc.perception.tracking.association import association_costs, gnn_assign
from mjasc.perception.tracking.config import TrackingConfig
from mjasc.perception.tracking.management import TrackManagement
from mjasc.perception.tracking.manoeuvre import ManoeuvreDetector
from mjasc.perception.tracking.outlines import TrackOutlines
from mjasc.perception.tracking.team import TeamMatcher

__all__ = ["MultiTargetTracker", "TrackEvent"]


@dataclass(frozen=True)
class TrackEvent:
    time_s: float
    kind: str  # "born" | "confirmed" | "lost" | "merged"
    track_id: int
    text: str


class MultiTargetTracker:
    """The tracks of one vessel. ``step(t, detections, origin)`` once per scan; ``estimates()``."""

    def __init__(self, config: TrackingConfig = TrackingConfig(), max_range_m: float = math.inf):
        if not isinstance(config, TrackingConfig):
            raise ValueError(f"config: expected a TrackingConfig, got {type(config).__name__}")
        self.config = config
        self.max_range_m = float(max_range_m)
        self.bank = IMMBank(config.imm)
        self._R = float(config.imm.measurement_variance_m2)
        self._gate = config.gate_threshold
        self.events: list[TrackEvent] = []
        self.counts = {"born": 0, "confirmed": 0, "lost": 0, "merged": 0, "scans": 0, "detections": 0,
                       "associated": 0}
        # per-track state beside the bank's, rows aligned with bank.track_ids
        self._mgmt = TrackManagement(config)
        self._manoeuvres = ManoeuvreDetector(config)
        self._team = TeamMatcher(config)
        self._outlines = TrackOutlines(config)
        self.last_assignment: dict[int, int] = {}  # track id → detection index of the last step

    def __len__(self) -> int:
        return len(self.bank)

    # ------------------------------------------------------------------ association
    def association_costs(self, z: np.ndarray, var: np.ndarray, t_s: float) -> tuple[np.ndarray, np.ndarray]:
        """(n_tracks, m) squared Mahalanobis distances d²_ij and GNN costs d² + ln det S_ij for
        detections z (m, 2) with isotropic variances var (m,) or (n_tracks, m)
        (:func:`mjasc.perception.tracking.association.association_costs`)."""
        bank = self.bank
        return association_costs(bank.states, bank.state_covariances, bank.times_s, bank.turn_rates, z, var, t_s)

    # ------------------------------------------------------------------ one scan
    def step(self, t_s: float, detections: Detections | None, origin_m=None, use=None, points_m=None) -> None:
        """Process one scan at t_s: associate, update every track, manage the track list.

        ``detections`` None (no scan) only coasts. ``use`` (m,) bool selects the detections for
        tracking (default: ``detections.targets``, the non-extended ones). ``origin_m`` is the
        sensor position (for the out-of-range test). ``points_m`` (k, 2): the scan's returns in
        world coordinates, in the order of ``detections.labels`` (for the outlines of slow tracks).
        """
        cfg = self.config
        self.counts["scans"] += 1
        if detections is None:
            z = np.zeros((0, 2))
            var = rad = np.zeros(0)
            idx = np.zeros(0, dtype=int)
            occ = np.zeros(0, dtype=bool)
        else:
            sel = detections.targets if use is None else np.asarray(use, dtype=bool)
            idx = np.flatnonzero(sel)
            z = detections.centres_m[idx]
            var = detections.variances_m2[idx] if cfg.use_detection_variance else np.full(idx.size, self._R)
            rad = detections.radii_m[idx]
            occ = detections.occluded[idx] if detections.occluded is not None else np.zeros(idx.size, bool)
        m = z.shape[0]
        self.counts["detections"] += m
        n = len(self.bank)
        assigned_det = np.full(n, -1)
        claimed = np.zeros(m, dtype=bool)
        var_ij = np.zeros((n, m))
        if n and m:
            # a partly hidden object shows less than its width: its centre is off by up to the
            # unseen part of the track's radius
            radius = self._mgmt.radii_m
            var_ij = var[None, :] + occ[None, :] * np.maximum(radius[:, None] - rad[None, :], 0.0) ** 2
            d2, cost = self.association_costs(z, var_ij, t_s)
            inside = d2 <= self._gate
            assigned_det = gnn_assign(inside, cost)
            # a detection inside some track's gate does not start a track (split returns, near clutter)
            claimed = inside.any(axis=0)
            self._manoeuvres.detect(t_s, assigned_det, d2, self._gate, self.bank)
        if n:
            meas = assigned_det >= 0
            zr = np.full((n, 2), np.nan)
            vr = np.full(n, self._R)
            zr[meas] = z[assigned_det[meas]]
            vr[meas] = var_ij[meas, assigned_det[meas]]
            used = self.bank.update(zr, t_s, meas, vr if cfg.use_detection_variance else None)
            self.counts["associated"] += int(used.sum())
            self._after_update(t_s, used, assigned_det, rad, occ)
            if points_m is not None and detections is not None:
                self._outlines.grow(used, assigned_det, idx, detections.labels, points_m, self.bank.speeds,
                                    self.bank.positions, self._mgmt.radii_m)
            ids = self.bank.track_ids
            self.last_assignment = {int(ids[k]): int(idx[assigned_det[k]]) for k in np.flatnonzero(used)
                                    if assigned_det[k] >= 0}
        else:
            self.last_assignment = {}
        self._prune(t_s, origin_m)
        # births
        if m:
            free = ~claimed
            if len(self.bank) and free.any():
                pos = self.bank.positions
                dist = np.hypot(*(z[free][None, :, :] - pos[:, None, :]).transpose(2, 0, 1))
                near = (dist <= self._mgmt.radii_m[:, None] + rad[free][None, :]).any(axis=0)
                free[np.flatnonzero(free)[near]] = False
            for j in np.flatnonzero(free):
                sigma2 = var[j] if cfg.use_detection_variance else None
                tid = self.bank.add_track(z[j], t_s, measurement_variance=sigma2)
                self._append(t_s, rad[j])
                self.counts["born"] += 1
                self.events.append(TrackEvent(t_s, "born", tid, f"track {tid} born at {_fmt(z[j])}"))
                self.last_assignment[tid] = int(idx[j])
        self._team.match(t_s, self.bank.states, self._mgmt.confirmed)

    @property
    def manoeuvring(self) -> np.ndarray:
        """(n,) bool per bank row: the track is manoeuvring (its process noise is raised)."""
        return self._manoeuvres.manoeuvring

    def _append(self, t_s: float, radius: float) -> None:
        """Rows for the track just added to the bank."""
        self._mgmt.append(t_s, radius)
        self._manoeuvres.append()
        self._team.append()
        self._outlines.append(self.bank.positions[-1:])

    def _after_update(self, t_s, used, assigned_det, rad, occ) -> None:
        new_conf = self._mgmt.after_update(t_s, used, assigned_det, rad, occ, self.bank.speeds)
        ids = self.bank.track_ids
        born = self._mgmt.born_s
        for k in np.flatnonzero(new_conf):
            self.counts["confirmed"] += 1
            self.events.append(TrackEvent(t_s, "confirmed", int(ids[k]), f"track {ids[k]} confirmed at "
                                          f"{_fmt(self.bank.positions[k])} (born {t_s - born[k]:.1f} s ago)"))

    def _prune(self, t_s: float, origin_m) -> None:
        """Drop the tracks that management gives up (:meth:`TrackManagement.drops`), with events."""
        if len(self.bank) == 0:
            return
        ids = self.bank.track_ids
        conf = self._mgmt.confirmed
        drop, reason, merged = self._mgmt.drops(t_s, self.bank.positions, self.bank.position_covariances, origin_m,
                                                self.max_range_m)
        for go, keep in merged:
            self.counts["merged"] += 1
            self.events.append(TrackEvent(t_s, "merged", int(ids[go]), f"track {ids[go]} merged into "
                                          f"track {ids[keep]}"))
        for k in np.flatnonzero(drop):
            if conf[k] and reason[k]:
                self.counts["lost"] += 1
                self.events.append(TrackEvent(t_s, "lost", int(ids[k]), f"track {ids[k]} lost: {reason[k]}"))
            self.bank.remove_track(int(ids[k]))
        if drop.any():
            keep = ~drop
            for part in (self._mgmt, self._manoeuvres, self._team, self._outlines):
                part.keep(keep)

    # ------------------------------------------------------------------ team mates
    def set_team_positions(self, positions: dict) -> None:
        """``{name: (t_b [s], position (2,) [m])}``: the team's latest broadcast positions."""
        self._team.set_positions(positions)

    # ------------------------------------------------------------------ outputs
    @property
    def track_ids(self) -> np.ndarray:
        return self.bank.track_ids

    @property
    def confirmed(self) -> np.ndarray:
        """(n,) bool per bank row."""
        return self._mgmt.confirmed

    @property
    def radii_m(self) -> np.ndarray:
        return self._mgmt.radii_m

    @property
    def static(self) -> np.ndarray:
        return self._mgmt.static

    @property
    def team_members(self) -> list:
        return self._team.members

    def estimates(self, include_tentative: bool = False) -> list[TrackEstimate]:
        """TrackEstimate of every confirmed track (and tentative ones if asked)."""
        out = []
        ids = self.bank.track_ids
        confirmed, static, radius = self._mgmt.confirmed, self._mgmt.static, self._mgmt.radii_m
        team = self._team.members
        for k in range(ids.size):
            if not (confirmed[k] or include_tentative):
                continue
            outline = None
            if static[k] or self.bank.speeds[k] < self.config.static_speed_m_s:
                outline = self.outline(k)
            out.append(self.bank.estimate(int(ids[k]), float(radius[k]), is_static=bool(static[k]),
                                          team_member=team[k], outline_m=outline))
        return out

    def outline(self, row: int) -> np.ndarray:
        """(k, 2) CCW outline [m] of the track in bank row ``row``: the hull of its returns united
        with its reflection through the track's centre, or the 12-gon around its disc
        (:mod:`mjasc.perception.tracking.outlines`)."""
        return self._outlines.outline(row, self.bank.positions[row], self._mgmt.radii_m[row])

    def drain_events(self) -> list[TrackEvent]:
        ev, self.events = self.events, []
        return ev


def _fmt(p) -> str:
    return f"({p[0]:.1f}, {p[1]:.1f}) m"
