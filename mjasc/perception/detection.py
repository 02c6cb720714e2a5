"""Detections from one range scan: cluster the returns into objects, estimate each one's centre,
radius and measurement noise (world ENU, SI).

**Clustering** (adaptive breakpoint segmentation, Borges & Aldon 2004). Returns are taken in beam
order; consecutive returns i, j (beams b_i < b_j) belong to the same object when at most
``max_gap_beams`` beams between them are empty and ::

    ‖p_j − p_i‖ ≤ d₀ + λ · min(ρ_i, ρ_j) · (b_j − b_i) · Δθ

(``cluster_distance_m`` = d₀, ``cluster_range_factor`` = λ; ρ range, Δθ beam spacing): the
threshold grows with range like the spacing between beams. A 360° fan closes on itself (the last and
first returns are neighbours). Empty beams allowed inside a cluster bridge dropouts. Beams that
graze a wall spread their returns along it far beyond that threshold: a step between neighbouring
beams (≤ 50 m) that continues a straight line through the previous or next return (within 2° plus
the range noise) does not break the cluster, so a wall seen at grazing incidence stays one
(extended) object instead of single returns sliding along it like fast small targets.

**Centre and radius** (each object is taken as a disc, as the thesis's collision prediction does).
With the extreme returns p_f, p_l of a cluster (chord width w = ‖p_l − p_f‖), its mean range ρ̄ and
the beam spacing at that range Δ = ρ̄·Δθ, the object's true edges lie on average Δ/2 beyond the
extreme beams, so the radius seen across the line of sight is ``r_w = (w + Δ)/2``. The centre lies on
the line of sight u through the chord's midpoint, behind the visible surface: each return at lateral
offset y_i from that line and depth d_i along it puts the centre at depth ``d_i + √(r_w² − y_i²)``
(a disc's surface), and the centre depth D is their mean weighted by √(r_w² − y_i²) (∝ the
cosine of the surface's slope: near the edges an error in r_w moves the estimate most); a single
return gives D = ρ + r_w. From ``origin + D·u``, two damped Gauss–Newton steps on
``Σ_i (‖p_i − c‖ − r_w)²`` move the centre onto the disc through the returns (this removes most of
the lateral error of the chord's jittery ends: 1-σ 0.03 m instead of 0.17 m at 100 m). Then
``radius = max(r_w, max_i ‖p_i − centre‖, min_radius_m)``. What remains is radial: r_w is off by
up to ±Δ/2 depending on where the beams fall on the disc, and the centre moves with it (a bias of
−0.09 m at 30 m to +0.06 m at 140 m, measured over random geometries for a 2.5 m disc).

**Measurement noise.** Each edge of the chord is uncertain by a uniform ±Δ/2, so r_w has variance
Δ²/24; the depth D carries the range noise σ_ρ²/n of n returns plus the radius error, amplified at
the slanted edges (measured over random geometries: about twice Δ²/24 radially; laterally the fit
is much better); ``centre_noise_floor_m`` covers the shape not being a disc. The detection's
covariance is taken isotropic, with the larger (radial) variance::

    σ_c² = Δ²/12 + σ_ρ²/n + σ_floor²        (cov = σ_c² I₂; + Δ²·p/(1−p)² with lost returns, below)

(≈ (0.26 m)² at 100 m with 0.5° beams, (0.07 m)² at 20 m; tests/test_detection.py checks it
against the spread of the centres over random geometries).

**Lost returns.** A sensor that loses each true return with probability p (its
``dropout_probability``, known to the detection like σ_ρ) loses, beyond each visible edge, a
geometric number of the object's beams: p/(1−p) on average, variance p/(1−p)². The chord is
widened by the mean (``r_w = (w + Δ(1 + 2p/(1−p)))/2``, unbiased again) and the centre variance
gains the edges' spread, ``Δ²·p/(1−p)²`` (× 7 over Δ²/12 at p = 0.3). Runs of lost returns inside an
object are bridged up to the larger of ``max_gap_beams`` and the gap a run exceeds with probability
≤ 0.5 % (:func:`dropout_gap_beams`: 4 beams at p = 0.3). Without both, a 6 m ship seen through
30 % dropout gave centres jittering by metres (splits) and over-confident variances, and the
tracker's speed estimate swung between 0.7 and 2.5 m/s for a 1 m/s ship (stressed §6.4.1 crossing;
docs/avoidance.md, "Hardening").

**Partly hidden objects.** When a return nearer by more than 1 m lies within ``max_gap_beams + 1``
beams beyond a cluster's edge (or the edge is the end of a partial fan), that edge is not the
object's: the detection is flagged ``occluded`` and the tracker inflates its variance by the part of
the track's radius that is not seen, ``(R_track − r̂)²``, and does not shrink the track's radius.

**Extended objects.** A cluster wider than ``max_target_radius_m`` (a quay wall, an island's shore)
is not a target: it is flagged ``extended`` and its returns go to the static map
(:mod:`mjasc.perception.static_map`), not to the tracker.

**Many scans at once.** :func:`detect_many` takes the scans of a whole fleet's tick (their returns
stacked, each with its scan's index; per-scan parameters as (S,) arrays) and runs each step once
over all returns, in compiled loops: the cyclic neighbours, breaks, the rotation that starts each
fan after a break, the clusters and hidden edges (:mod:`mjasc.perception.cluster_kernels`), then
every cluster's disc (:mod:`mjasc.perception.detection_kernels`, sums in ``np.add.reduceat``'s
order). Every step is per return, per cluster or a reduction within one cluster, so each scan's
detections are the same bits as when it is detected alone (:func:`detect` is :func:`detect_many`
of one scan).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from mjasc.core.config_tables import ConfigError, check_params, dataclass_from_table, param, show
from mjasc.perception.detection_kernels import detect_clusters
from mjasc.perception.pass_views import FilledOnRead, filled_on_read
from mjasc.perception.range_sensor import Scan
from mjasc.perception.scan_batch import ScanStack, scan_pose

__all__ = ["DetectionConfig", "Detections", "PassDetections", "DetectionBatch", "detect", "detect_many",
           "detection_constants",
           "dropout_gap_beams",
           "finite_detections", "centres_body",
           "parse_detection_options",
           "check_detection"]

#: A run of lost returns this unlikely (at one place inside an object) may split it in two.
SPLIT_PROBABILITY = 0.005


@dataclass(frozen=True)
class DetectionConfig:
    """Clustering and centre estimation parameters (each declared once with its bounds, unit and
    doc; the one relation between fields is :func:`check_detection`)."""

    cluster_distance_m: float = param(1.0, nonneg=True, unit="m", doc="d₀, the fixed part of the breakpoint distance")
    cluster_range_factor: float = param(
        3.0, nonneg=True,
        doc="λ, the range-proportional part of the breakpoint distance (× beam spacing at that range)")
    max_gap_beams: int = param(2, minimum=0, doc="empty beams tolerated inside one object (bridges dropouts)")
    min_points: int = param(
        1, minimum=1, doc="clusters with fewer returns are dropped (1 keeps single returns; clutter is then removed "
                          "by the tracker's M-of-N confirmation instead)")
    min_radius_m: float = param(0.3, nonneg=True, unit="m", doc="smallest radius reported")
    max_target_radius_m: float = param(
        8.0, nonneg=True, unit="m",
        doc="clusters with a larger radius are extended structures for the static map; > min_radius_m")
    centre_noise_floor_m: float = param(
        0.05, nonneg=True, unit="m", doc="σ_floor, the 1-σ centre error not explained by beams and noise")

    def __post_init__(self):
        check_params(self, "detection")
        check_detection(self, "detection")


def check_detection(c: DetectionConfig, where: str) -> None:
    """The relation between :class:`DetectionConfig`'s fields (ConfigError naming ``f"{where}.{key}"``)."""
    if not c.max_target_radius_m > c.min_radius_m:
        raise ConfigError(f"{where}.max_target_radius_m: must be > min_radius_m ({c.min_radius_m}), "
                          f"got {show(c.max_target_radius_m)}")


