"""Multi-target tracking for one vessel: detections → IMM tracks (thesis §3.2.1, digest §2).

Every track of a vessel lives in one batched :class:`mjasc.perception.imm.IMMBank` (all tracks predicted and
updated in one call). One :meth:`MultiTargetTracker.step` per scan:

1. **Prediction and gating.** Each track's combined estimate predicted to the scan time (one EKF
   step with ω̂), ẑ_i with covariance J P Jᵀ, plus the detection's own isotropic variance σ_j²:
   ``S_ij = J_i P_i J_iᵀ + σ_j²·I`` and ``d²_ij = (z_j − ẑ_i)ᵀ S_ij⁻¹ (z_j − ẑ_i)``. A pair is
   admissible when ``d²_ij ≤ −2 ln(1 − gate_probability)`` (chi-square, 2 dof). (The bank then
   gates again on its own models when it updates.)
2. **Global nearest neighbour** association: ``scipy.optimize.linear_sum_assignment`` on the cost
   ``d²_ij + ln det S_ij`` (−2 log-likelihood up to a constant); inadmissible pairs cost a large
   constant and are dropped from the solution. Each track takes at most one detection per scan
   and vice versa.
3. **Update** of every track at once: assigned tracks with their detection (and its σ²), the
   others coast (``IMMBank.update(z, t, mask, measurement_variance)``).
4. **Track management.** A track is born *tentative* from a detection that no track claimed and
   that lies outside every track's gate and disc; it is *confirmed* once it was updated in
   ``confirm_hits`` (M) of its last ``confirm_window`` (N) scans, and a tentative track that can no
   longer reach M of N is dropped silently (clutter). A confirmed track is *lost* when it was not
   updated for ``max_coast_s`` (occlusions shorter than that are coasted and recovered), when its
   1-σ position uncertainty exceeds ``max_position_std_m``, or when its predicted position is out
   of sensor range (beyond ``max_range_m + range_margin_m``). Two tracks closer than
   ``merge_fraction`` × the larger radius describe one object: the one with fewer updates goes.
5. **Radius** per track: the detections' radii, smoothed asymmetrically (quick to grow, slow to
   shrink: an elongated hull looks narrow bow-on).
6. **Static objects**: a confirmed track older than ``static_min_age_s`` whose speed estimate is
   below ``static_speed_m_s`` is static (``TrackEstimate.is_static``); it becomes moving again above
   twice that speed. **Outline from the returns**: while a track is slower than
   ``static_speed_m_s`` the world-frame returns of its detections (``step(..., points_m=...)``) are
   accumulated as the convex hull of everything seen of it (returns farther than
   ``1.5·R + 0.5 m`` from its centre — another object's, merged into one cluster — are left out);
   the accumulation restarts when the track moves (faster than twice that speed, or its centre
   more than ``outline_reset_m`` from where the accumulation started). The outline handed on
   (``TrackEstimate.outline_m``, for every confirmed track slower than ``static_speed_m_s``) is that
   hull united with its reflection through the track's centre (a hull is roughly point-symmetric
   about midships; only the side facing the sensor is ever seen at once); without returns, the
   12-gon circumscribing the track's disc.
7. **Team mates** are tracked like anything else; :meth:`set_team_positions` receives the team's
   broadcast positions ``{name: (t_b, position)}`` and each confirmed track is matched (GNN, gate
   ``team_match_distance_m``) against them, comparing the broadcast with the track's position
   extrapolated back to t_b; a match sets ``TrackEstimate.team_member``.

Events (born, confirmed, lost, with the reason) are kept for the recording.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import linear_sum_assignment

from mjasc.core.config_tables import ConfigError, boolean, dataclass_from_table, integer, number, show
from mjasc.perception.detection import DetectionConfig, Detections
from mjasc.core.estimates import TrackEstimate
from mjasc.perception.imm import IMMBank, IMMConfig, parse_imm_options

__all__ = ["TrackingConfig", "MultiTargetTracker", "TrackEvent", "parse_tracking_options"]

_BIG = 1e9


@dataclass(frozen=True)
class TrackingConfig:
    """Track management parameters (SI). Defaults in docs/perception.md.

    imm: the IMM bank (thesis Table 6.1 defaults). With ``use_detection_variance`` (default) each
        update uses the σ² of its detection, and ``imm.measurement_variance_m2`` only seeds
        association before a first update.
    detection: clustering and centre estimation (:class:`mjasc.perception.detection.DetectionConfig`).
    gate_probability: association gate (chi-square, 2 dof).
    confirm_hits, confirm_window: M-of-N confirmation (updated in M of the last N scans).
    max_coast_s: a confirmed track not updated for this long is lost [s].
    max_position_std_m: a track whose 1-σ position uncertainty exceeds this is lost [m].
    range_margin_m: a track predicted beyond the sensor's range + this margin is dropped [m].
    merge_fraction: two tracks closer than this × the larger radius are merged.
    static_speed_m_s, static_min_age_s: static-object test (speed below, age above).
    radius_grow_gain, radius_shrink_gain: smoothing gains of a track's radius per scan.
    team_match_distance_m: gate between a track and a team mate's broadcast position [m].
    team_max_age_s: broadcasts older than this are not used [s].
    map_cell_m, map_min_hits: static map cell size [m] and scans needed to occupy a cell
        (:mod:`mjasc.perception.static_map`).
    outline_reset_m: a slow track's outline (the hull of its returns) restarts when its centre has
        moved this far from where the accumulation started [m].
    manoeuvre_fading, manoeuvre_threshold: manoeuvre detector (MultiTargetTracker._detect_manoeuvres):
        fading factor α of the average of the normalized innovations squared, and the level of
        that average (2 without a manoeuvre) above which the track is manoeuvring;
        manoeuvre_end_threshold: the level below which the manoeuvre has ended (hysteresis).
    manoeuvre_speed_noise_m2_s3, manoeuvre_heading_noise_rad2_s: process noise intensities added
        to every model's Q_V, Q_θ while a track manoeuvres (0 and 0: detector off).
    """

    imm: IMMConfig = field(default_factory=IMMConfig)
    detection: DetectionConfig = field(default_factory=DetectionConfig)
    use_detection_variance: bool = True
    gate_probability: float = 0.9999
    confirm_hits: int = 4
    confirm_window: int = 6
    max_coast_s: float = 10.0
    max_position_std_m: float = 10.0
    range_margin_m: float = 5.0
    merge_fraction: float = 0.5
    static_speed_m_s: float = 0.2
    static_min_age_s: float = 10.0
    radius_grow_gain: float = 0.3
    radius_shrink_gain: float = 0.02
    team_match_distance_m: float = 5.0
    team_max_age_s: float = 5.0
    map_cell_m: float = 1.0
    map_min_hits: int = 3
    outline_reset_m: float = 1.5
    manoeuvre_fading: float = 0.8
    manoeuvre_threshold: float = 6.0
    manoeuvre_end_threshold: float = 3.0
    manoeuvre_speed_noise_m2_s3: float = 0.5
    manoeuvre_heading_noise_rad2_s: float = 0.01

    def __post_init__(self):
        _check_tracking(self, "tracking")

    @property
    def gate_threshold(self) -> float:
        p = self.gate_probability
        return math.inf if p >= 1.0 else -2.0 * math.log1p(-p)


#: TrackingConfig's numeric fields by their bounds (every float field is in exactly one group).
_POSITIVE = ("max_coast_s", "max_position_std_m", "map_cell_m", "outline_reset_m")
_NONNEG = ("range_margin_m", "merge_fraction", "static_speed_m_s", "static_min_age_s", "team_match_distance_m",
           "team_max_age_s", "manoeuvre_threshold", "manoeuvre_end_threshold", "manoeuvre_speed_noise_m2_s3",
           "manoeuvre_heading_noise_rad2_s")
_UNIT_INTERVAL = ("gate_probability", "radius_grow_gain", "radius_shrink_gain")  # (0, 1]


def _check_tracking(c: TrackingConfig, where: str) -> None:
    """Validate a :class:`TrackingConfig` (ConfigError, a ValueError, naming ``f"{where}.{key}"``)."""
    def bad(key, reason, value):
        raise ConfigError(f"{where}.{key}: {reason}, got {show(value)}")

    if not isinstance(c.imm, IMMConfig):
        bad("imm", "must be an IMMConfig", c.imm)
    if not isinstance(c.detection, DetectionConfig):
        bad("detection", "must be a DetectionConfig", c.detection)
    boolean(c.use_detection_variance, f"{where}.use_detection_variance")
    integer(c.map_min_hits, f"{where}.map_min_hits", minimum=1)
    for key in ("confirm_hits", "confirm_window"):
        integer(getattr(c, key), f"{where}.{key}", minimum=1, maximum=30)
    if c.confirm_hits > c.confirm_window:
        bad("confirm_hits", f"must be ≤ confirm_window ({c.confirm_window})", c.confirm_hits)
    for key in _POSITIVE:
        number(getattr(c, key), f"{where}.{key}", positive=True)
    for key in _NONNEG:
        number(getattr(c, key), f"{where}.{key}", nonneg=True)
    for key in _UNIT_INTERVAL:
        number(getattr(c, key), f"{where}.{key}", positive=True, maximum=1.0)
    if not number(c.manoeuvre_fading, f"{where}.manoeuvre_fading", nonneg=True) < 1.0:
        bad("manoeuvre_fading", "must be < 1", c.manoeuvre_fading)
    if c.manoeuvre_end_threshold > c.manoeuvre_threshold:
        bad("manoeuvre_end_threshold", f"must be ≤ manoeuvre_threshold ({c.manoeuvre_threshold})",
            c.manoeuvre_end_threshold)


def _check_detection(c: DetectionConfig, where: str) -> None:
    """DetectionConfig's own checks (its ``__post_init__``, whose messages name the table
    ``detection``), addressed to ``where``."""
    try:
        DetectionConfig.__post_init__(c)
    except ValueError as exc:
        msg = str(exc)
        raise ConfigError(where + msg[len("detection"):] if msg.startswith("detection.") else f"{where}: {msg}") from None


def parse_tracking_options(table: dict, where: str = "tracking") -> TrackingConfig:
    """Validate a scenario's ``[vessels.tracking]`` table (None: all defaults; optional ``imm`` and
    ``detection`` sub-tables) into a :class:`TrackingConfig`. Unknown keys, wrong types and
    out-of-range values raise ValueError naming ``f"{where}.{key}"``
    (:func:`mjasc.core.config_tables.dataclass_from_table`)."""
    return dataclass_from_table(TrackingConfig, {} if table is None else table, where, {
        "imm": parse_imm_options,
        "detection": lambda t, w: dataclass_from_table(DetectionConfig, t, w, check=_check_detection),
    }, check=_check_tracking)


@dataclass(frozen=True)
class TrackEvent:
    time_s: float
    kind: str  # "born" | "confirmed" | "lost" | "merged"
    track_id: int
    text: str


def _popcount_table(bits: int) -> np.ndarray:
    return np.array([bin(i).count("1") for i in range(1 << bits)], dtype=np.int64)


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
        self._window_mask = (1 << config.confirm_window) - 1
        self._popcount = _popcount_table(config.confirm_window)
        self._team: dict[str, tuple[float, np.ndarray]] = {}
        self.events: list[TrackEvent] = []
        self.counts = {"born": 0, "confirmed": 0, "lost": 0, "merged": 0, "scans": 0, "detections": 0,
                       "associated": 0}
        # per-track metadata, rows aligned with bank.track_ids
        self._hist = np.zeros(0, dtype=np.int64)  # update history bits, newest = bit 0
        self._scans = np.zeros(0, dtype=np.int64)  # scans since birth (incl. the first)
        self._n_upd = np.zeros(0, dtype=np.int64)
        self._confirmed = np.zeros(0, dtype=bool)
        self._static = np.zeros(0, dtype=bool)
        self._born = np.zeros(0)
        self._last = np.zeros(0)
        self._radius = np.zeros(0)
        self._team_of: list[str | None] = []
        self._nis = np.zeros(0)  # faded average of the normalized innovation squared (2: no manoeuvre)
        self._man = np.zeros(0, dtype=bool)  # manoeuvring (between the start and end thresholds)
        self._hull: list[np.ndarray | None] = []  # per track: hull vertices (k, 2) of its returns [m]
        self._hull_anchor = np.zeros((0, 2))  # per track: its centre when the hull was started
        self.last_assignment: dict[int, int] = {}  # track id → detection index of the last step

    _META = ("_hist", "_scans", "_n_upd", "_confirmed", "_static", "_born", "_last", "_radius", "_nis", "_man")

    def __len__(self) -> int:
        return len(self.bank)

    # ------------------------------------------------------------------ association
    def association_costs(self, z: np.ndarray, var: np.ndarray, t_s: float) -> tuple[np.ndarray, np.ndarray]:
        """(n_tracks, m) squared Mahalanobis distances d²_ij and GNN costs d² + ln det S_ij for
        detections z (m, 2) with isotropic variances var (m,) or (n_tracks, m).

        The prediction is that of each track's *combined* estimate (one EKF step of thesis eq. 3.3
        with ω̂, not the r models: association needs ẑ and S, not the mixture; 10× cheaper):
        ``ẑ = p + Ts·V·[cos, sin](θ + ω̂ Ts/2)``, ``S = J P Jᵀ + σ_j² I`` with J the position rows of
        the transition Jacobian.
        """
        bank = self.bank
        x = bank.states
        P = bank.state_covariances
        dt = np.maximum(t_s - bank.times_s, 0.0)
        th_mid = x[:, 2] + 0.5 * dt * bank.turn_rates
        c, s = np.cos(th_mid), np.sin(th_mid)
        dv = dt * x[:, 3]
        zhat = x[:, :2] + np.stack([dv * c, dv * s], axis=-1)
        J = np.zeros((x.shape[0], 2, 4))
        J[:, 0, 0] = J[:, 1, 1] = 1.0
        J[:, 0, 2], J[:, 0, 3] = -dv * s, dt * c
        J[:, 1, 2], J[:, 1, 3] = dv * c, dt * s
        S = J @ P @ np.swapaxes(J, 1, 2)
        var = np.broadcast_to(var, (S.shape[0], z.shape[0]))
        a = S[:, 0, 0, None] + var
        b = S[:, 0, 1, None]
        d = S[:, 1, 1, None] + var
        det = a * d - b * b
        y = z[None, :, :] - zhat[:, None, :]
        y0, y1 = y[..., 0], y[..., 1]
        d2 = (d * y0 * y0 - 2.0 * b * y0 * y1 + a * y1 * y1) / det
        return d2, d2 + np.log(det)

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
            var_ij = var[None, :] + occ[None, :] * np.maximum(self._radius[:, None] - rad[None, :], 0.0) ** 2
            d2, cost = self.association_costs(z, var_ij, t_s)
            inside = d2 <= self._gate
            if inside.any():
                rows, cols = linear_sum_assignment(np.where(inside, cost, _BIG))
                ok = inside[rows, cols]
                assigned_det[rows[ok]] = cols[ok]
            # a detection inside some track's gate does not start a track (split returns, near clutter)
            claimed = inside.any(axis=0)
        if n and m:
            self._detect_manoeuvres(t_s, assigned_det, d2)
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
                self._grow_outlines(used, assigned_det, idx, detections.labels, points_m)
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
                near = (dist <= self._radius[:, None] + rad[free][None, :]).any(axis=0)
                free[np.flatnonzero(free)[near]] = False
            for j in np.flatnonzero(free):
                tid = self.bank.add_track(z[j], t_s, measurement_variance=var[j] if cfg.use_detection_variance else None)
                self._append(t_s, rad[j])
                self.counts["born"] += 1
                self.events.append(TrackEvent(t_s, "born", tid, f"track {tid} born at {_fmt(z[j])}"))
                self.last_assignment[tid] = int(idx[j])
        self._match_team(t_s)

    def _detect_manoeuvres(self, t_s: float, assigned_det, d2) -> None:
        """Manoeuvre detection and adjustable process noise (Bar-Shalom, Li & Kirubarajan 2001,
        §11.2). The normalized innovation squared of each associated detection, ε = d²_ij (χ²₂,
        mean 2, under the filter's own model), is averaged with fading factor α:
        ε̄ ← α ε̄ + (1 − α) min(ε, gate). While ε̄ exceeds ``manoeuvre_threshold`` the track
        manoeuvres beyond what the IMM's models explain (a speed change: every model has the same
        tiny Q_V; a turn sharper than the fastest model), until it falls below
        ``manoeuvre_end_threshold`` (hysteresis: the filter keeps following the change while the
        average decays); each of its cycles then gets the extra process
        noise diag(Q_θ,m, Q_V,m)·Ts (:meth:`mjasc.perception.imm.IMMBank.add_process_noise`), so the speed
        (course) estimate follows within a second instead of the track coasting on at its old
        speed out of its own gate."""
        cfg = self.config
        if cfg.manoeuvre_speed_noise_m2_s3 == 0 and cfg.manoeuvre_heading_noise_rad2_s == 0:
            return
        rows = np.flatnonzero(assigned_det >= 0)
        if rows.size == 0:
            return
        eps = np.minimum(d2[rows, assigned_det[rows]], self._gate)
        a = cfg.manoeuvre_fading
        self._nis[rows] = a * self._nis[rows] + (1.0 - a) * eps
        nis = self._nis[rows]
        self._man[rows] = np.where(self._man[rows], nis >= cfg.manoeuvre_end_threshold, nis > cfg.manoeuvre_threshold)
        hot = rows[self._man[rows]]
        if hot.size:
            dt = np.maximum(t_s - self.bank.times_s[hot], 0.0)
            self.bank.add_process_noise(hot, cfg.manoeuvre_heading_noise_rad2_s * dt,
                                        cfg.manoeuvre_speed_noise_m2_s3 * dt)

    @property
    def manoeuvring(self) -> np.ndarray:
        """(n,) bool per bank row: the track is manoeuvring (its process noise is raised)."""
        return self._man.copy()

    def _append(self, t_s: float, radius: float) -> None:
        self._hist = np.append(self._hist, 1)
        self._scans = np.append(self._scans, 1)
        self._n_upd = np.append(self._n_upd, 1)
        self._confirmed = np.append(self._confirmed, self.config.confirm_hits <= 1)
        self._static = np.append(self._static, False)
        self._born = np.append(self._born, t_s)
        self._last = np.append(self._last, t_s)
        self._radius = np.append(self._radius, radius)
        self._nis = np.append(self._nis, 2.0)
        self._man = np.append(self._man, False)
        self._team_of.append(None)
        self._hull.append(None)
        self._hull_anchor = np.vstack([self._hull_anchor, self.bank.positions[-1:]])

    def _after_update(self, t_s, used, assigned_det, rad, occ) -> None:
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
        ids = self.bank.track_ids
        for k in np.flatnonzero(new_conf):
            self.counts["confirmed"] += 1
            self.events.append(TrackEvent(t_s, "confirmed", int(ids[k]), f"track {ids[k]} confirmed at "
                                          f"{_fmt(self.bank.positions[k])} (born {t_s - self._born[k]:.1f} s ago)"))
        self._confirmed |= new_conf
        speed = self.bank.speeds
        old = (t_s - self._born) >= cfg.static_min_age_s
        self._static = self._confirmed & old & np.where(self._static, speed < 2 * cfg.static_speed_m_s,
                                                         speed < cfg.static_speed_m_s)

    def _grow_outlines(self, used, assigned_det, idx, labels, points_m) -> None:
        """Add the returns of each slow track's detection to the hull of its returns (see the
        module docstring, item 6); restart it when the track moves."""
        cfg = self.config
        v = self.bank.speeds
        pos = self.bank.positions
        moved = np.hypot(*(pos - self._hull_anchor).T) > cfg.outline_reset_m
        for k in np.flatnonzero((v > 2.0 * cfg.static_speed_m_s) | moved):
            self._hull[k] = None
            self._hull_anchor[k] = pos[k]
        rows = np.flatnonzero(used & (assigned_det >= 0) & (v < cfg.static_speed_m_s))
        if rows.size == 0:
            return
        labels = np.asarray(labels)
        points_m = np.asarray(points_m, dtype=float).reshape(-1, 2)
        for k in rows:
            p = points_m[labels == idx[assigned_det[k]]]
            p = p[np.hypot(*(p - pos[k]).T) <= 1.5 * self._radius[k] + 0.5]
            if p.shape[0] == 0:
                continue
            if self._hull[k] is None:
                self._hull_anchor[k] = pos[k]
            else:
                p = np.vstack([self._hull[k], p])
            self._hull[k] = _hull_vertices(p)

    def _prune(self, t_s: float, origin_m) -> None:
        cfg = self.config
        n = len(self.bank)
        if n == 0:
            return
        ids = self.bank.track_ids
        drop = np.zeros(n, dtype=bool)
        reason = [""] * n
        # tentative tracks that can no longer reach M of N
        misses = np.minimum(self._scans, cfg.confirm_window) - self._popcount[self._hist]
        hopeless = ~self._confirmed & (misses > cfg.confirm_window - cfg.confirm_hits)
        drop |= hopeless
        pos = self.bank.positions
        Pc = self.bank.position_covariances
        tr = 0.5 * (Pc[:, 0, 0] + Pc[:, 1, 1])
        lam = tr + np.sqrt(np.maximum(tr**2 - (Pc[:, 0, 0] * Pc[:, 1, 1] - Pc[:, 0, 1] ** 2), 0.0))
        conf = self._confirmed
        for k in np.flatnonzero(conf & (t_s - self._last > cfg.max_coast_s)):
            drop[k], reason[k] = True, f"not seen for {t_s - self._last[k]:.1f} s"
        for k in np.flatnonzero(conf & ~drop & (lam > cfg.max_position_std_m**2)):
            drop[k], reason[k] = True, f"position uncertainty {math.sqrt(lam[k]):.1f} m"
        if origin_m is not None and math.isfinite(self.max_range_m):
            rng = np.hypot(*(pos - np.asarray(origin_m)).T)
            out = rng > self.max_range_m + cfg.range_margin_m
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
                reason[go] = f"merged into track {ids[keep]}"
                if conf[go]:
                    self.counts["merged"] += 1
                    self.events.append(TrackEvent(t_s, "merged", int(ids[go]), f"track {ids[go]} merged into "
                                                  f"track {ids[keep]}"))
                    reason[go] = ""
        for k in np.flatnonzero(drop):
            if conf[k] and reason[k]:
                self.counts["lost"] += 1
                self.events.append(TrackEvent(t_s, "lost", int(ids[k]), f"track {ids[k]} lost: {reason[k]}"))
            self.bank.remove_track(int(ids[k]))
        if drop.any():
            keep = ~drop
            for name in self._META:
                setattr(self, name, getattr(self, name)[keep])
            self._team_of = [x for x, k in zip(self._team_of, keep) if k]
            self._hull = [x for x, k in zip(self._hull, keep) if k]
            self._hull_anchor = self._hull_anchor[keep]

    # ------------------------------------------------------------------ team mates
    def set_team_positions(self, positions: dict) -> None:
        """``{name: (t_b [s], position (2,) [m])}``: the team's latest broadcast positions."""
        self._team = {str(k): (float(v[0]), np.asarray(v[1], dtype=float).reshape(2)) for k, v in positions.items()}

    def _match_team(self, t_s: float) -> None:
        n = len(self.bank)
        self._team_of = [None] * n
        if not self._team or n == 0:
            return
        cfg = self.config
        names = [k for k, (tb, _) in self._team.items() if t_s - tb <= cfg.team_max_age_s]
        rows = np.flatnonzero(self._confirmed)
        if not names or rows.size == 0:
            return
        x = self.bank.states[rows]
        vel = x[:, 3, None] * np.stack([np.cos(x[:, 2]), np.sin(x[:, 2])], axis=-1)
        tb = np.array([self._team[k][0] for k in names])
        pb = np.array([self._team[k][1] for k in names])
        back = x[:, None, :2] - vel[:, None, :] * (t_s - tb)[None, :, None]
        dist = np.hypot(*(back - pb[None, :, :]).transpose(2, 0, 1))
        inside = dist <= cfg.team_match_distance_m
        if not inside.any():
            return
        r, c = linear_sum_assignment(np.where(inside, dist, _BIG))
        for a, b in zip(r, c):
            if inside[a, b]:
                self._team_of[rows[a]] = names[b]

    # ------------------------------------------------------------------ outputs
    @property
    def track_ids(self) -> np.ndarray:
        return self.bank.track_ids

    @property
    def confirmed(self) -> np.ndarray:
        """(n,) bool per bank row."""
        return self._confirmed.copy()

    @property
    def radii_m(self) -> np.ndarray:
        return self._radius.copy()

    @property
    def static(self) -> np.ndarray:
        return self._static.copy()

    @property
    def team_members(self) -> list:
        return list(self._team_of)

    def estimates(self, include_tentative: bool = False) -> list[TrackEstimate]:
        """TrackEstimate of every confirmed track (and tentative ones if asked)."""
        out = []
        ids = self.bank.track_ids
        for k in range(ids.size):
            if not (self._confirmed[k] or include_tentative):
                continue
            outline = None
            if self._static[k] or self.bank.speeds[k] < self.config.static_speed_m_s:
                outline = self.outline(k)
            out.append(self.bank.estimate(int(ids[k]), float(self._radius[k]), is_static=bool(self._static[k]),
                                          team_member=self._team_of[k], outline_m=outline))
        return out

    def outline(self, row: int) -> np.ndarray:
        """(k, 2) CCW outline [m] of the track in bank row ``row``: the hull of its returns united
        with its reflection through the track's centre, or the 12-gon around its disc."""
        c = self.bank.positions[row]
        h = self._hull[row]
        if h is None or h.shape[0] < 2:
            return _disc_outline(c, self._radius[row])
        return _hull_vertices(np.vstack([h, 2.0 * c - h]))

    def drain_events(self) -> list[TrackEvent]:
        ev, self.events = self.events, []
        return ev


