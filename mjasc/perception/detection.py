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

    σ_c² = Δ²/12 + σ_ρ²/n + σ_floor²        (cov = σ_c² I₂)

(≈ (0.26 m)² at 100 m with 0.5° beams, (0.07 m)² at 20 m; tests/test_detection.py checks it
against the spread of the centres over random geometries).

**Partly hidden objects.** When a return nearer by more than 1 m lies within ``max_gap_beams + 1``
beams beyond a cluster's edge (or the edge is the end of a partial fan), that edge is not the
object's: the detection is flagged ``occluded`` and the tracker inflates its variance by the part of
the track's radius that is not seen, ``(R_track − r̂)²``, and does not shrink the track's radius.

**Extended objects.** A cluster wider than ``max_target_radius_m`` (a quay wall, an island's shore)
is not a target: it is flagged ``extended`` and its returns go to the static map
(:mod:`mjasc.perception.static_map`), not to the tracker.

Every step is vectorized over the clusters of a scan (``np.add.reduceat``); no Python loop.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from mjasc.core.config_tables import ConfigError, check_params, dataclass_from_table, param, show
from mjasc.perception.range_sensor import Scan

__all__ = ["DetectionConfig", "Detections", "detect", "parse_detection_options", "check_detection"]

_REFINE = 2  # Gauss–Newton iterations of the centre
_DAMP = 0.1  # their damping per return (keeps a one- or two-return cluster at its first estimate)
_OCCLUDER_MARGIN_M = 1.0  # a neighbouring return this much nearer hides the cluster's edge
_WALL_SIN_TOL = 0.035  # 2°: three returns this straight on neighbouring beams are a wall
_WALL_STEP_MAX_M = 50.0  # longest step along a grazed wall kept in one object
#: Neighbouring beams hit a straight wall at spacings h·sin Δθ / (sin φ_k sin φ_k+1) (h the wall's
#: distance, φ_k the beam's angle to the wall), so successive spacings differ by the factor
#: sin φ_k / sin φ_k+2: at most 5 while φ ≥ Δθ/2. A long step after (or before) a short one is
#: not the same wall: it is the jump from another object's edge onto a wall behind it.
_WALL_STEP_RATIO = 5.0


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


def _empty(scan: Scan, k: int) -> Detections:
    z2, z1 = np.zeros((0, 2)), np.zeros(0)
    return Detections(scan.time_s, scan.origin_m, scan.heading_rad, z2, z2.copy(), z1, z1.copy(),
                      np.zeros(0, dtype=int), z1.copy(), np.zeros(0, dtype=bool), np.full(k, -1),
                      np.zeros(0, dtype=bool))


def detect(scan: Scan, config: DetectionConfig = DetectionConfig(), range_noise_std_m: float = 0.0) -> Detections:
    """Cluster ``scan`` and estimate each object's centre, radius and centre variance."""
    beams = scan.hit_beams
    k = beams.size
    if k == 0:
        return _empty(scan, 0)
    n_beams = scan.angles_body.size
    dth = scan.beam_spacing_rad
    P = scan.hit_points_world
    rho = scan.ranges[beams]
    gap_max = config.max_gap_beams + 1
    # cyclic breaks: brk[i] is the break between return i and return (i + 1) % k
    nxt = np.roll(np.arange(k), -1)
    gaps = beams[nxt] - beams
    gaps[-1] += n_beams
    step = np.hypot(*(P[nxt] - P).T)
    thr = config.cluster_distance_m + config.cluster_range_factor * np.minimum(rho, rho[nxt]) * gaps * dth
    brk = (gaps > gap_max) | (step > thr)
    if k >= 3 and brk.any():
        brk &= ~_wall_continues(P, gaps, step, nxt, range_noise_std_m)
    if not scan.full_circle or k == 1:
        brk[-1] = True
    if brk.any():
        s = int(np.argmax(brk)) + 1  # start the sequence just after a break
        order = (np.arange(k) + s) % k
        brk = brk[order]
    else:  # one object all around (e.g. inside a closed basin)
        order = np.arange(k)
    P = P[order]
    rho = rho[order]
    starts = np.concatenate([[0], np.flatnonzero(brk[:-1]) + 1])
    counts = np.diff(np.append(starts, k))
    lab = np.repeat(np.arange(starts.size), counts)
    ends = starts + counts - 1

    o = scan.origin_m
    pf, pl = P[starts], P[ends]
    width = np.hypot(*(pl - pf).T)
    rho_mean = np.add.reduceat(rho, starts) / counts
    spacing = rho_mean * dth
    r_w = np.maximum(0.5 * (width + spacing), config.min_radius_m)
    mid = 0.5 * (pf + pl)
    los = mid - o
    los_n = np.hypot(*los.T)
    u = los / np.where(los_n > 0, los_n, 1.0)[:, None]
    v = np.stack([-u[:, 1], u[:, 0]], axis=-1)
    rel = P - o
    d = np.einsum("ij,ij->i", rel, u[lab])
    y = np.einsum("ij,ij->i", P - mid[lab], v[lab])
    behind = np.sqrt(np.maximum(r_w[lab] ** 2 - y * y, 0.0))
    wgt = behind + 1e-3 * r_w[lab]  # ∝ cos of the surface angle (edges carry the radius error)
    D = np.add.reduceat(wgt * (d + behind), starts) / np.add.reduceat(wgt, starts)
    centres = o + D[:, None] * u
    for _ in range(_REFINE):  # damped Gauss–Newton on Σ (‖p_i − c‖ − r_w)²
        dv = centres[lab] - P
        dist = np.hypot(*dv.T)
        J = dv / np.maximum(dist, 1e-9)[:, None]
        e = dist - r_w[lab]
        a11 = np.add.reduceat(J[:, 0] ** 2, starts) + _DAMP * counts
        a12 = np.add.reduceat(J[:, 0] * J[:, 1], starts)
        a22 = np.add.reduceat(J[:, 1] ** 2, starts) + _DAMP * counts
        g1 = np.add.reduceat(J[:, 0] * e, starts)
        g2 = np.add.reduceat(J[:, 1] * e, starts)
        det_ = a11 * a22 - a12 * a12
        centres = centres - np.stack([(a22 * g1 - a12 * g2) / det_, (a11 * g2 - a12 * g1) / det_], axis=-1)
    far = np.maximum.reduceat(np.hypot(*(P - centres[lab]).T), starts)
    radii = np.maximum(r_w, far)
    var = spacing**2 / 12.0 + range_noise_std_m**2 / counts + config.centre_noise_floor_m**2

    occluded = _occluded_edges(scan, beams[order], rho, starts, ends, gap_max)

    keep = counts >= config.min_points
    labels = np.full(k, -1)
    new_index = np.cumsum(keep) - 1
    labels[order] = np.where(keep[lab], new_index[lab], -1)
    centres, radii, var, counts, occluded = centres[keep], radii[keep], var[keep], counts[keep], occluded[keep]
    rel_c = centres - o
    c, s_ = math.cos(scan.heading_rad), math.sin(scan.heading_rad)
    body = np.stack([c * rel_c[:, 0] + s_ * rel_c[:, 1], -s_ * rel_c[:, 0] + c * rel_c[:, 1]], axis=-1)
    return Detections(scan.time_s, o, scan.heading_rad, centres, body, radii, var, counts,
                      np.hypot(*rel_c.T), radii > config.max_target_radius_m, labels, occluded)


def _wall_continues(P, gaps, step, nxt, sigma) -> np.ndarray:
    """(k,) bool: the step from return i to i + 1 (neighbouring beams, at most ``_WALL_STEP_MAX_M``)
    continues the straight line through i − 1, i, or through i + 1, i + 2 (within the noise), and the
    two steps' lengths are alike (``_WALL_STEP_RATIO``): the beams graze a wall, whose returns spread
    out along it; they stay one object. Without the length test a short step's direction (noise:
    anything goes) let a boat's hull in front of a wall join the wall's cluster."""
    prv = np.roll(nxt, 2)  # i − 1 (nxt is a cyclic shift by one)
    seg = P[nxt] - P  # i → i + 1
    length = np.maximum(step, 1e-9)
    unit = seg / length[:, None]
    tol = np.minimum(1.0, 3.0 * sigma * (1.0 / length + 1.0 / length[prv])) + _WALL_SIN_TOL
    cross_back = np.abs(unit[prv, 0] * unit[:, 1] - unit[prv, 1] * unit[:, 0])
    similar = np.maximum(length, length[prv]) <= _WALL_STEP_RATIO * np.minimum(length, length[prv]) + 6.0 * sigma
    back = (gaps == 1) & (gaps[prv] == 1) & (np.einsum("ij,ij->i", unit[prv], unit) > 0) & (cross_back < tol) & similar
    fwd = np.roll(back, -1)  # the step i+1 → i+2 continues i → i+1
    return (back | fwd) & (gaps == 1) & (step <= _WALL_STEP_MAX_M)


def _occluded_edges(scan: Scan, beams, rho, starts, ends, gap_max: int) -> np.ndarray:
    """(m,) bool: a cluster's first or last return has, within ``gap_max`` beams beyond it, a return
    nearer by more than ``_OCCLUDER_MARGIN_M`` (something in front hides part of the object), or its
    edge is the edge of a partial fan."""
    n = scan.angles_body.size
    off = np.arange(1, gap_max + 1)
    occ = np.zeros(starts.size, dtype=bool)
    for edge, sign in ((starts, -1), (ends, 1)):
        nb = beams[edge][:, None] + sign * off[None, :]
        if scan.full_circle:
            nb %= n
        else:
            outside = (nb < 0) | (nb >= n)
            occ |= outside[:, 0]
            nb = np.clip(nb, 0, n - 1)
        nearer = scan.hit[nb] & (scan.ranges[nb] < rho[edge][:, None] - _OCCLUDER_MARGIN_M)
        occ |= nearer.any(axis=1)
    return occ