def parse_detection_options(table: Mapping | None, where: str = "detection") -> DetectionConfig:
    """A scenario's ``detection`` table (None: all defaults) → :class:`DetectionConfig`; unknown keys,
    wrong types and out-of-range values raise ValueError naming ``f"{where}.{key}"``."""
    return dataclass_from_table(DetectionConfig, {} if table is None else table, where, check=check_detection)


@dataclass(frozen=True)
class Detections:
    """The objects found in one scan (m of them), world frame unless ``_body``.

    centres_m (m, 2) and centres_body (m, 2) [m]; radii_m (m,) [m]; variances_m2 (m,) isotropic
    centre variance σ_c² [m²] (covariances (m, 2, 2) = σ_c² I); n_points (m,); ranges_m (m,) from
    the sensor to the centre; extended (m,) bool (wider than ``max_target_radius_m``);
    labels (k,) cluster index of each return of the scan, in ``scan.hit_beams`` order (−1: dropped);
    occluded (m,) bool: an edge of the object is hidden (by a nearer return beside it, or the end of
    a partial fan), so its width, radius and centre are biased (the tracker inflates its variance).
    """

    time_s: float
    origin_m: np.ndarray
    heading_rad: float
    centres_m: np.ndarray
    centres_body: np.ndarray
    radii_m: np.ndarray
    variances_m2: np.ndarray
    n_points: np.ndarray
    ranges_m: np.ndarray
    extended: np.ndarray
    labels: np.ndarray
    occluded: np.ndarray | None = None

    def __len__(self) -> int:
        return self.centres_m.shape[0]

    @property
    def covariances(self) -> np.ndarray:
        """(m, 2, 2) centre covariances [m²]."""
        return self.variances_m2[:, None, None] * np.eye(2)

    @property
    def targets(self) -> np.ndarray:
        """(m,) bool: detections the tracker should take (not extended)."""
        return ~self.extended