def _disc_outline(centre, radius: float, sides: int = 12) -> np.ndarray:
    """A polygon (sides, 2) circumscribing the disc, counter-clockwise."""
    a = np.linspace(0.0, 2.0 * np.pi, sides, endpoint=False)
    r = radius / math.cos(math.pi / sides)
    return np.asarray(centre) + r * np.stack([np.cos(a), np.sin(a)], axis=-1)


def _hull_vertices(p: np.ndarray) -> np.ndarray:
    """Convex hull vertices (k, 2) of points p, counter-clockwise (Andrew's monotone chain; a
    degenerate set gives its extreme points)."""
    p = np.unique(np.round(np.asarray(p, dtype=float), 6), axis=0)
    if p.shape[0] <= 2:
        return p

    def half(q):
        out: list = []
        for pt in q:
            while len(out) >= 2 and ((out[-1][0] - out[-2][0]) * (pt[1] - out[-2][1])
                                     - (out[-1][1] - out[-2][1]) * (pt[0] - out[-2][0])) <= 0:
                out.pop()
            out.append(pt)
        return out

    lower, upper = half(p), half(p[::-1])
    return np.array(lower[:-1] + upper[:-1])


def _fmt(p) -> str:
    return f"({p[0]:.1f}, {p[1]:.1f}) m"
