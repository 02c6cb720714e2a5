"""Which beams of a fan can meet anything: the range sensor casts only those (world ENU, metres,
radians).

On open water most beams of a fan meet nothing, yet ``mj_multiRay`` pays for every beam (two
``atan2`` for its direction, a bounding-sphere test per body, an angle test per geom: ~70 ns a
beam, ~26 µs for a 360-beam fan among a dozen geoms, twice that inside a run). A beam can only
meet a geom whose bounding sphere it crosses, and a horizontal beam from the sensor at (x, y)
crosses the bounding sphere (centre c, radius R) of a geom only where its *horizontal* crossing,
the disc of radius R about (c_x, c_y), lies on the beam:

* ρ = |c − (x, y)| ≤ R: the sensor is inside the disc, every direction can meet the geom;
* otherwise the beam's world angle φ must be within ``asin(R / ρ)`` of the bearing θ of c (the
  half-line from the sensor meets the disc exactly there);
* ρ − R > the cutoff: MuJoCo drops the geom itself (its 3-D distance is at least ρ).

:func:`fan_candidates` marks, per geom of the sensor's groups (not of its own body), the beams in
θ ± asin(R / ρ), widened by one beam on each side (the beam angles are ``a_0 + k·Δ`` to a few
ulps) and by a relative 10⁻⁹ on R; writes the marked beams' world directions — the same
expressions as :func:`~mjasc.perception.scan_kernels.fan_directions`, so the same bits — into a
compact array, and every beam's distance and geom as a miss (−1). The caller casts the compact
fan with ``mj_multiRay`` and :func:`scatter_hits` puts its answers back in place.

The scans are the same bits as casting every beam: ``mj_multiRay`` answers each beam on its own
(its per-call set-up depends on the sensor's position only), and a beam that crosses no bounding
disc meets nothing, which MuJoCo reports as −1 (tests/test_beam_culling.py casts both ways on
random poses). A geom with no bounding radius (a plane, ``geom_rbound`` 0) or a geom type whose
rays are not bounded by the sphere marks every beam: :func:`can_cull` says when a model's geoms
allow culling at all.
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.compiled import kernel

__all__ = ["fan_candidates", "scatter_hits", "candidate_geoms"]

#: relative widening of a geom's bounding radius (the test stays conservative through rounding)
_R_WIDEN = 1e-9


def candidate_geoms(model, geomgroup: np.ndarray, body_exclude: int) -> tuple[np.ndarray, np.ndarray] | None:
    """The geom ids (G,) int64 a fan of this sensor can meet — every geom of ``geomgroup``'s groups
    not on body ``body_exclude`` (MuJoCo's own elimination drops more, never fewer) — and their
    bounding radii (G,) [m], widened; None when one of them has no bounding radius (a plane: rays
    would have to be cast in every direction, so the sensor casts its whole fan as before)."""
    groups = np.clip(model.geom_group, 0, len(geomgroup) - 1)
    seen = (np.asarray(geomgroup)[groups] != 0) & (model.geom_group >= 0) & (model.geom_group < len(geomgroup))
    seen &= model.geom_bodyid != body_exclude
    ids = np.flatnonzero(seen).astype(np.int64)
    rbound = model.geom_rbound[ids]
    if ids.size and not np.all(rbound > 0.0):
        return None
    return ids, rbound * (1.0 + _R_WIDEN) + _R_WIDEN


@kernel
def fan_candidates(x, y, yaw, angles_body, full_circle, geom_xpos, ids, radii, cutoff_m, mark, beams, vec, dist, gid):
    """Mark the beams of a fan (body angles ``angles_body`` (n,) [rad], uniformly spaced; a full
    circle wraps) of a sensor at world (x, y) [m] and heading ``yaw`` [rad] that can meet one of
    the geoms ``ids`` (world centres in ``geom_xpos`` (ngeom, 3), bounding radii ``radii`` [m]),
    within ``cutoff_m`` (module docstring). Writes the marked beams' indices, ascending, into
    ``beams`` (n,) and their world directions into the rows of ``vec`` (n, 3); sets ``dist`` (n,) to
    −1 and ``gid`` (n,) to −1 for every beam; ``mark`` (n,) bool is scratch. Returns how many beams
    are marked."""
    n = angles_body.shape[0]
    for i in range(n):
        mark[i] = False
        dist[i] = -1.0
        gid[i] = -1
    a0 = angles_body[0]
    step = (angles_body[n - 1] - a0) / (n - 1) if n > 1 else 2.0 * math.pi
    two_pi = 2.0 * math.pi
    every = False
    for j in range(ids.shape[0]):
        g = ids[j]
        dx = geom_xpos[g, 0] - x
        dy = geom_xpos[g, 1] - y
        r = radii[j]
        rho = math.sqrt(dx * dx + dy * dy)
        if rho - r > cutoff_m:
            continue
        if rho <= r:
            every = True
            break
        half = math.asin(r / rho)
        centre = math.atan2(dy, dx) - yaw - a0  # the bearing in beam steps' frame [rad]
        for shift in (-two_pi, 0.0, two_pi):
            lo = int(math.floor((centre + shift - half) / step)) - 1
            hi = int(math.ceil((centre + shift + half) / step)) + 1
            if full_circle:
                if hi - lo + 1 >= n:
                    every = True
                    break
                if shift != 0.0:
                    continue  # (a full circle wraps by index below: one interval is enough)
                for k in range(lo, hi + 1):
                    mark[k % n] = True
            else:
                if lo < 0:
                    lo = 0
                if hi > n - 1:
                    hi = n - 1
                for k in range(lo, hi + 1):
                    mark[k] = True
        if every:
            break
    m = 0
    for i in range(n):
        if every or mark[i]:
            beams[m] = i
            a = angles_body[i] + yaw
            vec[m, 0] = math.cos(a)
            vec[m, 1] = math.sin(a)
            vec[m, 2] = 0.0
            m += 1
    return m


@kernel
def scatter_hits(beams, m, dist_c, gid_c, dist, gid):
    """Put the compact cast's answers ``dist_c`` / ``gid_c`` (the first m) back at their beams
    ``beams`` in ``dist`` / ``gid`` (n,)."""
    for j in range(m):
        i = beams[j]
        dist[i] = dist_c[j]
        gid[i] = gid_c[j]