@dataclass(frozen=True)
class DetectionBatch:
    """The detections of several scans (:func:`detect_many`): the fields of :class:`Detections`
    concatenated over the scans, scan s owning detections ``det_offsets[s]:det_offsets[s+1]`` and
    returns ``ret_offsets[s]:ret_offsets[s+1]`` (``labels``: each return's detection index within its
    own scan, −1 dropped, in each scan's ``hit_beams`` order)."""

    scans: tuple
    centres_m: np.ndarray
    centres_body: np.ndarray
    radii_m: np.ndarray
    variances_m2: np.ndarray
    n_points: np.ndarray
    ranges_m: np.ndarray
    extended: np.ndarray
    occluded: np.ndarray
    labels: np.ndarray
    det_offsets: np.ndarray
    ret_offsets: np.ndarray

    def split(self) -> list[Detections]:
        """One :class:`Detections` per scan (views of the batch's arrays), each a
        :class:`PassDetections`: its fields made on first read."""
        return [filled_on_read(PassDetections, _detection_fields, (k, self)) for k in range(len(self.scans))]


class PassDetections(FilledOnRead, Detections):
    """A :class:`Detections` of a :class:`DetectionBatch` whose fields are made on first read
    (:mod:`mjasc.perception.pass_views`)."""

    @property
    def occluded(self):  # (the field's class default would otherwise hide it while not made)
        d = self.__dict__
        if "occluded" not in d:
            self.__getattr__("occluded")
        return d["occluded"]

    @occluded.setter
    def occluded(self, value) -> None:  # (the frozen dataclass's __init__ sets fields through object.__setattr__)
        self.__dict__["occluded"] = value


def _detection_fields(d: dict, k: int, batch: DetectionBatch) -> None:
    """The fields of scan ``k``'s detections of ``batch`` into ``d``: views of the batch's arrays,
    as ``Detections(...)`` had them."""
    a, b = batch.det_offsets[k:k + 2].tolist()
    r0, r1 = batch.ret_offsets[k:k + 2].tolist()
    t, origin, heading = scan_pose(batch.scans[k])  # (the scan's other fields not made)
    d.update(time_s=t, origin_m=origin, heading_rad=heading, centres_m=batch.centres_m[a:b],
             centres_body=batch.centres_body[a:b], radii_m=batch.radii_m[a:b], variances_m2=batch.variances_m2[a:b],
             n_points=batch.n_points[a:b], ranges_m=batch.ranges_m[a:b], extended=batch.extended[a:b],
             labels=batch.labels[r0:r1], occluded=batch.occluded[a:b])


def centres_body(det: Detections) -> np.ndarray:
    """``det.centres_body`` (k, 2) [m, body FLU] without making a pass's other fields (the
    recording draws only these: :mod:`mjasc.perception.recording`)."""
    src = det.__dict__.get("_src")
    if src is not None and src[0] is _detection_fields:
        k, batch = src[1]
        a, b = batch.det_offsets[k:k + 2].tolist()
        return batch.centres_body[a:b]
    return det.centres_body


def finite_detections(det: "Detections | DetectionBatch") -> np.ndarray:
    """(m,) bool: detections whose centre, radius and variance are all finite. The rest are
    dropped before the tracker (:meth:`mjasc.perception.pipeline.Perception._scanned`, counted in
    the summary as ``non_finite_detections_dropped``): one NaN centre would poison the IMM bank."""
    return (np.isfinite(det.centres_m).all(axis=1) & np.isfinite(det.radii_m) & np.isfinite(det.variances_m2))


def detect(scan: Scan, config: DetectionConfig = DetectionConfig(), range_noise_std_m: float = 0.0,
           dropout_probability: float = 0.0) -> Detections:
    """Cluster ``scan`` and estimate each object's centre, radius and centre variance (σ_ρ and the
    return dropout probability p of the sensor that took it: see "Lost returns" in the module doc)."""
    return detect_many([scan], [config], [range_noise_std_m], [dropout_probability]).split()[0]


def dropout_gap_beams(p: float) -> int:
    """The smallest number g of empty beams that a run of lost returns inside one object exceeds
    with probability ≤ :data:`SPLIT_PROBABILITY` (p^(g+1) ≤ it): 0 for p = 0, 1 for p = 0.05, 4 for
    p = 0.3. The gap bridged is the larger of this and ``max_gap_beams``."""
    if p <= 0.0:
        return 0
    return max(0, math.ceil(math.log(SPLIT_PROBABILITY) / math.log(p) - 1e-9) - 1)


_PER_SCAN_CACHE: dict = {}  # _PerScan.of: (configs, constants) per combination of scans


class _PerScan:
    """Per-scan constants, each an (S,) array (squares computed in Python floats), grouped as the
    compiled steps take them: ``cluster_scan`` (beams, d₀, λ, beam spacing Δθ, gap bridged + 1, σ_ρ,
    full circle), ``per_scan`` (Δθ, mean and variance of the beams lost beyond each edge, min radius,
    σ_ρ², σ_floor²), ``keep_scan`` (min points, max target radius) and ``beam_off`` (S + 1,), the
    offsets of the scans' beams when stacked."""

    _NAMES = ("n_beams", "dth", "full", "d0", "lam", "gap_max", "min_pts", "min_rad", "max_tr", "sig", "sig2", "floor2",
              "edge_lost", "edge_var")

    def __init__(self, scans, configs, noise, dropout):
        rows = [(sc.angles_body.size, sc.beam_spacing_rad, sc.full_circle) for sc in scans]
        rows = [g + (c.cluster_distance_m, c.cluster_range_factor, max(c.max_gap_beams, dropout_gap_beams(p)) + 1,
                     c.min_points, c.min_radius_m, c.max_target_radius_m, float(sig), float(sig) ** 2,
                     c.centre_noise_floor_m ** 2, p / (1.0 - p), p / (1.0 - p) ** 2)
                for g, c, sig, p in zip(rows, configs, noise, (float(x) for x in dropout))]
        cols = dict(zip(self._NAMES, zip(*rows)))
        self.cluster_scan = tuple(np.array(cols[name], dtype=t) for name, t in (
            ("n_beams", np.int64), ("d0", float), ("lam", float), ("dth", float), ("gap_max", np.int64),
            ("sig", float), ("full", bool)))
        self.per_scan = tuple(np.array(cols[name], dtype=float)
                              for name in ("dth", "edge_lost", "min_rad", "edge_var", "sig2", "floor2"))
        self.keep_scan = (np.array(cols["min_pts"], dtype=np.int64), np.array(cols["max_tr"], dtype=float))
        self.beam_off = np.zeros(len(rows) + 1, dtype=np.int64)
        np.cumsum(self.cluster_scan[0], out=self.beam_off[1:])

    @classmethod
    def of(cls, scans, configs, noise, dropout) -> "_PerScan":
        """The constants of these scans and configs, made once per combination (a fleet's scans
        at a tick are the same combination every tick). Configs are frozen; the cache keeps them
        alive, so their ids name them."""
        key = tuple((sc.angles_body.size, sc.beam_spacing_rad, sc.full_circle, id(c), float(sig), float(p))
                    for sc, c, sig, p in zip(scans, configs, noise, dropout))
        got = _PER_SCAN_CACHE.get(key)
        if got is None:
            if len(_PER_SCAN_CACHE) >= 64:
                _PER_SCAN_CACHE.clear()
            got = _PER_SCAN_CACHE[key] = (tuple(configs), cls(scans, configs, noise, dropout))
        return got[1]


def detect_many(scans: Sequence[Scan], configs: Sequence[DetectionConfig], range_noise_std_m: Sequence[float],
                dropout_probability: Sequence[float] | None = None, stack: ScanStack | None = None,
                constants: _PerScan | None = None) -> DetectionBatch:
    """Cluster every scan of ``scans`` (one config, σ_ρ and return dropout probability — None: 0 —
    per scan) in one pass; see the module docstring. Each scan's detections equal those of
    :func:`detect` on it alone. ``stack``: the :class:`~mjasc.perception.scan_batch.ScanStack` these
    scans came in (its stacked arrays are taken as they are); ``constants``: their
    :func:`detection_constants`, made before (otherwise looked up)."""
    scans = tuple(scans) if stack is None else stack.scans
    S = len(scans)
    c = constants if constants is not None else _PerScan.of(
        scans, configs, range_noise_std_m, [0.0] * S if dropout_probability is None else dropout_probability)
    if stack is not None:
        return _detect(scans, c, stack.hit_beams, stack.hit_points_world, stack.hit_ranges_m, stack.hit,
                       stack.ranges_m, stack.ret_off, stack.origins_m, stack.cos_heading, stack.sin_heading)
    k_s = np.array([sc.hit_beams.size for sc in scans], dtype=np.int64)
    ret_off = np.zeros(S + 1, dtype=np.int64)
    np.cumsum(k_s, out=ret_off[1:])
    if S == 1:
        sc = scans[0]
        beams, P, hit_all, ranges_all = sc.hit_beams, sc.hit_points_world, sc.hit, sc.ranges
        rho = ranges_all[beams]
        origins = np.asarray(sc.origin_m, dtype=float).reshape(1, 2)
    else:
        beams = np.concatenate([sc.hit_beams for sc in scans])
        P = np.concatenate([sc.hit_points_world for sc in scans])
        hit_all = np.concatenate([sc.hit for sc in scans])
        ranges_all = np.concatenate([sc.ranges for sc in scans])
        rho = ranges_all[np.repeat(c.beam_off[:-1], k_s) + beams]
        origins = np.array([sc.origin_m for sc in scans], dtype=float)
    cos_h = np.array([math.cos(sc.heading_rad) for sc in scans])
    sin_h = np.array([math.sin(sc.heading_rad) for sc in scans])
    return _detect(scans, c, beams, P, rho, hit_all, ranges_all, ret_off, origins, cos_h, sin_h)


def detection_constants(sensors, configs: Sequence[DetectionConfig], range_noise_std_m: Sequence[float],
                        dropout_probability: Sequence[float]) -> _PerScan:
    """The per-scan constants :func:`detect_many` makes for scans of these sensors (anything with a
    scan's ``angles_body``, ``beam_spacing_rad`` and ``full_circle``: a
    :class:`~mjasc.perception.range_sensor.RangeSensor` or its :class:`Scan`), one config, σ_ρ and
    dropout probability each: made once for a fleet's sensing passes (``detect_many(…, constants=)``)."""
    return _PerScan.of(sensors, configs, range_noise_std_m, dropout_probability)


def _detect(scans, c: _PerScan, beams, P, rho, hit_all, ranges_all, ret_off, origins, cos_h, sin_h) -> DetectionBatch:
    """The steps of :func:`detect_many` on the scans' stacked returns: hit beams (K,), points (K, 2)
    and ranges (K,), scan s owning ``ret_off[s] : ret_off[s+1]``; every beam's hit and range
    stacked; per scan the origin (S, 2), cosine and sine of the heading."""
    if P.shape[0] == 0:
        return empty_batch(scans, ret_off)
    n_beams, d0, lam, dth, gap, sig, full = c.cluster_scan
    _, edge_lost, min_rad, edge_var, sig2, floor2 = c.per_scan
    points, floats, ints, flags, d = detect_clusters(
        beams, P, rho, ret_off, n_beams, d0, lam, dth, gap, sig, full, c.beam_off, hit_all, ranges_all, origins, cos_h,
        sin_h, edge_lost, min_rad, edge_var, sig2, floor2, *c.keep_scan)
    return packed_batch(scans, ret_off, P.shape[0], points, floats, ints, flags, d)


def empty_batch(scans, ret_off) -> DetectionBatch:
    """The :class:`DetectionBatch` of scans without a return."""
    z2, z1 = np.zeros((0, 2)), np.zeros(0)
    return DetectionBatch(scans, z2, z2.copy(), z1, z1.copy(), np.zeros(0, dtype=np.int64), z1.copy(),
                          np.zeros(0, dtype=bool), np.zeros(0, dtype=bool), np.full(0, -1),
                          np.zeros(len(scans) + 1, dtype=np.int64), ret_off)


def packed_batch(scans, ret_off, K, points, floats, ints, flags, d) -> DetectionBatch:
    """The :class:`DetectionBatch` of :func:`~mjasc.perception.detection_kernels.detect_clusters`'
    packed outputs (d detections of K returns; its slices as views)."""
    centres, body, radii, var, counts, ranges = points[:d], points[d:], floats[:d], floats[d:2 * d], ints[:d], \
        floats[2 * d:]
    extended, occluded, labels, det_off = flags[:d], flags[d:], ints[d:d + K], ints[d + K:]
    batch = object.__new__(DetectionBatch)  # (DetectionBatch(...) without its frozen __init__'s setattr calls)
    batch.__dict__.update(scans=scans, centres_m=centres, centres_body=body, radii_m=radii, variances_m2=var,
                          n_points=counts, ranges_m=ranges, extended=extended, occluded=occluded, labels=labels,
                          det_offsets=det_off, ret_offsets=ret_off)
    return batch
